"""How numbers are shown to a person and written to JSON: one owner for each rule.

* :func:`finite_or_none` — JSON has no NaN/inf: a non-finite number is written as ``null``.
* :func:`format_mg` — a value in g shown in mg; with an uncertainty, with the decimals that show
  the uncertainty's first two significant digits (GUM 7.2.6: an uncertainty is quoted with at
  most two significant digits and the value to the same decimal place), and without one, four
  significant digits.
"""

from __future__ import annotations

import math
from typing import Any

# What a missing or non-finite number shows as in a table.
MISSING = "–"


def finite_or_none(x: Any) -> float | None:
    """``float(x)``, or ``None`` when ``x`` is None, NaN or infinite (JSON has no NaN/inf)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _decimals_for(u: float) -> int:
    """Decimal places that show the first two significant digits of ``u`` (0 to 6)."""
    if not math.isfinite(u) or u <= 0:
        return 1
    return max(0, min(6, 1 - math.floor(math.log10(u))))


def format_value_u(value: float | None, u: float | None = None, scale: float = 1.0,
                   signed: bool = False) -> str:
    """``value·scale`` (± ``u·scale``) with the decimals the uncertainty calls for.

    Without a usable uncertainty the value is shown with four significant digits.
    """
    if value is None or not math.isfinite(float(value)):
        return MISSING
    v = float(value) * scale
    if u is None or not math.isfinite(float(u)) or u <= 0:
        return format(v, "+.4g" if signed else ".4g")
    uu = float(u) * scale
    d = _decimals_for(uu)
    return f"{v:{'+' if signed else ''}.{d}f} ± {uu:.{d}f}"


def format_mg(value_g: float | None, u_g: float | None = None, signed: bool = True) -> str:
    """A value [g] in mg (no unit appended), ± its uncertainty when given (see module notes)."""
    return format_value_u(value_g, u_g, scale=1e3, signed=signed)


def format_mg_text(value_g: float | None, u_g: float | None = None) -> str:
    """:func:`format_mg` with its unit: ``"-83.1 ± 0.4 mg"`` (``"–"`` when unknown)."""
    text = format_mg(value_g, u_g)
    return text if text == MISSING else f"{text} mg"
