"""Time signals from vibration profiles, streamed in blocks (physics §3).

Every generator here yields consecutive blocks of a record of ``n_samples`` samples. The values
depend only on the absolute sample index, the profile and the seed, never on ``block_size``;
memory is bounded by internal frame sizes, never by ``n_samples``.

* :func:`sine_blocks`: ``x[k] = √2·rms·sin(2π·f·k/fs + φ)``.
* :func:`random_blocks`: a zero-mean drive whose one-sided PSD follows a
  :class:`~vrelab.profiles.RandomProfile` and whose rms is its grms, either a periodic
  random-phase multisine (exact PSD and rms on every period) or a true stationary Gaussian
  process (white Gaussian noise through an FIR filter designed from the profile). Options: drive
  clipping at k·σ as a shaker controller does, and a non-Gaussian drive of target kurtosis. A
  :class:`~vrelab.profiles.SineOnRandom` adds its tones to that drive, each with a random phase
  (:func:`tone_phases`).
* :func:`psd_tolerance_check`: streaming Welch PSD of a drive (or of a recorded reference
  channel) against a profile, ±3 dB / ±10 % rms by default.

References
----------
.. [1] J. S. Bendat, A. G. Piersol, *Random Data: Analysis and Measurement Procedures*, 4th ed.,
   Wiley, 2010: normalized random error of a mean-square estimate ε = 1/√(B·T); of a PSD
   estimate averaged over n_d segments ε = 1/√n_d.
.. [2] S. R. Winterstein, "Nonlinear vibration models for extremes and fatigue", J. Eng. Mech.
   114(10), 1988: Hermite model ``x = κ·(u + h3·(u²-1) + h4·(u³-3u))`` for kurtosis > 3.
.. [3] D. O. Smallwood, "Generating non-Gaussian vibration for testing purposes", Sound and
   Vibration, Oct. 2005 (zero-memory transforms of a Gaussian drive; effect on the PSD).
.. [4] MIL-STD-202 method 214: random vibration PSD tolerance ±1.5 dB up to 1 kHz, ±3 dB
   1-2 kHz.
"""

from __future__ import annotations

import math
from typing import Iterator, Literal

import numpy as np
import scipy.fft
import scipy.signal
from numpy.typing import NDArray
from scipy import optimize, stats

from vrelab import _validate as v
from vrelab.profiles import RandomProfile, SineOnRandom

__all__ = [
    "sine_blocks",
    "random_blocks",
    "random_signal",
    "tone_phases",
    "design_fir",
    "multisine_period",
    "hermite_h4_for_kurtosis",
    "clip_prescale",
    "WelchAccumulator",
    "ToleranceResult",
    "psd_tolerance_check",
]

Method = Literal["gaussian", "multisine"]

# The FIR / multisine frequency resolution is this fraction of the profile's lowest frequency,
# so the lowest segment spans many bins and the band edge is sharp.
_BINS_BELOW_F_LO = 8
# Bounds on FIR length (and multisine period): below 256 taps the design is too coarse to be
# useful; above 2^15 the per-frame FFTs dominate memory for little gain in PSD accuracy.
_MIN_TAPS = 256
_MAX_TAPS = 2**15
# Overlap-save FFT length for the Gaussian method: a power of two (pocketfft's fastest
# lengths: 2^16 points take 10 ns per sample for rfft + irfft, against 12 ns for the
# 69 632 = 2^12·17 that "a 2^16-sample frame + the overlap" would need), at least 2^16 and five
# filter lengths, so the overlap (M - 1 samples) costs at most a fifth and memory stays a few MB
# whatever the record length.
MIN_FFT = 2**16


# --- validation helpers -----------------------------------------------------------------------


def _seed(value: object) -> int:
    return v.integer("seed", value, 0)


def _check_band(profile: RandomProfile, fs_hz: float) -> None:
    if not isinstance(profile, RandomProfile):
        raise ValueError(f"profile must be a RandomProfile, got {type(profile).__name__}")
    if profile.band[1] > fs_hz / 2:
        raise ValueError(
            f"profile band {profile.band[0]:g}-{profile.band[1]:g} Hz exceeds fs_hz/2 = "
            f"{fs_hz / 2:g} Hz (fs_hz = {fs_hz:g}); raise the sample rate"
        )


