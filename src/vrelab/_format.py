"""How numbers are shown to a person and written to JSON: the one owner of each rule.

Every number vrelab shows (CLI tables, the report's tables, prose and figure labels, the JSON's
human-readable fields) goes through this module; the JSON's numeric fields are never rounded.

* :func:`finite_or_none` — JSON has no NaN/inf: a non-finite number is written as ``null``.
* :func:`format_value_u` — ``value ± u unit``: the uncertainty rounded to two significant digits
  and the value rounded at the uncertainty's last digit (GUM, JCGM 100:2008, 7.2.6: "the numerical
  values of the estimate y and its standard uncertainty u(y) should not be given with an excessive
  number of digits ... it usually suffices to quote u(y) [to] at most two significant digits").
  ``20908 ± 538`` is shown ``20910 ± 540``; ``2.6431 ± 0.0149`` is shown ``2.643 ± 0.015``.
* :func:`format_u` — an uncertainty (u or an expanded U) alone: two significant digits.
* :func:`format_value` — a value without an uncertainty: rounded at its ``resolution`` when one is
  known (a value below half of it is shown ``0``), else four significant digits.
* :func:`format_mg` / :func:`format_mg_text` — the same rules for a VRE [g] shown in mg.

Very small or very large numbers (below 1e-4 or from 1e6 on) are written with a power of ten so
that a table cell never holds ``-8.943e-112`` or 20 digits.
"""

from __future__ import annotations

import math
from typing import SupportsFloat, TextIO, TypeGuard

from vrelab.units import UG_PER_G

