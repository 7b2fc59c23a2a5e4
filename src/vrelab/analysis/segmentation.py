"""First streaming pass over a record, and its segmentation into baselines and levels.

One pass reads the record in blocks and keeps, per short window (``window_s``, 0.1 s by
default), a handful of numbers: DUT sum / extremes / samples at its extremes / a Hann-smoothed
mean, the reference's AC and band-limited power (from the window's FFT, Parseval). These
small arrays (a 2 h record at 0.1 s: 72 000 windows) are all that segmentation, baselines,
random-method levels and their batch-means uncertainty need, so memory does not grow with the
length of the record beyond them. No per-sample filter runs, so there is no filter state to
carry across blocks: windows never straddle a block edge, and the smoothing kernel's parts
are kept per window and combined after the pass.

Segmentation is either given (a :class:`~vrelab.record.Schedule`: the user's, or the one
embedded in the record) or found from the rms envelope of the reference (the DUT's AC part
when there is no reference): windows below a noise threshold are "off"; among the "on"
windows, plateaus are the pieces of constant envelope found by binary segmentation (ramps,
where it changes, are left out); a settling time is trimmed at both edges of every segment.
"""

from __future__ import annotations

import functools
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Iterator, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _budget
from vrelab import _validate as V
from vrelab._ahead import prefetch
from vrelab.record import Record, Schedule, Segment
from vrelab.record import window_length as window_length  # its owner is vrelab.record
from vrelab.results import Notice

# Samples within this relative distance of the record's extreme count as "at the rail".
RAIL_EPS_REL = 1e-6
# A rail is declared only when at least this many samples sit on the same extreme (a clipped
# signal pins many samples there; an unclipped one reaches its maximum once).
RAIL_MIN_SAMPLES = 10

SharedCache = dict[tuple[str, int, int], float]
"""What the DUT channels of one record share, found once for all of them: a sine level's drive
frequency [Hz] under ``("frequency", i0, i1)`` (its first and end sample)."""


@dataclass(frozen=True)
class WindowStats:
    """Per-window sums from the first pass (window ``k`` covers samples ``k·window ... ``)."""

    fs_hz: float
    window: int  # samples per window
    n_samples: int
    count: NDArray[np.int64]
    dut_sum: NDArray[np.float64]  # raw sum: segment means are exact
    dut_smooth: NDArray[np.float64]  # Hann-kernel mean centred on the window (for uncertainties)
    dut_max: NDArray[np.float64]
    dut_min: NDArray[np.float64]
    n_at_max: NDArray[np.int64]  # samples within eps of the window's maximum (candidate windows only)
    n_at_min: NDArray[np.int64]
    n_beyond_rail: NDArray[np.int64]  # samples at or beyond a given rail (0 when none given)
    ref_ac_sumsq: NDArray[np.float64]  # window length x mean square of the reference minus its mean
    ref_sum: NDArray[np.float64]  # raw sum of the reference (its DC: a reference reads none)
    ref_band_sumsq: NDArray[np.float64]  # window length x mean square of the reference in the band
    band_hz: tuple[float, float]
    reference: str  # channel used as reference ("dut" when the record has no reference)
    rail_g: float | None = None  # the given rail n_beyond_rail counts against (None: none given)
    # variance of ref_band_sumsq were the reference a Gaussian process, from the window's own
    # spectrum (band_variance_weights); None: not computed
    ref_band_var: NDArray[np.float64] | None = None
    # what the DUT channels of one pass share beyond these arrays (a sine level's drive frequency)
    shared: SharedCache = field(default_factory=dict, compare=False, repr=False)

    @property
    def n_windows(self) -> int:
        return len(self.count)

    @property
    def times_s(self) -> NDArray[np.float64]:
        """Centre time of each window."""
        return self.window_times_s(0, self.n_windows)

    def window_times_s(self, k0: int, k1: int) -> NDArray[np.float64]:
        """Centre times of windows ``k0 ... k1-1`` (``times_s[k0:k1]`` without the others)."""
        start = np.arange(k0, k1) * self.window
        return (start + self.count[k0:k1] / 2.0) / self.fs_hz

    def dut_mean(self) -> NDArray[np.float64]:
        return self.dut_sum / np.maximum(self.count, 1)

    def envelope(self) -> NDArray[np.float64]:
        """AC rms of the reference (its mean removed) per window, in g."""
        return np.sqrt(np.maximum(self.ref_ac_sumsq, 0.0) / np.maximum(self.count, 1))

    def band_rms(self) -> NDArray[np.float64]:
        return np.sqrt(np.maximum(self.ref_band_sumsq, 0.0) / np.maximum(self.count, 1))

    def saturated(self) -> tuple[NDArray[np.int64], list[str]]:
        """Saturated DUT samples per window, and a description of the rails found."""
        notes: list[str] = []
        sat = self.n_beyond_rail.copy()
        valid = self.count > 0
        if not valid.any():
            return sat, notes
        hi = float(np.max(self.dut_max[valid]))
        lo = float(np.min(self.dut_min[valid]))
        for side, ext, wext, nat in (
            ("upper", hi, self.dut_max, self.n_at_max),
            ("lower", lo, self.dut_min, self.n_at_min),
        ):
            if self.rail_g is not None and abs(ext) >= self.rail_g * (1 - RAIL_EPS_REL):
                # the samples on this extreme are at or beyond the given rail: n_beyond_rail
                # holds them already (adding them again counted each twice)
                continue
            on = valid & (np.abs(wext - ext) <= _eps(ext))
            n = int(nat[on].sum())
            if n >= RAIL_MIN_SAMPLES:
                sat = sat + np.where(on, nat, 0)
                notes.append(Notice("rail-found", f"DUT {side} rail found at {ext:.6g} g ({n} samples on it)"))
        return sat, notes


