"""The one owner of the µg ↔ g factor: a VRC (k2) in µg/g² is the normalised coefficient in 1/g
times :data:`UG_PER_G` (k3: µg/g³ ↔ 1/g², k4: µg/g⁴ ↔ 1/g³; a VRE or a noise density in µg is
the one in g times it).

The sensor files, the CLI and every report speak µg/gⁿ (the datasheets' unit, = ppm/gⁿ⁻¹); the
models compute in normalised coefficients (physics §1.2: VRE = k2·σ² + ... in g). Converting is one
multiplication (:func:`to_ug`) or one division (:func:`from_ug`) by the same factor, so a value
read from a file and one given to a model function agree to the last bit. A leaf module, so that
any module can import it.
"""

from __future__ import annotations

from typing import overload

import numpy as np
from numpy.typing import NDArray

UG_PER_G = 1e6  # µg in 1 g (SI prefix micro): [µg/gⁿ] = UG_PER_G · [1/gⁿ⁻¹]


@overload
def to_ug(x: float) -> float: ...
@overload
def to_ug(x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def to_ug(x: float | NDArray[np.float64]) -> float | NDArray[np.float64]:
    """A g-based value (1/g, g, g/√Hz; a float or an array) in its µg-based unit: ×1e6."""
    return x * UG_PER_G


@overload
def from_ug(x: float) -> float: ...
@overload
def from_ug(x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def from_ug(x: float | NDArray[np.float64]) -> float | NDArray[np.float64]:
    """A µg-based value (µg/g², µg, µg/√Hz; a float or an array) in its g-based unit: ÷1e6."""
    return x / UG_PER_G
