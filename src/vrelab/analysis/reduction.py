"""Reduction of a recorded shaker test to VRE per level (SPEC section 4).

Steps, each over data streamed in blocks:

1. :func:`~vrelab.analysis.segmentation.window_pass`: per-window numbers (0.1 s windows, longer
   when the band starts below 20 Hz), the next block read in a background thread.
2. Segmentation: the user's schedule, else the one embedded in the record, else automatic from
   the reference's rms envelope; ``settle_s`` trimmed at both edges of every segment.
3. DUT mean of a segment (baseline or random level) and its uncertainty: from the Hann-smoothed
   window series (:func:`dut_mean_estimate`), batch means sized by the autocorrelation time.
4. Levels. *Random*: level = reference rms in the test band (the window FFTs' in-band power).
   *Sine*: a second pass over each level: the drive frequency from the reference
   (Hann-windowed FFT peak, log-parabolic interpolation), then batches of a whole number of
   drive periods (the number chosen so that a batch is within a small fraction of a sample of
   whole periods), in each a three-parameter sine fit (IEEE Std 1057: offset, cos, sin at the
   drive frequency) of reference and DUT: level = rms of the reference's fitted sine, DUT mean
   = the DUT's fitted offset, the drive removed exactly. A plain mean over a non-integer number of periods would
   leave a residual of order A/(2π·f·T) (SPEC 4).
5. VRE = DUT mean under vibration − baseline at the level's centre time, the baseline linearly
   interpolated between the off-segments before and after the level (bracketing removes a
   linear drift exactly); fall back to the nearest baseline with a warning.
   ``u² = u_level² + (1-λ)²·u_before² + λ²·u_after²`` (λ the interpolation weight).

Public API: :func:`reduce_record` (levels and warnings, what the simulated test calls),
:func:`reduce` (everything, for the CLI's output files), :func:`analyze` (levels + fits as a
:class:`~vrelab.results.VreResult`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Collection, Iterator, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab._version import __version__
from vrelab.analysis.plausibility import MethodRequest
from vrelab.analysis.segmentation import (
    SMOOTH_WINDOWS,
    WindowStats,
    auto_segment,
    channel_labels,
    check_finite,
    exact_blocks,
    kernel_tau,
    segment_windows,
    trim,
    window_pass,
)
from vrelab.analysis.uncertainty import MeanEstimate, batch_mean
from vrelab.fits import fit_levels
from vrelab.models.clipping import KINDS
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.record import DEFAULT_SETTLE_S, WINDOW_S, Record, Schedule, Segment
from vrelab.results import (
    Conditions,
    Estimate,
    FitResult,
    LevelResult,
    Method,
    Notice,
    VreResult,
)

DEFAULT_BAND_HZ = (50.0, 2000.0)
DEFAULT_BLOCK = 1 << 18
# A segment needs this many whole averaging windows after the trim, or it is ignored.
MIN_SEGMENT_WINDOWS = 3


def default_band(fs_hz: float, band_hz: tuple[float, float] | None = None, profile: Any = None) -> tuple[float, float]:
    """The test band: given, else the profile's band, else 50–2000 Hz; clamped to Nyquist."""
    if band_hz is None:
        band_hz = tuple(profile.band) if profile is not None and hasattr(profile, "band") else DEFAULT_BAND_HZ
    f1, f2 = (float(x) for x in band_hz)
    if not (0 < f1 < f2) or not (math.isfinite(f1) and math.isfinite(f2)):
        raise ValueError(f"band_hz must be F1:F2 with 0 < F1 < F2, got {f1:g}:{f2:g}")
    nyq = fs_hz / 2
    if f1 >= nyq:
        raise ValueError(f"band_hz lower edge {f1:g} Hz is not below Nyquist ({nyq:g} Hz at fs {fs_hz:g} Hz)")
    return f1, min(f2, nyq)


@dataclass(frozen=True)
class Baseline:
    t_s: float  # centre time
    mean_g: float
    u_g: float
    segment: Segment
    n_saturated: int = 0  # DUT samples at a rail: the vibration-off reading is off-scale
    dof: float = math.inf  # degrees of freedom of u_g (batch means: batches - 1)
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
    whose coefficients sum to 0, for noise of one-sided PSD ``f^α`` (unit level), per α:
    ``∫ f^α·|Σ c·e^{-2πift}·sinc(fT)|² df``. Numerical, on a logarithmic grid (no closed form
    for general boxes); the integrand is O(f^(α+4)) at 0 for a second difference, which removes
    a line, and O(f^(α-2)) above 1/T, so the grid's ends (10⁻⁴/span, 10³/T) lose nothing."""
    t = np.array([b[0] for b in boxes])
    T = np.array([b[1] for b in boxes])
    c = np.array([b[2] for b in boxes])
    span = float(np.max(t + T / 2) - np.min(t - T / 2))
    f = np.logspace(math.log10(1e-4 / span), math.log10(1e3 / float(np.min(T))), 1500)
    W = (c[None, :] * np.exp(-2j * np.pi * f[:, None] * (t - t.mean())[None, :])
         * np.sinc(f[:, None] * T[None, :])).sum(axis=1)
    y = f[None, :] ** (np.asarray(alpha)[:, None] + 1.0) * (np.abs(W) ** 2)[None, :]  # × f: over ln f
    return np.trapezoid(y, np.log(f), axis=1)


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