def _eps(x: float | NDArray[np.float64]) -> float | NDArray[np.float64]:
    return RAIL_EPS_REL * np.maximum(np.abs(x), 1.0)


# The DUT's smoothed series: a Hann kernel over SMOOTH_WINDOWS windows, centred on each window.
SMOOTH_WINDOWS = 3
# Samples per channel the window pass works on at once (512 KiB of float64: within a core's L2
# cache on most machines); a block read from the record is worked chunk by chunk.
CHUNK_SAMPLES = 1 << 16


def smoothing_kernel(window: int) -> NDArray[np.float64]:
    """Hann kernel of SMOOTH_WINDOWS·window samples, as a (window, SMOOTH_WINDOWS) matrix.

    Why: the vibration the DUT reads averages to zero over a level, but over one 0.1 s window a
    boxcar leaves a residual of order σ/(π·f·T) (-24 dB at 50 Hz) that would dominate the
    window-to-window scatter and so the batch-means uncertainty, although neighbouring windows'
    residuals cancel in the level's mean. A 3-window (0.3 s) Hann kernel (sidelobes falling as
    1/f³: -80 dB at 50 Hz) removes it; it costs one small matrix product per block instead of a
    per-sample IIR low-pass. Column q weighs the samples of window k-1+q for the value at window k.
    """
    L = SMOOTH_WINDOWS * window
    h = 0.5 - 0.5 * np.cos(2 * np.pi * (np.arange(L) + 0.5) / L)
    return np.ascontiguousarray(h.reshape(SMOOTH_WINDOWS, window).T)


@functools.lru_cache(maxsize=32)
def kernel_correlation(window: int) -> tuple[float, ...]:
    """Correlation at lags 0, 1, ... windows that the smoothing kernel puts between the smoothed
    values of noise white at the sample scale. Cached per window length (a tuple: immutable):
    every level and baseline of a record asks for it (600 kernels of a 2 h record rebuilt)."""
    h = smoothing_kernel(window).T.ravel()
    r0 = float(h @ h)
    return tuple(float(h[lag * window :] @ h[: len(h) - lag * window]) / r0 for lag in range(SMOOTH_WINDOWS))


def kernel_tau(window: int) -> float:
    """Integrated autocorrelation time (in windows) the kernel gives white noise: Σ_l ρ(l·window)."""
    rho = kernel_correlation(window)
    return 1.0 + 2.0 * sum(rho[1:])


