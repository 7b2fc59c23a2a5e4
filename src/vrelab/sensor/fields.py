"""The one table of sensor fields: TOML parsing, validation, the ``Sensor``, the parameters and the schema docs.

Each row says how a value is written in a sensor file (its key, in the file's units), what the
:class:`~vrelab.sensor.loader.Sensor` holds (its attribute, in g and Hz), what is allowed, its
default when a file leaves it out, what it means, and what the rest of vrelab may do with it:

* ``identifiable``: a campaign can estimate it; it has a parameter name (the file key; a rails
  pair has one per element, ``elements``) that an identified file's covariance, ``vrelab
  identify``'s JSON and :func:`vrelab.sensor.parameters.with_parameters` use. ``fitted``: of
  those, the ones ``vrelab identify`` fits today (:data:`vrelab.sensor.parameters.PARAMETERS`).
* ``sweepable``: a sweep's ``predict``/``simulate`` point may set it (``[grid]``, ``[fixed]``,
  ``[montecarlo]``, by its file key; :func:`sweepable`).
* ``assumable``: a sensor file's ``[uncertainty]`` table may give it an assumed standard
  uncertainty (:data:`vrelab.sensor.parameters.ASSUMABLE`).
* ``default_fact``: the ``facts`` text of the value when a file leaves it at its default (a
  preset then need not repeat it).

The loader parses and checks a file by this table, ``Sensor`` validates itself by it,
:mod:`vrelab.sensor.parameters`, the sweep's parameter lists and the sensor-file writer
(:mod:`vrelab.sensor.writer`) are views of it, and ``presets/README`` documents every row (a
test holds the README to :func:`schema_text`; :func:`update_readme` rewrites that block:
``python -c "from vrelab.sensor.fields import update_readme; update_readme()"``). A new sensor
parameter is one row here, one ``Sensor`` attribute and its stage (and its closed form in
:mod:`vrelab.predict`, where it has one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from vrelab._format import field_label
from vrelab.units import UG_PER_G

Kind = Literal["positive", "finite", "non_negative", "order", "bool", "choice", "rails"]


@dataclass(frozen=True)
class Field:
    """One sensor parameter."""

    key: str  # TOML key (in the file's units)
    name: str  # Sensor attribute (g, Hz, s; nonlinearity in 1/g^(n-1))
    kind: Kind
    default: Any  # when a file leaves it out (None: the element is absent)
    doc: str
    scale: float = 1.0  # attribute = file value / scale (µg/g² -> 1/g: 1e6)
    choices: tuple[str, ...] = ()
    upper: float | None = None  # largest allowed value
    why_upper: str = ""  # and why
    identifiable: bool = False  # a campaign can estimate it (a covariance may name it)
    fitted: bool = False  # vrelab identify fits it (identifiable rows only)
    sweepable: bool = False  # a sweep's predict/simulate point may set it
    assumable: bool = False  # a file's [uncertainty] may give it an assumed standard u
    default_fact: str = ""  # the facts text of the default value ("": a file must mark it)
    elements: tuple[str, ...] = ()  # a rails pair's parameter names (low, high)

    @property
    def parameters(self) -> tuple[str, ...]:
        """The parameter names of this row: its key, or one per element of a rails pair."""
        return self.elements or (self.key,)

    @property
    def text_unit(self) -> str:
        """The unit a person reads, from the key's suffix (``µg/g²``; "" for a pure number)."""
        return field_label(self.key)[1] or ""

    @property
    def unit(self) -> str:
        """The unit in ASCII, as ``vrelab identify``'s JSON writes it (``ug/g^2``; ``1`` for a pure number)."""
        text = self.text_unit
        for a, b in (("µ", "u"), ("²", "^2"), ("³", "^3"), ("⁴", "^4"), ("√", "sqrt"), ("°", "deg")):
            text = text.replace(a, b)
        return text or "1"

    def parse(self, raw: Any, where: str) -> Any:
        """A file's value as the attribute's value, or ``ValueError`` naming ``where`` and the key."""
        if self.kind == "bool":
            if not isinstance(raw, bool):
                raise ValueError(f"sensor {where}: {self.key} must be true or false, got {raw!r}")
            return raw
        if self.kind == "choice":
            if raw not in self.choices:
                raise ValueError(f"sensor {where}: {self.key} must be one of {', '.join(self.choices)}; got {raw!r}")
            return raw
        if self.kind == "rails":
            if not isinstance(raw, list) or len(raw) != 2:
                raise ValueError(f"sensor {where}: {self.key} must be [low, high], got {raw!r}")
            return tuple(_number(r, self.key, where) for r in raw)
        if self.kind == "order":
            if not isinstance(raw, int) or isinstance(raw, bool):
                raise ValueError(f"sensor {where}: {self.key} must be an integer, got {raw!r}")
            return raw
        return _number(raw, self.key, where) / self.scale

    def check(self, value: Any, sensor: str) -> None:
        """Validate an attribute value (``None`` allowed where the default is None)."""
        if value is None and self.default is None:
            return
        bad = f"sensor {sensor}: {self.name}"
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{bad} must be true or false, got {value!r}")
            return
        if self.kind == "choice":
            if value not in self.choices:
                raise ValueError(f"{bad} must be one of {', '.join(self.choices)}; got {value!r}")
            return
        if self.kind == "rails":
            rails = tuple(value) if isinstance(value, (tuple, list)) else ()
            if len(rails) != 2 or not all(is_number(r) and math.isfinite(r) for r in rails) or not rails[0] < rails[1]:
                raise ValueError(f"{bad} must be [low, high] with low < high, got {value!r}")
            return
        if self.kind == "order":
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{bad} must be an integer >= 1, got {value!r}")
        elif not is_number(value) or not math.isfinite(value):
            raise ValueError(f"{bad} must be a {'number > 0' if self.kind == 'positive' else 'finite number'}, got {value!r}")
        elif self.kind == "positive" and value <= 0:
            raise ValueError(f"{bad} must be a number > 0, got {value!r}")
        elif self.kind == "non_negative" and value < 0:
            raise ValueError(f"{bad} must be >= 0, got {value!r}")
        if self.upper is not None and value > self.upper:
            raise ValueError(f"{bad} must be at most {self.upper:g} ({self.why_upper}), got {value!r}")


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _number(value: Any, key: str, where: str) -> float:
    if not is_number(value):
        raise ValueError(f"sensor {where}: {key} must be a number, got {value!r}")
    return float(value)


