"""A vibration-off baseline averaged over short windows when the first pass's are long.

The first pass's window is ``2/f1`` for a band from below 20 Hz
(:func:`vrelab.record.window_seconds`: 0.4 s from 5 Hz, 0.8 s from 2.5 Hz), so that a level's
band power is resolved. A baseline has no vibration to resolve: its DUT mean needs windows only
to measure its scatter. A 2 s baseline of a lab record, trimmed by 0.5 s at each edge, holds
one or two whole 0.4 s windows: too few to be averaged (``MIN_SEGMENT_WINDOWS``; the record was
then refused: "no vibration-off baseline"). Over windows of :data:`vrelab.record.WINDOW_S`
(0.1 s) it holds ten. Such a baseline's DUT samples are read again from the record (a baseline
is a small part of it) and put through the same window pass
(:func:`~vrelab.analysis.segmentation.window_pass`) at that window, so its mean, u and degrees
of freedom come from the same estimators as every other segment's
(:func:`vrelab.analysis.levels.dut_mean_estimate`). The band does not enter: the in-band power
of these windows is not read.

Only baselines that the long windows leave too short are read again: one of 3 or 4 long windows
keeps its estimate from them (the "raw" rule of few interior windows, whose u is honest on a
baseline, with 1 to 2 degrees of freedom), so the numbers of every record that reduced before
stay the same bits.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.segmentation import RAIL_EPS_REL, WindowStats, auto_segment, exact_blocks, window_pass
from vrelab.record import WINDOW_S, ArrayRecord, Record, Schedule, window_length
from vrelab.results import Notice

# Samples read at once from the record for a baseline's second look.
READ_BLOCK = 1 << 16


def fine_band(fs_hz: float) -> tuple[float, float]:
    """A band whose window (:func:`vrelab.record.window_length`) is WINDOW_S at ``fs_hz``: its
    lower edge at 2/WINDOW_S (20 Hz), below Nyquist (a record sampled under 80 Hz gets the
    longer window its Nyquist allows)."""
    return min(2.0 / WINDOW_S, fs_hz / 4), fs_hz / 2


def finer_window(stats: WindowStats) -> int | None:
    """Samples per window of a baseline's second look, when shorter than the first pass's
    (a band from below 20 Hz); None when the first pass's windows are already that short."""
    w = window_length(stats.fs_hz, fine_band(stats.fs_hz), WINDOW_S)
    return w if w < stats.window else None


def fine_baseline_stats(record: Record, stats: WindowStats, sat: NDArray[np.int64], i0: int, i1: int
                        ) -> tuple[WindowStats, int]:
    """The window stats of the DUT's samples ``[i0, i1)`` (a vibration-off baseline) over
    windows of WINDOW_S (window 0 starts at sample ``i0``), and the DUT samples among them
    that sit at a rail (``sat``: the first pass's saturated samples per window).

    Rails: a sample counts when it is at or beyond the given rail (``stats.rail_g``), or at one
    of the record's extremes while the first pass found samples on a rail in the windows the
    baseline overlaps (:meth:`WindowStats.saturated` decides over the whole record whether an
    extreme is a rail; a quiet baseline's own extreme, reached by a few quantised samples, is
    not one)."""
    fs = stats.fs_hz
    x = np.concatenate([np.asarray(b["dut"], dtype=np.float64)
                        for b in exact_blocks(record, READ_BLOCK, ["dut"], i0, i1)])
    fine = window_pass(ArrayRecord({"dut": x}, fs), fine_band(fs), WINDOW_S, READ_BLOCK, stats.rail_g)
    return fine, _rail_samples(x, stats, sat, i0, i1)


def _rail_samples(x: NDArray[np.float64], stats: WindowStats, sat: NDArray[np.int64], i0: int, i1: int) -> int:
    """The samples ``x`` (the DUT's ``[i0, i1)``) at a rail (see :func:`fine_baseline_stats`)."""
    at = np.zeros(len(x), dtype=bool)
    if stats.rail_g is not None:
        at |= np.abs(x) >= stats.rail_g * (1 - RAIL_EPS_REL)
    w = stats.window
    valid = stats.count > 0
    if int(sat[i0 // w : -(-i1 // w)].sum()) > 0 and valid.any():
        hi, lo = float(np.max(stats.dut_max[valid])), float(np.min(stats.dut_min[valid]))
        at |= x >= hi - RAIL_EPS_REL * max(abs(hi), 1.0)
        at |= x <= lo + RAIL_EPS_REL * max(abs(lo), 1.0)
    return int(at.sum())


def segment_any_band(record: Record, stats: WindowStats) -> tuple[Schedule, list[str]]:
    """The automatic segmentation (:func:`~vrelab.analysis.segmentation.auto_segment`) of a
    record whose first pass is ``stats``: its levels from ``stats``, its vibration-off
    baselines from windows of WINDOW_S whatever the band.

    Off is told from on by the reference's envelope per window. Over the long windows of a band
    from below 20 Hz (0.8 s from 2.5 Hz) an off stretch is found only as whole windows of at
    least 2 of them, so a 2 s baseline whose edges fall badly holds one and is lost (one at the
    record's end was: its level then took the nearest baseline alone, drift not removed, 6 U
    off the truth). The off test is made over a second pass at WINDOW_S instead (the same rule:
    under 4 times the envelope's 5th percentile, for a second or more), and its baselines that
    overlap no level found over the long windows are the schedule's. Levels keep the long
    windows: their plateaus are judged on an envelope that holds the band's lowest frequency.
    A first pass already at WINDOW_S is segmented as it is (the same bits)."""
    if finer_window(stats) is None:
        return auto_segment(stats)
    levels, w_lv = auto_segment(stats)
    fine = window_pass(record, fine_band(stats.fs_hz), WINDOW_S, READ_BLOCK, stats.rail_g)
    off, _ = auto_segment(fine)
    lv = [g for g in levels.segments if not g.is_baseline]
    base = [g for g in off.segments if g.is_baseline
            and not any(g.start_s < v.end_s and v.start_s < g.end_s for v in lv)]
    warnings = [w for w in w_lv if "vibration-off baseline" not in w]
    if not base:
        warnings.append(Notice("schedule", "automatic segmentation found no vibration-off baseline"))
    return Schedule(tuple(sorted(lv + base, key=lambda g: g.start_s))), warnings


def too_short(longest_s: float, need_s: float) -> str:
    """The refusal of a record whose baselines are all shorter than ``need_s`` (the longest
    ``longest_s``) after the settling trims, even over windows of WINDOW_S."""
    return (f"no vibration-off baseline long enough to average: the longest holds {longest_s:.3g} s after the "
            f"settling trims, under the {need_s:.3g} s a baseline needs; record longer baselines "
            "(or give a shorter --settle)")


__all__ = ["fine_band", "fine_baseline_stats", "finer_window", "segment_any_band", "too_short"]