def rechunk(frames: Iterator[NDArray[np.float64]], n_samples: int, block_size: int) -> Iterator[NDArray[np.float64]]:
    """Cut a stream of frames into blocks of ``block_size`` (last one shorter), ``n_samples`` in all."""
    # Each block is filled straight from the frames (one copy, no concatenation keeping
    # earlier frames alive through views); a frame is pulled only while samples are still
    # owed: it costs an FFT pair and its noise, and one pulled past the end would be wasted.
    frame: NDArray[np.float64] = np.empty(0)
    pos = 0  # read position in frame
    remaining = n_samples
    while remaining > 0:
        out = np.empty(min(block_size, remaining))
        filled = 0
        while filled < out.size:
            if pos == frame.size:
                frame, pos = next(frames), 0
            take = min(frame.size - pos, out.size - filled)
            out[filled : filled + take] = frame[pos : pos + take]
            filled += take
            pos += take
        remaining -= out.size
        yield out


# --- sine -------------------------------------------------------------------------------------


def sine_blocks(
    freq_hz: float,
    rms_g: float,
    fs_hz: float,
    n_samples: int,
    block_size: int,
    phase_rad: float = 0.0,
) -> Iterator[NDArray[np.float64]]:
    """A sine drive ``x[k] = √2·rms_g·sin(2π·freq_hz·k/fs_hz + phase_rad)`` in blocks.

    Parameters
    ----------
    freq_hz : float
        Frequency [Hz], 0 < freq_hz < fs_hz/2.
    rms_g : float
        Level [g rms], >= 0 (peak = √2·rms).
    fs_hz : float
        Sample rate [Hz].
    n_samples, block_size : int
        Record length and block length [samples]; the last block may be shorter.
    phase_rad : float
        Phase at sample 0 [rad].

    Notes
    -----
    The phase is computed from the absolute sample index k, reduced modulo one cycle before
    the sine, so the waveform is continuous across blocks, identical for any block size, and
    free of the phase drift that accumulating ``2π·f/fs`` per sample would build up.
    """
    f = v.positive_scalar("freq_hz", freq_hz)
    fs = v.positive_scalar("fs_hz", fs_hz)
    if f >= fs / 2:
        raise ValueError(f"freq_hz must be below fs_hz/2 = {fs / 2:g} Hz, got {freq_hz!r}")
    rms = v.finite_scalar("rms_g", rms_g)
    if rms < 0:
        raise ValueError(f"rms_g must be >= 0, got {rms_g!r}")
    phase = v.finite_scalar("phase_rad", phase_rad)
    n = v.integer("n_samples", n_samples, 0)
    bs = v.integer("block_size", block_size, 1)
    amp = math.sqrt(2.0) * rms
    cycles_per_sample = f / fs
    phase_cycles = phase / (2.0 * math.pi)
    for start in range(0, n, bs):
        k = np.arange(start, min(start + bs, n), dtype=np.float64)
        cyc = np.mod(k * cycles_per_sample, 1.0) + phase_cycles
        yield amp * np.sin(2.0 * np.pi * cyc)


# --- random: shared design --------------------------------------------------------------------


def resolution_length(profile: RandomProfile, fs_hz: float) -> int:
    """Power-of-two length whose bin width fs/N is at most f_lo/8 (within the tap bounds)."""
    want = fs_hz / (profile.band[0] / _BINS_BELOW_F_LO)
    n = 1 << max(0, math.ceil(math.log2(want)))
    return int(min(max(n, _MIN_TAPS), _MAX_TAPS))