def band_weights(
    window: int, fs_hz: float, band_hz: tuple[float, float]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Weights turning |rfft|² of one window into (AC, in-band) sums of squares (Parseval).

    One-sided: bins 1..N/2-1 count twice, the Nyquist bin of an even window once; divided by
    the window length so that the weighted sum is Σx² over the window.
    """
    nb = window // 2 + 1
    f = np.arange(nb) * fs_hz / window
    two = np.full(nb, 2.0)
    two[0] = 0.0  # the window's mean is not vibration
    if window % 2 == 0:
        two[-1] = 1.0
    ac = two / window
    band = np.where((f >= band_hz[0] - 1e-9) & (f <= band_hz[1] + 1e-9), ac, 0.0)
    return ac, band


def band_variance_weights(window: int, fs_hz: float, band_hz: tuple[float, float]) -> NDArray[np.float64]:
    """Weights turning |rfft|⁴ of one window into the variance of its in-band sum of squares
    (:func:`band_weights`), were the signal a Gaussian process.

    The in-band sum of squares is ``Σ_k w_k·|X_k|²``. For a stationary Gaussian process whose
    spectrum is smooth over a bin, the bins are nearly independent, complex Gaussian (|X_k|²
    exponential: variance (E|X_k|²)² = E|X_k|⁴/2), the DC and Nyquist bins real Gaussian
    (variance 2·(E|X|²)² = (2/3)·E|X|⁴). So ``Σ_k w_k²·c_k·|X_k|⁴`` (c = 1/2, or 2/3) is an
    unbiased estimate of the sum's variance from the window's own spectrum: the mean-square
    error ``1/(B_e·T)`` of Bendat & Piersol (Random Data, 4th ed., 8.2.2: B_e the spectrum's
    equivalent bandwidth (∫S)²/∫S², T the averaging time), measured rather than assumed.
    """
    _, band = band_weights(window, fs_hz, band_hz)
    c = np.full(band.size, 0.5)
    c[0] = 2.0 / 3.0
    if window % 2 == 0:
        c[-1] = 2.0 / 3.0
    out: NDArray[np.float64] = band * band * c
    return out


def _window_reduce(x: NDArray[np.float64], w: int) -> list[NDArray[np.float64]]:
    """Reshape into full windows plus a tail; returns list of 2-D views."""
    nfull = len(x) // w
    parts = [x[: nfull * w].reshape(nfull, w)] if nfull else []
    if len(x) > nfull * w:
        parts.append(x[nfull * w :][None, :])
    return parts


def exact_blocks(
    record: Record, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
) -> Iterator[dict[str, NDArray[np.float64]]]:
    """Blocks of exactly ``block_size`` samples (the last may be shorter), whatever the record yields.

    The Record protocol allows shorter blocks; window sums need block edges on window edges.
    """
    buf: list[dict[str, NDArray[np.float64]]] = []
    have = 0
    for blk in record.blocks(block_size, channels, start, stop):
        m = len(next(iter(blk.values())))
        if not buf and m == block_size:
            yield blk
            continue
        buf.append(blk)
        have += m
        while have >= block_size:
            cat = {c: np.concatenate([b[c] for b in buf]) for c in channels}
            yield {c: v[:block_size] for c, v in cat.items()}
            rest = {c: v[block_size:] for c, v in cat.items()}
            have -= block_size
            buf = [rest] if have else []
    if have:
        yield {c: np.concatenate([b[c] for b in buf]) for c in channels}


def channel_labels(record: Record) -> dict[str, str]:
    """How to name a record channel in messages: with the file's name for it when known."""
    mapping = getattr(record, "mapping", None) or {}
    names = dict.fromkeys(("dut", "reference", *record.channels))
    return {c: (f"'{mapping[c]}' ({c})" if c in mapping and mapping[c] != c else f"'{c}'") for c in names}


Block = dict[str, NDArray[np.float64]]


def check_finite(name: str, x: NDArray[np.float64], offset: int) -> None:
    """NaN/inf in a channel: one line naming the channel and the first bad sample index."""
    if not np.isfinite(x).all():
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        raise ValueError(f"channel {name} has a non-finite value ({x[i]}) at sample index {offset + i}")


class _DutWindows:
    """One DUT channel's per-window sums, filled block by block (see :func:`window_pass_many`)."""

    def __init__(self, k: int, w: int, rail_g: float | None) -> None:
        self.dsum, self.dmax, self.dmin = np.zeros(k), np.zeros(k), np.zeros(k)
        self.nmax, self.nmin, self.nrail = (np.zeros(k, dtype=np.int64) for _ in range(3))
        self.parts = np.zeros((k + SMOOTH_WINDOWS, SMOOTH_WINDOWS))  # kernel partial sums per window
        self.run_max, self.run_min = -np.inf, np.inf
        self.k, self.w, self.rail_g = k, w, rail_g

    def add(self, dv: NDArray[np.float64], kk: int, kern: NDArray[np.float64]) -> None:
        """Windows ``kk ...`` of this block, ``dv`` shaped (windows, samples); ``kern`` is
        :func:`smoothing_kernel` transposed (one row per window of the kernel)."""
        m, L = dv.shape
        sl = slice(kk, kk + m)
        self.dsum[sl] = dv.sum(axis=1)
        mx = dv.max(axis=1)
        mn = dv.min(axis=1)
        self.dmax[sl], self.dmin[sl] = mx, mn
        # A window can hold the record's extreme only if it reaches the running extreme.
        self.run_max = max(self.run_max, float(mx.max()))
        self.run_min = min(self.run_min, float(mn.min()))
        cand = np.flatnonzero(mx >= self.run_max - _eps(self.run_max))
        if len(cand):
            self.nmax[kk + cand] = (dv[cand] >= (mx[cand] - _eps(mx[cand]))[:, None]).sum(axis=1)
        cand = np.flatnonzero(mn <= self.run_min + _eps(self.run_min))
        if len(cand):
            self.nmin[kk + cand] = (dv[cand] <= (mn[cand] + _eps(mn[cand]))[:, None]).sum(axis=1)
        if self.rail_g is not None:
            thr = self.rail_g * (1 - RAIL_EPS_REL)
            cand = np.flatnonzero((mx >= thr) | (mn <= -thr))
            if len(cand):
                self.nrail[kk + cand] = ((dv[cand] >= thr) | (dv[cand] <= -thr)).sum(axis=1)
        # each kernel column's weighted sum per window: einsum's own loop, not BLAS (whose threads,
        # woken for every small product, made this pass 5 to 30 times slower on a busy machine)
        # (all the columns in one call: each is still its own dot product over the window)
        rows = self.parts[kk : kk + m]
        if L == self.w:
            np.einsum("ij,qj->iq", dv, kern, out=rows)
        else:  # the record's last, partial window
            np.einsum("ij,qj->iq", dv, kern[:, :L], out=rows)
            rows *= self.w / L

    def smooth(self, kern: NDArray[np.float64]) -> NDArray[np.float64]:
        """value at window j = Σ_q parts[j - h + q, q] / Σ(kernel weights present)"""
        k = self.k
        h = SMOOTH_WINDOWS // 2
        num = np.zeros(k)
        den = np.zeros(k)
        col = kern.sum(axis=0)
        for q in range(SMOOTH_WINDOWS):
            src = np.arange(k) - h + q
            ok = (src >= 0) & (src < k)
            num[ok] += self.parts[src[ok], q]
            den[ok] += col[q]
        return num / den


class _RefWindows:
    """The reference's per-window numbers, filled chunk by chunk (see :func:`window_pass_many`):
    sample count, sum (the FFT's DC bin), AC and in-band sums of squares (Parseval) and the
    in-band sum's variance (:func:`band_variance_weights`)."""

    def __init__(self, k: int, w: int, fs: float, band: tuple[float, float]) -> None:
        from scipy import fft as sfft

        self.rfft = sfft.rfft
        self.count = np.zeros(k, dtype=np.int64)
        self.ac, self.band, self.sum, self.var = np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k)
        self.w, self.fs, self.band_hz = w, fs, band
        # the weights of |X|² repeated for the (re, im) pairs of the spectrum viewed as float64
        self.weights2 = np.repeat(np.vstack(band_weights(w, fs, band)), 2, axis=1)
        self.weights4 = band_variance_weights(w, fs, band)

    def add(self, rv: NDArray[np.float64], kk: int) -> None:
        """Windows ``kk ...`` of this chunk, ``rv`` shaped (windows, samples)."""
        m, L = rv.shape
        sl = slice(kk, kk + m)
        self.count[sl] = L
        # |X|² summed with weights: view the complex spectrum as (re, im) pairs, square in place
        # and weigh both halves (no complex temporaries; einsum, not BLAS: see _DutWindows.add)
        spec = self.rfft(rv, axis=1).view(np.float64)
        wts = self.weights2 if L == self.w else np.repeat(np.vstack(band_weights(L, self.fs, self.band_hz)), 2, axis=1)
        self.sum[sl] = spec[:, 0]  # the FFT's DC bin is the window's sum, free
        np.multiply(spec, spec, out=spec)
        np.einsum("ij,j->i", spec, wts[0], out=self.ac[sl])
        np.einsum("ij,j->i", spec, wts[1], out=self.band[sl])
        p = np.add(spec[:, 0::2], spec[:, 1::2])  # |X|² per bin
        np.multiply(p, p, out=p)
        vw = self.weights4 if L == self.w else band_variance_weights(L, self.fs, self.band_hz)
        np.einsum("ij,j->i", p, vw, out=self.var[sl])