# What a missing or non-finite number shows as in a table.
MISSING = "–"
# GUM 7.2.6: an uncertainty is quoted with (at most) two significant digits.
U_DIGITS = 2
# A value without an uncertainty or a resolution: four significant digits.
VALUE_DIGITS = 4
# A model's prediction has no uncertainty to round at: its VRE and shares are shown to 1 µg
# (0.001 mg), well below any measured u; a smaller share shows as 0.
PREDICTION_RESOLUTION_MG = 0.001
# The tilt error a VRE means [°], shown to this resolution.
TILT_RESOLUTION_DEG = 1e-4
# Outside [SMALL, LARGE) a number is shown with a power of ten.
_SMALL, _LARGE = 1e-4, 1e6
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def finite_or_none(x: SupportsFloat | None) -> float | None:
    """``float(x)``, or ``None`` when ``x`` is None, NaN or infinite (JSON has no NaN/inf)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _usable(x: float | None) -> TypeGuard[float]:
    return x is not None and math.isfinite(float(x))


def _last_digit(u: float) -> int:
    """Decimal exponent of the last of ``u``'s two significant digits once ``u`` is rounded to them
    (0.0149 → -3, 538 → 1, 0.0996 → -2: it rounds to 0.10)."""
    e = math.floor(math.log10(u)) - (U_DIGITS - 1)
    if round(u / 10.0**e) >= 10**U_DIGITS:  # rounding carried into a new digit: 0.0996 → 0.10
        e += 1
    return e


def _fixed(x: float, last: int, signed: bool = False) -> str:
    """``x`` rounded at the decimal exponent ``last`` (-2 → hundredths, 1 → tens), in fixed point."""
    sign = "+" if signed else ""
    if last >= 0:
        r = round(x / 10.0**last) * 10**last
        return f"{r:{sign}d}" if r != 0 or not signed else "0"
    r = round(x, -last)
    return f"{r if r != 0 else 0.0:{sign}.{-last}f}"  # never "-0.000"


def _power(x: float) -> int:
    return math.floor(math.log10(abs(x))) if x != 0 else 0


def _with_unit(text: str, unit: str | None) -> str:
    return text if not unit or text == MISSING else f"{text} {unit}"


def format_value_u(value: float | None, u: float | None = None, scale: float = 1.0, signed: bool = False,
                   unit: str | None = None, resolution: float | None = None) -> str:
    """``value·scale ± u·scale unit`` by GUM 7.2.6 (see the module notes).

    Without a usable uncertainty (None, non-finite or ≤ 0) the value alone, by :func:`format_value`
    (rounded at ``resolution`` when given, else four significant digits). ``"–"`` when the value is
    missing or not finite.
    """
    if not _usable(value):
        return MISSING
    if not _usable(u) or float(u) <= 0:
        return format_value(value, scale=scale, signed=signed, unit=unit, resolution=resolution)
    v, uu = float(value) * scale, float(u) * scale
    if resolution is not None and resolution > 0 and uu < resolution:
        # a u below the resolution the number is shown at (a prediction's 1e-14 mg from a far-off
        # over-range threshold) is said as such, not written out to its own last digit
        at = math.floor(math.log10(resolution) + 1e-9)
        shown = "0" if abs(v) < resolution / 2 else _fixed(v, at, signed)
        return _with_unit(f"{shown} ± <{_fixed(resolution, at)}", unit)
    last = _last_digit(uu)
    big = max(abs(v), uu)
    if big >= _LARGE or big < _SMALL:  # a common power of ten: (1.234 ± 0.012)·10⁻⁵
        p = _power(big)
        s = 10.0**-p
        body = f"({_fixed(v * s, last - p, signed)} ± {_fixed(uu * s, last - p)})·10{str(p).translate(_SUPERSCRIPT)}"
        return _with_unit(body, unit)
    return _with_unit(f"{_fixed(v, last, signed)} ± {_fixed(uu, last)}", unit)


def u_resolution(u: float | None) -> float | None:
    """The place of ``u``'s last shown digit (0.0149 → 0.001, 538 → 10): the resolution at which
    numbers that go with ``u`` (an interval v ± U, a limit) are shown. None without a usable u."""
    if not _usable(u) or float(u) <= 0:
        return None
    return 10.0 ** _last_digit(float(u))


def format_u(u: float | None, scale: float = 1.0, unit: str | None = None) -> str:
    """An uncertainty alone (a standard u or an expanded U): two significant digits (GUM 7.2.6)."""
    if not _usable(u) or float(u) < 0:
        return MISSING
    uu = float(u) * scale
    if uu == 0:
        return _with_unit("0", unit)
    if uu >= _LARGE or uu < _SMALL:
        return _with_unit(f"{uu:.{U_DIGITS - 1}e}", unit)
    return _with_unit(_fixed(uu, _last_digit(uu)), unit)


def format_value(value: float | None, scale: float = 1.0, signed: bool = False, unit: str | None = None,
                 resolution: float | None = None, digits: int = VALUE_DIGITS) -> str:
    """A value without an uncertainty.

    With ``resolution`` (in the shown unit, after ``scale``): rounded at it, and a value smaller
    than half of it is shown ``0`` (a prediction of -8.9e-112 mg is 0 at a 0.001 mg resolution).
    Without: ``digits`` significant digits (trailing zeros dropped, the integer part never
    rounded), with a power of ten outside [1e-4, 1e6).
    """
    if not _usable(value):
        return MISSING
    sign = "+" if signed else ""
    if isinstance(value, int) and not isinstance(value, bool) and scale == 1.0 and resolution is None:
        return _with_unit(f"{value:{sign}d}", unit)  # a count is exact: all its digits
    v = float(value) * scale
    if resolution is not None and resolution > 0:
        if abs(v) < resolution / 2:
            return _with_unit("0", unit)
        return _with_unit(_fixed(v, math.floor(math.log10(resolution) + 1e-9), signed), unit)
    if v != 0 and (abs(v) >= _LARGE or abs(v) < _SMALL):
        p = _power(v)
        mant = format_value(v / 10.0**p, signed=signed, digits=digits)
        return _with_unit(f"{mant}·10{str(p).translate(_SUPERSCRIPT)}", unit)
    # `digits` significant digits in fixed point (never rounding the integer part), trailing zeros
    # dropped as %g does: a value without u claims no more digits than it has.
    last = min(_power(v) - (digits - 1), 0)
    text = _fixed(v, last, signed)
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return _with_unit(text, unit)


def format_mg(value_g: float | None, u_g: float | None = None, signed: bool = True,
              resolution_mg: float | None = None) -> str:
    """A value [g] in mg (no unit appended), ± its uncertainty when given (see module notes)."""
    return format_value_u(value_g, u_g, scale=1e3, signed=signed, resolution=resolution_mg)


def format_mg_text(value_g: float | None, u_g: float | None = None, signed: bool = True) -> str:
    """:func:`format_mg` with its unit: ``"-83.1 ± 0.4 mg"`` (``"–"`` when unknown)."""
    return _with_unit(format_mg(value_g, u_g, signed=signed), "mg")


# A field's unit from its name's suffix (STYLE: units in names), longest suffix first, with the
# factor to the unit a person reads (a sensor's k2 of 2e-05 1/g is 20 µg/g²).
_UNIT_SUFFIXES: tuple[tuple[str, str, float], ...] = (
    ("_ug_per_rthz", "µg/√Hz", 1.0), ("_ug_per_g2", "µg/g²", 1.0), ("_ug_per_g3", "µg/g³", 1.0),
    ("_ug_per_g4", "µg/g⁴", 1.0), ("_g_per_s", "g/s", 1.0), ("_per_g3", "µg/g⁴", UG_PER_G), ("_per_g2", "µg/g³", UG_PER_G),
    ("_per_g", "µg/g²", UG_PER_G), ("_g2_per_hz", "g²/Hz", 1.0), ("_hz", "Hz", 1.0), ("_db", "dB", 1.0),
    ("_deg", "°", 1.0), ("_s", "s", 1.0), ("_mg", "mg", 1.0), ("_g", "g", 1.0),
)
# Short names a person reads for the keys whose name alone says too little.
_FIELD_NAMES = {"odr": "output data rate", "fs": "sampling rate", "fn": "resonance fn", "q": "quality factor Q",
                "lsb": "resolution (1 LSB)"}


def _field(key: str) -> tuple[str, str | None, float]:
    for suffix, unit, scale in _UNIT_SUFFIXES:
        if key.endswith(suffix) and len(key) > len(suffix):
            stem = key[: -len(suffix)]
            return _FIELD_NAMES.get(stem, stem.replace("_", " ")), unit, scale
    return _FIELD_NAMES.get(key, key.replace("_", " ")), None, 1.0


def field_label(key: str) -> tuple[str, str | None]:
    """A JSON key as a person reads it, and its unit: ``"odr_hz"`` → ``("output data rate", "Hz")``,
    ``"k2_ug_per_g2"`` → ``("k2", "µg/g²")``, ``"rails_g"`` → ``("rails", "g")``."""
    name, unit, _ = _field(key)
    return name, unit


def field_text(key: str, value: object) -> tuple[str, str]:
    """A JSON field as a person reads it: its name and its value with the unit, e.g.
    ``("k2", "20 µg/g²")`` for ``"k2_per_g": 2e-05``; ``("rails", "-2.048, 2.048 g")``."""
    name, unit, scale = _field(key)
    if scale != 1.0 and isinstance(value, (int, float)) and not isinstance(value, bool):
        value = value * scale
    elif scale != 1.0 and isinstance(value, (list, tuple)):
        value = [x * scale if isinstance(x, (int, float)) and not isinstance(x, bool) else x for x in value]
    return name, format_field(value, unit)


def format_field(value: object, unit: str | None = None) -> str:
    """A JSON field's value as text: numbers by :func:`format_value` with the unit, lists as
    ``"-2.048, 2.048 g"``, ``None`` as ``"not set"``, booleans as yes/no (never ``null``,
    ``[...]`` or ``4000.0``)."""
    if value is None:
        return "not set"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        return format_value(value, unit=unit)
    if isinstance(value, (list, tuple)):
        if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value) and value:
            return _with_unit(", ".join(format_value(x) for x in value), unit)
        return "; ".join(format_field(x) for x in value) or "none"
    if isinstance(value, dict):
        return "; ".join(": ".join(field_text(str(k), v)) for k, v in value.items()) or "none"
    return str(value)


def progress_stream() -> TextIO:
    """Where a progress bar draws: the process's stderr itself, from under :func:`vrelab.cli.main`'s
    escaping wrapper (``PrintableStream.raw``), whose escapes would print the bar's carriage returns
    as text. A bar's text is vrelab's own (counts, rates, a fixed description), no file's."""
    import sys

    return getattr(sys.stderr, "raw", sys.stderr)
