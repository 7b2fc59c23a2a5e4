"""Expectations over the phases of sine tones riding on random vibration (the environments page).

Sine-on-random motion at a point of the sensor is ``x = G + Σ A_i·cos θ_i``: ``G`` zero-mean
Gaussian (the random part through the dynamics), ``A_i`` the tones' amplitudes there and
``θ_i`` their phases, each uniform on [0, 2π) and independent of one another and of ``G``
(the random-phase model of a sine plus noise, Rice [1] §4.10). Given the phases, x is Gaussian
with mean ``s = Σ A_i·cos θ_i``, so a mean shift, a moment or a crossing rate of x is a
Gaussian closed form averaged over the phases. :func:`phase_grid` gives the points of that
average.

The rule: the product trapezoidal rule on the torus, ``N_i`` equally spaced phases per tone.
For a smooth periodic integrand it converges geometrically and is exact for trigonometric
polynomials of degree below N_i (Trefethen & Weideman [2]). The integrands here are smooth
functions of ``μ + s`` that vary on the scale σ (the Gaussian smooths them), so along θ_i
they vary on the scale σ/A_i: tone i gets ``N_i = 16 + ⌈6·A_i/σ⌉`` phases (at most 1024).
Measured against adaptive quadrature (scipy ``quad``, tests/test_sine_on_random.py), this leaves
below 1e-12 relative error on the censored clip shift of one tone for A/σ from 0.5 to 100. When the product of the N_i
exceeds ``MAX_GRID`` (several strong tones), a Monte Carlo average over ``MC_DRAWS`` phase
draws from a fixed seed replaces it: its standard error is the spread (standard deviation) of
the integrand over the phases divided by √MC_DRAWS = 512, i.e. 0.2 % of that spread.

References
----------
.. [1] S. O. Rice, "Mathematical analysis of random noise", Bell Syst. Tech. J. 23 (1944) and
   24 (1945): §3.3 expected number of crossings, §4.10 sine wave plus random noise.
.. [2] L. N. Trefethen, J. A. C. Weideman, "The exponentially convergent trapezoidal rule",
   SIAM Review 56(3), 2014.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate

_BASE_NODES = 16
_NODES_PER_RATIO = 6
_MAX_NODES_PER_TONE = 1024
#: Largest product grid (phases in all); beyond it, Monte Carlo.
MAX_GRID = 2**20
#: Phase draws of the Monte Carlo average (standard error: spread/512).
MC_DRAWS = 2**18
# A fixed seed: the same tones give the same average on every call and every machine.
_MC_SEED = 61


@dataclass(frozen=True)
class PhaseGrid:
    """Points of an average over the tones' phases, all of equal weight.

    ``cos`` and ``sin`` have shape (tones, points); ``monte_carlo`` says whether the points are
    random draws (else the product trapezoidal rule).

    Examples
    --------
    >>> from vrelab.models.tones import phase_grid
    >>> grid = phase_grid([1.0, 0.5], 1.0)
    >>> grid.cos.shape == grid.sin.shape, grid.monte_carlo
    (True, False)
    """

    cos: NDArray[np.float64]
    sin: NDArray[np.float64]
    monte_carlo: bool

    @property
    def n_points(self) -> int:
        return int(self.cos.shape[1])

    def sum_of(self, amplitudes: ArrayLike) -> NDArray[np.float64]:
        """``Σ a_i·cos θ_i`` at every point (the tones' sum for amplitudes ``a``)."""
        return np.asarray(amplitudes, dtype=np.float64) @ self.cos

    def slope_of(self, amplitudes: ArrayLike, freqs_hz: ArrayLike) -> NDArray[np.float64]:
        """``d/dt Σ a_i·cos(2π f_i t + θ_i) = -Σ 2π f_i a_i·sin θ_i`` at every point [g/s]."""
        w = 2.0 * np.pi * np.asarray(freqs_hz, dtype=np.float64)
        return -(np.asarray(amplitudes, dtype=np.float64) * w) @ self.sin


def nodes_per_tone(peaks_g: Sequence[float], scale_g: float) -> list[int]:
    """Trapezoid phases per tone: ``16 + ⌈6·A_i/σ⌉``, at most 1024 (see the module notes).

    Examples
    --------
    A tone of 1 g peak against 1 g rms of random vibration, and one of 10 g:

    >>> from vrelab.models.tones import nodes_per_tone
    >>> nodes_per_tone([1.0, 10.0], 1.0)
    [22, 76]
    """
    if scale_g <= 0:
        return [_MAX_NODES_PER_TONE] * len(peaks_g)
    return [min(_BASE_NODES + math.ceil(_NODES_PER_RATIO * a / scale_g), _MAX_NODES_PER_TONE) for a in peaks_g]


def phase_grid(peaks_g: Sequence[float], scale_g: float) -> PhaseGrid:
    """The points of an average over independent uniform tone phases.

    Parameters
    ----------
    peaks_g : sequence of float
        Tone amplitudes A_i >= 0 [g peak] where the average is taken.
    scale_g : float
        The scale on which the integrand varies in ``s = Σ A_i cos θ_i`` (the rms σ of the
        Gaussian part there) [g].

    Returns
    -------
    PhaseGrid
        The product trapezoidal rule, or ``MC_DRAWS`` seeded draws beyond ``MAX_GRID`` points.

    Examples
    --------
    The average of cos² over the phases of one tone is 1/2:

    >>> from vrelab.models.tones import phase_grid
    >>> grid = phase_grid([1.0], 1.0)
    >>> print(f"{(grid.cos[0] ** 2).mean():.6f}")
    0.500000
    """
    peaks = _validate.non_negative("peaks_g", np.atleast_1d(np.asarray(peaks_g, dtype=np.float64)))
    if peaks.ndim != 1 or peaks.size == 0:
        raise ValueError(f"peaks_g must be a non-empty list of amplitudes, got {peaks_g!r}")
    scale = float(_validate.non_negative("scale_g", scale_g))
    counts = nodes_per_tone(list(peaks), scale)
    if math.prod(counts) <= MAX_GRID:
        axes = [2.0 * np.pi * np.arange(n) / n for n in counts]
        theta = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")])
        return PhaseGrid(np.cos(theta), np.sin(theta), False)
    rng = np.random.default_rng(np.random.SeedSequence(_MC_SEED))
    theta = rng.uniform(0.0, 2.0 * np.pi, (peaks.size, MC_DRAWS))
    return PhaseGrid(np.cos(theta), np.sin(theta), True)