def _pass_inputs(record: Record, band_hz: tuple[float, float], duts: Sequence[str]
                 ) -> tuple[float, int, list[str], tuple[float, float]]:
    """The record's rate and length, the DUT channels and the band, checked (one line each)."""
    fs = V.positive_scalar("fs_hz", record.fs_hz)
    n = int(record.n_samples)
    if n <= 0:
        raise ValueError("record has no samples")
    duts = list(duts)
    if not duts:
        raise ValueError("no DUT channel to reduce")
    for d in duts:
        if d not in record.channels:
            raise ValueError(f"record has no {d!r} channel; channels: {', '.join(record.channels)}")
    f1, f2 = (float(x) for x in band_hz)
    if not (0 < f1 < f2):
        raise ValueError(f"band_hz must satisfy 0 < f1 < f2, got {band_hz}")
    return fs, n, duts, (f1, f2)


class _BlockWork:
    """One block's windows, the reference's and every DUT's (see :func:`window_pass_many`).

    With two cores or more, the DUT statistics of a block run in a second thread while this one
    takes the reference's FFTs (pocketfft and numpy's reductions release the GIL): each thread
    writes its own arrays and the block is joined before the next, so every number is the one a
    single thread computes, in the same order. (A third thread reads ahead.)"""

    def __init__(self, ref: _RefWindows, accs: dict[str, _DutWindows], ref_name: str, w: int) -> None:
        self.ref, self.accs, self.ref_name, self.w = ref, accs, ref_name, w
        self.kern_rows = np.ascontiguousarray(smoothing_kernel(w).T)
        # a block is worked in cache-sized chunks of whole windows: the FFT, the squares, the
        # sums, the extremes and the kernel then read each chunk from cache rather than memory
        self.chunk = max(1, CHUNK_SAMPLES // w) * w
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="vrelab-dut") if _cores() > 1 else None

    def duts(self, xs: dict[str, NDArray[np.float64]], kk: int) -> None:
        """Every DUT channel's window statistics of one block (windows ``kk ...``)."""
        for lo in range(0, len(next(iter(xs.values()))), self.chunk):
            for d, acc in self.accs.items():
                kd = kk + lo // self.w
                for dv in _window_reduce(xs[d][lo : lo + self.chunk], self.w):
                    acc.add(dv, kd, self.kern_rows)
                    kd += dv.shape[0]

    def reference(self, r: NDArray[np.float64], kk: int) -> int:
        """The reference's windows of one block from window ``kk``; returns the next window."""
        for lo in range(0, len(r), self.chunk):
            for rv in _window_reduce(r[lo : lo + self.chunk], self.w):
                self.ref.add(rv, kk)
                kk += rv.shape[0]
        return kk

    def block(self, blk: Block, pos: int) -> int:
        """Block ``blk`` starting at sample ``pos``; returns the window after its last."""
        r = np.asarray(blk[self.ref_name], dtype=np.float64)
        xs = {d: np.asarray(blk[d], dtype=np.float64) for d in self.accs}
        dut_done = self.pool.submit(self.duts, xs, pos // self.w) if self.pool is not None else None
        try:
            kk = self.reference(r, pos // self.w)
        finally:
            if dut_done is not None:
                dut_done.result()  # its error, if any, is raised here; it is joined either way
        if dut_done is None:
            self.duts(xs, pos // self.w)
        return kk

    def finite(self, sl: slice) -> bool:
        """NaN/inf anywhere in a window makes its sums non-finite (g-level data cannot overflow a
        sum): the small arrays tell, the samples are scanned only to name the first bad one."""
        return bool(np.isfinite(self.ref.ac[sl]).all() and np.isfinite(self.ref.band[sl]).all()
                    and all(np.isfinite(a.dsum[sl]).all() for a in self.accs.values()))

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)


def window_pass(
    record: Record,
    band_hz: tuple[float, float],
    window_s: float = 0.1,
    block_size: int = 1 << 18,
    rail_g: float | None = None,
    progress: bool = False,
) -> WindowStats:
    """Stream the record once and return per-window sums of its ``dut`` channel (see
    :func:`window_pass_many`, which does it for several DUT channels in one pass)."""
    return window_pass_many(record, band_hz, ["dut"], window_s, block_size, rail_g, progress)["dut"]


def window_pass_many(
    record: Record,
    band_hz: tuple[float, float],
    duts: Sequence[str],
    window_s: float = 0.1,
    block_size: int = 1 << 18,
    rail_g: float | None = None,
    progress: bool = False,
) -> dict[str, WindowStats]:
    """Stream the record once and return per-window sums for each DUT channel in ``duts``.

    Reference power per window from its FFT (Parseval): the AC power (all bins but DC) gives
    the envelope, the bins in ``band_hz`` the band-limited power (a brick-wall band with the
    window's leakage, no filter-edge attenuation); computed once and shared by every DUT's
    stats. DUT: raw sums (exact means), extremes, samples at the extremes (counted only in
    windows that can hold the record's extreme: those at the running maximum or minimum), and
    the Hann-smoothed series of :func:`smoothing_kernel`. Without a ``reference`` channel the
    first DUT is the reference.
    """
    fs, n, duts, band = _pass_inputs(record, band_hz, duts)
    ref_name = "reference" if "reference" in record.channels else duts[0]
    w = window_length(fs, band, window_s)
    block = max(w, (int(block_size) // w) * w)  # windows never straddle blocks
    k = -(-n // w)
    # a dozen 8-byte numbers per window and DUT, and the smoothing kernel's partial sums: sized
    # before anything is allocated from the record's length
    _budget.check_memory(f"the analysis of {n} samples ({k} windows of {w} samples, {len(duts)} DUT channel(s))",
                         k * (5 + len(duts) * (9 + SMOOTH_WINDOWS)) * 8.0)
    ref = _RefWindows(k, w, fs, band)
    accs = {d: _DutWindows(k, w, rail_g) for d in duts}
    chans = list(dict.fromkeys(duts + [ref_name]))
    labels = channel_labels(record)
    bar = _progress_bar(n) if progress else None
    pos = 0
    work = _BlockWork(ref, accs, ref_name, w)
    try:
        for blk in prefetch(exact_blocks(record, block, chans, 0, n), depth=read_ahead_depth(block, len(chans))):
            kk = work.block(blk, pos)
            if not work.finite(slice(pos // w, kk)):
                for c in chans:
                    check_finite(labels.get(c, repr(c)), np.asarray(blk[c]), pos)
            m = len(blk[ref_name])
            pos += m
            if bar is not None:
                bar.update(m)
    finally:
        work.close()
    if bar is not None:
        bar.close()
    if pos != n:
        raise ValueError(f"record delivered {pos} samples, expected {n} (truncated file?)")
    shared: SharedCache = {}
    kern = smoothing_kernel(w)
    return {
        d: WindowStats(
            fs_hz=fs, window=w, n_samples=n, count=ref.count, dut_sum=a.dsum, dut_smooth=a.smooth(kern),
            dut_max=a.dmax, dut_min=a.dmin, n_at_max=a.nmax, n_at_min=a.nmin, n_beyond_rail=a.nrail,
            ref_ac_sumsq=ref.ac, ref_sum=ref.sum, ref_band_sumsq=ref.band, band_hz=band,
            reference="dut" if ref_name == d else ref_name, shared=shared, rail_g=rail_g, ref_band_var=ref.var,
        )
        for d, a in accs.items()
    }  # fmt: skip


def _progress_bar(n: int) -> Any:
    """A progress bar of the samples read (on the progress stream)."""
    from tqdm import tqdm

    from vrelab._format import progress_stream

    return tqdm(total=n, unit="S", unit_scale=True, desc="reading", leave=False, file=progress_stream())


# How far the reader runs ahead of the pass, in bytes. A file not in the page cache is read at
# the storage's pace, which jitters from block to block: with one block in hand the reader waits
# on the pass as often as the pass on the reader; eight blocks ahead keep the storage busy (the
# 2 h bench record from a dropped page cache: first pass 0.23-0.44 s one block ahead, 0.23 s in
# five runs of six eight ahead; bench/bench_analyze_hdf5.py). Bounded in bytes, not blocks, so
# that a file of many channels holds no more.
READ_AHEAD_BYTES = 32 << 20


def read_ahead_depth(block: int, n_channels: int) -> int:
    """Blocks the reader may hold ahead of the pass: READ_AHEAD_BYTES of float64 blocks, 1 to 8."""
    return max(1, min(8, READ_AHEAD_BYTES // max(1, block * n_channels * 8)))


def _cores() -> int:
    """CPU cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Half-open index ranges [a, b) where mask is True."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


# Pieces shorter than this are searched for their split in plain Python (the same operations on
# the same doubles as the array code; a ramp cut into a thousand pieces of a few windows spent
# most of its time in numpy's per-call overhead)
_SCALAR_PIECE = 24


def _binary_segmentation(x: NDArray[np.float64], sigma: float, min_step: float) -> list[tuple[int, int]]:
    """Piecewise-constant pieces of ``x`` by binary segmentation (Scott & Knott 1974).

    A piece is split at the point that most reduces the squared error, when the reduction
    exceeds ``4·ln(n)·σ²`` (a BIC-like penalty, so noise alone does not split) and the two
    sides' means differ by more than ``min_step``. Cumulative sums make each split O(n).
    """
    n = len(x)
    pen = 4.0 * math.log(max(n, 2)) * sigma**2
    out: list[tuple[int, int]] = []
    stack = [(0, n)]
    c1 = np.concatenate([[0.0], np.cumsum(x)])
    cs = c1.tolist()  # the same doubles, for the short pieces' scalar search
    steps = np.arange(n + 1, dtype=np.float64)  # piece lengths either side of a split
    while stack:
        a, b = stack.pop()
        m = b - a
        if m < 4:
            out.append((a, b))
            continue
        # (the gain at split a + j: sl²/j + sr²/(m - j) - tot²/m, sl and sr the sums either side)
        tot = c1[b] - c1[a]
        t2 = float(tot**2 / m)
        if m < _SCALAR_PIECE:
            i, g, dl, dr = _best_split(cs, a, b, t2)
        else:
            sl = c1[a + 1 : b] - c1[a]
            sr = c1[b] - c1[a + 1 : b]
            nl, nr = steps[1:m], steps[m - 1 : 0 : -1]
            gain = sl**2 / nl + sr**2 / nr - t2
            i = int(np.argmax(gain))
            g, dl, dr = float(gain[i]), float(sl[i] / nl[i]), float(sr[i] / nr[i])
        if g > pen and abs(dl - dr) > min_step:
            c = a + 1 + i
            stack += [(c, b), (a, c)]
        else:
            out.append((a, b))
    return sorted(out)


def _best_split(cs: list[float], a: int, b: int, t2: float) -> tuple[int, float, float, float]:
    """(index, gain, left mean, right mean) of :func:`_binary_segmentation`'s best split of the
    piece [a, b), ``cs`` the cumulative sums and ``t2`` tot²/m: the first largest gain, as
    ``np.argmax`` takes it (x*x is numpy's square of ``**2``)."""
    m, ca, cb = b - a, cs[a], cs[b]
    best, gbest = 0, -math.inf
    for j in range(1, m):
        sl, sr = cs[a + j] - ca, cb - cs[a + j]
        g = sl * sl / j + sr * sr / (m - j) - t2
        if g != g:  # NaN: np.argmax takes the first
            best, gbest = j - 1, g
            break
        if g > gbest:
            best, gbest = j - 1, g
    sl, sr = cs[a + best + 1] - ca, cb - cs[a + best + 1]
    return best, gbest, sl / (best + 1), sr / (m - best - 1)


def auto_segment(
    stats: WindowStats,
    min_duration_s: float = 1.0,
    min_step: float = 0.05,
    off_threshold_g: float | None = None,
    max_rate_per_s: float = 0.02,
) -> tuple[Schedule, list[str]]:
    """Find baselines and level plateaus from the envelope (untrimmed; see :func:`trim`).

    Rules (window = ``stats.window`` samples, 0.1 s):

    * envelope ``e_k`` = AC rms of the reference per window;
    * off: ``e_k`` below ``off_threshold_g`` (default: the larger of 4× the 5th percentile of
      ``e`` (the reference's noise floor) and 1e-4 × its maximum, so that a silent synthetic
      reference does not make it zero);
    * on-runs are cut into pieces of constant ``log e`` by binary segmentation; the noise of
      ``log e`` per window (a 0.1 s rms of band-limited noise scatters by ``1/√(2·B·T)``) is
      measured robustly from the median absolute first difference, so noise does not cut; steps
      smaller than ``min_step`` (5 % in level) do not cut either;
    * a piece is a plateau when it lasts ``min_duration_s`` or more and is not a ramp: its level
      (straight-line fit of ``log e``) changes across it by more than 30 %, or significantly
      (more than ``min_step`` and 4 standard errors) at more than ``max_rate_per_s`` (2 %/s).
      Ramps, cut into short or sloping pieces, are left out; the slow wander of a shaker
      controller on a long plateau is kept. Adjacent plateaus within ``min_step`` are merged.

    Levels may come in any order and repeat; each plateau is its own segment.
    """
    e = stats.envelope()
    ok = stats.count == stats.window
    fs, w = stats.fs_hz, stats.window
    warnings: list[str] = []
    if not ok.any():
        raise ValueError("record too short for segmentation (no full window)")
    emax = float(e[ok].max())
    if off_threshold_g is None:
        floor = float(np.percentile(e[ok], 5))
        thr = max(4.0 * floor, 1e-4 * emax, 1e-12)
    else:
        thr = V.positive_scalar("off_threshold_g", off_threshold_g)
    off = (e < thr) & ok
    on = (e >= thr) & ok
    min_w = max(2, int(math.ceil(min_duration_s * fs / w)))
    loge = np.log(np.maximum(e, thr))
    d = np.diff(loge[on])
    sigma = float(1.4826 * np.median(np.abs(d)) / math.sqrt(2)) if len(d) else 0.0
    plateaus: list[tuple[int, int, float]] = []
    for a, b in _runs(on):
        merged: list[list[float]] = []
        for pa, pb in _binary_segmentation(loge[a:b], sigma, min_step):
            if pb - pa < min_w:
                merged.append([])  # a transition piece separates plateaus
                continue
            # binary segmentation places edges to a window or two: shed edge windows that are
            # off the piece's median by more than 3σ (the start of the next ramp)
            med = float(np.median(loge[a + pa : a + pb]))
            while pb - pa > min_w and abs(loge[a + pa] - med) > 3 * sigma + min_step:
                pa += 1
            while pb - pa > min_w and abs(loge[a + pb - 1] - med) > 3 * sigma + min_step:
                pb -= 1
            seg = loge[a + pa : a + pb]
            tt = np.arange(len(seg))
            slope = np.polyfit(tt, seg, 1)[0]
            # A ramp: the level changes across the piece, significantly (4 standard errors of
            # the change) and fast (more than max_rate_per_s in log level); or by more than 30 %
            # whatever the rate. Slow wander of a controller on a long plateau is not a ramp.
            change = abs(slope) * len(seg)
            rate = abs(slope) * fs / w
            significant = change > max(min_step, 4.0 * sigma * math.sqrt(12.0 / len(seg)))
            if (significant and rate > max_rate_per_s) or change > 0.3:
                merged.append([])
                continue
            lvl = float(np.mean(seg))
            if merged and merged[-1] and abs(merged[-1][2] - lvl) < min_step and merged[-1][1] == a + pa:
                m0 = merged[-1]
                m0[2] = (m0[2] * (m0[1] - m0[0]) + lvl * (pb - pa)) / (m0[1] - m0[0] + pb - pa)
                m0[1] = a + pb
            else:
                merged.append([a + pa, a + pb, lvl])
        plateaus += [(int(m[0]), int(m[1]), m[2]) for m in merged if m]
    segs: list[Segment] = []
    for a, b in _runs(off):
        if b - a >= min_w:
            segs.append(Segment(a * w / fs, b * w / fs, 0.0))
    for a, b, _ in plateaus:
        segs.append(Segment(a * w / fs, b * w / fs, float(np.sqrt(np.mean(e[a:b] ** 2)))))
    segs.sort(key=lambda s: s.start_s)
    if not any(s.is_baseline for s in segs):
        warnings.append(Notice("schedule", "automatic segmentation found no vibration-off baseline"))
    if not any(not s.is_baseline for s in segs):
        warnings.append(Notice("schedule", "automatic segmentation found no vibration level"))
    return Schedule(tuple(segs)), warnings


def trim(schedule: Schedule, settle_s: float) -> tuple[Schedule, list[str]]:
    """Trim ``settle_s`` at both edges of every segment (at most a quarter of it per edge)."""
    settle_s = float(settle_s)
    if not math.isfinite(settle_s) or settle_s < 0:
        raise ValueError(f"settle_s must be >= 0, got {settle_s!r}")
    out: list[Segment] = []
    warnings: list[str] = []
    for s in schedule.segments:
        dur = s.end_s - s.start_s
        cut = settle_s
        if 2 * cut > 0.5 * dur:
            cut = 0.25 * dur
            warnings.append(Notice(
                "segment", f"segment {s.start_s:.3g}-{s.end_s:.3g} s is short for settle_s={settle_s:g} s: trimmed {cut:.3g} s per edge"
            ))
        out.append(Segment(s.start_s + cut, s.end_s - cut, s.nominal_rms_g, s.freq_hz))
    return Schedule(tuple(out)), warnings


def segment_windows(stats: WindowStats, seg: Segment) -> tuple[int, int]:
    """Full windows inside a segment: half-open window index range [k0, k1)."""
    per = stats.window / stats.fs_hz
    k0 = int(math.ceil(seg.start_s / per - 1e-9))
    k1 = int(math.floor(seg.end_s / per + 1e-9))
    k1 = min(k1, stats.n_samples // stats.window)
    return k0, max(k0, k1)


def segments_to_labels(stats: WindowStats, schedule: Schedule) -> NDArray[np.int64]:
    """Per-window label: -1 unused, 0 baseline, i >= 1 the i-th level of the schedule."""
    lab = np.full(stats.n_windows, -1, dtype=np.int64)
    i = 0
    for s in schedule.segments:
        k0, k1 = segment_windows(stats, s)
        if s.is_baseline:
            lab[k0:k1] = 0
        else:
            i += 1
            lab[k0:k1] = i
    return lab


__all__: Sequence[str] = (
    "WindowStats",
    "window_pass",
    "auto_segment",
    "trim",
    "segment_windows",
    "segments_to_labels",
    "check_finite",
)
