"""What ``vrelab compare`` weighs: the candidates (a part, its range and output rate), the budget
(a VRE or a tilt error) and the static field (a number or a tilt range)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Sequence

from vrelab import _validate as V
from vrelab.units import UG_PER_G

# A tilt range is judged at its ends, its middle and at 0 where it spans level: the tilt
# conversion 1/cos θ grows toward the ends, the clipping asymmetry with |sin θ|; a range is
# sampled, not searched.
_TILT_SAMPLES = 3


@dataclass(frozen=True)
class Candidate:
    """One configuration of one part: a preset name or a sensor file, its range [g] and output
    rate [Hz] (None: the file's default; a part without an ODR has none), its axis (None: the
    file's default axis).

    Examples
    --------
    The ADXL355 at ±2 g and 4000 Hz, as ``--candidates`` writes it and as a table labels it:

    >>> from vrelab.comparison.candidates import Candidate
    >>> candidate = Candidate("adxl355", range_g=2.0, odr_hz=4000.0)
    >>> print(candidate.spec, "|", candidate.label)
    adxl355:2g:4000 | adxl355 ±2 g 4000 Hz
    """

    part: str
    range_g: float | None = None
    odr_hz: float | None = None
    axis: str | None = None

    @property
    def label(self) -> str:
        """``adxl355 ±2 g 4000 Hz`` (a part without an ODR: ``no ODR``)."""
        rng = f"±{self.range_g:g} g" if self.range_g is not None else "default range"
        rate = f"{self.odr_hz:g} Hz" if self.odr_hz is not None else "no ODR"
        return f"{self.part} {rng} {rate}" + (f" axis {self.axis}" if self.axis else "")

    @property
    def spec(self) -> str:
        """The candidate as ``--candidates`` writes it: ``part:RANGEg:ODR[:axis]``."""
        parts = [self.part, f"{self.range_g:g}g" if self.range_g is not None else "",
                 f"{self.odr_hz:g}" if self.odr_hz is not None else ""]
        if self.axis:
            parts.append(self.axis)
        return ":".join(parts).rstrip(":")


def parse_candidates(text: str) -> list[Candidate]:
    """``adxl355:2g:4000,my_part.toml:8:500,adxl354:4g``: ``PART[:RANGE[g][:ODR[Hz][:AXIS]]]``
    separated by commas (an empty field: the part's default). Each part is checked when it is
    loaded (:func:`loaded`), not here.

    Examples
    --------
    A preset at a range and rate, a sensor file at ±8 g and 500 Hz, a part without an ODR:

    >>> from vrelab.comparison.candidates import parse_candidates
    >>> for candidate in parse_candidates("adxl355:2g:4000,my_part.toml:8:500,adxl354:4g"):
    ...     print(candidate.label)
    adxl355 ±2 g 4000 Hz
    my_part.toml ±8 g 500 Hz
    adxl354 ±4 g no ODR
    """
    items = [t.strip() for t in str(text).split(",")]
    if not items or any(not t for t in items):
        raise ValueError(f"--candidates: give PART[:RANGE[:ODR[:AXIS]]] separated by commas, got {text!r}")
    out = []
    for item in items:
        fields = item.split(":")
        if len(fields) > 4:
            raise ValueError(f"--candidates: {item!r} has more than PART:RANGE:ODR:AXIS")
        part, rng, odr, axis = (fields + ["", "", ""])[:4]
        out.append(Candidate(part.strip(), _number(rng, "g", "range", item), _number(odr, "hz", "ODR", item),
                             axis.strip() or None))
    return out


def _number(text: str, unit: str, what: str, item: str) -> float | None:
    t = text.strip().lower()
    if not t:
        return None
    t = t[: -len(unit)] if t.endswith(unit) else t
    try:
        value = float(t)
    except ValueError:
        raise ValueError(f"--candidates: the {what} of {item!r} must be a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"--candidates: the {what} of {item!r} must be a number > 0, got {text!r}")
    return value


def default_candidates() -> list[Candidate]:
    """Every preset that lists its ranges (a part; ``ideal`` takes any range and is none) at
    each range and each output rate it lists (a part without an ODR: once per range).

    Examples
    --------
    The ADXL355's three ranges at its 4000 Hz rate are among them; the ideal part is not:

    >>> from vrelab.comparison.candidates import default_candidates
    >>> candidates = default_candidates()
    >>> [c.label for c in candidates if c.part == "adxl355" and c.odr_hz == 4000]
    ['adxl355 ±2 g 4000 Hz', 'adxl355 ±4 g 4000 Hz', 'adxl355 ±8 g 4000 Hz']
    >>> any(c.part == "ideal" for c in candidates)
    False
    """
    from vrelab.sensor import list_presets, load_sensor

    out = []
    for name in list_presets():
        s = load_sensor(name)
        for r in s.ranges_g:
            out += [Candidate(name, float(r), float(o) if o is not None else None) for o in (s.odrs_hz or (None,))]
    return out


@dataclass(frozen=True)
class Budget:
    """What the designer allows: a VRE [g] (``kind`` "vre") or a tilt error [deg] (``kind`` "tilt").

    A tilt error from a VRE at the static orientation: an axis at tilt θ reads ``g0 = g·sin θ``
    with no vibration and ``g0 + δ`` with a VRE δ, which it takes for the tilt
    ``asin((g0 + δ)/g)``. To first order in δ (Taylor, d asin(x)/dx = 1/sqrt(1 − x²) = 1/cos θ),
    ``δθ ≈ δ/(g·cos θ)`` rad; the next term, ``tan θ·δθ²/2``, is below 1e-4 of δθ for
    δθ < 0.1° at |θ| < 60° (a budget's tenths of a degree). So a tilt budget ``δθ_max`` is a
    VRE budget ``g·cos θ·δθ_max`` at that orientation (:meth:`limit_g`), and a VRE's tilt error
    is :meth:`tilt_deg` (:func:`vrelab.models.design.tilt_error_from_static_deg` is the exact
    ``asin`` difference; physics §1.5, §4).

    Examples
    --------
    On an axis tilted 30° (static 0.5 g), a tilt budget of 0.05° is a VRE budget of
    ``g·cos 30°·0.05°`` = 0.756 mg; a VRE of 1 mg there is a tilt error of 0.0662°, to first
    order as the exact ``asin`` difference (0.06616° against 0.06618°):

    >>> from vrelab.comparison.candidates import Budget
    >>> from vrelab.models.design import tilt_error_from_static_deg
    >>> budget = Budget("tilt", 0.05)
    >>> print(f"{budget.text}: VRE {budget.limit_g(0.5) * 1e3:.3f} mg at 0.5 g")
    tilt error 0.05 deg: VRE 0.756 mg at 0.5 g
    >>> print(f"{Budget.tilt_deg(1e-3, 0.5):.4f} deg, exact {tilt_error_from_static_deg(1e-3, 0.5):.4f} deg")
    0.0662 deg, exact 0.0662 deg
    """

    kind: str  # "vre" or "tilt"
    value: float  # g (vre) or deg (tilt)

    @property
    def text(self) -> str:
        return f"VRE {self.value * 1e3:g} mg" if self.kind == "vre" else f"tilt error {self.value:g} deg"

    def limit_g(self, static_g: float) -> float:
        """The budget as a VRE [g] at the static field ``static_g`` [g] along the axis."""
        if self.kind == "vre":
            return self.value
        return math.radians(self.value) * _cos_tilt(static_g)

    @staticmethod
    def tilt_deg(vre_g: float, static_g: float) -> float:
        """The tilt error [deg] of a VRE at ``static_g``, ``δ/(g·cos θ)`` (first order; class docstring)."""
        return math.degrees(vre_g / _cos_tilt(static_g))


def _cos_tilt(static_g: float) -> float:
    from vrelab.models.design import NEAR_VERTICAL_G

    if abs(static_g) > 1.0 - NEAR_VERTICAL_G:
        raise ValueError(f"a tilt error needs a static field away from ±1 g (the axis is vertical: a tilt barely "
                         f"moves its reading), got {static_g:g} g; give --static below 1 or --tilt-range")
    return math.sqrt(1.0 - static_g * static_g)


_VRE_UNITS = {"g": 1.0, "mg": 1e-3, "ug": 1.0 / UG_PER_G, "µg": 1.0 / UG_PER_G}


def parse_budget(vre: str | None, tilt: str | None) -> Budget:
    """``--budget-vre 1mg`` (g, mg, ug) or ``--budget-tilt 0.05deg`` (deg; the unit optional): exactly one.

    Examples
    --------
    >>> from vrelab.comparison.candidates import parse_budget
    >>> budget = parse_budget("500ug", None)
    >>> print(budget.kind, f"{budget.value * 1e3:.1f} mg")
    vre 0.5 mg
    >>> parse_budget(None, "0.05deg")
    Budget(kind='tilt', value=0.05)
    >>> parse_budget("1mg", "0.05deg")
    Traceback (most recent call last):
    ...
    ValueError: give one budget: --budget-vre (e.g. 1mg) or --budget-tilt (e.g. 0.05deg)
    """
    if (vre is None) == (tilt is None):
        raise ValueError("give one budget: --budget-vre (e.g. 1mg) or --budget-tilt (e.g. 0.05deg)")
    if vre is not None:
        m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*(g|mg|ug|µg)\s*", str(vre))
        if m is None:
            raise ValueError(f"--budget-vre must be a number with its unit (g, mg, ug), e.g. 1mg; got {vre!r}")
        value = _positive(m.group(1), "--budget-vre", vre) * _VRE_UNITS[m.group(2)]
        return Budget("vre", value)
    m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*(deg)?\s*", str(tilt))
    if m is None:
        raise ValueError(f"--budget-tilt must be a number of degrees, e.g. 0.05deg; got {tilt!r}")
    value = _positive(m.group(1), "--budget-tilt", tilt)
    if value >= 90:
        raise ValueError(f"--budget-tilt must be below 90 deg, got {tilt!r}")
    return Budget("tilt", value)


def _positive(text: str, name: str, given: object) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{name} must be a number with its unit, got {given!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be > 0, got {given!r}")
    return value


def static_fields(static_g: float | None, tilt_range_deg: Sequence[float] | None) -> list[float]:
    """The static fields [g] a candidate is judged at: ``static_g``, or a tilt range [deg] sampled
    at its ends and middle (and 0 where it spans it), each ``sin θ``.

    Examples
    --------
    An axis tilted anywhere from -30° to 30° is judged at -30°, 0° and 30°, static ``sin θ``;
    one from 10° to 40° at its ends and middle (sin 10° = 0.174, sin 25° = 0.423, sin 40° = 0.643):

    >>> from vrelab.comparison.candidates import static_fields
    >>> print([f"{g:.3f}" for g in static_fields(None, (-30.0, 30.0))])
    ['-0.500', '0.000', '0.500']
    >>> print([f"{g:.3f}" for g in static_fields(None, (10.0, 40.0))])
    ['0.174', '0.423', '0.643']
    >>> static_fields(0.5, None)
    [0.5]
    """
    if tilt_range_deg is None:
        return [float(V.acceleration("--static", 1.0 if static_g is None else static_g))]
    lo, hi = (float(V.finite_scalar("--tilt-range", t)) for t in tilt_range_deg)
    if not -90 < lo <= hi < 90:
        raise ValueError(f"--tilt-range must be a:b degrees with -90 < a <= b < 90, got {lo:g}:{hi:g}")
    angles = {lo + (hi - lo) * k / (_TILT_SAMPLES - 1) for k in range(_TILT_SAMPLES)}
    if lo < 0 < hi:
        angles.add(0.0)
    return [math.sin(math.radians(a)) for a in sorted(angles)]


def parse_tilt_range(text: str) -> tuple[float, float]:
    """``--tilt-range a:b`` [deg].

    Examples
    --------
    >>> from vrelab.comparison.candidates import parse_tilt_range
    >>> parse_tilt_range("-30:30")
    (-30.0, 30.0)
    """
    parts = str(text).split(":")
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"--tilt-range must be a:b in degrees, e.g. -30:30; got {text!r}") from None
    return lo, hi
