"""Input validation shared by every public function.

Every check raises ``ValueError`` with a message that names the parameter and the offending
value, in one line; the CLI prints exactly that message on stderr and exits with status 2.
"""

from __future__ import annotations

import math
import operator
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _show(value: Any) -> str:
    arr = np.asarray(value)
    if arr.size == 1:
        return f"{arr.item()!r}"
    bad = arr.ravel()
    return f"array of shape {arr.shape} (first values {np.array2string(bad[:3], separator=', ')})"


def as_float_array(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Convert ``value`` to a float64 array; reject NaN and non-numeric input."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numeric, got {value!r}") from None
    if np.isnan(arr).any():
        raise ValueError(f"{name} contains NaN: {_show(value)}")
    return arr


def finite(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = as_float_array(name, value)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite, got {_show(value)}")
    return arr


def non_negative(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = finite(name, value)
    if (arr < 0).any():
        raise ValueError(f"{name} must be >= 0, got {_show(arr[arr < 0])}")
    return arr


def positive(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = finite(name, value)
    if (arr <= 0).any():
        raise ValueError(f"{name} must be > 0, got {_show(arr[arr <= 0])}")
    return arr


def positive_scalar(name: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x) or x <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return x


def finite_scalar(name: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return x


def one_of(name: str, value: str, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


# The largest vibration level [g rms] any input may ask for. The strongest electrodynamic
# shakers reach a few hundred g rms and pyroshock tests about 1e5 g peak; beyond this a level is
# a slip (units, exponent), and squaring it (PSD values scale with level²) would overflow.
MAX_LEVEL_G_RMS = 1e5


def vibration_level(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Vibration levels [g rms]: finite, > 0 and at most ``MAX_LEVEL_G_RMS``."""
    arr = positive(name, value)
    if (arr > MAX_LEVEL_G_RMS).any():
        raise ValueError(
            f"{name} must be at most {MAX_LEVEL_G_RMS:g} g rms (beyond any shaker or shock test), "
            f"got {_show(arr[arr > MAX_LEVEL_G_RMS])}"
        )
    return arr


def integer(name: str, value: Any, minimum: int) -> int:
    """An integer >= ``minimum`` (a float with an integral value is accepted)."""
    try:
        n = operator.index(value)
    except TypeError:
        if isinstance(value, float) and value.is_integer():
            n = int(value)
        else:
            raise ValueError(f"{name} must be an integer, got {value!r}") from None
    if n < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return n
