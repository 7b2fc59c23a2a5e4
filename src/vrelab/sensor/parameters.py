"""The parameters of a sensor's VRE model that a campaign can identify (SPEC 6.1).

One table (:data:`TABLE`): the name a parameter has in ``vrelab identify``'s JSON and in an
identified sensor file's covariance (units in the name), its unit, the sensor-file key that
holds it, the ``facts`` key that says where it comes from, and how it reads from and writes to
a :class:`~vrelab.sensor.Sensor`. :mod:`vrelab.identify` fits these on a base sensor, and
:func:`vrelab.predict.predict` carries an identified sensor's covariance over the same names
into ``u_vre_g``: both go through :func:`with_parameters`, so they cannot read a parameter two
ways.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping

from vrelab.units import UG_PER_G

if TYPE_CHECKING:
    from vrelab.sensor.loader import Sensor


@dataclass(frozen=True)
class Param:
    """One identifiable parameter: ``Sensor.<attribute>`` (element ``rail`` of a rails pair)
    holds ``value / scale``."""

    name: str  # JSON and covariance name, units in it
    unit: str  # ASCII, as in the JSON
    text_unit: str  # for people
    file_key: str  # the sensor file's key that holds it
    attribute: str  # the Sensor attribute
    scale: float = 1.0
    rail: int | None = None  # 0 (low) or 1 (high) of rails_g

    @property
    def fact_key(self) -> str:
        """The ``facts`` key (a Sensor attribute) saying where the number comes from."""
        return self.attribute


TABLE: dict[str, Param] = {p.name: p for p in (
    Param("k2_ug_per_g2", "ug/g^2", "µg/g²", "k2_ug_per_g2", "k2_per_g", UG_PER_G),
    Param("k3_ug_per_g3", "ug/g^3", "µg/g³", "k3_ug_per_g3", "k3_per_g2", UG_PER_G),
    Param("fn_hz", "Hz", "Hz", "fn_hz", "fn_hz"),
    Param("q", "1", "", "q", "q"),
    Param("rail_low_g", "g", "g", "rails_g", "rails_g", rail=0),
    Param("rail_high_g", "g", "g", "rails_g", "rails_g", rail=1),
    Param("overrange_threshold_g", "g", "g", "overrange_threshold_g", "overrange_threshold_g"),
    Param("kip_ug_per_g2", "ug/g^2", "µg/g²", "kip_ug_per_g2", "kip_per_g", UG_PER_G),
    Param("kpp_ug_per_g2", "ug/g^2", "µg/g²", "kpp_ug_per_g2", "kpp_per_g", UG_PER_G),
    Param("kio_ug_per_g2", "ug/g^2", "µg/g²", "kio_ug_per_g2", "kio_per_g", UG_PER_G),
    Param("koo_ug_per_g2", "ug/g^2", "µg/g²", "koo_ug_per_g2", "koo_per_g", UG_PER_G),
)}  # fmt: skip
PARAMETERS: tuple[str, ...] = tuple(TABLE)
# Parameters a sensor file may give an assumed standard uncertainty (``[uncertainty]``, SPEC 6.1)
# without a campaign identifying them: the identifiable ones and the base sensor's filters (a
# datasheet gives their corners as "about"; predict propagates these u like the covariance).
ASSUMABLE: dict[str, Param] = {**TABLE, **{p.name: p for p in (
    Param("bandwidth_hz", "Hz", "Hz", "bandwidth_hz", "bandwidth_hz"),
    Param("anti_alias_hz", "Hz", "Hz", "anti_alias_hz", "anti_alias_hz"),
)}}  # fmt: skip


def _param(name: str) -> Param:
    if name not in ASSUMABLE:
        raise ValueError(f"unknown sensor parameter {name!r}; known: {', '.join(ASSUMABLE)}")
    return ASSUMABLE[name]


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
    The copy carries no covariance and no assumed uncertainties (it is one point of the
    parameter space, not an estimate).
    """
    change: dict[str, object] = {}
    rails = list(sensor.rails_g)
    for name, v in values.items():
        p = _param(name)
        if p.rail is not None:
            rails[p.rail] = float(v)
            change["rails_g"] = None  # set below, once both sides are known
        else:
            change[p.attribute] = float(v) / p.scale
    if "rails_g" in change:
        if not rails[0] < rails[1]:
            raise ValueError(f"rails must satisfy low < high, got [{rails[0]:g}, {rails[1]:g}] g")
        change["rails_g"] = (rails[0], rails[1])
    return dataclasses.replace(sensor, covariance=None, uncertainty={}, **change)  # type: ignore[arg-type]