@dataclass
class Reduction:
    """Everything one reduction found (the CLI writes parts of it to files)."""

    levels: list[LevelResult]
    warnings: list[str]
    stats: WindowStats
    schedule: Schedule  # trimmed, the segments actually averaged
    baselines: list[Baseline]
    level_segments: list[Segment]
    level_times_s: list[float]
    psd: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = field(default_factory=list)
    method: Method = "random"  # what the levels were reduced as (auto: what they showed)
    # (kind, peak_hz, DUT/reference rms ratio) of each level probed: a campaign judges a channel's
    # units over all its runs with them (plausibility.check_units_over_runs)
    unit_probes: list[tuple[str | None, float, float]] = field(default_factory=list)

    @property
    def static_g(self) -> float | None:
        """The DUT's mean reading with vibration off (static field plus its offset)."""
        if not self.baselines:
            return None
        return float(np.mean([b.mean_g for b in self.baselines]))


# --------------------------------------------------------------------------- sine helpers


def estimate_frequency(x: NDArray[np.float64], fs_hz: float) -> float:
    """Drive frequency: peak of a Hann-windowed FFT, a parabola through the log peak, then a
    least-squares sine-fit refinement.

    For a Hann window the log-magnitude peak is close to a parabola; the interpolated bin is
    good to about 0.01 bin for a clean sine (Gasior & Gonzalez, CERN AB-Note-2004-021). The
    refinement minimises the residual of the least-squares sine over the probe (IEEE Std 1057,
    four-parameter fit), good to about 1e-6 bin for a clean sine.
    """
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    if n < 16:
        raise ValueError(f"segment too short to find the drive frequency ({n} samples)")
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n)))
    spec[:2] = 0.0
    k = int(np.argmax(spec))
    if spec[k] <= 0:
        raise ValueError("reference has no oscillation to find the drive frequency from")
    if 1 <= k < len(spec) - 1 and spec[k - 1] > 0 and spec[k + 1] > 0:
        a, b, c = np.log(spec[k - 1 : k + 2])
        den = a - 2 * b + c
        delta = 0.5 * (a - c) / den if den != 0 else 0.0
    else:
        delta = 0.0
    f0 = (k + delta) * fs_hz / n
    # Refine: the frequency whose least-squares sine (offset, cos, sin) leaves the smallest
    # residual over the probe (the four-parameter fit of IEEE Std 1057), searched within ±0.2 bin
    # of the interpolated peak; Hann-parabola interpolation alone is biased by up to ~0.01 bin.
    from scipy.optimize import minimize_scalar

    t = np.arange(n) / fs_hz
    xc = x - x.mean()
    xx = float(xc @ xc)
    sx = float(xc.sum())

    def residual(f: float) -> float:
        # the 3x3 normal equations of the (offset, cos, sin) fit: the residual is xᵀx − coefᵀ·Bᵀx
        # (no n×3 design matrix and SVD per evaluation; columns this well conditioned need none)
        ph = 2 * np.pi * f * t
        c, s = np.cos(ph), np.sin(ph)
        G = np.array([[n, c.sum(), s.sum()], [0.0, c @ c, c @ s], [0.0, 0.0, s @ s]])
        G = np.triu(G) + np.triu(G, 1).T
        rhs = np.array([sx, c @ xc, s @ xc])
        coef = np.linalg.solve(G, rhs)
        return xx - float(coef @ rhs)

    bw = fs_hz / n
    bounds = (f0 - 0.2 * bw, f0 + 0.2 * bw)
    res = minimize_scalar(residual, bounds=bounds, method="bounded", options={"xatol": 1e-7 * bw})
    return float(res.x) if res.success else f0


def whole_period_batch(freq_hz: float, fs_hz: float, target_s: float = WINDOW_S) -> tuple[int, int]:
    """(periods m, samples L) per batch: L = round(m·fs/f) closest to a whole number of periods.

    m is searched around ``target_s·f``; the one whose m·fs/f lies nearest an integer wins, so
    the leftover of the drive in a batch mean is a tiny fraction of A/(2π·f·T).
    """
    p = fs_hz / freq_hz
    m0 = max(1, int(round(target_s * freq_hz)))
    cands = np.arange(max(1, int(0.6 * m0)), int(1.6 * m0) + 2)
    frac = np.abs(cands * p - np.round(cands * p))
    m = int(cands[int(np.argmin(frac + 1e-6 * np.abs(cands - m0) / m0))])
    return m, int(round(m * p))


