"""First streaming pass over a record, and its segmentation into baselines and levels.

One pass reads the record in blocks and keeps, per short window (``window_s``, 0.1 s by
default), a handful of sums: DUT sum / sum of squares / extremes / samples at its extremes,
reference sum / sum of squares and band-limited power (a band-pass designed once, its state
``zi`` carried across blocks). These small arrays (a 2 h record at 0.1 s: 72 000 windows) are
all that segmentation, baselines, random-method levels and their batch-means uncertainty need,
so memory does not grow with the length of the record beyond them.

Segmentation is either given (a :class:`~vrelab.record.Schedule`: the user's, or the one
embedded in the record) or found from the rms envelope of the reference (the DUT's AC part
when there is no reference): windows below a noise threshold are "off"; among the "on"
windows, plateaus are the stretches where the envelope is steady (ramps, where it changes,
are left out); a settling time is trimmed at both edges of every segment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from vrelab import _validate as V
from vrelab.record import Record, Schedule, Segment

# Samples within this relative distance of the record's extreme count as "at the rail".
RAIL_EPS_REL = 1e-6
# A rail is declared only when at least this many samples sit on the same extreme (a clipped
# signal pins many samples there; an unclipped one reaches its maximum once).
RAIL_MIN_SAMPLES = 10


@dataclass(frozen=True)
class WindowStats:
    """Per-window sums from the first pass (window ``k`` covers samples ``k·window ... ``)."""

    fs_hz: float
    window: int  # samples per window
    n_samples: int
    count: NDArray[np.int64]
    dut_sum: NDArray[np.float64]  # of the low-passed DUT (see design_dut_lowpass)
    dut_sumsq: NDArray[np.float64]
    dut_max: NDArray[np.float64]
    dut_min: NDArray[np.float64]
    n_at_max: NDArray[np.int64]  # samples within eps of the window's maximum
    n_at_min: NDArray[np.int64]
    n_beyond_rail: NDArray[np.int64]  # samples at or beyond a given rail (0 when none given)
    ref_sum: NDArray[np.float64]
    ref_sumsq: NDArray[np.float64]
    ref_band_sumsq: NDArray[np.float64]
    band_hz: tuple[float, float]
    reference: str  # channel used as reference ("dut" when the record has no reference)

    @property
    def n_windows(self) -> int:
        return len(self.count)

    @property
    def times_s(self) -> NDArray[np.float64]:
        """Centre time of each window."""
        start = np.arange(self.n_windows) * self.window
        return (start + self.count / 2.0) / self.fs_hz

    def dut_mean(self) -> NDArray[np.float64]:
        return self.dut_sum / np.maximum(self.count, 1)

    def envelope(self) -> NDArray[np.float64]:
        """AC rms of the reference (its mean removed) per window, in g."""
        n = np.maximum(self.count, 1)
        m = self.ref_sum / n
        return np.sqrt(np.maximum(self.ref_sumsq / n - m**2, 0.0))

    def band_rms(self) -> NDArray[np.float64]:
        return np.sqrt(self.ref_band_sumsq / np.maximum(self.count, 1))

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
            eps = RAIL_EPS_REL * max(abs(ext), 1.0)
            on = valid & (np.abs(wext - ext) <= eps)
            n = int(nat[on].sum())
            if n >= RAIL_MIN_SAMPLES:
                sat = sat + np.where(on, nat, 0)
                notes.append(f"DUT {side} rail found at {ext:.6g} g ({n} samples on it)")
        return sat, notes


def design_band(fs_hz: float, band_hz: tuple[float, float]) -> NDArray[np.float64]:
    """Butterworth band-pass (order 4 per edge) as sos; a high-pass when f2 reaches Nyquist."""
    f1, f2 = band_hz
    nyq = fs_hz / 2
    if not (0 < f1 < f2):
        raise ValueError(f"band_hz must satisfy 0 < f1 < f2, got {band_hz}")
    if f1 >= nyq:
        raise ValueError(f"band_hz lower edge {f1} Hz must be below Nyquist ({nyq} Hz)")
    if f2 >= 0.95 * nyq:
        return signal.butter(4, f1, btype="highpass", fs=fs_hz, output="sos")
    return signal.butter(4, [f1, f2], btype="bandpass", fs=fs_hz, output="sos")


def design_dut_lowpass(fs_hz: float, band_hz: tuple[float, float]) -> NDArray[np.float64]:
    """Low-pass for the DUT's window means: Butterworth order 6 at a quarter of the band's lower edge.

    The vibration the DUT reads averages to zero over a level, but over one 0.1 s window it
    leaves a residual of order σ/(π·f·T) that would dominate the window-to-window scatter, and
    so the batch-means uncertainty (for a band-limited signal the residuals of neighbouring
    windows cancel, which batch means cannot see). The low-pass (-72 dB at the band edge, DC
    gain exactly 1) removes it before averaging; its DC group delay (about 0.6/fc: 50 ms for a
    50 Hz band) is well inside the settling time trimmed at every segment edge.
    """
    fc = min(band_hz[0] / 4.0, 0.2 * fs_hz)
    return signal.butter(6, fc, btype="lowpass", fs=fs_hz, output="sos")


def _window_reduce(x: NDArray[np.float64], w: int):
    """Reshape into full windows plus a tail; returns list of 2-D views."""
    nfull = len(x) // w
    parts = [x[: nfull * w].reshape(nfull, w)] if nfull else []
    if len(x) > nfull * w:
        parts.append(x[nfull * w :][None, :])
    return parts


def exact_blocks(
    record: Record, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
):
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
    return {c: (f"'{mapping[c]}' ({c})" if c in mapping and mapping[c] != c else f"'{c}'") for c in ("dut", "reference")}


def check_finite(name: str, x: NDArray[np.float64], offset: int) -> None:
    """NaN/inf in a channel: one line naming the channel and the first bad sample index."""
    if not np.isfinite(x).all():
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        raise ValueError(f"channel {name} has a non-finite value ({x[i]}) at sample index {offset + i}")


def window_pass(
    record: Record,
    band_hz: tuple[float, float],
    window_s: float = 0.1,
    block_size: int = 1 << 18,
    rail_g: float | None = None,
    progress: bool = False,
) -> WindowStats:
    """Stream the record once and return per-window sums (see module docstring)."""
    fs = V.positive_scalar("fs_hz", record.fs_hz)
    n = int(record.n_samples)
    if n <= 0:
        raise ValueError("record has no samples")
    if "dut" not in record.channels:
        raise ValueError(f"record has no 'dut' channel; channels: {', '.join(record.channels)}")
    ref_name = "reference" if "reference" in record.channels else "dut"
    w = max(1, int(round(window_s * fs)))
    block = max(w, (int(block_size) // w) * w)  # windows never straddle blocks
    k = -(-n // w)
    z = lambda dt: np.zeros(k, dtype=dt)  # noqa: E731
    count, dsum, dsq, dmax, dmin = z(np.int64), z(float), z(float), z(float), z(float)
    nmax, nmin, nrail = z(np.int64), z(np.int64), z(np.int64)
    rsum, rsq, rband = z(float), z(float), z(float)
    sos = design_band(fs, band_hz)
    sos_lp = design_dut_lowpass(fs, band_hz)
    zi = None
    zi_lp = None
    chans = ["dut"] if ref_name == "dut" else ["dut", "reference"]
    labels = channel_labels(record)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n, unit="S", unit_scale=True, desc="reading", leave=False)
    pos = 0
    for blk in exact_blocks(record, block, chans, 0, n):
        d = np.asarray(blk["dut"], dtype=np.float64)
        r = d if ref_name == "dut" else np.asarray(blk["reference"], dtype=np.float64)
        check_finite(labels["dut"], d, pos)
        if r is not d:
            check_finite(labels["reference"], r, pos)
        if zi is None:
            zi = signal.sosfilt_zi(sos) * r[0]
            zi_lp = signal.sosfilt_zi(sos_lp) * d[0]
        rb, zi = signal.sosfilt(sos, r, zi=zi)
        dl, zi_lp = signal.sosfilt(sos_lp, d, zi=zi_lp)
        k0 = pos // w
        kk = k0
        parts = zip(_window_reduce(d, w), _window_reduce(dl, w), _window_reduce(r, w), _window_reduce(rb, w))
        for dv, dlv, rv, rbv in parts:
            m = dv.shape[0]
            sl = slice(kk, kk + m)
            count[sl] = dv.shape[1]
            dsum[sl] = dlv.sum(axis=1)
            dsq[sl] = np.einsum("ij,ij->i", dv, dv)
            mx = dv.max(axis=1)
            mn = dv.min(axis=1)
            dmax[sl], dmin[sl] = mx, mn
            nmax[sl] = (dv >= (mx - RAIL_EPS_REL * np.maximum(np.abs(mx), 1.0))[:, None]).sum(axis=1)
            nmin[sl] = (dv <= (mn + RAIL_EPS_REL * np.maximum(np.abs(mn), 1.0))[:, None]).sum(axis=1)
            if rail_g is not None:
                thr = rail_g * (1 - RAIL_EPS_REL)
                nrail[sl] = ((dv >= thr) | (dv <= -thr)).sum(axis=1)
            rsum[sl] = rv.sum(axis=1)
            rsq[sl] = np.einsum("ij,ij->i", rv, rv)
            rband[sl] = np.einsum("ij,ij->i", rbv, rbv)
            kk += m
        pos += len(d)
        if bar is not None:
            bar.update(len(d))
    if bar is not None:
        bar.close()
    if pos != n:
        raise ValueError(f"record delivered {pos} samples, expected {n} (truncated file?)")
    return WindowStats(
        fs_hz=fs, window=w, n_samples=n, count=count, dut_sum=dsum, dut_sumsq=dsq, dut_max=dmax,
        dut_min=dmin, n_at_max=nmax, n_at_min=nmin, n_beyond_rail=nrail, ref_sum=rsum, ref_sumsq=rsq,
        ref_band_sumsq=rband, band_hz=(float(band_hz[0]), float(band_hz[1])), reference=ref_name,
    )  # fmt: skip


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Half-open index ranges [a, b) where mask is True."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


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
    while stack:
        a, b = stack.pop()
        m = b - a
        if m < 4:
            out.append((a, b))
            continue
        k = np.arange(a + 1, b)
        sl = c1[k] - c1[a]
        sr = c1[b] - c1[k]
        nl = (k - a).astype(float)
        nr = (b - k).astype(float)
        tot = c1[b] - c1[a]
        gain = sl**2 / nl + sr**2 / nr - tot**2 / m
        i = int(np.argmax(gain))
        c = int(k[i])
        if gain[i] > pen and abs(sl[i] / nl[i] - sr[i] / nr[i]) > min_step:
            stack += [(c, b), (a, c)]
        else:
            out.append((a, b))
    return sorted(out)


def auto_segment(
    stats: WindowStats,
    min_duration_s: float = 1.0,
    min_step: float = 0.05,
    off_threshold_g: float | None = None,
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
    * a piece is a plateau when it lasts ``min_duration_s`` or more and its level does not
      change across it (straight-line fit) by more than ``min_step`` or 5 standard errors of
      that change, whichever is larger: ramps, cut into short or sloping pieces, are left out. Adjacent plateaus within ``min_step`` are merged.

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
            # level change across the piece against its noise (5 standard errors of the change:
            # band-limited noise and shaker controllers wander more than white noise would)
            if abs(slope) * len(seg) > max(min_step, 5.0 * sigma * math.sqrt(12.0 / len(seg))):
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
        warnings.append("automatic segmentation found no vibration-off baseline")
    if not any(not s.is_baseline for s in segs):
        warnings.append("automatic segmentation found no vibration level")
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
            warnings.append(
                f"segment {s.start_s:.3g}-{s.end_s:.3g} s is short for settle_s={settle_s:g} s: trimmed {cut:.3g} s per edge"
            )
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
    "design_band",
    "check_finite",
)
