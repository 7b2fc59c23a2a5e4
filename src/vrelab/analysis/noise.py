"""The DUT's own noise on the vibration-off stretches of a record (physics §4.4): the channel's
noise result, what a metrologist checks first.

* :func:`allan_deviation`: the overlapping Allan deviation of the baselines' window means (IEEE
  Std 1554 and 952: ``σ²(τ) = ½⟨(ȳ_{k+1} − ȳ_k)²⟩`` over all overlapping pairs of adjacent
  τ-means), pooled over the baselines without a pair across a gap.
* :func:`fit_noise_model`: the power-law model ``S(f) = h₀ + h₋₁/f + h₋₂/f²`` (white, flicker,
  random walk: IEEE Std 952 Annex C, IEEE Std 1554) fitted to the overlapping Hadamard variances
  of the same window means (second differences: a linear drift cancels in them), each
  observation's expectation written as the integral :func:`contrast_var` of the box means it
  compares.
* :func:`channel_noise`: the noise density ``√h₀`` [g/√Hz, one-sided, as datasheets state it]
  and the bias instability ``B = √(π·h₋₁)`` (IEEE Std 952 C.3: a flicker floor
  ``σ = √(2·ln 2/π)·B ≈ 0.664·B``; with the one-sided ``h₋₁``, ``σ² = 2·ln 2·h₋₁``), each with its
  u from the fit, and the Allan deviation curve.

Written with numpy rather than with ``allantools``: the baselines are separate stretches of a
record (gaps between them) of already-averaged windows, and the estimators pool over them and
feed a fit whose rows need box-mean integrals; allantools takes one contiguous series of
samples, and these sums are a few lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.results import Estimate, NoiseResult

# The noise types of the model, S(f) = Σ h_α·f^α: white (0), flicker (-1), random walk (-2).
NOISE_ALPHAS = (0.0, -1.0, -2.0)
NOISE_NAMES = ("white", "flicker", "random-walk")
# The Allan deviation's octaves stop where fewer than this many τ-means fit in the longest stretch
MIN_TAU_MEANS = 3

# Observations the noise model keeps beyond its fitted terms (fit_noise_model)
MIN_RESIDUAL_DOF = 2

Box = tuple[float, float, float]  # (centre time [s], length [s], coefficient)


def contrast_var(boxes: Sequence[Box]) -> NDArray[np.float64]:
    """Variance of ``Σ c·(mean of the offset over [t − T/2, t + T/2])`` over boxes (t, T, c) for
    noise of one-sided PSD ``f^α``, α in :data:`NOISE_ALPHAS` (unit level each):
    ``∫ f^α·|Σ c·e^{−2πift}·sinc(fT)|² df``.

    The coefficients sum to 0 (a difference, which makes the random walk's integral converge).
    White noise in closed form, ``Σ c²/(2T)`` (boxes that do not overlap); flicker and random
    walk by :func:`vrelab.analysis.levels.second_difference_var` (the same integral on its
    logarithmic grid, cached by the boxes' geometry: every record's Hadamard rows ask for the
    same octaves), whose ends lose nothing: the integrand is O(f^(α+3)) at 0 for a difference
    (O(f^(α+5)) for a second difference) and O(f^(α−2)) above 1/T."""
    from vrelab.analysis.levels import second_difference_var

    c = np.array([b[2] for b in boxes], dtype=float)
    T = np.array([b[1] for b in boxes], dtype=float)
    white = float(np.sum(c * c / (2 * T)))
    out: NDArray[np.float64] = np.concatenate([[white], second_difference_var(boxes, _RED_ALPHAS)])
    return out


_RED_ALPHAS = np.array(NOISE_ALPHAS[1:])


def _cumulative(stretches: Sequence[NDArray[np.float64]]) -> list[NDArray[np.float64]]:
    """Each stretch's cumulative sums from 0, what :func:`_box_means` takes at every octave
    (made once per stretch, not once per stretch and octave)."""
    return [np.concatenate([[0.0], np.cumsum(y)]) for y in stretches]


def _box_means(c: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """Means of every run of m consecutive values (all start positions), from their cumulative
    sums ``c`` (:func:`_cumulative`)."""
    out: NDArray[np.float64] = (c[m:] - c[:-m]) / m
    return out


def _octaves(n_max: int, parts: int) -> list[int]:
    """m = 1, 2, 4, ... while ``parts`` runs of m values fit in the longest stretch."""
    out, m = [], 1
    while parts * m <= n_max:
        out.append(m)
        m *= 2
    return out


@dataclass(frozen=True)
class AllanDeviation:
    """Overlapping Allan deviation of vibration-off window means, pooled over the stretches
    (:func:`allan_deviation`)."""

    tau_s: tuple[float, ...]
    adev_g: tuple[float, ...]
    n_pairs: tuple[int, ...]  # overlapping pairs of adjacent τ-means behind each point


def allan_deviation(stretches: Sequence[NDArray[np.float64]], tau0_s: float) -> AllanDeviation:
    """Overlapping Allan deviation (IEEE Std 1554-2005, 3.1; IEEE Std 952-1997, Annex C) of
    contiguous series of τ₀-means (the baselines' window means), at τ = m·τ₀ for m = 1, 2, 4, ...:
    ``σ²(τ) = Σ (ȳ_{j+m} − ȳ_j)² / (2·N)`` over every start j where both τ-means lie inside one
    stretch, N of them over all the stretches (each a gap-free run; no pair spans a gap)."""
    n_max = max((len(y) for y in stretches), default=0)
    taus, devs, ns = [], [], []
    sums = _cumulative(stretches)
    for m in _octaves(n_max, MIN_TAU_MEANS):
        ss, n = 0.0, 0
        for y, c in zip(stretches, sums):
            if len(y) < 2 * m:
                continue
            a = _box_means(c, m)
            d = a[m:] - a[:-m]
            ss += float(d @ d)
            n += len(d)
        if n:
            taus.append(m * tau0_s)
            devs.append(math.sqrt(ss / (2 * n)))
            ns.append(n)
    return AllanDeviation(tuple(taus), tuple(devs), tuple(ns))


@dataclass(frozen=True)
class NoiseModel:
    """``S(f) = h₀ + h₋₁/f + h₋₂/f²`` fitted to the vibration-off stretches
    (:func:`fit_noise_model`), with the covariance of the fitted ``h``. An ``h`` may come out
    negative (unbiased, not bounded); a variance made of them is taken at 0 or more."""

    h: tuple[float, float, float]  # [g²/Hz, g², g²·Hz]
    cov: tuple[tuple[float, ...], ...]
    n_rows: int  # observations fitted
    n_terms: int  # terms fitted, in the order white, flicker, random walk (the others held at 0)


def hadamard_rows(stretches: Sequence[NDArray[np.float64]], tau0_s: float
                  ) -> list[tuple[float, NDArray[np.float64], float]]:
    """(mean squared second difference, its expectation per unit h, degrees of freedom) per
    octave τ = m·τ₀: the overlapping Hadamard differences ``ȳ_j − 2·ȳ_{j+m} + ȳ_{j+2m}``
    pooled over the stretches. Degrees of freedom: the overlapping terms over 2m (white noise's
    second differences at m = 1 carry about half a degree of freedom each: their lag-1 and lag-2
    correlations are -2/3 and 1/6, so N terms hold N/(1 + 2·(4/9 + 1/36)) ≈ N/1.94)."""
    n_max = max((len(y) for y in stretches), default=0)
    rows = []
    sums = _cumulative(stretches)
    for m in _octaves(n_max, 3):
        ss, n = 0.0, 0
        for y, c in zip(stretches, sums):
            if len(y) < 3 * m:
                continue
            a = _box_means(c, m)
            d = a[: -2 * m] - 2 * a[m:-m] + a[2 * m:]
            ss += float(d @ d)
            n += len(d)
        if n:
            tau = m * tau0_s
            k = contrast_var(((-tau, tau, 1.0), (0.0, tau, -2.0), (tau, tau, 1.0)))
            rows.append((ss / n, k, max(n / (2.0 * m), 1.0)))
    return rows


def fit_noise_model(rows: Sequence[tuple[float, NDArray[np.float64], float]]) -> NoiseModel | None:
    """``h`` by weighted least squares of the observed mean squares o_r against
    their expectations K_r·h; each o_r is a scaled χ² of ν_r degrees of freedom, so its variance
    is 2·E²/ν_r, E = K_r·h taken from the previous iterate of a fit bounded at h ≥ 0 (the
    observations themselves first); the last step drops the bound (see the comment there).
    None without an observation, or when none shows any noise."""
    from scipy.optimize import nnls

    rows = [r for r in rows if math.isfinite(r[0]) and r[0] >= 0 and np.all(np.isfinite(r[1]))]
    if not rows:
        return None
    o = np.array([r[0] for r in rows])
    if not np.max(o) > 0:
        return None  # a noiseless record: no noise to model (the batch means' u stands)
    K = np.array([r[1] for r in rows])
    nu = np.array([r[2] for r in rows])
    scale = np.max(K, axis=0)  # columns of unit order: h's span many decades
    scale[scale <= 0] = 1.0
    Ks = K / scale
    floor = max(float(np.max(o)) * 1e-12, 1e-300)
    e = np.maximum(o, floor)
    hs = np.zeros(K.shape[1])
    for _ in range(4):
        w = np.sqrt(nu / 2.0) / e
        hs, _res = nnls(Ks * w[:, None], o * w)
        e = np.maximum(Ks @ hs, floor)
    # The final h: weighted least squares without the bound (the weights from the bounded fit's
    # expectations). A term at its bound 0 would otherwise claim to be known exactly (a bias
    # instability of 0 ± 0 from stretches that cannot tell flicker from white noise); unbounded,
    # its estimate is unbiased and its covariance (AᵀA)⁻¹ carries the doubt.
    w = np.sqrt(nu / 2.0) / e
    A = Ks * w[:, None]
    # Terms in the order white, flicker, random walk, as many as leave MIN_RESIDUAL_DOF rows
    # beyond them: an exactly determined fit traded white noise for flicker at will (3 baselines
    # of 1 s of white noise alone: h₀ < 0 and h₋₁ ≈ 3·|h₀| in some records)
    cols = np.flatnonzero(np.linalg.norm(A, axis=0) > 0)
    cols = cols[: max(min(len(cols), len(o) - MIN_RESIDUAL_DOF), 1)]
    ncol = len(cols)
    cov_s = np.zeros((K.shape[1], K.shape[1]))
    hs = np.zeros(K.shape[1])
    if ncol:
        Aa = A[:, cols]
        cov_a = np.linalg.pinv(Aa.T @ Aa)
        hs[cols] = cov_a @ Aa.T @ (o * w)
        cov_s[np.ix_(cols, cols)] = cov_a
    h = hs / scale
    cov = cov_s / np.outer(scale, scale)
    if not (np.all(np.isfinite(h)) and np.all(np.isfinite(cov))):
        return None
    return NoiseModel((float(h[0]), float(h[1]), float(h[2])),
                      tuple(tuple(float(x) for x in row) for row in cov), len(rows), int(ncol))


def channel_noise(stretches: Sequence[NDArray[np.float64]], tau0_s: float) -> NoiseResult | None:
    """The channel's noise result (:class:`~vrelab.results.NoiseResult`) from its vibration-off
    window means (``tau0_s`` each): the Allan deviation, and the density ``√h₀`` and bias
    instability ``√(π·h₋₁)`` of the model fitted to their Hadamard variances, each with its u by
    the delta method from the fit's covariance. A flicker term fitted at or below 0 gives a bias
    instability of 0 with the u of ``√(π·u(h₋₁))`` (the flicker one standard uncertainty of h₋₁
    would show); one the stretches are too short to fit at all (too few octaves) gives null. None
    without a stretch, or for a noiseless record."""
    model = fit_noise_model(hadamard_rows(stretches, tau0_s)) if stretches else None
    if model is None:
        return None
    adev = allan_deviation(stretches, tau0_s)
    micro = 1e6

    def root(i: int, scale: float) -> Estimate:
        if model.n_terms <= i:
            return Estimate(math.nan, math.nan, "µg")
        h, u_h = model.h[i], math.sqrt(max(model.cov[i][i], 0.0))
        if h > 0:
            return Estimate(micro * math.sqrt(scale * h), micro * scale * u_h / (2 * math.sqrt(scale * h)), "µg")
        return Estimate(0.0, micro * math.sqrt(scale * u_h), "µg")

    dens = root(0, 1.0)
    return NoiseResult(
        Estimate(dens.value, dens.u, "µg/√Hz"), root(1, math.pi),
        adev.tau_s, tuple(micro * a for a in adev.adev_g), adev.n_pairs,
        float(sum(len(y) for y in stretches)) * tau0_s, len(stretches), tau0_s,
    )


__all__ = [
    "NOISE_ALPHAS",
    "NOISE_NAMES",
    "MIN_RESIDUAL_DOF",
    "AllanDeviation",
    "Box",
    "NoiseModel",
    "allan_deviation",
    "channel_noise",
    "contrast_var",
    "fit_noise_model",
    "hadamard_rows",
]
