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
from typing import Any, Iterable, Literal, Mapping

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
    upper: float | None = None  # largest allowed value, in the file's units
    why_upper: str = ""  # and why
    lower: float | None = None  # smallest allowed value, in the file's units (beyond the kind's own)
    why_lower: str = ""  # and why
    needs: str = ""  # the attribute without which this one has no effect ("": acts alone)
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
            for r in rails:
                self._check_bounds(r, sensor)
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
        self._check_bounds(value, sensor)

    def _check_bounds(self, value: float, sensor: str) -> None:
        """The row's physical bounds (``lower``, ``upper``, in the file's units), naming the file key."""
        v = float(value) * self.scale
        unit = f" {self.text_unit}" if self.text_unit else ""
        if self.upper is not None and v > self.upper:
            raise ValueError(f"sensor {sensor}: {self.key} must be at most {self.upper:g} ({self.why_upper}), "
                             f"got {v:g}{unit}")
        if self.lower is not None and v < self.lower:
            raise ValueError(f"sensor {sensor}: {self.key} must be at least {self.lower:g} ({self.why_lower}), "
                             f"got {v:g}{unit}")

    def span(self) -> float:
        """The width of the row's physical bounds in the file's units (inf where one is open): a
        standard uncertainty wider than this is outside any physical bound (:func:`check_u`)."""
        lower = self.lower if self.lower is not None else (0.0 if self.kind in ("positive", "non_negative") else None)
        if self.upper is None or lower is None:
            return math.inf
        return self.upper - lower


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
# Physical bounds (file units), each with its reason: a value beyond them is a slip (a unit, an
# exponent), and the closed forms' arithmetic (squares, Hermite moments) overflows long before
# float64 does. An acceleration [g]: ten times the largest vibration or static field vrelab takes
# (vrelab._validate.MAX_ACCELERATION_G, pyroshock's 1e5 g), so a rail or threshold beyond it is
# never reached.
_MAX_G = 1e6
_WHY_G = "ten times the largest acceleration vrelab takes (1e5 g, pyroshock): never reached"
# A nonlinearity coefficient [µg/g^(n-1)]: 1e6 is k_n = 1 g^(1-n), the term as large as the linear
# one at 1 g; the transfer is then not monotonic beyond about ±0.5 g (dy/da = 1 + n·k_n·a^(n-1)
# vanishes), which is no accelerometer's over any range.
_MAX_K = 1e6
_WHY_K = "1e6 is the term as large as the linear one at 1 g: no accelerometer's transfer"
# A frequency [Hz]: the range vrelab's drives take (vrelab._validate.MIN_FREQ_HZ..MAX_FREQ_HZ).
_WHY_FREQ = "beyond any vibration test's frequencies"
_WHY_HOLD = "an over-range recovery is a circuit's (ADXL355: 0.5 ms); beyond 10 s the part is off, not protected"
_NEEDS_THRESHOLD = "overrange_threshold_g"

