"""A series' own slow wander: the second differences of its thirds, fourths and fifths
(:func:`thirds_difference`), against what white noise of the series' own correlation gives.

What :func:`vrelab.analysis.levels.short_baseline_u` reads the DUT's low-frequency noise at a
level's time scale from, when the level's baselines are too short to show it.
"""

from __future__ import annotations

import functools
import math
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

# The parts a level is cut into for its own low-frequency noise (:func:`thirds_difference`):
# second differences of runs of a 1/p of the level, p in THIRDS_PARTS
THIRDS_PARTS = (3, 4, 5)


# The run of values the white scatter of a level's series is read at (:func:`thirds_difference`):
# at least the smoothing kernel's reach (SMOOTH_WINDOWS), a few tenths of a second
WHITE_RUN = 3


def thirds_difference(y: NDArray[np.float64], rho: Sequence[float] = (1.0,)
                     ) -> tuple[tuple[float, float], ...] | None:
    """Per p in THIRDS_PARTS, (mean square of the second differences ``m2 - (m1 + m3)/2`` of three
    adjacent runs of m = ``len(y)//p`` values at every start, its expectation were the noise white)
    of a segment's series (a random level's smoothed windows, whose correlation at lags 0, 1, ...
    is ``rho``, the kernel's; a sine level's batch offsets, independent).

    The white expectation is read on the series itself at runs of WHITE_RUN values, the same
    mean square there scaled by the ratio of the two differences' variances under ``rho``
    (:func:`_run_difference_var`; m₀/m for independent values): not from the u of the series'
    mean, whose batch means hold some of the flicker they are to be told from (measured: it ate
    the excess whole in some records, and those levels' z reached 4). Flicker at the short runs
    is scale-free, so it takes about WHITE_RUN/m of itself off the excess (a tenth for thirds of
    90 values). None under 15 values."""
    n = len(y)
    if n < 15:
        return None
    c = np.concatenate([[0.0], np.cumsum(np.asarray(y, dtype=np.float64) - float(np.mean(y)))])

    def msd(m: int) -> float:
        r = (c[m:] - c[:-m]) / m  # means of every run of m values
        d = r[m:-m] - (r[: -2 * m] + r[2 * m:]) / 2
        return float(np.mean(d * d))

    white, v0 = msd(WHITE_RUN), _run_difference_var(WHITE_RUN, rho)
    out = tuple((msd(n // p), white * _run_difference_var(n // p, rho) / v0) for p in THIRDS_PARTS)
    return out if all(math.isfinite(v) and math.isfinite(w) for v, w in out) else None


def _run_difference_var(m: int, rho: Sequence[float]) -> float:
    """Variance (unit variance per value) of ``m2 - (m1 + m3)/2`` over three adjacent runs of m
    values of a series whose correlation at lags 0, 1, ... is ``rho`` (0 beyond): ``wᵀRw``,
    w the 3m weights; O(m·len(rho)). Computed once per (m, ρ) (:func:`_run_difference_var_of`):
    a record's levels share a few lengths and one kernel correlation (a 2 h record asked 480
    times for a dozen)."""
    return _run_difference_var_of(int(m), tuple(float(r) for r in rho))


@functools.lru_cache(maxsize=256)
def _run_difference_var_of(m: int, rho: tuple[float, ...]) -> float:
    """:func:`_run_difference_var` keyed by its exact inputs: the same bits as a fresh computation."""
    w = np.concatenate([np.full(m, -0.5 / m), np.full(m, 1.0 / m), np.full(m, -0.5 / m)])
    v = float(w @ w)
    for lag in range(1, min(len(rho), len(w))):
        v += 2.0 * float(rho[lag]) * float(w[lag:] @ w[:-lag])
    return v


__all__ = ["THIRDS_PARTS", "WHITE_RUN", "thirds_difference"]
