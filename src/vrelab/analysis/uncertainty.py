"""Standard uncertainty of a mean of autocorrelated data: batch means sized by the autocorrelation.

A DUT offset is not white: 1/f noise, thermal wander and the rectified vibration itself make
neighbouring samples (and neighbouring 0.1 s windows) correlated, and ``σ/√N`` then
understates the uncertainty of the mean by ``√τ`` (τ the integrated autocorrelation time in
samples). Non-overlapping batch means [1]_ fix that when each batch is long compared with τ:
the batch means are then nearly independent and their scatter gives an honest uncertainty.

References
----------
.. [1] H. Flyvbjerg and H. G. Petersen, "Error estimates on averages of correlated data",
   J. Chem. Phys. 91, 461 (1989).
.. [2] A. D. Sokal, "Monte Carlo methods in statistical mechanics: foundations and new
   algorithms" (1996), section 3: integrated autocorrelation time with the automatic window
   ``M >= c·τ(M)``, c = 5.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

# Batches of this many integrated autocorrelation times: adjacent batch means then correlate by
# about 1/(2·BATCH_TAUS), a few per cent, small enough for an honest standard error.
BATCH_TAUS = 10.0
MIN_BATCHES = 20


@dataclass(frozen=True)
class MeanEstimate:
    """Mean of a series with its standard uncertainty and how it was found."""

    mean: float
    u: float
    tau: float  # integrated autocorrelation time, in series steps
    batch: int  # series steps per batch
    n_batches: int


def integrated_autocorr_time(x: ArrayLike, c: float = 5.0) -> float:
    """Integrated autocorrelation time ``τ = 1 + 2·Σ ρ(t)`` with Sokal's automatic window [2]_.

    Returns 1 for white noise; ``(1+φ)/(1-φ)`` for an AR(1) process of coefficient φ.
    """
    y = np.asarray(x, dtype=np.float64)
    n = len(y)
    if n < 4:
        return 1.0
    y = y - y.mean()
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    f = np.fft.rfft(y, nfft)
    acov = np.fft.irfft(f * np.conj(f), nfft)[:n]
    if acov[0] <= 0:
        return 1.0
    rho = acov / acov[0]
    taus = 2.0 * np.cumsum(rho) - 1.0
    m = np.arange(n)
    ok = m >= c * taus
    M = int(np.argmax(ok)) if ok.any() else n - 1
    return float(max(taus[M], 1.0))


def batch_mean(y: ArrayLike, detrend: bool = True, tau_min: float = 1.0) -> MeanEstimate:
    """Mean of ``y`` (equally spaced, equal-weight steps) with a batch-means uncertainty.

    Parameters
    ----------
    y : array_like
        The series (e.g. DUT means of consecutive 0.1 s windows), in its own unit.
    detrend : bool
        Remove a straight line before measuring the scatter: a slow linear drift is handled by
        baseline bracketing (its mean over the segment is its value at the centre), so it must
        not inflate the uncertainty.
    tau_min : float
        A floor for τ when the series is known to be correlated at least that much (a smoothed
        series: the kernel's own τ); short series underestimate τ.

    Returns
    -------
    MeanEstimate

    Notes
    -----
    τ from the (detrended) series by Sokal's window; batch length ``b = ⌈10·τ⌉`` steps, capped so
    that there are at least 20 batches; ``u = s_b/√n_b`` with ``s_b`` the scatter of the batch
    means of the residuals (2 degrees of freedom used by the line when detrending). When the
    cap makes batches shorter than 10·τ, ``u`` is at least the direct ``√(s²·τ/n)`` (``s²`` over
    ``n - 2·τ`` degrees of freedom: a fitted line takes about τ each).
    """
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    if n == 0:
        return MeanEstimate(math.nan, math.nan, math.nan, 0, 0)
    mean = float(y.mean())
    if n < 3:
        return MeanEstimate(mean, math.inf, math.nan, 1, n)
    t = np.arange(n, dtype=np.float64)
    if detrend:
        r = y - np.polyval(np.polyfit(t, y, 1), t)
    else:
        r = y - mean
    tau = max(integrated_autocorr_time(r), float(tau_min))
    b = int(math.ceil(BATCH_TAUS * tau))
    b = max(1, min(b, n // MIN_BATCHES))
    nb = n // b
    rb = r[: nb * b].reshape(nb, b).mean(axis=1)
    dof = nb - (2 if detrend else 1)
    if dof < 1:
        return MeanEstimate(mean, math.inf, tau, b, nb)
    s2 = float(np.sum(rb**2) if detrend else np.sum((rb - rb.mean()) ** 2)) / dof
    u = math.sqrt(s2 / nb)
    if b < BATCH_TAUS * tau:
        # Batches capped by MIN_BATCHES are too short to be independent and batch means then
        # understate u: fall back to the direct estimate var·τ/n when it is larger.
        p = 2 if detrend else 1
        u = max(u, math.sqrt(float(np.sum(r**2)) / max(n - p * tau, 1.0) * tau / n))
    return MeanEstimate(mean, u, tau, b, nb)