# Default facts and bounds several rows share.
_ZERO = "assumption: 0 (not a datasheet value)"
_NO_CROSS_AXIS = "assumption: 0 (the axis feels only its own axis; no cross-axis sensitivity modelled)"
_NO_COUPLING = "assumption: 0 (no IEEE 1293 cross-coupling; not a datasheet value)"
_WHY_CROSS = "a sensitivity to another axis above half the own one is no accelerometer axis"
_WHY_ORDER = "higher orders are no part's filter and lose precision as second-order sections"

FIELDS: tuple[Field, ...] = (
    Field("full_scale_g", "full_scale_g", "positive", None, "digital full scale [g] (default: the nominal range)"),
    Field("bandwidth_hz", "bandwidth_hz", "positive", None,
          "digital low-pass corner [Hz] (or bandwidth_per_odr × ODR); below ODR/2", assumable=True),
    Field("fn_hz", "fn_hz", "positive", None,
          "proof-mass resonance [Hz] (with q; omit both for none)", upper=1e6,
          why_upper="a resonance above 1 MHz is beyond any accelerometer's; it would only make the simulation rate run away",
          sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("q", "q", "positive", None, "quality factor of the resonance (the gain at fn_hz)",
          sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("k2_ug_per_g2", "k2_per_g", "finite", 0.0, "second-order nonlinearity k2 = K2/K1 [µg/g²] (the VRC)",
          scale=UG_PER_G, default_fact=_ZERO, sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("k3_ug_per_g3", "k3_per_g2", "finite", 0.0, "third-order nonlinearity k3 [µg/g³]", scale=UG_PER_G,
          default_fact=_ZERO, sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("k4_ug_per_g4", "k4_per_g3", "finite", 0.0, "fourth-order nonlinearity k4 [µg/g⁴]", scale=UG_PER_G,
          default_fact=_ZERO),
    Field("rails_g", "rails_g", "rails", None, "[low, high] clip levels [g] (default ±full_scale_g)",
          elements=("rail_low_g", "rail_high_g"), identifiable=True, fitted=True, assumable=True),
    Field("clip_position", "clip_position", "choice", "output",
          "where the rails sit: output (after the low-pass) or proof-mass", choices=("output", "proof-mass")),
    Field("overrange_threshold_g", "overrange_threshold_g", "positive", None,
          "over-range trip level on |proof-mass motion| [g] (omit for none)",
          identifiable=True, fitted=True, assumable=True),
    Field("overrange_hold_s", "overrange_hold_s", "positive", None, "how long the output is held after a trip [s]",
          assumable=True),
    Field("overrange_value_g", "overrange_value_g", "finite", 0.0, "what the output reads while held [g]",
          default_fact="assumption: 0 g (mid-scale) while held; used only with an over-range threshold"),
    Field("overrange_float_tau_s", "overrange_float_tau_s", "non_negative", 0.0,
          "time constant of the float toward overrange_value_g [s] (0: a jump)",
          default_fact="assumption: 0 (a jump); used only with an over-range threshold"),
    Field("overrange_retrigger", "overrange_retrigger", "bool", True,
          "a hold re-arms while the input stays beyond the threshold"),
    Field("noise_ug_per_rthz", "noise_ug_per_rthz", "non_negative", 0.0, "noise density [µg/√Hz]",
          default_fact="assumption: noiseless"),
    Field("lsb_g", "lsb_g", "positive", None, "output resolution [g] (omit for none)"),
    Field("anti_alias_hz", "anti_alias_hz", "positive", None, "analog anti-alias corner [Hz] (omit for none)",
          assumable=True),
    Field("anti_alias_order", "anti_alias_order", "order", None,
          "anti-alias Butterworth order (default 2)", upper=12, why_upper=_WHY_ORDER, assumable=True),
    Field("lowpass_order", "lowpass_order", "order", None,
          "digital low-pass order (default 4)", upper=12, why_upper=_WHY_ORDER, assumable=True),
    Field("lowpass_kind", "lowpass_kind", "choice", "butterworth", "digital low-pass family",
          choices=("butterworth", "bessel")),
    Field("highpass_hz", "highpass_hz", "positive", None, "high-pass corner [Hz] (omit: off)"),
    Field("offset_g", "offset_g", "finite", 0.0, "0 g offset [g], added before the output rails", sweepable=True,
          default_fact="assumption: 0 g offset 0 (a parameter)"),
    Field("drift_g_per_s", "drift_g_per_s", "finite", 0.0, "slow linear output drift [g/s]",
          default_fact="assumption: 0 (no bias drift simulated unless set; a parameter)"),
    # Beyond one axis (SPEC 1.6, IEEE 1293): this axis's cross-axis sensitivity row (its output
    # per g along x, y, z relative to its own sensitivity; its own entry stays 0) and the model
    # equation's second-order cross-coupling coefficients, on the triad (i, p, o) = this axis,
    # pendulous_axis and the third.
    Field("cross_axis_x", "cross_axis_x", "finite", 0.0, "cross-axis sensitivity to x [g/g] (0 on the x axis itself)",
          upper=0.5, why_upper=_WHY_CROSS, sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS),
    Field("cross_axis_y", "cross_axis_y", "finite", 0.0, "cross-axis sensitivity to y [g/g] (0 on the y axis itself)",
          upper=0.5, why_upper=_WHY_CROSS, sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS),
    Field("cross_axis_z", "cross_axis_z", "finite", 0.0, "cross-axis sensitivity to z [g/g] (0 on the z axis itself)",
          upper=0.5, why_upper=_WHY_CROSS, sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS),
    Field("input_axis", "input_axis", "choice", None,
          "which of the part's x, y, z this axis senses (default: the axis's own name; an identified file "
          "names its axes by campaign channel)", choices=("x", "y", "z")),
    Field("pendulous_axis", "pendulous_axis", "choice", None,
          "IEEE 1293 pendulous axis p (default: the next axis, x->y->z->x); o is the third",
          choices=("x", "y", "z")),
    # fitted by vrelab identify from a campaign's mount-angle runs (IEEE 1293's IP and IO planes);
    # Kpo needs a p-o plane mount, which those runs do not excite: identifiable, not fitted
    Field("kip_ug_per_g2", "kip_per_g", "finite", 0.0, "cross-coupling Kip, output per a_i·a_p [µg/g²]",
          scale=UG_PER_G, identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("kio_ug_per_g2", "kio_per_g", "finite", 0.0, "cross-coupling Kio, output per a_i·a_o [µg/g²]",
          scale=UG_PER_G, identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("kpp_ug_per_g2", "kpp_per_g", "finite", 0.0, "cross-axis nonlinearity Kpp, output per a_p² [µg/g²]",
          scale=UG_PER_G, identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("koo_ug_per_g2", "koo_per_g", "finite", 0.0, "cross-axis nonlinearity Koo, output per a_o² [µg/g²]",
          scale=UG_PER_G, identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("kpo_ug_per_g2", "kpo_per_g", "finite", 0.0, "cross-coupling Kpo, output per a_p·a_o [µg/g²]",
          scale=UG_PER_G, identifiable=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
)

# The kinds whose value is a number (or a pair of numbers): every file marks where it comes from.
NUMERIC_KINDS: tuple[Kind, ...] = ("positive", "finite", "non_negative", "order", "rails")


# Views of the table, read at call time (so a row added to FIELDS, even patched in by a test,
# reaches every user without a second list to keep in step).

def by_key() -> dict[str, Field]:
    """The rows by file key."""
    return {f.key: f for f in FIELDS}


def numeric() -> tuple[str, ...]:
    """The ``Sensor`` attributes of the numeric rows (each one a file marks in ``facts``)."""
    return tuple(f.name for f in FIELDS if f.kind in NUMERIC_KINDS)


def sweepable() -> tuple[Field, ...]:
    """The rows a sweep's predict/simulate point may set, by file key."""
    return tuple(f for f in FIELDS if f.sweepable)


def _flags(f: Field) -> str:
    flags = ("I" if f.fitted else "i" if f.identifiable else "") + ("s" if f.sweepable else "") + ("u" if f.assumable else "")
    return flags or "-"


def schema_text() -> str:
    """The value keys as the presets README lists them (a test holds the README to this;
    :func:`update_readme` rewrites the README's copy)."""
    pairs = "; ".join(f"{f.key} holds the parameters {' and '.join(f.elements)}" for f in FIELDS if f.elements)
    lines = [
        "Value keys (top level, `[axes.*]` or `[ranges.*]`), from vrelab/sensor/fields.py. Flags: i identifiable",
        "(a campaign's covariance may name it; I: `vrelab identify` fits it), s a sweep may set it (by the key),",
        f"u an `[uncertainty]` table may give it an assumed standard uncertainty; {pairs}.",
        "",
    ]
    for f in FIELDS:
        default = "absent" if f.default is None else repr(f.default).lower() if isinstance(f.default, bool) else f"{f.default!r}"
        bound = f"; at most {f.upper:g}" if f.upper is not None else ""
        lines.append(f"    {f.key:<24} {f.kind:<13} default {default:<14} {_flags(f):<4} {f.doc}{bound}")
    return "\n".join(lines) + "\n"


def update_readme() -> Path:
    """Rewrite the presets README's copy of :func:`schema_text` (after a row changed)."""
    path = Path(__file__).with_name("presets") / "README"
    text = path.read_text(encoding="utf-8")
    start = text.index("Value keys (top level")
    rows = text.index("\n\n", start) + 2
    end = text.index("\n\n", rows) + 1
    path.write_text(text[:start] + schema_text() + text[end:], encoding="utf-8")
    return path