def _sine_level(
    record: Record, i0: int, i1: int, ref: str, block_size: int, freq_hint: float | None,
    shared: dict[Any, Any] | None = None,
) -> tuple[float, MeanEstimate, MeanEstimate, float, float, list[str], MeanEstimate | None]:
    """Second pass over one sine level: (freq, DUT mean, ref rms estimate, t_centre, n, warnings,
    the 2f estimate of the rectified shift or None).

    ``shared``: what the DUT channels of one record share (their window stats' ``shared``): the
    drive frequency of a level is the reference's, found once for all of them.

    The 2f estimate (SPEC 6.1): a quadratic term k·m² on the DUT's motion m = Re[c1·e^{jθ}]
    (c1 the DUT's fitted phasor at f) adds k·|c1|²/2 at DC and k·c1²/2 at 2f, the same
    coefficient. So ``Re[(c2 - r2)·conj(c1)²]/|c1|²``, with c2 the DUT's fitted 2f phasor and r2
    the reference's (the shaker's own distortion, which the DUT merely follows), estimates the
    rectified shift k·|c1|²/2 without using the DC, hence immune to drift. None without a
    reference, or when 2f is at or above Nyquist."""
    fs = record.fs_hz
    warnings: list[str] = []
    key = ("frequency", i0, i1)
    if shared is not None and key in shared:
        f = shared[key]
    else:
        n_probe = min(i1 - i0, 1 << 17)
        probe = next(record.blocks(n_probe, [ref], i0, i0 + n_probe))[ref]
        f = estimate_frequency(probe, fs)
        if shared is not None:
            shared[key] = f
    if freq_hint is not None and abs(f - freq_hint) > 0.05 * freq_hint:
        warnings.append(Notice("frequency", f"drive found at {f:.4g} Hz, schedule says {freq_hint:.4g} Hz"))
    m, L = whole_period_batch(f, fs)
    nb = (i1 - i0) // L
    if nb < 3:
        raise ValueError(
            f"sine level {i0 / fs:.3g}-{i1 / fs:.3g} s holds fewer than 3 batches of {m} periods at {f:.4g} Hz"
        )
    stop = i0 + nb * L
    w = 2 * np.pi * f / fs
    # Per batch, the three-parameter sine fit of IEEE Std 1057 (offset + cos + sin at the drive
    # frequency, least squares): its offset is the DUT mean with the drive removed exactly, its
    # amplitude the reference level with no leakage from the negative-frequency image (a
    # single-bin DFT over not-quite-whole periods would bias the rms by up to |Σe^{-2jωn}|²/L²).
    # offset, cos, sin at f, and at 2f when it is below Nyquist (and a reference gives r2): five
    # orthogonal functions over whole periods, so the offset is the same as the three-term fit's
    two_f = ref != "dut" and 2 * f < 0.5 * fs
    nf = 5 if two_f else 3
    basis_sums = np.zeros((nb, nf, nf))
    dut_ss = np.zeros(nb)  # Σ dut² per batch: the fit's residual, for the leakage term below
    rhs = {c: np.zeros((nb, nf)) for c in ("dut", ref)}
    blk_len = max(L, (block_size // L) * L)
    chans = ["dut"] if ref == "dut" else ["dut", ref]
    labels = channel_labels(record)
    # The basis of a batch starting at phase φ is the first batch's, rotated: each harmonic h's
    # (cos, sin) pair turns by h·φ. So the functions are evaluated once, on L samples; each
    # batch's sums are the first batch's sums rotated (Gram matrix R·G0·Rᵀ, right side R·(B0·x)),
    # with no trigonometry per sample.
    n0 = np.arange(L)
    rows = [np.ones(L), np.cos(w * n0), np.sin(w * n0)] + ([np.cos(2 * w * n0), np.sin(2 * w * n0)] if two_f else [])
    B0 = np.stack(rows)  # (functions, L)
    G0 = B0 @ B0.T
    pos = i0
    for blk in exact_blocks(record, blk_len, chans, i0, stop):
        nn = len(blk["dut"])
        k = nn // L
        sl = slice((pos - i0) // L, (pos - i0) // L + k)
        # Phase from the segment start: batches of whole periods line up with it.
        R = _harmonic_rotations(w * ((pos - i0) + L * np.arange(k)), nf)  # (batch, nf, nf)
        basis_sums[sl] = R @ G0 @ R.transpose(0, 2, 1)
        for c in chans:
            x = blk[c]
            check_finite(labels[c], x, pos)
            rhs[c][sl] = np.einsum("kij,kj->ki", R, x.reshape(k, L) @ B0.T)
            if c == "dut":
                dut_ss[sl] = np.einsum("ij,ij->i", x.reshape(k, L), x.reshape(k, L))
        pos += nn
    coef = {c: np.linalg.solve(basis_sums, rhs[c][..., None])[..., 0] for c in chans}
    dut_means = coef["dut"][:, 0]
    ref_ms = (coef[ref][:, 1] ** 2 + coef[ref][:, 2] ** 2) / 2.0  # mean square at the drive frequency
    dm = batch_mean(dut_means)
    # A batch is L samples, ε = |m·fs/f - L| samples off m whole periods: the fit removes the
    # drive's f (and 2f) exactly, but what the DUT holds beyond them (harmonics of a clipped or
    # nonlinear output, rms r from the fit's residual) is averaged over ε samples too many or
    # too few, the same in every batch (they start at the same phase), so their scatter cannot
    # show it: up to ε·√2·r/L in the offset, taken as a rectangular bound (÷√3).
    eps = abs(m * fs / f - L)
    resid = np.maximum(dut_ss - np.einsum("ki,ki->k", coef["dut"], rhs["dut"]), 0.0) / L
    u_leak = eps * math.sqrt(2.0 * float(np.mean(resid))) / L / math.sqrt(3.0)
    if u_leak > 0:
        dm = MeanEstimate(dm.mean, math.hypot(dm.u, u_leak), dm.tau, dm.batch, dm.n_batches)
    rm = batch_mean(ref_ms, detrend=False)
    rms = math.sqrt(max(rm.mean, 0.0))
    u_rms = rm.u / (2 * rms) if rms > 0 else math.nan
    t_c = (i0 + stop) / 2 / fs
    h2 = None
    if two_f:
        c1 = coef["dut"][:, 1] - 1j * coef["dut"][:, 2]
        c2 = (coef["dut"][:, 3] - coef[ref][:, 3]) - 1j * (coef["dut"][:, 4] - coef[ref][:, 4])
        m2 = np.abs(c1) ** 2
        if np.all(m2 > 0):
            h2 = batch_mean(np.real(c2 * np.conj(c1) ** 2) / m2, detrend=False)
    return (f, dm, MeanEstimate(rms, u_rms, rm.tau, rm.batch, rm.n_batches), t_c, float(stop - i0), warnings, h2)


def _harmonic_rotations(phi: NDArray[np.float64], nf: int) -> NDArray[np.float64]:
    """Per phase φ, the matrix turning [1, cos θ, sin θ, cos 2θ, sin 2θ] (its first ``nf``)
    into the same functions of θ + φ: block-diagonal, 1 then the rotation by h·φ of harmonic h."""
    R = np.zeros((len(phi), nf, nf))
    R[:, 0, 0] = 1.0
    for h in range(1, (nf - 1) // 2 + 1):
        c, s = np.cos(h * phi), np.sin(h * phi)
        i = 2 * h - 1
        R[:, i, i], R[:, i, i + 1] = c, -s
        R[:, i + 1, i], R[:, i + 1, i + 1] = s, c
    return R


def dut_mean_estimate(stats: WindowStats, k0: int, k1: int) -> MeanEstimate:
    """DUT mean over windows [k0, k1) with its standard uncertainty.

    The Hann-smoothed values (see :func:`~vrelab.analysis.segmentation.smoothing_kernel`) of the
    windows whose kernel stays inside the segment ("interior" windows) average the segment's
    samples with weights that are flat inside and taper over its first and last 0.2 s: a
    hard-edged (boxcar) mean would keep a residual of the vibration the DUT reads (of order
    σ/(π·f·T): 0.4 mg for 1.5 g of 80-200 Hz noise over 9 s) that no batch-means uncertainty
    accounts for.

    * 10 interior windows or more: batch means (:func:`batch_mean`) of the interior values;
    * 3 to 9: too few for batch means: ``u = s·√(τ_k/n)`` with ``s²`` their squared residuals
      about a straight line over ``n - 2·τ_k`` degrees of freedom and ``τ_k`` the correlation
      the kernel itself puts between neighbours
      (:func:`~vrelab.analysis.segmentation.kernel_tau`), i.e. noise taken as white at 0.1 s;
    * fewer: the plain mean, uncertainty from the raw window means.
    """
    h = SMOOTH_WINDOWS // 2
    a, b = k0 + h, k1 - h
    n = b - a
    if n >= 10:
        return batch_mean(stats.dut_smooth[a:b], tau_min=kernel_tau(stats.window))
    if n >= 3:
        y = stats.dut_smooth[a:b]
        t = np.arange(n, dtype=float)
        r = y - np.polyval(np.polyfit(t, y, 1), t)
        tau = kernel_tau(stats.window)
        # residuals of a correlated series about a fitted line understate its variance: about
        # 2·τ degrees of freedom go to the line, not 2
        u = math.sqrt(float(r @ r) / max(n - 2 * tau, 1.0) * tau / n)
        return MeanEstimate(float(y.mean()), u, tau, 1, n)
    raw = batch_mean(stats.dut_mean()[k0:k1])
    mean = float(stats.dut_sum[k0:k1].sum() / stats.count[k0:k1].sum())
    return MeanEstimate(mean, raw.u, raw.tau, raw.batch, raw.n_batches)


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


# --------------------------------------------------------------------------- main reduction


def _resolve_schedule(
    record: Record, schedule: Schedule | None, stats: WindowStats, settle_s: float
) -> tuple[Schedule, list[str]]:
    warnings: list[str] = []
    if schedule is None and getattr(record, "schedule", None) is not None:
        schedule = record.schedule
        warnings.append(Notice("schedule", "segments from the schedule embedded in the record"))
    if schedule is None:
        schedule, w = auto_segment(stats)
        warnings += w
    trimmed, w = trim(schedule, settle_s)
    return trimmed, warnings + w


def reduce(
    record: Record,
    schedule: Schedule | None = None,
    method: MethodRequest = "auto",
    band_hz: tuple[float, float] | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    block_size: int = DEFAULT_BLOCK,
    progress: bool = False,
    rail_g: float | None = None,
    profile: Any = None,
    psd: bool = False,
    accept: Collection[str] = (),
    stats: WindowStats | None = None,
) -> Reduction:
    """Reduce a record; see the module docstring. :func:`reduce_record` is the short form.

    ``stats``: the record's first pass when already made (:func:`analyze_channels` makes one
    pass for all the DUTs of a file).

    ``method`` "auto" reduces each level as its reference spectrum shows (one line: sine;
    broad: random); an explicit method that a level contradicts is refused. Before any number
    is made the record is held against SPEC 4.2 (:mod:`vrelab.analysis.plausibility`): a units
    or sensitivity slip, swapped channels, a method that does not fit. ``accept`` names the
    checks to pass on purpose: ``"unit-ratio"``, ``"channels"``, ``"method"``.
    """
    V.one_of("method", method, ("auto", "random", "sine"))
    unknown = set(accept) - set(ACCEPTABLE)
    if unknown:
        raise ValueError(f"accept: unknown check {sorted(unknown)[0]!r}; one of {', '.join(ACCEPTABLE)}")
    block_size = int(block_size)
    if block_size < 1:
        raise ValueError(f"block_size must be >= 1, got {block_size}")
    if rail_g is not None:
        rail_g = V.positive_scalar("rail_g", rail_g)
    fs = V.positive_scalar("fs_hz", record.fs_hz)
    band = default_band(fs, band_hz, profile)
    if stats is None:
        stats = window_pass(record, band, WINDOW_S, block_size, rail_g, progress)
    elif stats.band_hz != band or stats.n_samples != record.n_samples:
        raise ValueError("reduce: the given window stats were made for another band or record")
    warnings: list[str] = []
    if stats.reference == "dut":
        warnings.append(Notice("reference", "no reference channel: levels and segmentation from the DUT's AC part"))
    sched, w = _resolve_schedule(record, schedule, stats, settle_s)
    warnings += w
    sat, rail_notes = stats.saturated()
    warnings += rail_notes

    baselines = _baselines(stats, sched, sat, warnings)
    if not baselines:
        raise ValueError("no vibration-off baseline in the record (or schedule): VRE cannot be referred to one")
    lf = low_frequency(baselines)
    kind, probes = _plausible_method(record, sched, stats, band, method, baselines, accept)

    levels: list[LevelResult] = []
    level_segs: list[Segment] = []
    times: list[float] = []
    psds: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []
    for seg in (g for g in sched.segments if not g.is_baseline):
        k0, k1 = segment_windows(stats, seg)
        if k1 - k0 < MIN_SEGMENT_WINDOWS:
            warnings.append(Notice("segment", f"level {seg.start_s:.4g}-{seg.end_s:.4g} s too short, ignored"))
            continue
        level, t_c = _level(record, stats, seg, kind, k0, k1, int(sat[k0:k1].sum()), baselines, block_size,
                            warnings, lf)
        levels.append(level)
        level_segs.append(seg)
        times.append(t_c)
        if psd and kind == "random":
            psds.append(_level_psd(record, seg, stats))
    if not levels:
        raise ValueError("no vibration level found in the record (or schedule)")
    n_sat_levels = sum(1 for lv in levels if lv.n_saturated)
    if n_sat_levels:
        warnings.append(Notice("saturated-levels", f"{n_sat_levels} level(s) with saturated DUT samples (flagged 'saturated')"))
    if profile is not None and kind == "random":
        warnings += _tolerance_checks(record, level_segs, levels, stats, profile)
    return Reduction(levels, warnings, stats, sched, baselines, level_segs, times, psds, method=kind,
                     unit_probes=[(p.kind, p.peak_hz, p.unit_ratio) for p in probes])


def _n_windows(stats: WindowStats, seg: Segment) -> int:
    k0, k1 = segment_windows(stats, seg)
    return k1 - k0


def _baselines(stats: WindowStats, sched: Schedule, sat: NDArray[np.int64], warnings: list[str]) -> list[Baseline]:
    """The DUT's vibration-off readings, one per baseline segment long enough to average."""
    out: list[Baseline] = []
    for seg in sched.segments:
        if not seg.is_baseline:
            continue
        k0, k1 = segment_windows(stats, seg)
        if k1 - k0 < MIN_SEGMENT_WINDOWS:
            warnings.append(Notice("segment", f"baseline {seg.start_s:.4g}-{seg.end_s:.4g} s too short, ignored"))
            continue
        est = dut_mean_estimate(stats, k0, k1)
        t_c = float(np.mean(stats.times_s[k0:k1]))
        h = SMOOTH_WINDOWS // 2
        y = stats.dut_smooth[k0 + h : k1 - h]
        thirds, white = None, 0.0
        if len(y) >= 15:  # thirds of 0.5 s or more: longer than the smoothing kernel
            m = len(y) // 3
            m1, m2, m3 = (float(y[i * m : (i + 1) * m].mean()) for i in range(3))
            # each third holds a third of the samples: variance 3·u² if white; m2 - (m1+m3)/2
            # then has 3·u²·(1 + 1/4 + 1/4)
            thirds, white = m2 - (m1 + m3) / 2, 4.5 * est.u**2
        out.append(Baseline(t_c, est.mean, est.u, seg, int(sat[k0:k1].sum()), max(est.n_batches - 1, 1),
                            thirds, white))
    return out


def _level(
    record: Record,
    stats: WindowStats,
    seg: Segment,
    method: Method,
    k0: int,
    k1: int,
    n_sat: int,
    baselines: Sequence[Baseline],
    block_size: int,
    warnings: list[str],
    lf: LowFrequency | None = None,
) -> tuple[LevelResult, float]:
    """One level (windows ``k0:k1``): its rms and DUT mean by ``method``, its VRE against the
    bracketing baselines; and its centre time. Its u: the level's and the baselines' batch
    means and the low-frequency term ``lf`` (:class:`LowFrequency`)."""
    fs = record.fs_hz
    freq = None
    vre_2f = None
    if method == "random":
        dm = dut_mean_estimate(stats, k0, k1)
        power = stats.ref_band_sumsq[k0:k1] / stats.count[k0:k1]
        pm = batch_mean(power, detrend=False)
        rms = math.sqrt(max(pm.mean, 0.0))
        u_rms = pm.u / (2 * rms) if rms > 0 else math.nan
        t_c = float(np.mean(stats.times_s[k0:k1]))
        n_used = int(stats.count[k0:k1].sum())
    else:
        i0 = int(math.ceil(seg.start_s * fs - 1e-9))
        i1 = min(int(math.floor(seg.end_s * fs + 1e-9)), stats.n_samples)
        freq, dm, rm, t_c, n_f, w, h2 = _sine_level(record, i0, i1, stats.reference, block_size, seg.freq_hz,
                                                    stats.shared)
        warnings += w
        rms, u_rms, n_used = rm.mean, rm.u, int(n_f)
        if h2 is not None and math.isfinite(h2.mean) and math.isfinite(h2.u):
            vre_2f = Estimate(h2.mean, h2.u, "g")
    base, u_base, note = bracket(t_c, baselines)
    if note:
        warnings.append(Notice("bracket", note))
    flags: tuple[str, ...] = ("saturated",) if n_sat > 0 else ()
    var_lf, dof_lf = _low_frequency_at(lf, t_c, n_used / fs, baselines)
    vre = Estimate(dm.mean - base, math.sqrt(dm.u**2 + u_base**2 + var_lf), "g")
    dof = _vre_dof(vre.u, dm, t_c, baselines, (math.sqrt(var_lf), dof_lf))
    off = _off_scale_baselines(t_c, baselines)
    if off:
        # SPEC 4.2: a vibration-off reading at a rail makes VRE undefined: no plain number
        flags += ("baseline-off-scale",)
        vre = Estimate(math.nan, math.nan, "g")
        warnings.append(Notice(
            "baseline-off-scale",
            f"level {rms:.4g} g rms: its baseline at {off[0].t_s:.4g} s sits at a rail ({off[0].n_saturated} "
            f"samples; mean {off[0].mean_g:+.4g} g): VRE undefined, reported as null",
        ))
    level = LevelResult(rms_g=rms, vre=vre, freq_hz=freq, u_rms_g=u_rms, duration_s=n_used / fs, n_samples=n_used,
                        n_saturated=n_sat, flags=flags, dof=dof, vre_2f=vre_2f)
    return level, t_c


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
    from vrelab.gum import welch_satterthwaite

    parts: list[tuple[float, float]] = [(dm.u, max(dm.n_batches - 1, 1))]
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


# Checks of SPEC 4.2 a user may accept on purpose (``accept=``; CLI ``--accept-<name>``).
ACCEPTABLE = ("unit-ratio", "channels", "method")


def _plausible_method(
    record: Record,
    sched: Schedule,
    stats: WindowStats,
    band: tuple[float, float],
    method: MethodRequest,
    baselines: Sequence[Baseline],
    accept: Collection[str],
) -> tuple[Method, list[Any]]:
    """The method the record's levels are reduced with, after SPEC 4.2's checks on a short probe
    of every level (:mod:`vrelab.analysis.plausibility`); levels of both kinds are refused. With
    it, the probes (empty when nothing was checked)."""
    from vrelab.analysis import plausibility as P

    if method != "auto" and set(ACCEPTABLE) <= set(accept):
        return method, []  # nothing to check: no probe (a simulated record re-runs for one)
    # levels the reduction will skip as too short are not probed (their method is moot)
    usable = [g for g in sched.segments if not g.is_baseline and _n_windows(stats, g) >= MIN_SEGMENT_WINDOWS]
    ref = stats.reference
    probes = P.probe_segments(record, "dut", ref, [(g.start_s, g.end_s) for g in usable], band)
    kinds = P.resolve_methods(method, probes, accept="method" in accept)
    if ref != "dut":
        names = record.meta.get("channels", {})
        dut_name, ref_name = names.get("dut", "dut"), names.get("reference", ref)
        P.check_units(probes, dut_name, ref_name, accept="unit-ratio" in accept)
        # the baselines' DC readings come from the window pass (no probe): the DUT's mean, and the
        # reference's from its windows' sums
        base = []
        for b in baselines:
            k0, k1 = segment_windows(stats, b.segment)
            ref_dc = float(stats.ref_sum[k0:k1].sum() / max(stats.count[k0:k1].sum(), 1))
            base.append(P.SegmentProbe(b.segment.start_s, b.segment.end_s, math.nan, 0.0, 0.0, 0.0, ref_dc, b.mean_g))
        P.check_channels(base, dut_name, ref_name, accept="channels" in accept)
    if len(set(kinds)) > 1:
        n_sine = kinds.count("sine")
        raise ValueError(
            f"the record holds {n_sine} sine and {len(kinds) - n_sine} random level(s): reduce each kind "
            "on its own (--schedule with the levels of one kind, and --method)"
        )
    return (kinds[0] if kinds else ("sine" if method == "sine" else "random")), (probes if ref != "dut" else [])


def _segment_blocks(record: Record, seg: Segment, ch: str, block: int = DEFAULT_BLOCK) -> Iterator[NDArray[np.float64]]:
    fs = record.fs_hz
    i0 = int(math.ceil(seg.start_s * fs - 1e-9))
    i1 = min(int(math.floor(seg.end_s * fs + 1e-9)), record.n_samples)
    for b in record.blocks(block, [ch], i0, i1):
        yield b[ch]


def _level_psd(record: Record, seg: Segment, stats: WindowStats) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Welch PSD (Hann, 50 % overlap, about 1 Hz resolution) of the reference over a level,
    streamed (:class:`vrelab.spectra.WelchAccumulator`: the same PSD as one ``scipy.signal.welch``
    over the whole level)."""
    from vrelab.spectra import WelchAccumulator

    nper = int(min(2 ** round(math.log2(record.fs_hz)), 1 << 14))
    acc = WelchAccumulator(record.fs_hz, nper)
    for x in _segment_blocks(record, seg, stats.reference):
        acc.add(x)
    if acc.n_segments == 0:
        return np.array([]), np.array([])
    return acc.freq_hz, acc.psd


def _tolerance_checks(
    record: Record, segs: Sequence[Segment], levels: list[LevelResult], stats: WindowStats, profile: Any
) -> list[str]:
    """Reference PSD against the profile (SPEC 3: ±3 dB, rms ±10 %) for each random level."""
    from vrelab.spectra import psd_tolerance_check

    out: list[str] = []
    for i, (seg, lv) in enumerate(zip(segs, levels)):
        target = seg.nominal_rms_g if seg.nominal_rms_g > 0 else lv.rms_g
        prof = profile.scaled_to(target) if hasattr(profile, "scaled_to") else profile
        try:
            res = psd_tolerance_check(_segment_blocks(record, seg, stats.reference), record.fs_hz, prof)
        except ValueError as exc:
            out.append(Notice("tolerance", f"level {lv.rms_g:.4g} g rms: PSD tolerance check not possible: {exc}"))
            continue
        if not res.passed:
            levels[i] = replace(lv, flags=lv.flags + ("psd-out-of-tolerance",))
            out.append(Notice(
                "tolerance",
                f"level {lv.rms_g:.4g} g rms: reference PSD outside the profile tolerance "
                f"(deviation {res.min_dev_db:+.2f} to {res.max_dev_db:+.2f} dB, ±{res.tol_db:g} dB allowed; "
                f"rms ratio {res.rms_ratio:.3f})"
            ))
    return out


def reduce_record(
    record: Record,
    schedule: Schedule | None = None,
    method: MethodRequest = "auto",
    band_hz: tuple[float, float] | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    block_size: int = DEFAULT_BLOCK,
    progress: bool = False,
    accept: Collection[str] = (),
) -> tuple[list[LevelResult], list[str]]:
    """Reduce a record to VRE per level.

    Parameters
    ----------
    record : Record
        Channels ``dut`` (and ``reference``, both in g) streamed in blocks.
    schedule : Schedule, optional
        Segments (``nominal_rms_g == 0`` for vibration off). Default: the record's embedded
        schedule, else automatic segmentation from the reference's rms envelope.
    method : {"auto", "random", "sine"}
        Level = reference rms in ``band_hz`` (random) or at the drive frequency (sine); "auto"
        decides per level from the reference's spectrum (:func:`reduce`).
    band_hz : (f1, f2), optional
        Test band for the random method [Hz]; default 50–2000 Hz, clamped to Nyquist.
    settle_s : float
        Trimmed at both edges of every segment [s].
    block_size : int
        Samples per block read; memory is bounded by it.

    Returns
    -------
    levels : list of LevelResult
        In time order; ``vre`` in g with its standard uncertainty; ``flags`` has "saturated"
        when the DUT sat on a rail.
    warnings : list of str
    """
    red = reduce(record, schedule, method, band_hz, settle_s, block_size, progress, accept=accept)
    return red.levels, red.warnings


# --------------------------------------------------------------------------- analyze


def analyze_full(
    record: Record,
    method: MethodRequest = "auto",
    schedule: Schedule | None = None,
    profile: Any = None,
    static_g: float | None = None,
    rail_g: float | None = None,
    clip_kind: ClipKind = DEFAULT_CLIP_KIND,
    band_hz: tuple[float, float] | None = None,
    fit_k4: bool = False,
    progress: bool = False,
    conditions: Conditions | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    block_size: int = DEFAULT_BLOCK,
    provenance: Mapping[str, Any] | None = None,
    psd: bool = False,
    rail_with_vrc: bool = False,
    accept: Collection[str] = (),
    stats: WindowStats | None = None,
    typeb: Any = None,
    limit_g: float | None = None,
) -> tuple[VreResult, Reduction]:
    """:func:`analyze`, also returning the :class:`Reduction` (envelope, segments, PSDs).

    ``typeb`` (:class:`vrelab.gum.TypeB`) adds the Type B terms to every level's and fitted
    parameter's uncertainty, with ``U_vre_g`` and ``k``; ``limit_g`` decides each level.
    """
    V.one_of("clip_kind", clip_kind, KINDS)
    if static_g is not None:
        static_g = V.finite_scalar("static_g", static_g)
    red = reduce(record, schedule, method, band_hz, settle_s, block_size, progress, rail_g, profile, psd, accept,
                 stats)
    method = red.method
    g0 = static_g if static_g is not None else red.static_g
    nominal = [seg.freq_hz for seg in red.level_segments]
    fits, w = fit_levels(red.levels, method, g0, clip_kind, fit_k4, rail_with_vrc, nominal_freqs_hz=nominal)
    levels = list(red.levels)
    if typeb is not None or limit_g is not None:
        levels, fits = _with_budget(levels, fits, method, g0, clip_kind, fit_k4, rail_with_vrc, nominal, typeb,
                                    limit_g)
    meta = dict(getattr(record, "meta", None) or {})
    if conditions is None:
        given = meta.get("conditions")
        conditions = Conditions.from_dict(given) if isinstance(given, Mapping) else Conditions()
    extra = dict(conditions.extra)
    extra.setdefault("band_hz", list(default_band(record.fs_hz, band_hz, profile)) if method == "random" else None)
    extra.setdefault("settle_s", settle_s)
    extra.setdefault("static_g_from", "given" if static_g is not None else "mean DUT reading at the baselines")
    if typeb is not None:
        extra["type_b"] = typeb.to_dict()
    if limit_g is not None:
        from vrelab.gum import DECISION_RULE

        extra["limit_g"] = limit_g
        extra["decision_rule"] = DECISION_RULE
    desc = conditions.profile
    if desc is None and profile is not None and hasattr(profile, "describe_shape"):
        # The shape, never its unit level: the levels are the ones the run reached (its levels).
        desc = profile.describe_shape()
    conditions = Conditions(
        **{
            **{k: getattr(conditions, k) for k in conditions.__dataclass_fields__ if k != "extra"},
            "model": conditions.model or "measured",
            "profile": desc,
            "static_g": conditions.static_g if conditions.static_g is not None else g0,
        },
        extra=extra,
    )
    prov = {"vrelab_version": __version__, "fs_hz": record.fs_hz, "n_samples": int(record.n_samples)}
    for key in ("source", "format", "channels", "fs_from"):
        if key in meta:
            prov[key] = meta[key]
    prov.update(dict(provenance or {}))
    result = VreResult(
        method=method,
        conditions=conditions,
        levels=tuple(levels),
        fits=tuple(fits),
        warnings=tuple(list(meta.get("reader_notes") or []) + red.warnings + w),
        provenance=prov,
        kind="measurement",
    )
    return result, red


def _with_budget(levels: list[LevelResult], fits: list[Any], method: Method, g0: float | None, clip_kind: ClipKind,
                 fit_k4: bool, rail_with_vrc: bool, nominal: list[float | None], typeb: Any,
                 limit_g: float | None) -> tuple[list[LevelResult], list[Any]]:
    """Levels and fits with the GUM budget of :mod:`vrelab.gum` (Type B terms by their
    sensitivity coefficients; fits refitted with each input perturbed)."""
    from vrelab import gum

    typeb = typeb if typeb is not None else gum.TypeB()
    if limit_g is not None:
        limit_g = V.positive_scalar("limit_g", limit_g)
    coeff = _static_coefficients(levels, fits, g0)
    out = [gum.level_budget(lv, typeb, c, limit_g) for lv, c in zip(levels, coeff)]
    if not typeb.declared:
        return out, fits

    def refit_for(fit: FitResult) -> Callable[[dict[str, float]], FitResult | None]:
        def refit(delta: dict[str, float]) -> FitResult | None:
            lv = gum.perturb_levels(levels, delta.get("rms_rel", 0.0), delta.get("vre_rel", 0.0),
                                    delta.get("offset_g", 0.0))
            g = None if g0 is None else g0 + delta.get("static_g", 0.0)
            again, _ = fit_levels(lv, method, g, clip_kind, fit_k4, rail_with_vrc, nominal_freqs_hz=nominal)
            same = [f for f in again if f.model == fit.model and f.freq_hz == fit.freq_hz]
            return same[0] if same else None
        return refit

    return out, [gum.fit_budget(f, refit_for(f), typeb) for f in fits]


def _static_coefficients(levels: Sequence[LevelResult], fits: Sequence[Any], g0: float | None) -> list[float | None]:
    """∂VRE/∂g0 per level from the fitted clipping model (central difference of its Gaussian
    mean shift at the level's rms), None where no fitted model gives it."""
    from vrelab.models.clipping import censored_mean_shift, truncated_mean_shift

    clip = next((f for f in fits if f.model.startswith("clip-")), None)
    if clip is None or g0 is None:
        return [None] * len(levels)
    if "rail_g" in clip.params:
        lo, hi = -clip.params["rail_g"].value, clip.params["rail_g"].value
    elif {"rail_low_g", "rail_high_g"} <= set(clip.params):
        lo, hi = clip.params["rail_low_g"].value, clip.params["rail_high_g"].value
    else:
        return [None] * len(levels)
    shift = censored_mean_shift if clip.model == "clip-censored" else truncated_mean_shift
    h = 1e-4
    return [float(shift(g0 + h, lv.rms_g, lo, hi) - shift(g0 - h, lv.rms_g, lo, hi)) / (2 * h)
            if math.isfinite(lv.rms_g) and lv.rms_g > 0 else None for lv in levels]


def analyze(record: Record, method: MethodRequest = "auto", schedule: Schedule | None = None, **options: Any) -> VreResult:
    """Reduce a record and fit it: the whole test station in one call.

    ``options`` are the keywords of :func:`analyze_full`: those of :func:`reduce_record` plus:
    ``profile`` (a
    :class:`~vrelab.profiles.RandomProfile`: default band, and the reference PSD is checked
    against it), ``static_g`` (static field for the rail fit; default: the DUT's mean reading at
    the baselines), ``rail_g`` (DUT samples at or beyond ±rail_g count as saturated, besides
    the rails found from the data), ``clip_kind`` (rail-fit model), ``fit_k4`` (quartic term in
    the VRC fit), ``conditions`` (default: those in the record's metadata), ``rail_with_vrc``
    (fit the rail jointly with a VRC·rms² term, see :func:`vrelab.fits.fit_rail`).

    Returns
    -------
    VreResult
        ``kind="measurement"``; fits by :func:`vrelab.fits.fit_levels`: "vrc" per frequency for
        sine; for random "clip-<kind>" (``rail_g``, ``departure_rms_g``), then "vrc".
    """
    return analyze_full(record, method, schedule, **options)[0]


def analyze_channels(
    record: Record,
    duts: Sequence[str] | None = None,
    method: MethodRequest = "auto",
    schedule: Schedule | None = None,
    static_g: float | Mapping[str, float] | None = None,
    band_hz: tuple[float, float] | None = None,
    rail_g: float | None = None,
    block_size: int = DEFAULT_BLOCK,
    progress: bool = False,
    **options: Any,
) -> list[tuple[str, VreResult, Reduction]]:
    """Several DUT channels of one record, each reduced against one reference.

    One streaming pass makes every DUT's window sums beside the reference's
    (:func:`~vrelab.analysis.segmentation.window_pass_many`); the segmentation comes from the
    reference, so every channel has the same levels; each channel's static field is its own
    (``static_g`` a number for all, a mapping name -> g, or None: each from its baselines).
    ``duts`` are record channels (``dut:<name>`` from :func:`vrelab.analysis.readers.open_record`
    with several DUTs; default: all of them). Returns (name, result, reduction) per channel,
    in order. ``options`` are :func:`analyze_full`'s.
    """
    from vrelab.analysis.segmentation import window_pass_many
    from vrelab.record import ChannelView

    if duts is None:
        duts = [c for c in record.channels if c == "dut" or c.startswith("dut:")]
    duts = list(duts)
    if len(duts) > 1 and "reference" not in record.channels:
        raise ValueError("several DUT channels need a reference channel: their levels and segments come from it")
    if rail_g is not None:
        rail_g = V.positive_scalar("rail_g", rail_g)
    band = default_band(V.positive_scalar("fs_hz", record.fs_hz), band_hz, options.get("profile"))
    stats = window_pass_many(record, band, duts, WINDOW_S, int(block_size), rail_g, progress)
    out: list[tuple[str, VreResult, Reduction]] = []
    for d in duts:
        name = d[4:] if d.startswith("dut:") else d
        g0: float | None
        if isinstance(static_g, Mapping):
            if name not in static_g:
                raise ValueError(f"no static field for DUT channel {name!r}")
            g0 = static_g[name]
        else:
            g0 = static_g
        view = record if d == "dut" else ChannelView(record, d)
        result, red = analyze_full(view, method, schedule, static_g=g0, band_hz=band_hz, rail_g=rail_g,
                                   block_size=block_size, stats=stats[d], **options)
        out.append((name, result, red))
    return out