FIELDS: tuple[Field, ...] = (
    Field("full_scale_g", "full_scale_g", "positive", None, "digital full scale [g] (default: the nominal range)",
          upper=_MAX_G, why_upper=_WHY_G),
    Field("bandwidth_hz", "bandwidth_hz", "positive", None,
          "output low-pass corner [Hz] (or bandwidth_per_odr × ODR): the digital low-pass below ODR/2, or without "
          "an ODR the analog output filter", lower=1e-6, why_lower=_WHY_FREQ, upper=1e7, why_upper=_WHY_FREQ,
          assumable=True),
    Field("fn_hz", "fn_hz", "positive", None,
          "proof-mass resonance [Hz] (with q; omit both for none)", upper=1e6, lower=0.1,
          why_lower="an accelerometer works below its resonance: a proof mass resonating below 0.1 Hz is a "
          "seismometer's",
          why_upper="a resonance above 1 MHz is beyond any accelerometer's; it would only make the simulation rate run away",
          sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("q", "q", "positive", None, "quality factor of the resonance (the gain at fn_hz)",
          lower=0.01, why_lower="below 0.01 a mass is so overdamped that no resonance is left to speak of",
          upper=1e5, why_upper="vacuum-packaged MEMS resonators reach 1e4 to 1e5; no accelerometer's proof mass beyond",
          sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("k2_ug_per_g2", "k2_per_g", "finite", 0.0, "second-order nonlinearity k2 = K2/K1 [µg/g²] (the VRC)",
          scale=UG_PER_G, default_fact=_ZERO, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("k3_ug_per_g3", "k3_per_g2", "finite", 0.0, "third-order nonlinearity k3 [µg/g³]", scale=UG_PER_G,
          default_fact=_ZERO, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          sweepable=True, identifiable=True, fitted=True, assumable=True),
    Field("k4_ug_per_g4", "k4_per_g3", "finite", 0.0, "fourth-order nonlinearity k4 [µg/g⁴]", scale=UG_PER_G,
          default_fact=_ZERO, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K),
    Field("rails_g", "rails_g", "rails", None, "[low, high] clip levels [g] (default ±full_scale_g)",
          elements=("rail_low_g", "rail_high_g"), lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G, why_upper=_WHY_G,
          identifiable=True, fitted=True, assumable=True),
    Field("clip_position", "clip_position", "choice", "output",
          "where the rails sit: output (after the low-pass) or proof-mass", choices=("output", "proof-mass")),
    Field("overrange_threshold_g", "overrange_threshold_g", "positive", None,
          "over-range trip level on |proof-mass motion| [g] (omit for none)", upper=_MAX_G, why_upper=_WHY_G,
          identifiable=True, fitted=True, assumable=True),
    Field("overrange_hold_s", "overrange_hold_s", "positive", None, "how long the output is held after a trip [s]",
          upper=10.0, why_upper=_WHY_HOLD, needs=_NEEDS_THRESHOLD, assumable=True),
    Field("overrange_value_g", "overrange_value_g", "finite", 0.0, "what the output reads while held [g]",
          lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G, why_upper=_WHY_G, needs=_NEEDS_THRESHOLD,
          default_fact="assumption: 0 g (mid-scale) while held; used only with an over-range threshold"),
    Field("overrange_float_tau_s", "overrange_float_tau_s", "non_negative", 0.0,
          "time constant of the float toward overrange_value_g [s] (0: a jump)", upper=10.0, why_upper=_WHY_HOLD,
          needs=_NEEDS_THRESHOLD, default_fact="assumption: 0 (a jump); used only with an over-range threshold"),
    Field("overrange_retrigger", "overrange_retrigger", "bool", True,
          "a hold re-arms while the input stays beyond the threshold", needs=_NEEDS_THRESHOLD),
    Field("noise_ug_per_rthz", "noise_ug_per_rthz", "non_negative", 0.0, "noise density [µg/√Hz]",
          upper=1e7, why_upper="10 g/√Hz buries any vibration test's signal: no sensor's noise",
          default_fact="assumption: noiseless"),
    Field("lsb_g", "lsb_g", "positive", None, "output resolution [g] (omit for none)", upper=_MAX_G,
          why_upper=_WHY_G),
    Field("anti_alias_hz", "anti_alias_hz", "positive", None, "analog anti-alias corner [Hz] (omit for none)",
          lower=1e-6, why_lower=_WHY_FREQ, upper=1e7, why_upper=_WHY_FREQ, assumable=True),
    Field("anti_alias_order", "anti_alias_order", "order", None,
          "anti-alias Butterworth order (default 2)", upper=12, why_upper=_WHY_ORDER, needs="anti_alias_hz",
          assumable=True),
    Field("lowpass_order", "lowpass_order", "order", None,
          "output low-pass order (default 4)", upper=12, why_upper=_WHY_ORDER, needs="bandwidth_hz", assumable=True),
    Field("lowpass_kind", "lowpass_kind", "choice", "butterworth", "output low-pass family",
          choices=("butterworth", "bessel"), needs="bandwidth_hz"),
    Field("highpass_hz", "highpass_hz", "positive", None, "high-pass corner [Hz] (omit: off)",
          lower=1e-6, why_lower=_WHY_FREQ, upper=1e7, why_upper=_WHY_FREQ),
    Field("offset_g", "offset_g", "finite", 0.0, "0 g offset [g], added before the output rails", sweepable=True,
          lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G, why_upper=_WHY_G,
          default_fact="assumption: 0 g offset 0 (a parameter)"),
    Field("drift_g_per_s", "drift_g_per_s", "finite", 0.0, "slow linear output drift [g/s]",
          lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G + " in a second", why_upper=_WHY_G + " in a second",
          default_fact="assumption: 0 (no bias drift simulated unless set; a parameter)"),
    # Beyond one axis (SPEC 1.6, IEEE 1293): this axis's cross-axis sensitivity row (its output
    # per g along x, y, z relative to its own sensitivity; its own entry stays 0) and the model
    # equation's second-order cross-coupling coefficients, on the triad (i, p, o) = this axis,
    # pendulous_axis and the third.
    Field("cross_axis_x", "cross_axis_x", "finite", 0.0, "cross-axis sensitivity to x [g/g] (0 on the x axis itself)",
          upper=0.5, why_upper=_WHY_CROSS, lower=-0.5, why_lower=_WHY_CROSS, sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS),
    Field("cross_axis_y", "cross_axis_y", "finite", 0.0, "cross-axis sensitivity to y [g/g] (0 on the y axis itself)",
          upper=0.5, why_upper=_WHY_CROSS, lower=-0.5, why_lower=_WHY_CROSS, sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS),
    Field("cross_axis_z", "cross_axis_z", "finite", 0.0, "cross-axis sensitivity to z [g/g] (0 on the z axis itself)",
          upper=0.5, why_upper=_WHY_CROSS, lower=-0.5, why_lower=_WHY_CROSS, sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS),
    Field("input_axis", "input_axis", "choice", None,
          "which of the part's x, y, z this axis senses (default: the axis's own name; an identified file "
          "names its axes by campaign channel)", choices=("x", "y", "z")),
    Field("pendulous_axis", "pendulous_axis", "choice", None,
          "IEEE 1293 pendulous axis p (default: the next axis, x->y->z->x); o is the third",
          choices=("x", "y", "z")),
    # fitted by vrelab identify from a campaign's mount-angle runs (IEEE 1293's IP and IO planes);
    # Kpo needs a p-o plane mount, which those runs do not excite: identifiable, not fitted
    Field("kip_ug_per_g2", "kip_per_g", "finite", 0.0, "cross-coupling Kip, output per a_i·a_p [µg/g²]",
          scale=UG_PER_G, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("kio_ug_per_g2", "kio_per_g", "finite", 0.0, "cross-coupling Kio, output per a_i·a_o [µg/g²]",
          scale=UG_PER_G, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("kpp_ug_per_g2", "kpp_per_g", "finite", 0.0, "cross-axis nonlinearity Kpp, output per a_p² [µg/g²]",
          scale=UG_PER_G, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("koo_ug_per_g2", "koo_per_g", "finite", 0.0, "cross-axis nonlinearity Koo, output per a_o² [µg/g²]",
          scale=UG_PER_G, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          identifiable=True, fitted=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
    Field("kpo_ug_per_g2", "kpo_per_g", "finite", 0.0, "cross-coupling Kpo, output per a_p·a_o [µg/g²]",
          scale=UG_PER_G, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
          identifiable=True, sweepable=True, assumable=True, default_fact=_NO_COUPLING),
)

# The kinds whose value is a number (or a pair of numbers): every file marks where it comes from.
NUMERIC_KINDS: tuple[Kind, ...] = ("positive", "finite", "non_negative", "order", "rails")


# Views of the table, read at call time (so a row added to FIELDS, even patched in by a test,
# reaches every user without a second list to keep in step).

def by_key() -> dict[str, Field]:
    """The rows by file key."""
    return {f.key: f for f in FIELDS}


def by_name() -> dict[str, Field]:
    """The rows by ``Sensor`` attribute."""
    return {f.name: f for f in FIELDS}


def numeric() -> tuple[str, ...]:
    """The ``Sensor`` attributes of the numeric rows (each one a file marks in ``facts``)."""
    return tuple(f.name for f in FIELDS if f.kind in NUMERIC_KINDS)


def sweepable() -> tuple[Field, ...]:
    """The rows a sweep's predict/simulate point may set, by file key."""
    return tuple(f for f in FIELDS if f.sweepable)


def idle(values: Mapping[str, Any], given: Iterable[str]) -> list[Field]:
    """The rows among ``given`` (attribute names a file or a user set) that have no effect given
    the others: their ``needs`` attribute is absent (None) in ``values`` (the resolved attributes).
    A sensor file means what it says: the loader refuses each, naming it."""
    chosen = set(given)
    return [f for f in FIELDS if f.needs and f.name in chosen and values.get(f.needs) is None]


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
        bound = (f"; within {f.lower:g}..{f.upper:g}" if f.lower is not None and f.upper is not None
                 else f"; at most {f.upper:g}" if f.upper is not None else f"; at least {f.lower:g}" if f.lower is not None
                 else "")
        keys = {g.name: g.key for g in FIELDS}
        bound += f"; only with {keys.get(f.needs, f.needs)}" if f.needs else ""
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

