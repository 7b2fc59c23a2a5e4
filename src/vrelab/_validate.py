"""Input validation shared by every public function.

Every check raises ``ValueError`` with a message that names the parameter and the offending
value, in one line; the CLI prints exactly that message on stderr and exits with status 2.
"""

from __future__ import annotations

import math
import operator

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _show(value: object) -> str:
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


def non_negative_scalar(name: str, value: ArrayLike) -> float:
    """``float(non_negative(name, value))``; a float that passes is returned without building an
    array (the closed forms check their rms thousands of times in one fit)."""
    if isinstance(value, float) and 0.0 <= value < math.inf:
        return float(value)
    return float(non_negative(name, value))


def positive(name: str, value: ArrayLike) -> NDArray[np.float64]:
    arr = finite(name, value)
    if (arr <= 0).any():
        raise ValueError(f"{name} must be > 0, got {_show(arr[arr <= 0])}")
    return arr


def positive_scalar(name: str, value: object) -> float:
    try:
        x = float(value)  # type: ignore[arg-type]  # any value: what float() refuses is refused below
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x) or x <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return x


def finite_scalar(name: str, value: object) -> float:
    try:
        x = float(value)  # type: ignore[arg-type]  # any value: what float() refuses is refused below
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
# The largest acceleration [g] any input may give (a static field, a tone's peak): the same
# bound, pyroshock's 1e5 g; a 1 g field or a centrifuge's few hundred g are far inside it, and
# its fourth power (k4·a⁴ of the nonlinearity) stays far from float64's 1.8e308.
MAX_ACCELERATION_G = MAX_LEVEL_G_RMS
# Frequencies [Hz] any input may give (a sine, a tone, a profile breakpoint). Shock
# accelerometers' resonances reach about 1 MHz and the slowest tests (tilt, drift) run at
# millihertz; outside 1 µHz..10 MHz a frequency is a slip (units, exponent), and the ratio of two
# of them (log-log profile slopes) must not overflow.
MIN_FREQ_HZ = 1e-6
MAX_FREQ_HZ = 1e7


def vibration_level(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Vibration levels [g rms]: finite, > 0 and at most ``MAX_LEVEL_G_RMS``."""
    arr = positive(name, value)
    if (arr > MAX_LEVEL_G_RMS).any():
        raise ValueError(
            f"{name} must be at most {MAX_LEVEL_G_RMS:g} g rms (beyond any shaker or shock test), "
            f"got {_show(arr[arr > MAX_LEVEL_G_RMS])}"
        )
    return arr


def acceleration(name: str, value: object) -> float:
    """An acceleration [g] (a static field): finite and at most ``MAX_ACCELERATION_G`` in size."""
    x = finite_scalar(name, value)
    if abs(x) > MAX_ACCELERATION_G:
        raise ValueError(f"{name} must be within ±{MAX_ACCELERATION_G:g} g (beyond any shaker, centrifuge or "
                         f"shock test), got {value!r}")
    return x


# A mount angle [deg] lies within one turn either way (IEEE 1293 mounts span 0-360°): beyond, it
# is a slip (radians for degrees, an exponent), and cos/sin of 1e300° is rounding noise.
MAX_MOUNT_DEG = 360.0


def mount_angle(name: str, value: object) -> float:
    """A mount angle [deg]: finite and within ``±MAX_MOUNT_DEG``."""
    x = finite_scalar(name, value)
    if abs(x) > MAX_MOUNT_DEG:
        raise ValueError(f"{name} must be within ±{MAX_MOUNT_DEG:g}° (degrees, not radians), got {value!r}")
    return x


def frequency(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Frequencies [Hz]: finite, within ``MIN_FREQ_HZ``..``MAX_FREQ_HZ``."""
    arr = positive(name, value)
    bad = (arr < MIN_FREQ_HZ) | (arr > MAX_FREQ_HZ)
    if bad.any():
        raise ValueError(f"{name} must be within {MIN_FREQ_HZ:g}..{MAX_FREQ_HZ:g} Hz (beyond any vibration test), "
                         f"got {_show(arr[bad])}")
    return arr


# Sensitivities [units per g] a channel may declare: a 32-bit converter on ±1 g gives 2e9 LSB/g,
# a shock accelerometer 0.001 mV/g; outside 1e-9..1e12 a sensitivity is a slip (units, exponent),
# and dividing a raw record by it would overflow float64 in the window sums of squares.
MIN_SENSITIVITY = 1e-9
MAX_SENSITIVITY = 1e12


def sensitivity(name: str, value: object) -> float:
    """A sensitivity [units per g]: finite, within ``MIN_SENSITIVITY``..``MAX_SENSITIVITY``."""
    x = positive_scalar(name, value)
    if not MIN_SENSITIVITY <= x <= MAX_SENSITIVITY:
        raise ValueError(f"{name} must be within {MIN_SENSITIVITY:g}..{MAX_SENSITIVITY:g} units per g "
                         f"(beyond any accelerometer or converter), got {value!r}")
    return x


def integer(name: str, value: object, minimum: int) -> int:
    """An integer >= ``minimum`` (a float with an integral value is accepted)."""
    try:
        n = operator.index(value)  # type: ignore[arg-type]  # any value: what is not an index is refused below
    except TypeError:
        if isinstance(value, float) and value.is_integer():
            n = int(value)
        else:
            raise ValueError(f"{name} must be an integer, got {value!r}") from None
    if n < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return n


def static_vector(static_g: ArrayLike) -> NDArray[np.float64]:
    """The static acceleration (gx, gy, gz) [g] in the part's frame: three finite numbers."""
    g = np.asarray(static_g, dtype=np.float64).ravel()
    if g.size != 3 or not np.isfinite(g).all():
        raise ValueError(f"static_g must be three finite numbers (gx, gy, gz) [g], got {static_g!r}")
    return g
