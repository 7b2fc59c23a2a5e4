"""The parameters of a sensor's VRE model: the identifiable ones (physics §6.1) and the assumable ones.

A view of the one field table (:data:`vrelab.sensor.fields.FIELDS`, its ``identifiable``,
``fitted`` and ``assumable`` columns): the name a parameter has in ``vrelab identify``'s JSON
and in an identified sensor file's covariance (the file key, units in the name; a rails pair's
``rail_low_g`` and ``rail_high_g``), its unit, the sensor-file key that holds it, the ``facts``
key that says where it comes from, and how it reads from and writes to a
:class:`~vrelab.sensor.Sensor`. :mod:`vrelab.identify` fits :data:`PARAMETERS` on a base
sensor, and :func:`vrelab.predict.predict` carries an identified sensor's covariance over the
same names into ``u_vre_g``: both go through :func:`with_parameters`, so they cannot read a
parameter two ways.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from vrelab.sensor import fields

if TYPE_CHECKING:
    from vrelab.sensor.loader import Sensor


@dataclass(frozen=True)
class Param:
    """One parameter: ``Sensor.<attribute>`` (element ``rail`` of a rails pair) holds ``value / scale``."""

    name: str  # JSON and covariance name, units in it
    unit: str  # ASCII, as in the JSON
    text_unit: str  # for people
    file_key: str  # the sensor file's key that holds it
    attribute: str  # the Sensor attribute
    scale: float = 1.0
    rail: int | None = None  # 0 (low) or 1 (high) of rails_g
    integer: bool = False  # a filter order: whole numbers only (its u is a span of orders)
    upper: float | None = None  # the largest value the field allows

    @property
    def fact_key(self) -> str:
        """The ``facts`` key (a Sensor attribute) saying where the number comes from."""
        return self.attribute


# (the table, its parameters by column): built again only when FIELDS is another table
_built: dict[str, tuple[tuple[fields.Field, ...], dict[str, Param]]] = {}


def _params(which: str) -> dict[str, Param]:
    """The parameters of the rows whose column ``which`` is set, in the table's order."""
    hit = _built.get(which)
    if hit is None or hit[0] is not fields.FIELDS:
        hit = _built[which] = (fields.FIELDS, {
            name: Param(name, f.unit, f.text_unit, f.key, f.name, f.scale, i if f.elements else None,
                        f.kind == "order", f.upper)
            for f in fields.FIELDS if getattr(f, which) for i, name in enumerate(f.parameters)})
    return dict(hit[1])


def identifiable() -> dict[str, Param]:
    """Every parameter a campaign can identify (an identified file's covariance may name it)."""
    return _params("identifiable")


def assumable() -> dict[str, Param]:
    """Every parameter a sensor file's ``[uncertainty]`` may give an assumed standard uncertainty."""
    return _params("assumable")


# The views as the table stands at import (the names other modules import):
# every identifiable parameter,
TABLE: dict[str, Param] = identifiable()
# the ones vrelab identify fits (its JSON's and its sensor file's parameters, in this order),
PARAMETERS: tuple[str, ...] = tuple(_params("fitted"))
# and the ones a file may give an assumed standard uncertainty ([uncertainty], physics §6.1) without
# a campaign identifying them (a datasheet tolerance, a base sensor's filter corner given as
# "about"; predict propagates these u like the covariance).
ASSUMABLE: dict[str, Param] = assumable()


def _param(name: str) -> Param:
    known = assumable() | identifiable()
    if name not in known:
        raise ValueError(f"unknown sensor parameter {name!r}; known: {', '.join(known)}")
    return known[name]


def check_u(name: str, u: float, where: str) -> None:
    """Refuse a standard uncertainty of ``name`` wider than the parameter's whole physical range
    (its field's bounds, :meth:`vrelab.sensor.fields.Field.span`): such a u says nothing of the
    part (a covariance diagonal of 1e300 would give a u_vre_g of 1e128 g), it is a slip."""
    p = _param(name)
    span = fields.by_key()[p.file_key].span()
    if not u <= span:
        unit = f" {p.text_unit}" if p.text_unit else ""
        raise ValueError(f"{where}: the standard uncertainty of {name}, {u:g}{unit}, is wider than the parameter's "
                         f"whole physical range ({span:g}{unit}): outside any physical bound")


def parameter(sensor: Sensor, name: str) -> float | None:
    """The value of ``name`` on ``sensor`` in the parameter's units (None: the element is absent)."""
    p = _param(name)
    v = getattr(sensor, p.attribute)
    if p.rail is not None:
        v = v[p.rail]
    return None if v is None else float(v) * p.scale


def with_parameters(sensor: Sensor, values: Mapping[str, float]) -> Sensor:
    """``sensor`` with the parameters in ``values`` set (the Sensor validates the result).

    A resonance needs both ``fn_hz`` and ``q``: setting one on a sensor that has none raises.
    The copy carries no covariance, no assumed uncertainties and no list of assumptions without
    one (it is one point of the parameter space, not an estimate: predict does not probe it).
    """
    # attributes chosen by name at run time (a float, or the rails pair): Any for replace's
    # per-field check; Sensor.__post_init__ validates the values (fields.Field.check)
    change: dict[str, Any] = {}
    rails = list(sensor.rails_g)
    for name, v in values.items():
        p = _param(name)
        if p.rail is not None:
            rails[p.rail] = float(v)
            change["rails_g"] = None  # set below, once both sides are known
        elif p.integer:  # a filter order: the nearest whole order (the Sensor checks its bounds)
            change[p.attribute] = int(round(float(v)))
        else:
            change[p.attribute] = float(v) / p.scale
    if "rails_g" in change:
        if not rails[0] < rails[1]:
            raise ValueError(f"rails must satisfy low < high, got [{rails[0]:g}, {rails[1]:g}] g")
        change["rails_g"] = (rails[0], rails[1])
    return dataclasses.replace(sensor, covariance=None, uncertainty={}, unstated=(), **change)