def bin_powers(profile: RandomProfile, fs_hz: float, n: int) -> NDArray[np.float64]:
    """Mean square [g²] of the profile in each rfft bin of an n-point frame.

    Bin k holds the exact (closed-form) area of the PSD over [(k-½)·df, (k+½)·df], so a
    profile edge that falls inside a bin is neither lost nor doubled. The DC and Nyquist bins
    are left empty (a zero-mean drive; a real Nyquist line has no phase to randomize) and the
    total is renormalized to the profile's mean square: the power moved is at most the area of
    two half-bins at the very ends of [0, fs/2].
    """
    df = fs_hz / n
    k = np.arange(n // 2 + 1)
    edges = np.clip((np.arange(n // 2 + 2) - 0.5) * df, 0.0, fs_hz / 2)
    powers = np.diff(np.asarray(profile.cumulative_mean_square(edges), dtype=np.float64))
    powers[0] = 0.0
    powers[k == n // 2] = 0.0
    total = float(powers.sum())
    if total <= 0:
        raise ValueError(
            f"profile band {profile.band[0]:g}-{profile.band[1]:g} Hz holds no frequency line at "
            f"fs_hz = {fs_hz:g} Hz with {n}-point frames"
        )
    return powers * (profile.mean_square_g2 / total)


def design_fir(profile: RandomProfile, fs_hz: float, n_taps: int | None = None) -> NDArray[np.float64]:
    """FIR taps that shape unit-variance white noise into the profile (frequency sampling).

    Parameters
    ----------
    profile : RandomProfile
        Target one-sided PSD [g²/Hz]; its band must lie below fs_hz/2.
    fs_hz : float
        Sample rate [Hz].
    n_taps : int, optional
        Even filter length; default: a power of two with bin width ≤ f_lo/8, 256 to 32768 taps.

    Returns
    -------
    ndarray
        Linear-phase taps h, with ``Σ h² = grms²``.

    Notes
    -----
    White noise of unit variance has a one-sided PSD of 2/fs, so a filter with
    ``|H(f_k)|² = S_k·fs/2`` gives output PSD S_k at its design frequencies
    ``f_k = k·fs/N``. S_k is the profile's mean over bin k (closed-form areas,
    :func:`bin_powers`), so by Parseval the output variance ``Σ h² = Σ_k S_k·df`` is the
    profile's mean square exactly. The zero-phase response is shifted by N/2 samples to make
    the filter causal. No window is applied: a window would smear the band edges and change
    the variance; the bins are fine enough (≤ f_lo/8) that the ripple between design
    frequencies is small (measured with scipy.signal.freqz on a 20 001-point grid at
    fs = 8192 Hz: within ±0.5 dB of the profile from 3 bins inside the band edges, ±0.1 dB from
    20 bins, for both the flat 50-2000 Hz profile and NAVMAT P-9492).
    scipy.signal.firwin2 samples the target at points instead of averaging it over bins, which
    loses the exact variance, hence this hand-written design.
    """
    fs = v.positive_scalar("fs_hz", fs_hz)
    _check_band(profile, fs)
    n = resolution_length(profile, fs) if n_taps is None else v.integer("n_taps", n_taps, 4)
    if n % 2:
        raise ValueError(f"n_taps must be even, got {n_taps!r}")
    powers = bin_powers(profile, fs, n)
    df = fs / n
    mag = np.sqrt(powers / df * fs / 2)  # |H_k|
    k = np.arange(n // 2 + 1)
    h: NDArray[np.float64] = scipy.fft.irfft(mag * np.exp(-1j * np.pi * k), n)  # e^{-iπk}: delay by n/2 samples
    return h


def multisine_period(profile: RandomProfile, fs_hz: float, seed: int, n_period: int | None = None) -> NDArray[np.float64]:
    """One period of a random-phase multisine with the profile's PSD and exactly its rms.

    Notes
    -----
    Line k (frequency k·fs/N, N the period) has amplitude ``a_k = √(2·P_k)`` with P_k the
    profile's mean square in bin k (closed form) and phase uniform in [0, 2π) from
    ``default_rng(SeedSequence(seed))``; ``x[n] = Σ a_k·cos(2π·k·n/N + φ_k)`` has mean square
    ``Σ a_k²/2 = Σ P_k`` = grms² on every whole period, independent of the phases.
    """
    fs = v.positive_scalar("fs_hz", fs_hz)
    _check_band(profile, fs)
    n = resolution_length(profile, fs) if n_period is None else v.integer("n_period", n_period, 4)
    powers = bin_powers(profile, fs, n)
    rng = np.random.default_rng(np.random.SeedSequence(_seed(seed)))
    phases = rng.uniform(0.0, 2.0 * np.pi, powers.size)
    amps = np.sqrt(2.0 * powers)
    # irfft(X)[n] = (1/N)·Σ_k X_k e^{2πikn/N} over the full spectrum: a real line of amplitude a
    # needs X_k = (N/2)·a·e^{iφ}.
    period: NDArray[np.float64] = scipy.fft.irfft(n / 2 * amps * np.exp(1j * phases), n)
    return period


# --- random: non-Gaussian and clipping transforms ---------------------------------------------


def _hermite_moments(h4: float) -> tuple[float, float]:
    """E[Y²], E[Y⁴] of Y = u + h4·(u³ - 3u), u ~ N(0, 1) (exact Gaussian moments)."""
    a, b = 1.0 - 3.0 * h4, h4  # Y = a·u + b·u³
    m2 = a * a + 6 * a * b + 15 * b * b
    m4 = 3 * a**4 + 60 * a**3 * b + 630 * a**2 * b**2 + 3780 * a * b**3 + 10395 * b**4
    return m2, m4


def hermite_h4_for_kurtosis(kurtosis: float, samples: NDArray[np.float64] | None = None) -> float:
    """h4 of the Hermite transform ``Y = u + h4·(u³-3u)`` whose output kurtosis is ``kurtosis``.

    With ``samples`` (unit-rms values of u, e.g. one multisine period, whose marginal is only
    nearly Gaussian) the kurtosis is that of the transformed samples, so it is exact on them.

    Notes
    -----
    Winterstein's (1988) [2] model for a softening (kurtosis > 3), symmetric process is
    ``x = κ·(u + h3·(u²-1) + h4·(u³-3u))``. A symmetric drive has zero skewness, so h3 = 0
    here; pyExSi's implementation gets the h3 (skewness) term wrong and leaves the output at
    unit variance (physics §3), which this module avoids: h3 is 0 by construction and the
    caller rescales to the target rms. Instead of Winterstein's approximate closed form
    ``h4 = (√(1 + 1.5·(γ4-3)) - 1)/18`` the exact kurtosis of Y, from the Gaussian moments
    E[u^2m] = (2m-1)!!, is solved for h4 with brentq. The transform is monotone for
    0 ≤ h4 < 1/3 (dY/du = 1 - 3h4 + 3h4·u² > 0), which covers kurtosis 3 to 10395/225 ≈ 46.2.
    """
    k = v.finite_scalar("kurtosis", kurtosis)
    k_max = 10395.0 / 225.0
    if not 3.0 <= k < k_max:
        raise ValueError(
            f"kurtosis must be in [3, {k_max:.1f}) for the monotone Hermite transform, got {kurtosis!r}"
        )
    if k == 3.0:
        return 0.0

    if samples is None:
        def excess(h4: float) -> float:
            m2, m4 = _hermite_moments(h4)
            return m4 / (m2 * m2) - k
    else:
        u = np.asarray(samples, dtype=np.float64)

        def excess(h4: float) -> float:
            y = u + h4 * (u**3 - 3.0 * u)
            y = y - y.mean()
            m2 = float(np.mean(y**2))
            return float(np.mean(y**4)) / (m2 * m2) - k

        if excess(0.0) > 0:
            raise ValueError(f"kurtosis {kurtosis!r} is below that of the untransformed drive ({excess(0.0) + k:.3g})")

    return float(optimize.brentq(excess, 0.0, 1.0 / 3.0 - 1e-12, xtol=1e-15, rtol=1e-14))


def _clip_mean_square(c: float) -> float:
    """E[clip(Z, ±c)²] for Z ~ N(0, 1): (2Φ(c)-1) - 2c·φ(c) + 2c²·(1-Φ(c))."""
    return float((2 * stats.norm.cdf(c) - 1) - 2 * c * stats.norm.pdf(c) + 2 * c * c * stats.norm.sf(c))


def clip_prescale(clip_sigma: float, samples: NDArray[np.float64] | None = None) -> float:
    """Gain s such that clip(s·x, ±clip_sigma) has unit mean square, for unit-rms x.

    A shaker controller that clips its drive at k·σ keeps raising the drive until the rms on
    the table reaches the target, so the clipped drive has the target rms *and* peaks at exactly
    k·σ_target. For Gaussian x the condition ``s²·E[clip(Z, ±k/s)²] = 1`` uses the closed form
    of :func:`_clip_mean_square`; for a multisine period (``samples``) it is solved on the
    samples themselves, so the rms of every period is exact.
    """
    k = v.positive_scalar("clip_sigma", clip_sigma)
    if k <= 1.0:
        raise ValueError(f"clip_sigma must be > 1 (a drive clipped at ≤ 1 σ cannot reach its rms), got {clip_sigma!r}")
    if samples is None:
        def resid(s: float) -> float:
            return s * s * _clip_mean_square(k / s) - 1.0
    else:
        x = np.asarray(samples, dtype=np.float64)

        def resid(s: float) -> float:
            return float(np.mean(np.clip(s * x, -k, k) ** 2)) - 1.0

    # resid(1) ≤ 0 (clipping only removes power) and resid grows without bound toward k² - 1.
    hi = 2.0
    while resid(hi) < 0:
        hi *= 2.0
        if hi > 1e6:
            raise ValueError(f"clip_sigma = {clip_sigma!r}: no drive gain reaches the target rms")
    return float(optimize.brentq(resid, 1.0, hi, xtol=1e-14, rtol=1e-14))


# --- random: generators -----------------------------------------------------------------------


def gaussian_frames(
    h: NDArray[np.float64], seed: int, frame: int, n_samples: int | None = None
) -> Iterator[NDArray[np.float64]]:
    """Frames of white Gaussian noise filtered by h ('valid' convolution), ``n_samples`` in all
    (endless if None); the last one may be shorter.

    Output sample k is Σ_m h[m]·w[k + M-1 - m], with w the noise sequence: every output sample
    sees a full filter's worth of noise, so the record starts stationary (no filter
    start-up transient). Noise frame j comes from
    ``default_rng(SeedSequence(entropy=seed, spawn_key=(j,)))``: the stream is a function of
    the frame index alone, hence the same for any block size and reproducible from the seed.
    The filter's transform is computed once; each frame costs one rfft/irfft pair of
    length ≥ frame + M - 1 (overlap-save). A last frame of ``k`` samples, when ``k + M - 1``
    noise samples of its own frame suffice, draws only those and convolves them with an FFT of
    the next power of two ≥ k + M - 1: the same values (to FFT rounding) for less work, which
    matters for short segments (a 1 s level at 16 kHz uses a quarter of a 2^16 frame).
    """
    m = h.size
    nfft = scipy.fft.next_fast_len(frame + m - 1, real=True)
    h_f = scipy.fft.rfft(h, nfft)

    def rng(j: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(j,)))

    # Frame j's output needs all of noise frame j and the first M-1 samples of frame j+1. A
    # Generator draws its normals in sequence, so drawing those M-1 first and the rest of the
    # frame when it is reached gives exactly the frame drawn at once, and the last frame of
    # a record costs M-1 draws of its successor, not a whole frame.
    if frame < m - 1:
        raise ValueError(f"frame must be >= the filter length - 1 = {m - 1}, got {frame}")
    seg = np.empty(frame + m - 1)
    nxt_rng = rng(0)
    head = nxt_rng.standard_normal(m - 1)
    j = 0
    left = n_samples
    while left is None or left > 0:
        need = frame if left is None else min(frame, left)
        if need + m - 1 <= frame and need < frame:
            # The last, short frame: only the first need + M - 1 samples of noise frame j
            # matter (drawn in sequence, they are those of the whole frame).
            length = need + m - 1
            seg[: m - 1] = head
            nxt_rng.standard_normal(out=seg[m - 1 : length])
            n_short = 1 << math.ceil(math.log2(length))
            spec = scipy.fft.rfft(seg[:length], n_short)
            spec *= scipy.fft.rfft(h, n_short)
            yield scipy.fft.irfft(spec, n_short, overwrite_x=True)[m - 1 : m - 1 + need]
            return
        if left is not None:
            left -= need
        # seg = noise frame j (its head, drawn already, then the rest) + the head of frame j+1
        cur_rng, nxt_rng = nxt_rng, rng(j + 1)
        seg[: m - 1] = head
        cur_rng.standard_normal(out=seg[m - 1 : frame])
        head = nxt_rng.standard_normal(m - 1)
        seg[frame:] = head
        spec = scipy.fft.rfft(seg, nfft)
        spec *= h_f
        y = scipy.fft.irfft(spec, nfft, overwrite_x=True)
        yield y[m - 1 : m - 1 + frame]
        j += 1


def _multisine_frames(period: NDArray[np.float64]) -> Iterator[NDArray[np.float64]]:
    while True:
        yield period


# Tags the tone phases' stream apart from the noise frames' (SeedSequence(seed, spawn_key=(j,))):
# the tones are drawn from SeedSequence([seed, _TONE_STREAM]), another entropy pool.
_TONE_STREAM = 0x746F6E65  # "tone"


def tone_phases(profile: SineOnRandom, seed: int) -> NDArray[np.float64]:
    """The phases [rad] of a sine-on-random drive's tones: uniform on [0, 2π), independent,
    from ``default_rng(SeedSequence([seed, TONE_STREAM]))`` (apart from the noise's streams)."""
    rng = np.random.default_rng(np.random.SeedSequence([_seed(seed), _TONE_STREAM]))
    return rng.uniform(0.0, 2.0 * np.pi, len(profile.tones))


def random_blocks(
    profile: RandomProfile | SineOnRandom,
    fs_hz: float,
    n_samples: int,
    block_size: int,
    seed: int,
    method: Method = "gaussian",
    clip_sigma: float | None = None,
    kurtosis: float | None = None,
) -> Iterator[NDArray[np.float64]]:
    """A random drive [g] whose PSD follows ``profile`` and whose rms is its grms, in blocks.

    Parameters
    ----------
    profile : RandomProfile or SineOnRandom
        Target one-sided PSD [g²/Hz]; its band must lie at or below fs_hz/2. A sine-on-random
        profile's tones are added to the random part's drive: ``peak_i·sin(2π f_i k/fs + φ_i)``
        with phases φ_i from :func:`tone_phases` (the drive's rms is then the profile's grms).
        The options below shape the random part only, as a sine-on-random controller does.
    fs_hz : float
        Sample rate [Hz].
    n_samples, block_size : int
        Record length and block length [samples]; the last block may be shorter. The values
        do not depend on block_size.
    seed : int
        Non-negative seed; equal seeds give equal records.
    method : {"gaussian", "multisine"}
        "gaussian": a stationary Gaussian process, white noise through the FIR of
        :func:`design_fir` (expected PSD and rms follow the profile; a finite record scatters
        around them as Bendat & Piersol [1] describe). "multisine": a random-phase multisine
        with period N = fs/df (:func:`multisine_period`), tiled; exact PSD on its lines and
        exact rms over each whole period.
    clip_sigma : float, optional
        Clip the drive at ±clip_sigma·σ (σ = the target rms), as shaker controllers do to limit
        the crest factor; the drive is first raised by :func:`clip_prescale` so the clipped
        drive keeps the target rms and peaks at exactly clip_sigma·σ. Clipping moves a little
        power out of the band (the clipped tails are broadband).
    kurtosis : float, optional
        Target kurtosis (> 3) of a non-Gaussian drive: a zero-memory monotone Hermite
        transform of the Gaussian drive (:func:`hermite_h4_for_kurtosis`), rescaled to the
        target rms. On a multisine, h4 and the scale are solved on the period's samples, so
        each period has exactly the target kurtosis and rms. Not combinable with clip_sigma.

    Yields
    ------
    ndarray
        Consecutive blocks, ``n_samples`` samples in all.

    Notes
    -----
    Why an FIR filter rather than overlap-added spectral frames for the Gaussian method: white
    Gaussian noise through a fixed linear filter is exactly a stationary Gaussian process at
    every sample, with PSD ``|H|²·2/fs`` and variance ``Σ h²``; overlap-adding independently
    synthesized frames with power-complementary windows keeps the variance constant but leaves
    a covariance that varies with position in the frame. The filter state across frames is the
    noise itself (overlap-save over a window of M-1 samples), which depends only on the
    frame index.

    The Hermite transform ``Y = u + h4·(u³-3u)`` has autocorrelation ``ρ + 6h4²·ρ³`` (Hermite
    polynomials are orthogonal under the Gaussian), so a fraction ``6h4²/(1+6h4²)`` of the
    power (1.8 % at kurtosis 5) is spread by the triple self-convolution of the PSD, partly
    outside the band; the in-band shape changes by a few tenths of a dB at most for kurtosis
    up to about 8 (Smallwood [3]). The rms is exact.
    """
    if isinstance(profile, SineOnRandom):
        return _with_tones(profile, fs_hz, n_samples, block_size, seed,
                           random_blocks(profile.random, fs_hz, n_samples, block_size, seed, method, clip_sigma,
                                         kurtosis))
    fs = v.positive_scalar("fs_hz", fs_hz)
    _check_band(profile, fs)
    n = v.integer("n_samples", n_samples, 0)
    bs = v.integer("block_size", block_size, 1)
    sd = _seed(seed)
    v.one_of("method", method, ("gaussian", "multisine"))
    if clip_sigma is not None and kurtosis is not None:
        raise ValueError("give clip_sigma or kurtosis, not both")
    sigma = profile.grms

    if method == "multisine":
        period = multisine_period(profile, fs, sd)
        frames: Iterator[NDArray[np.float64]] = _multisine_frames(period)
    else:
        h = design_fir(profile, fs)
        nfft = max(MIN_FFT, 1 << math.ceil(math.log2(5 * h.size)))
        frames = gaussian_frames(h, sd, nfft - (h.size - 1), n)

    if clip_sigma is not None:
        k = float(clip_sigma)
        sample = period / sigma if method == "multisine" else None
        gain = clip_prescale(k, sample)
        frames = (np.clip(fr * gain, -k * sigma, k * sigma) for fr in frames)
    elif kurtosis is not None:
        if method == "multisine":
            # A multisine's marginal is only nearly Gaussian: solve h4 and the rms on the period
            # itself, so that every period has exactly the target kurtosis and rms.
            u_period = period / sigma
            h4 = hermite_h4_for_kurtosis(kurtosis, u_period)
            y = u_period + h4 * (u_period**3 - 3.0 * u_period)
            offset = float(y.mean())  # u³ of a finite period has a tiny non-zero mean
            m2 = float(np.mean((y - offset) ** 2))
        else:
            h4 = hermite_h4_for_kurtosis(kurtosis)
            offset = 0.0
            m2, _ = _hermite_moments(h4)
        scale = sigma / math.sqrt(m2)

        def herm(fr: NDArray[np.float64]) -> NDArray[np.float64]:
            u = fr / sigma
            return scale * (u + h4 * (u**3 - 3.0 * u) - offset)

        frames = (herm(fr) for fr in frames)

    return rechunk(frames, n, bs)


def _with_tones(
    profile: SineOnRandom, fs_hz: float, n_samples: int, block_size: int, seed: int,
    noise: Iterator[NDArray[np.float64]],
) -> Iterator[NDArray[np.float64]]:
    """The random part's blocks ``noise`` plus the profile's tones, block by block."""
    fs = v.positive_scalar("fs_hz", fs_hz)
    if profile.tones[-1].freq_hz >= fs / 2:
        raise ValueError(f"tone at {profile.tones[-1].freq_hz:g} Hz is not below fs_hz/2 = {fs / 2:g} Hz; "
                         "raise the sample rate")
    tones = [sine_blocks(t.freq_hz, t.rms_g, fs, n_samples, block_size, phase_rad=float(ph))
             for t, ph in zip(profile.tones, tone_phases(profile, seed))]
    for blocks in zip(noise, *tones):
        yield np.sum(blocks, axis=0)


def random_signal(
    profile: RandomProfile | SineOnRandom,
    fs_hz: float,
    n_samples: int,
    seed: int,
    method: Method = "gaussian",
    clip_sigma: float | None = None,
    kurtosis: float | None = None,
) -> NDArray[np.float64]:
    """The whole record of :func:`random_blocks` as one array (for short records)."""
    n = v.integer("n_samples", n_samples, 0)
    blocks = list(random_blocks(profile, fs_hz, n, max(n, 1), seed, method, clip_sigma, kurtosis))
    return np.concatenate(blocks) if blocks else np.zeros(0)


# The tolerance check moved to vrelab.spectra (the analysis uses it on recorded references too);
# these names stay importable from here.
from vrelab.spectra import ToleranceResult, WelchAccumulator, psd_tolerance_check  # noqa: E402,F401
