"""One level's VRE against the vibration-off baselines that bracket it (physics §4, steps 3 and 5).

* DUT mean of a segment (baseline or random level), its uncertainty and degrees of freedom: from
  the Hann-smoothed window series (:func:`dut_mean_estimate`), batch means sized by the
  autocorrelation time; a short segment's few windows under the kernel's known correlation
  (:func:`correlated_mean`); a level too short for either is flagged (:func:`few_windows`).
* Baselines (:func:`find_baselines`): the DUT's vibration-off readings.
* Level (:func:`reduce_level`). *Random*: level = reference rms in the test band (the window
  FFTs' in-band power). *Sine*: the second pass of :func:`vrelab.analysis.sine.sine_level`.
* VRE = DUT mean under vibration − baseline at the level's centre time, the baseline linearly
  interpolated between the off-segments before and after the level (:func:`bracket`: bracketing
  removes a linear drift exactly); fall back to the nearest baseline with a warning.
  ``u² = u_level² + (1-λ)²·u_before² + λ²·u_after² + u_lf²`` (λ the interpolation weight, u_lf
  the low-frequency term of :class:`LowFrequency`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.baseline_windows import fine_baseline_stats, finer_window, too_short
from vrelab.analysis.segmentation import (
    SMOOTH_WINDOWS,
    WindowStats,
    kernel_correlation,
    kernel_tau,
    segment_windows,
)
from vrelab.analysis.sine import sine_level
from vrelab.analysis.thirds import THIRDS_PARTS, thirds_difference
from vrelab.analysis.uncertainty import BATCH_TAUS, MeanEstimate, batch_mean
from vrelab.gum import welch_satterthwaite
from vrelab.record import Record, Schedule, Segment
from vrelab.results import Estimate, LevelResult, Method, Notice

# A segment needs this many whole averaging windows after the trim, or it is ignored.
MIN_SEGMENT_WINDOWS = 3


@dataclass(frozen=True)
class Baseline:
    t_s: float  # centre time
    mean_g: float
    u_g: float
    segment: Segment
    n_saturated: int = 0  # DUT samples at a rail: the vibration-off reading is off-scale
    dof: float = math.inf  # degrees of freedom of u_g (DutMean.dof)
    # second difference of the baseline's thirds, m2 - (m1 + m3)/2 (None: too short to split),
    # and its variance were the noise white at the batch scale (4.5·u_g²)
    thirds_g: float | None = None
    thirds_white_var: float = 0.0


@dataclass(frozen=True)
class LowFrequency:
    """Offset wander the bracketing cannot remove and the segments' batch means cannot see.

    Batch means measure a segment's scatter about a straight line over a fraction of the
    segment, and the bracketing removes a linear drift; 1/f (flicker) noise, a random walk or
    thermal wander still move the offset between a level and its baselines. That movement is a
    second difference of the offset at the segment time scale. It is measured on the
    vibration-off readings (no vibration in them) as the excess of squared second differences
    over what the white scatter (the batch means) predicts, in two geometries:

    * ``between``: each inner baseline against the linear interpolation of its neighbours (the
      level's own geometry at twice the spacing), ``n_between`` of them;
    * ``within`` (a Hadamard-type term at a third of the segment): each baseline's middle third
      against the mean of its outer thirds, ``n_within`` of them.

    Each is carried to a level's geometry (its mean against the interpolated baselines) by the
    ratio of the two geometries' variances for power-law noise ``S(f) ∝ f^α``
    (:func:`second_difference_var`). α is where the two measured excesses agree, within
    [-2, -1] (random walk to flicker), and the larger of the two carried values is taken. With
    one excess only: when the other geometry was not measured (fewer than 3 baselines, or
    baselines too short to split), the α that gives the larger u; when it was and showed no
    excess, the α that gives the smaller. The term's degrees of freedom are the number of
    second differences behind it. The excesses are not truncated at a significance level, so
    white noise alone adds a little (measured: ±1u covers 0.79 instead of 0.68 on white noise,
    tests/test_coverage.py).
    """

    between: float  # mean excess [g²] (nan: none)
    within: float
    n_between: int
    n_within: int
    third_s: float  # length of a third in the within term (mean over baselines)

    def at(self, level: tuple[float, float], before: tuple[float, float], after: tuple[float, float]
           ) -> tuple[float, float, float]:
        """(variance [g²], degrees of freedom, α) of the term for a level (centre, length)
        bracketed by baselines ``before`` and ``after`` (centre, length)."""
        have_b = self.n_between > 0 and self.between > 0
        have_w = self.n_within > 0 and self.within > 0
        if not (have_b or have_w):
            return 0.0, math.inf, math.nan
        lam = (level[0] - before[0]) / (after[0] - before[0])
        lvl = ((level[0], level[1], 1.0), (before[0], before[1], -(1 - lam)), (after[0], after[1], -lam))
        # the between geometry: a baseline between neighbours at twice the bracket's spacing
        sp = after[0] - before[0]
        bl = ((before[0], before[1], 1.0), (before[0] - sp, before[1], -0.5), (before[0] + sp, before[1], -0.5))
        t = self.third_s
        th = ((0.0, t, 1.0), (-t, t, -0.5), (t, t, -0.5))
        v_l = second_difference_var(lvl, ALPHAS)
        v_b = second_difference_var(bl, ALPHAS)
        v_w = second_difference_var(th, ALPHAS)
        alphas = ALPHAS
        if have_b and have_w:
            i = int(np.argmin(np.abs(np.log(v_b / v_w) - math.log(self.between / self.within))))
            var = max(self.between * v_l[i] / v_b[i], self.within * v_l[i] / v_w[i])
            return float(var), float(self.n_between + self.n_within), float(alphas[i])
        # One estimate only: with the other absent, the α that gives the larger u; with the
        # other measured and showing no excess, the α that gives the smaller (the noise is not
        # red across both scales).
        if have_b:
            var_b = self.between * v_l / v_b
            i = int(np.argmin(var_b) if self.n_within else np.argmax(var_b))
            return float(var_b[i]), float(self.n_between), float(alphas[i])
        var_w = self.within * v_l / v_w
        i = int(np.argmin(var_w) if self.n_between else np.argmax(var_w))
        return float(var_w[i]), float(self.n_within), float(alphas[i])


# The noise types the low-frequency term spans, S(f) ∝ f^α: random walk (-2) to flicker (-1).
ALPHAS = np.linspace(-2.0, -1.0, 11)


def second_difference_var(boxes: Sequence[tuple[float, float, float]], alpha: NDArray[np.float64]
                          ) -> NDArray[np.float64]:
    """Variance of ``Σ c·(mean of the offset over [t - T/2, t + T/2])`` over boxes (t, T, c)
    whose coefficients sum to 0, for noise of one-sided PSD ``f^α`` (unit level), per α (see
    :func:`_second_difference_var`). Cached by the exact bits of what that computation reads (the
    boxes' times about their mean, lengths, coefficients, the span and α): a level's
    low-frequency term asks for the same within-baseline geometry at every level, and a
    regular schedule's levels repeat the same geometry at other times (a 2 h record of 120
    levels: 241 computations, 52 different)."""
    t, T, c, span = _box_geometry(boxes)
    a = np.asarray(alpha, dtype=np.float64)
    return _second_difference_var_cached(t.tobytes(), T.tobytes(), c.tobytes(), span, a.tobytes(), a.shape).copy()


@functools.lru_cache(maxsize=256)
def _second_difference_var_cached(t: bytes, T: bytes, c: bytes, span: float, alpha: bytes,
                                  alpha_shape: tuple[int, ...]) -> NDArray[np.float64]:
    """:func:`_box_difference_var` keyed by its inputs' bytes (-0.0 and 0.0, every NaN payload,
    apart: the same bits in, the same bits out); callers get a copy."""
    def arr(b: bytes) -> NDArray[np.float64]:
        return np.frombuffer(b, dtype=np.float64)

    return _box_difference_var(arr(t), arr(T), arr(c), span, arr(alpha).reshape(alpha_shape))


def _box_geometry(boxes: Sequence[tuple[float, float, float]]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """(centre times about their mean, lengths, coefficients, span from the first box's start to
    the last one's end) of boxes (t, T, c): all that :func:`_box_difference_var` reads."""
    t = np.array([b[0] for b in boxes], dtype=np.float64)
    T = np.array([b[1] for b in boxes], dtype=np.float64)
    c = np.array([b[2] for b in boxes], dtype=np.float64)
    span = float(np.max(t + T / 2) - np.min(t - T / 2))
    return t - t.mean(), T, c, span


def _second_difference_var(boxes: Sequence[tuple[float, float, float]], alpha: NDArray[np.float64]
                          ) -> NDArray[np.float64]:
    """Variance of ``Σ c·(mean of the offset over [t - T/2, t + T/2])`` over boxes (t, T, c)
    whose coefficients sum to 0, for noise of one-sided PSD ``f^α`` (unit level), per α:
    ``∫ f^α·|Σ c·e^{-2πift}·sinc(fT)|² df``. Numerical, on a logarithmic grid (no closed form
    for general boxes); the integrand is O(f^(α+4)) at 0 for a second difference, which removes
    a line, and O(f^(α-2)) above 1/T, so the grid's ends (10⁻⁴/span, 10³/T) lose nothing."""
    return _box_difference_var(*_box_geometry(boxes), np.asarray(alpha, dtype=np.float64))


def _box_difference_var(t: NDArray[np.float64], T: NDArray[np.float64], c: NDArray[np.float64], span: float,
                        alpha: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`_second_difference_var` of boxes given by :func:`_box_geometry` (times about their mean)."""
    f = np.logspace(math.log10(1e-4 / span), math.log10(1e3 / float(np.min(T))), 1500)
    W = (c[None, :] * np.exp(-2j * np.pi * f[:, None] * t[None, :])
         * np.sinc(f[:, None] * T[None, :])).sum(axis=1)
    y = f[None, :] ** (alpha[:, None] + 1.0) * (np.abs(W) ** 2)[None, :]  # × f: over ln f
    var: NDArray[np.float64] = np.trapezoid(y, np.log(f), axis=1)
    return var


def _mean_excess(excess: Sequence[float]) -> float:
    """Mean excess of the squared second differences over the white prediction (nan: none).
    Not truncated at a significance level: white noise then adds its own positive fluctuations
    to some records' u (about +10 % coverage of ±1u on white noise), which is the price of not
    dropping real low-frequency noise from records that show it only weakly."""
    return float(np.mean(excess)) if excess else math.nan


def low_frequency(baselines: Sequence[Baseline]) -> LowFrequency:
    """The measured second differences of the baselines (see :class:`LowFrequency`)."""
    between = []
    for a, b, c in zip(baselines, baselines[1:], baselines[2:]):
        lam = (b.t_s - a.t_s) / (c.t_s - a.t_s)
        r = b.mean_g - ((1 - lam) * a.mean_g + lam * c.mean_g)
        white = b.u_g**2 + ((1 - lam) * a.u_g) ** 2 + (lam * c.u_g) ** 2
        if math.isfinite(r) and math.isfinite(white):
            between.append(r * r - white)
    used = [b for b in baselines if b.thirds_g is not None and math.isfinite(b.thirds_g)
            and math.isfinite(b.thirds_white_var)]
    within = [b.thirds_g**2 - b.thirds_white_var for b in used]  # type: ignore[operator]
    third = float(np.mean([(b.segment.end_s - b.segment.start_s) / 3 for b in used])) if used else math.nan
    return LowFrequency(_mean_excess(between), _mean_excess(within),
                        len(between), len(within), third)


def _off_scale_baselines(t_s: float, baselines: Sequence[Baseline]) -> list[Baseline]:
    """The baselines a level at ``t_s`` is referred to (:func:`bracket`) that sit at a rail."""
    before = [b for b in baselines if b.t_s <= t_s]
    after = [b for b in baselines if b.t_s > t_s]
    used = ([before[-1]] if before else []) + ([after[0]] if after else [])
    return [b for b in used if b.n_saturated > 0]


# Interior windows a segment needs for the batch-means u of its DUT mean (:func:`batch_mean`);
# fewer, the u rests on the windows' scatter about a line under the kernel's own correlation
# (:func:`correlated_mean`).
BATCH_WINDOWS = 10
# Interior windows the smoothed estimators need (a line through them leaves a residual); fewer,
# the DUT mean of a segment falls back on its raw window means.
MIN_SMOOTHED_WINDOWS = 3
# The notice of a reduction with levels flagged by :func:`few_windows` (``n`` of them).
FEW_WINDOWS_NOTE = (
    "{n} level(s) hold fewer than "
    f"{MIN_SMOOTHED_WINDOWS} interior averaging windows after the settling trims (flagged 'few-windows'): "
    "their u comes from the raw window means, which hold the vibration's residual over each window, and "
    "is no calibrated uncertainty (measured: ±u covers about 0.9 for a claim of 0.6); record longer levels (a window is "
    "max(0.1 s, 2/F1), F1 the band's lower edge)"
)


@dataclass(frozen=True)
class DutMean(MeanEstimate):
    """A segment's DUT mean (:func:`dut_mean_estimate`) with the degrees of freedom of its u and
    the estimator behind it: "batch-means", "correlated" or "raw" (the raw window means: their
    scatter holds the vibration's residual over each window when the segment is a level)."""

    dof: float = math.inf
    rule: str = "batch-means"


def correlated_mean(y: NDArray[np.float64], rho: Sequence[float]) -> tuple[float, float, float]:
    """(mean, u, ν) of a short series whose correlation at lags 0, 1, ... is ``rho`` (known up
    to the common variance σ²) and whose scatter is measured about a fitted straight line.

    With R the series' correlation matrix, A = I − X(XᵀX)⁻¹Xᵀ the residual projector of the
    line (X = [1, t]) and Q = yᵀAy the residuals' sum of squares: E[Q] = σ²·tr(AR) and the
    mean's variance is σ²·1ᵀR1/n² (n²/1ᵀR1 is Bayley and Hammersley's effective number of
    observations [1]_), so ``u² = Q·(1ᵀR1/n²)/tr(AR)`` is unbiased. Q is a Gaussian quadratic
    form, approximated by a scaled χ² of ``ν = tr(AR)²/tr((AR)²)`` degrees of freedom
    (Satterthwaite [2]_; Box [3]_): the ν that u's Student-t coverage factor needs. Written by
    hand: statsmodels and scipy offer neither for a known correlation of a short series.

    References
    ----------
    .. [1] G. V. Bayley and J. M. Hammersley, "The 'effective' number of independent
       observations in an autocorrelated time series", J. R. Stat. Soc. Suppl. 8, 184 (1946).
    .. [2] F. E. Satterthwaite, "An approximate distribution of estimates of variance
       components", Biometrics Bulletin 2, 110 (1946).
    .. [3] G. E. P. Box, "Some theorems on quadratic forms applied in the study of analysis of
       variance problems, I", Ann. Math. Statist. 25, 290 (1954).
    """
    n = len(y)
    A, R, tr, nu = _line_residual_form(n, rho)
    # Q = ||A(y - ȳ)||², equal to yᵀAy (A·1 = 0, A symmetric idempotent) without the cancellation
    # of a large mean (a 1 g baseline gave u 4e-9 g from rounding alone)
    r = A @ (y - y.mean())
    q = float(r @ r)
    u = math.sqrt(max(q, 0.0) * float(R.sum()) / (n * n) / tr)
    return float(y.mean()), u, nu


def _line_residual_form(n: int, rho: Sequence[float]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], float, float]:
    """(A, R, tr(AR), ν) of :func:`correlated_mean` for a series of n values (they do not
    depend on the data)."""
    lags = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    c = np.zeros(n)
    c[: min(n, len(rho))] = np.asarray(rho, dtype=float)[: min(n, len(rho))]
    R = c[lags]
    t = np.arange(n, dtype=float)
    X = np.column_stack([np.ones(n), t - t.mean()])
    A = np.eye(n) - X @ np.linalg.solve(X.T @ X, X.T)
    AR = A @ R
    tr = float(np.trace(AR))
    return A, R, tr, tr * tr / float(np.trace(AR @ AR))


@functools.lru_cache(maxsize=256)
def _line_residual_dof(n: int, rho: tuple[float, ...]) -> float:
    """ν of :func:`_line_residual_form`, computed once per (n, ρ): the levels and baselines of
    a record share a handful of lengths and one kernel correlation, and each form is an O(n³)
    product of n×n matrices (a 2 h record of 120 levels of 40 s spent 80 % of its analysis
    rebuilding them). Keyed by the exact inputs, so every ν is the same bits as a fresh
    computation; only the scalar is kept (a matrix of a long segment is megabytes)."""
    return _line_residual_form(n, rho)[3]


def dut_mean_estimate(stats: WindowStats, k0: int, k1: int) -> DutMean:
    """DUT mean over windows [k0, k1) with its standard uncertainty and degrees of freedom.

    The Hann-smoothed values (see :func:`~vrelab.analysis.segmentation.smoothing_kernel`) of the
    windows whose kernel stays inside the segment ("interior" windows) average the segment's
    samples with weights that are flat inside and taper over its first and last 0.2 s: a
    hard-edged (boxcar) mean would keep a residual of the vibration the DUT reads (of order
    σ/(π·f·T): 0.4 mg for 1.5 g of 80-200 Hz noise over 9 s) that no batch-means uncertainty
    accounts for.

    * BATCH_WINDOWS interior windows or more: batch means (:func:`batch_mean`) of the interior
      values; ν = batches − 2 (a line is removed), and when the batches are capped below
      ``BATCH_TAUS·τ`` (single correlated windows, short segments) at most the ν of
      :func:`correlated_mean` at that length scaled by τ_kernel/τ: n − 1 overstated it about
      twice (13 windows: 12 for some 7.6);
    * MIN_SMOOTHED_WINDOWS to BATCH_WINDOWS − 1: :func:`correlated_mean` with the correlation
      the kernel itself puts between neighbours
      (:func:`~vrelab.analysis.segmentation.kernel_correlation`), i.e. noise taken
      as white at the window scale; ν ≈ 1 (3 windows) to 5 (9 windows), no longer n − 1;
    * fewer: the plain mean, its u from the raw window means (rule "raw"). Over a level those
      hold the vibration's residual over each window, which largely cancels in the segment's
      mean: the u is then not calibrated (:func:`few_windows`).
    """
    h = SMOOTH_WINDOWS // 2
    a, b = k0 + h, k1 - h
    n = b - a
    if n >= BATCH_WINDOWS:
        tau_k = kernel_tau(stats.window)
        est = batch_mean(stats.dut_smooth[a:b], tau_min=tau_k)
        dof = float(max(est.n_batches - 2, 1))
        if est.batch < BATCH_TAUS * est.tau:
            nu_k = _line_residual_dof(n, kernel_correlation(stats.window))
            dof = min(dof, nu_k * tau_k / est.tau)
        return DutMean(est.mean, est.u, est.tau, est.batch, est.n_batches, dof, "batch-means")
    if n >= MIN_SMOOTHED_WINDOWS:
        mean, u, nu = correlated_mean(stats.dut_smooth[a:b], kernel_correlation(stats.window))
        return DutMean(mean, u, kernel_tau(stats.window), 1, n, nu, "correlated")
    raw = batch_mean(stats.dut_mean()[k0:k1])
    mean = float(stats.dut_sum[k0:k1].sum() / stats.count[k0:k1].sum())
    return DutMean(mean, raw.u, raw.tau, raw.batch, raw.n_batches, float(max(raw.n_batches - 2, 1)), "raw")


def few_windows(stats: WindowStats, seg: Segment) -> bool:
    """Whether a random level's VRE u is not calibrated for want of windows: the level holds
    fewer than MIN_SMOOTHED_WINDOWS interior windows, so its DUT mean's u comes from the raw
    window means, which hold the vibration's residual over each window (it largely cancels in
    the segment's mean): measured ±u covering 0.88 for a claimed 0.61 (2 s levels, 0.2 s windows;
    tests/test_short_levels_coverage.py).

    Not flagged: fewer than BATCH_WINDOWS (:func:`correlated_mean` gives a calibrated u with
    few degrees of freedom, ``dof``, whose coverage is Student's t: use U = k(dof)·u); a
    baseline of few windows (no vibration in its raw window means: their scatter is honest,
    measured: 4 s levels between 2 s baselines of 0.2 s windows cover ±u, ±2u, ±U within the
    binomial limits of their claims)."""
    k0, k1 = segment_windows(stats, seg)
    return k1 - k0 - 2 * (SMOOTH_WINDOWS // 2) < MIN_SMOOTHED_WINDOWS


# --------------------------------------------------------------------------- bracketing


def bracket(t_s: float, baselines: Sequence[Baseline]) -> tuple[float, float, str | None]:
    """Baseline at time ``t_s``: linear interpolation between the bracketing baselines.

    Returns (value, standard uncertainty, warning or None). With a baseline on one side only,
    the nearest one is used and a warning says so.
    """
    before = [b for b in baselines if b.t_s <= t_s]
    after = [b for b in baselines if b.t_s > t_s]
    if before and after:
        a, b = before[-1], after[0]
        lam = (t_s - a.t_s) / (b.t_s - a.t_s)
        val = (1 - lam) * a.mean_g + lam * b.mean_g
        u = math.hypot((1 - lam) * a.u_g, lam * b.u_g)
        return val, u, None
    near = before[-1] if before else after[0]
    side = "after" if before else "before"
    return near.mean_g, near.u_g, f"no baseline {side} the level at {t_s:.4g} s: nearest baseline used, drift not removed"


# --------------------------------------------------------------------------- baselines and levels


def segment_samples(seg: Segment, fs_hz: float, n_samples: int) -> tuple[int, int]:
    """The samples ``[i0, i1)`` of a segment: those whose time lies within it."""
    i0 = int(math.ceil(seg.start_s * fs_hz - 1e-9))
    i1 = min(int(math.floor(seg.end_s * fs_hz + 1e-9)), n_samples)
    return i0, i1


def n_windows(stats: WindowStats, seg: Segment) -> int:
    """Whole averaging windows inside a segment."""
    k0, k1 = segment_windows(stats, seg)
    return k1 - k0


def find_baselines(stats: WindowStats, sched: Schedule, sat: NDArray[np.int64], warnings: list[str],
                   record: Record | None = None) -> list[Baseline]:
    """The DUT's vibration-off readings, one per baseline segment long enough to average; with
    ``record``, over 0.1 s windows where a band from below 20 Hz leaves too few windows
    (:mod:`~vrelab.analysis.baseline_windows`); all too short even so: refused, naming why."""
    out: list[Baseline] = []
    fine_w, short = (finer_window(stats) if record is not None else None), []
    for seg in sched.segments:
        if not seg.is_baseline:
            continue
        k0, k1 = segment_windows(stats, seg)
        src, n_sat, t0 = stats, int(sat[k0:k1].sum()), 0.0
        if fine_w is not None and record is not None and k1 - k0 < MIN_SEGMENT_WINDOWS:
            i0, i1 = segment_samples(seg, stats.fs_hz, stats.n_samples)
            if i1 - i0 >= MIN_SEGMENT_WINDOWS * fine_w:
                src, n_sat = fine_baseline_stats(record, stats, sat, i0, i1)
                k0, k1, t0 = 0, src.n_samples // src.window, i0 / stats.fs_hz
        if k1 - k0 >= MIN_SEGMENT_WINDOWS:
            out.append(_baseline(src, k0, k1, t0, seg, n_sat))
            continue
        warnings.append(Notice("segment", f"baseline {seg.start_s:.4g}-{seg.end_s:.4g} s too short, ignored"))
        short.append(seg.end_s - seg.start_s)
    if not out and short and fine_w is not None:
        raise ValueError(too_short(max(short), MIN_SEGMENT_WINDOWS * fine_w / stats.fs_hz))
    return out


def _baseline(stats: WindowStats, k0: int, k1: int, t0: float, seg: Segment, n_sat: int) -> Baseline:
    """The baseline of windows [k0, k1) of ``stats`` (whose time 0 is ``t0`` in the record)."""
    est, h = dut_mean_estimate(stats, k0, k1), SMOOTH_WINDOWS // 2
    y, thirds, white = stats.dut_smooth[k0 + h : k1 - h], None, 0.0
    if len(y) >= 15:  # thirds of 0.5 s or more: longer than the smoothing kernel
        m = len(y) // 3
        m1, m2, m3 = (float(y[i * m : (i + 1) * m].mean()) for i in range(3))
        # each third holds a third of the samples: variance 3·u² if white; m2 - (m1+m3)/2
        # then has 3·u²·(1 + 1/4 + 1/4)
        thirds, white = m2 - (m1 + m3) / 2, 4.5 * est.u**2
    t_c = t0 + float(np.mean(stats.window_times_s(k0, k1)))
    return Baseline(t_c, est.mean, est.u, seg, n_sat, est.dof, thirds, white)


@dataclass(frozen=True)
class LevelContext:
    """What every level of one record is reduced with (:func:`reduce_level`)."""

    record: Record
    stats: WindowStats  # the first pass
    saturated: NDArray[np.int64]  # saturated DUT samples per window (WindowStats.saturated)
    baselines: Sequence[Baseline]
    low_frequency: LowFrequency | None  # None: no low-frequency term
    block_size: int  # samples per block of a sine level's second pass


def reduce_level(ctx: LevelContext, seg: Segment, method: Method
                 ) -> tuple[LevelResult, float, list[str], tuple[tuple[float, float], ...] | None]:
    """One level (segment ``seg``): its rms and DUT mean by ``method``, its VRE against the
    bracketing baselines; its centre time, warnings and the second difference of its own thirds
    (:func:`thirds_difference`, for :func:`short_baseline_u`). Its u: the level's and the
    baselines' batch means and the low-frequency term (:class:`LowFrequency`)."""
    record, stats, baselines = ctx.record, ctx.stats, ctx.baselines
    k0, k1 = segment_windows(stats, seg)
    n_sat = int(ctx.saturated[k0:k1].sum())
    warnings: list[str] = []
    fs = record.fs_hz
    freq = None
    vre_2f = None
    drive = None
    dm: MeanEstimate
    if method == "random":
        dm = dut_mean_estimate(stats, k0, k1)
        power = stats.ref_band_sumsq[k0:k1] / stats.count[k0:k1]
        pm = batch_mean(power, detrend=False)
        rms = math.sqrt(max(pm.mean, 0.0))
        u_rms = random_level_u_ms(pm, stats, k0, k1) / (2 * rms) if rms > 0 else math.nan
        t_c = float(np.mean(stats.window_times_s(k0, k1)))
        n_used = int(stats.count[k0:k1].sum())
        h = SMOOTH_WINDOWS // 2
        thirds = thirds_difference(stats.dut_smooth[k0 + h : k1 - h], kernel_correlation(stats.window))
    else:
        i0, i1 = segment_samples(seg, fs, stats.n_samples)
        sl = sine_level(record, i0, i1, stats.reference, ctx.block_size, seg.freq_hz, stats.shared)
        freq, dm, t_c = sl.freq_hz, sl.dut_mean, sl.t_centre_s
        warnings += sl.warnings
        rms, u_rms, n_used, drive = sl.ref_rms.mean, sl.ref_rms.u, sl.n_samples, sl.drive
        h2 = sl.shift_2f
        if h2 is not None and math.isfinite(h2.mean) and math.isfinite(h2.u):
            vre_2f = Estimate(h2.mean, h2.u, "g")
        thirds = thirds_difference(sl.batch_offsets) if sl.batch_offsets is not None else None
    base, u_base, note = bracket(t_c, baselines)
    if note:
        warnings.append(Notice("bracket", note))
    flags: tuple[str, ...] = ("saturated",) if n_sat > 0 else ()
    var_lf, dof_lf = _low_frequency_at(ctx.low_frequency, t_c, n_used / fs, baselines)
    vre = Estimate(dm.mean - base, math.sqrt(dm.u**2 + u_base**2 + var_lf), "g")
    dof = _vre_dof(vre.u, dm, t_c, baselines, (math.sqrt(var_lf), dof_lf))
    if method == "random" and few_windows(stats, seg):
        flags += ("few-windows",)
    off = _off_scale_baselines(t_c, baselines)
    if off:
        # physics §4.2: a vibration-off reading at a rail makes VRE undefined: no plain number
        flags += ("baseline-off-scale",)
        vre = Estimate(math.nan, math.nan, "g")
        warnings.append(Notice(
            "baseline-off-scale",
            f"level {rms:.4g} g rms: its baseline at {off[0].t_s:.4g} s sits at a rail ({off[0].n_saturated} "
            f"samples; mean {off[0].mean_g:+.4g} g): VRE undefined, reported as null",
        ))
    level = LevelResult(rms_g=rms, vre=vre, freq_hz=freq, u_rms_g=u_rms, duration_s=n_used / fs, n_samples=n_used,
                        n_saturated=n_sat, flags=flags, dof=dof, vre_2f=vre_2f, drive=drive)
    return level, t_c, warnings, thirds


def _pooled_baseline_var(baselines: Sequence[Baseline], a: Baseline, b: Baseline) -> tuple[float, float]:
    """(u², ν) of one baseline's mean, pooled over the record's baselines within 10 % of the
    length of ``a`` and ``b`` (u² averaged, their ν summed); ``a``'s and ``b``'s own
    when their lengths differ more."""
    la, lb = (x.segment.end_s - x.segment.start_s for x in (a, b))
    if abs(la - lb) > 0.1 * max(la, lb):
        return math.hypot(a.u_g, b.u_g) ** 2 / 2, min(a.dof, b.dof)
    same = [x for x in baselines if abs((x.segment.end_s - x.segment.start_s) - la) <= 0.1 * la
            and x.n_saturated == 0 and math.isfinite(x.u_g)]
    if len(same) < 2:
        return math.hypot(a.u_g, b.u_g) ** 2 / 2, min(a.dof, b.dof)
    return float(np.mean([x.u_g**2 for x in same])), float(sum(x.dof for x in same))


def short_baseline_u(levels: Sequence[LevelResult], times: Sequence[float],
                     thirds: Sequence[tuple[tuple[float, float], ...] | None], baselines: Sequence[Baseline],
                     lf: LowFrequency | None) -> list[LevelResult]:
    """The levels, those bracketed by baselines shorter than SHORT_BASELINE_FRACTION of them
    (:func:`short_baselines`) with a u that holds the DUT's low-frequency noise at their own
    time scale.

    Such baselines (1 s between 9 s levels) cannot show flicker at the level's scale: their
    thirds see 0.3 s, where white noise dominates, and carried to the level's geometry a
    random walk's share of them grows 17-fold against flicker's 1.3 (:func:`second_difference_var`),
    so :class:`LowFrequency` cannot tell which; the u covered ±2u 0.87, |z| up to 5.5. The
    levels themselves are long: the excess of their own second differences at a third, a
    fourth and a fifth of the level over the white prediction (:func:`thirds_difference`),
    averaged over the record's levels (weights 1/white², see below), is the
    low-frequency noise at the level's scale. Each is carried to a level's geometry (its mean
    against the interpolated baselines) by the largest ratio over α in [-2, -1] (for thirds
    1.28 for flicker to 1.89 for a random walk, 9 s levels between 1 s baselines 12 s apart:
    at most 1.5× in variance conservative), and the three carried values averaged. The level's
    u takes this term in place of :class:`LowFrequency`'s when it is the larger, and the
    bracketing baselines' scatter pooled over the record's baselines of their length
    (:func:`_pooled_baseline_var`); the degrees of freedom follow by Welch-Satterthwaite (the
    term's: the effective number of levels averaged). Measured (60 records of
    tests/test_noise.py's lab noise, 240 levels each): ±2u 0.971 sine, 0.975 random, worst |z|
    3.0; on white noise alone ±1u 0.80 (sine) and 0.81 (random) against 0.71 and 0.77 before.
    Welch-Satterthwaite (the term's: the number of levels averaged)."""
    rows = [t for t in thirds if t is not None]
    if not rows:
        return list(levels)
    # Averaged over the levels with weights 1/white²: an excess's variance grows with the square
    # of its series' scatter, and a loud level (a clipped one: its rectification wanders) holds
    # an excess of its own that is not the DUT's noise; its weight keeps it off the quiet levels
    excess, n_eff = [], []
    for i in range(len(THIRDS_PARTS)):
        w = np.array([1.0 / r[i][1] ** 2 if r[i][1] > 0 else 0.0 for r in rows])
        if not w.sum() > 0:
            return list(levels)
        excess.append(float(w @ np.array([r[i][0] - r[i][1] for r in rows]) / w.sum()))
        n_eff.append(float(w.sum() ** 2 / (w @ w)))
    if not any(e > 0 for e in excess):
        return list(levels)
    n_ex = min(n_eff)
    out = []
    for lv, t_c in zip(levels, times):
        length = lv.duration_s if lv.duration_s is not None else math.nan
        before = [b for b in baselines if b.t_s <= t_c]
        after = [b for b in baselines if b.t_s > t_c]
        if (not (math.isfinite(lv.vre.u) and length > 0) or short_baselines(t_c, length, baselines) is None
                or not (before and after)):
            out.append(lv)
            continue
        a, b = before[-1], after[0]
        lam = (t_c - a.t_s) / (b.t_s - a.t_s)
        geo = ((t_c, length, 1.0), (a.t_s, a.segment.end_s - a.segment.start_s, -(1 - lam)),
               (b.t_s, b.segment.end_s - b.segment.start_s, -lam))
        v_geo = second_difference_var(geo, ALPHAS)
        carried = []
        for p, e in zip(THIRDS_PARTS, excess):
            part = length / p
            th = ((0.0, part, 1.0), (-part, part, -0.5), (part, part, -0.5))
            carried.append(max(e, 0.0) * float(np.max(v_geo / second_difference_var(th, ALPHAS))))
        var_new = float(np.mean(carried))
        var_old, dof_old = _low_frequency_at(lf, t_c, length, baselines)
        var_new = max(var_new, var_old)
        dof_new = float(n_ex) if var_new > var_old else dof_old
        # the bracketing baselines' white scatter: each from a second or so (ν of 3 to 5), pooled
        # over the record's baselines of that length (they share the DUT's noise)
        wa, wb = (1 - lam) ** 2, lam**2
        old_b = [(wa * a.u_g**2, a.dof), (wb * b.u_g**2, b.dof)]
        var_b, dof_b = _pooled_baseline_var(baselines, a, b)
        new_b = [(wa * var_b, dof_b), (wb * var_b, dof_b)]
        u_old = lv.vre.u
        u2 = u_old * u_old - var_old - sum(v for v, _ in old_b) + var_new + sum(v for v, _ in new_b)
        u_new = math.sqrt(max(u2, 0.0))
        # Welch-Satterthwaite: u⁴/ν is a sum over the components; the old terms' shares out, the new ones' in
        nu_old = lv.dof if lv.dof is not None and lv.dof > 0 else math.inf
        s = (u_old**4 / nu_old - (var_old * var_old / dof_old if var_old > 0 else 0.0) + var_new * var_new / dof_new
             - sum(v * v / d for v, d in old_b if v > 0) + sum(v * v / d for v, d in new_b if v > 0))
        dof = u_new**4 / s if s > 0 else float(n_ex)
        out.append(dataclasses.replace(lv, vre=Estimate(lv.vre.value, u_new, lv.vre.unit), dof=dof))
    return out


# One-sided significance at which the windows' scatter is taken to exceed what a Gaussian
# process of the measured spectrum allows (random_level_u_ms; why 10 % there).
GAUSSIAN_SCATTER_ALPHA = 0.1


def random_level_u_ms(pm: MeanEstimate, stats: WindowStats, k0: int, k1: int) -> float:
    """Standard uncertainty of a random level's mean square (windows [k0, k1)) as an estimate
    of the vibration's: of the profile's grms², not of this record's own sample.

    A band-limited random signal's mean square over T fluctuates by ``1/√(B_e·T)`` (Bendat &
    Piersol, Random Data, 4th ed., 8.2.2; B_e the equivalent bandwidth): far fewer degrees of
    freedom than samples. The windows' scatter (batch means, ``pm``) measures it, but from a
    handful of windows (4 to 20 in a 2 s level): a u with 3 to 19 degrees of freedom, reported
    as if exact, whose low draws go with low levels (window powers are skewed), so it covered
    ±1u 0.55-0.6 of the time and ±2u 0.85 (tests/test_u_honest_rms.py). Instead, each window's
    own spectrum gives the variance of its power were the signal Gaussian
    (:func:`~vrelab.analysis.segmentation.band_variance_weights`, summed over every bin of every
    window: hundreds of degrees of freedom), and windows ``T_w ≫ 1/B`` apart are independent,
    so ``u² = Σ_w var_w / (Σ_w n_w)²``. The windows' scatter stays the check: when it exceeds
    that Gaussian u at the 10 % level (χ² with the batches' degrees of freedom: a non-Gaussian
    drive, a level that wanders), the scatter's u is taken instead. (10 %, not 1 %: a drive of
    kurtosis 6 scatters 2.2× the Gaussian variance, which 9 degrees of freedom show at 10 % two
    times in three; Gaussian levels then take the scatter's u one time in ten, at little cost.)
    Domain: many bins in the band (B·T_w ≫ 1); a band of 5 bins (50 Hz in 0.1 s windows)
    gives a u about 10 % small (the rectangular window's leakage smooths the spectrum's edges).
    """
    var = stats.ref_band_var
    if var is None or pm.n_batches < 2:
        return pm.u
    n = k1 - k0
    u_model = math.sqrt(float(np.sum(var[k0:k1] / stats.count[k0:k1].astype(float) ** 2))) / n
    if not (math.isfinite(u_model) and u_model > 0):
        return pm.u
    # χ² quantile from scipy.special, as scipy.stats.chi2.ppf computes it (2·gammaincinv(ν/2, p)):
    # the same bits without importing scipy.stats, which cost the CLI's analysis a second of CPU
    from scipy.special import gammaincinv

    dof = pm.n_batches - 1
    if math.isfinite(pm.u) and (pm.u / u_model) ** 2 > 2 * gammaincinv(dof / 2, 1 - GAUSSIAN_SCATTER_ALPHA) / dof:
        return pm.u
    return u_model


def off_stretches(stats: WindowStats, baselines: Sequence[Baseline]) -> list[NDArray[np.float64]]:
    """The DUT's window means over each vibration-off stretch (baselines off-scale left out):
    what :func:`vrelab.analysis.noise.channel_noise` reads the channel's noise from."""
    y = stats.dut_mean()
    out = []
    for b in baselines:
        if b.n_saturated == 0:
            k0, k1 = segment_windows(stats, b.segment)
            out.append(y[k0:k1])
    return out


# A level whose bracketing baselines are all shorter than this fraction of it is named in a
# notice (SHORT_BASELINES_NOTE) and its u holds the levels' own low-frequency noise
# (:func:`short_baseline_u`): the baselines cannot show it at the level's time scale.
SHORT_BASELINE_FRACTION = 1 / 3
SHORT_BASELINES_NOTE = (
    "{n} level(s) are bracketed by vibration-off baselines shorter than a third of the level "
    "({base:.3g} s against {level:.3g} s after the trims): the DUT's flicker and drift at the level's time scale "
    "cannot be measured on them, so those levels' u takes it from the levels' own slow wander (the second "
    "differences of their thirds, fourths and fifths), with few degrees of freedom (use U = k·u); "
    "record baselines about as long as the levels"
)


def short_baselines(t_s: float, length_s: float, baselines: Sequence[Baseline]) -> float | None:
    """The longest of the baselines a level (centre ``t_s``, ``length_s`` long) is referred to
    (:func:`bracket`) when it is shorter than SHORT_BASELINE_FRACTION of the level, else None."""
    before = [b for b in baselines if b.t_s <= t_s]
    after = [b for b in baselines if b.t_s > t_s]
    used = ([before[-1]] if before else []) + ([after[0]] if after else [])
    longest = max((b.segment.end_s - b.segment.start_s for b in used), default=math.inf)
    return longest if longest < SHORT_BASELINE_FRACTION * length_s else None


def _low_frequency_at(lf: LowFrequency | None, t_s: float, length_s: float,
                      baselines: Sequence[Baseline]) -> tuple[float, float]:
    """(variance [g²], dof) of the low-frequency term for the level at ``t_s`` (0, inf when
    it is not bracketed: the nearest baseline alone is already flagged as not removing drift)."""
    before = [b for b in baselines if b.t_s <= t_s]
    after = [b for b in baselines if b.t_s > t_s]
    if lf is None or not (before and after):
        return 0.0, math.inf
    a, b = before[-1], after[0]
    var, dof, _ = lf.at((t_s, length_s), (a.t_s, a.segment.end_s - a.segment.start_s),
                        (b.t_s, b.segment.end_s - b.segment.start_s))
    return var, dof


def _vre_dof(u: float, dm: MeanEstimate, t_s: float, baselines: Sequence[Baseline],
             lf: tuple[float, float] | None = None) -> float:
    """Welch-Satterthwaite degrees of freedom of a VRE's u: the level's batch means, the
    bracketing baselines' (their weights as in :func:`bracket`) and the low-frequency term's."""
    # a DUT mean of dut_mean_estimate carries its dof; a sine level's its batches'
    nu = dm.dof if isinstance(dm, DutMean) else max(dm.n_batches - 1, 1)
    parts: list[tuple[float, float]] = [(dm.u, nu)]
    before = [b for b in baselines if b.t_s <= t_s]
    after = [b for b in baselines if b.t_s > t_s]
    if before and after:
        a, b = before[-1], after[0]
        lam = (t_s - a.t_s) / (b.t_s - a.t_s)
        parts += [((1 - lam) * a.u_g, a.dof), (lam * b.u_g, b.dof)]
    else:
        near = before[-1] if before else after[0]
        parts.append((near.u_g, near.dof))
    if lf is not None and lf[0] > 0:
        parts.append(lf)
    return welch_satterthwaite(u, parts) if u > 0 else math.inf


__all__ = [
    "ALPHAS",
    "BATCH_WINDOWS",
    "FEW_WINDOWS_NOTE",
    "MIN_SEGMENT_WINDOWS",
    "MIN_SMOOTHED_WINDOWS",
    "SHORT_BASELINES_NOTE",
    "SHORT_BASELINE_FRACTION",
    "Baseline",
    "DutMean",
    "LevelContext",
    "LowFrequency",
    "bracket",
    "correlated_mean",
    "dut_mean_estimate",
    "few_windows",
    "find_baselines",
    "low_frequency",
    "n_windows",
    "off_stretches",
    "reduce_level",
    "second_difference_var",
    "segment_samples",
    "short_baseline_u",
    "short_baselines",
]
