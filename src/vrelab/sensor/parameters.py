"""The parameters of a sensor's VRE model that a campaign can identify (SPEC 6.1).

One table: the name a parameter has in ``vrelab identify``'s JSON and in an identified sensor
file's covariance (units in the name), and how it reads from and writes to a
:class:`~vrelab.sensor.Sensor`. :mod:`vrelab.identify` fits these on a base sensor, and
:func:`vrelab.predict.predict` carries an identified sensor's covariance over the same names
into ``u_vre_g``: both go through :func:`with_parameters`, so they cannot read a parameter two
ways.

========================  ======================  ===============================================
name                      Sensor attribute        meaning
========================  ======================  ===============================================
``k2_ug_per_g2``          ``k2_per_g`` × 1e6      second-order nonlinearity (the VRC), SPEC 1.2
``k3_ug_per_g3``          ``k3_per_g2`` × 1e6     third-order nonlinearity, SPEC 1.2
``fn_hz``                 ``fn_hz``               proof-mass resonance, SPEC 1.3
``q``                     ``q``                   its quality factor
``rail_low_g``            ``rails_g[0]``          lower rail (physical, where the clip sits)
``rail_high_g``           ``rails_g[1]``          upper rail
``overrange_threshold_g`` ``overrange_threshold_g``  over-range trip level on the proof mass
========================  ======================  ===============================================
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Mapping

if TYPE_CHECKING:
    from vrelab.sensor.loader import Sensor

PARAMETERS: tuple[str, ...] = (
    "k2_ug_per_g2", "k3_ug_per_g3", "fn_hz", "q", "rail_low_g", "rail_high_g", "overrange_threshold_g",
)  # fmt: skip
UNITS = {"k2_ug_per_g2": "ug/g^2", "k3_ug_per_g3": "ug/g^3", "fn_hz": "Hz", "q": "1", "rail_low_g": "g",
         "rail_high_g": "g", "overrange_threshold_g": "g"}
# The sensor file's key that holds each parameter.
FILE_KEY = {"k2_ug_per_g2": "k2_ug_per_g2", "k3_ug_per_g3": "k3_ug_per_g3", "fn_hz": "fn_hz", "q": "q",
            "rail_low_g": "rails_g", "rail_high_g": "rails_g", "overrange_threshold_g": "overrange_threshold_g"}
# The sensor file's fact key (a Sensor attribute name) that says where each parameter comes from.
FACT_KEY = {"k2_ug_per_g2": "k2_per_g", "k3_ug_per_g3": "k3_per_g2", "fn_hz": "fn_hz", "q": "q",
            "rail_low_g": "rails_g", "rail_high_g": "rails_g", "overrange_threshold_g": "overrange_threshold_g"}


def parameter(sensor: "Sensor", name: str) -> float | None:
    """The value of ``name`` on ``sensor`` in the parameter's units (None: the element is absent)."""
    if name == "k2_ug_per_g2":
        return sensor.k2_per_g * 1e6
    if name == "k3_ug_per_g3":
        return sensor.k3_per_g2 * 1e6
    if name == "rail_low_g":
        return sensor.rails_g[0]
    if name == "rail_high_g":
        return sensor.rails_g[1]
    if name in ("fn_hz", "q", "overrange_threshold_g"):
        return getattr(sensor, name)
    raise ValueError(f"unknown sensor parameter {name!r}; known: {', '.join(PARAMETERS)}")


def with_parameters(sensor: "Sensor", values: Mapping[str, float]) -> "Sensor":
    """``sensor`` with the parameters in ``values`` set (the Sensor validates the result).

    A resonance needs both ``fn_hz`` and ``q``: setting one on a sensor that has none raises.
    The copy carries no covariance (it is one point of the parameter space, not an estimate).
    """
    change: dict[str, object] = {}
    rails = list(sensor.rails_g)
    for name, v in values.items():
        v = float(v)
        if name == "k2_ug_per_g2":
            change["k2_per_g"] = v / 1e6
        elif name == "k3_ug_per_g3":
            change["k3_per_g2"] = v / 1e6
        elif name == "rail_low_g":
            rails[0] = v
        elif name == "rail_high_g":
            rails[1] = v
        elif name in ("fn_hz", "q", "overrange_threshold_g"):
            change[name] = v
        else:
            raise ValueError(f"unknown sensor parameter {name!r}; known: {', '.join(PARAMETERS)}")
    if "rail_low_g" in values or "rail_high_g" in values:
        if not rails[0] < rails[1]:
            raise ValueError(f"rails must satisfy low < high, got [{rails[0]:g}, {rails[1]:g}] g")
        change["rails_g"] = (rails[0], rails[1])
    return dataclasses.replace(sensor, covariance=None, **change)  # type: ignore[arg-type]
