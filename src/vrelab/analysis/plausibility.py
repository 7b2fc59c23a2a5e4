"""Plausibility checks on a recorded test: no confident wrong number (physics §4.2).

Before a VRE leaves the reduction, the record is held against the mistakes labs make. Each check
reads a short stretch (at most :data:`PROBE_SAMPLES` samples) from the middle of each segment, so
it costs little and its memory does not grow with the record:

* **units or sensitivity slip** (:func:`check_units`): the DUT's vibration against the
  reference's, per level, where a DUT's response is flat: at the drive line for a sine level,
  over the lowest lines holding a tenth of the reference's in-band power for a random level (a
  DUT's low-pass or resonance shapes the top of the band, not its bottom). A ratio beyond :data:`UNIT_RATIO_LIMIT` (or below its
  inverse) at every level means a unit or a sensitivity is wrong.
* **swapped channels** (:func:`check_channels`): a reference accelerometer (piezoelectric) has no
  DC response; a DUT whose axis lies along the shaker's in a 1 g field reads it. A reference
  reading a static field and a DUT reading none are the two channels swapped.
* **method** (:func:`resolve_methods`): a sine level's reference spectrum
  is one line holding nearly all the in-band power, a random level's is broad. ``auto`` decides
  per level; an explicit method that contradicts the data is refused with what was found.

Each check raises ``ValueError`` with one line naming what was found and the option that
accepts it on purpose; nothing here changes a number.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable, Literal, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import G0
from vrelab.record import Record
from vrelab.results import Method

MethodRequest = Literal["auto", "random", "sine"]

# Samples read from the middle of each level (2^13: 1 s at 8 kHz, a 1 Hz line spacing, which
# resolves a drive from the test band's bottom (tens of Hz) upwards, for a few per cent of the
# reading the reduction itself does).
PROBE_SAMPLES = 1 << 13
# DUT/reference rms ratio beyond which (or below whose inverse) a level's units look wrong:
# physics §4.2. A flat-responding DUT agrees with the reference within a few per cent; a slip is a
# factor of 9.81 (m/s² vs g), 10-1000 (mV vs g), 1e3 or more (LSB vs g).
UNIT_RATIO_LIMIT = 3.0
# Fraction of the reference's in-band AC power in its strongest line (the peak bin ± the Hann
# window's main lobe) above which a level is a sine, below which it is random. A sine with
# harmonic distortion of a few per cent keeps > 0.99; a broadband random level gives ~ 1e-3.
SINE_LINE_FRACTION = 0.9
RANDOM_LINE_FRACTION = 0.5
# Share of a random level's in-band reference power, from the bottom of its band, over which the
# DUT is compared with the reference (units check).
LOW_POWER_SHARE = 0.1
# Hann main lobe: ± 2 bins; one more for a frequency between bins.
_LINE_HALF_WIDTH_BINS = 3
# |DC| of a reference [g] that reads as a static field (a 1 g field, or a tilted axis by more
# than 30°), and the fraction of it below which the DUT reads "none".
STATIC_FIELD_G = 0.5
_DUT_STATIC_FRACTION = 0.25


@dataclass(frozen=True)
class SegmentProbe:
    """What a short look at one segment shows (amplitudes in the record's units, g)."""

    start_s: float
    end_s: float
    peak_hz: float  # the reference's strongest in-band line
    line_fraction: float  # share of the reference's in-band AC power in that line
    ref_rms_g: float  # reference AC rms where the DUT should be flat (see module notes)
    dut_rms_g: float  # DUT AC rms over the same frequencies
    ref_dc_g: float
    dut_dc_g: float
    # the frequency the units ratio was measured at: the line for a sine, the reference-power
    # weighted mean frequency of the low lines compared for a random level
    ratio_hz: float = math.nan

    @property
    def kind(self) -> Method | None:
        """``"sine"``, ``"random"``, or ``None`` when the spectrum is neither clearly."""
        if self.line_fraction >= SINE_LINE_FRACTION:
            return "sine"
        if self.line_fraction <= RANDOM_LINE_FRACTION:
            return "random"
        return None

    @property
    def unit_ratio(self) -> float:
        """DUT/reference rms where both should agree (NaN without reference vibration)."""
        return self.dut_rms_g / self.ref_rms_g if self.ref_rms_g > 0 else math.nan


def _window(record: Record, start_s: float, end_s: float, max_samples: int) -> tuple[int, int]:
    """The stretch a probe reads: the middle ``max_samples`` samples of the segment."""
    fs = float(record.fs_hz)
    i0 = max(0, int(math.ceil(start_s * fs)))
    i1 = min(int(record.n_samples), int(math.floor(end_s * fs)))
    if i1 - i0 < 16:
        raise ValueError(f"segment {start_s:.4g}-{end_s:.4g} s holds {max(i1 - i0, 0)} samples: too short to check")
    if i1 - i0 > max_samples:
        mid = (i0 + i1) // 2
        i0, i1 = mid - max_samples // 2, mid - max_samples // 2 + max_samples
    return i0, i1


def probe_segments(
    record: Record,
    dut: str,
    reference: str,
    segments: Sequence[tuple[float, float]],
    band_hz: tuple[float, float],
    max_samples: int = PROBE_SAMPLES,
) -> list[SegmentProbe]:
    """:func:`probe_segment` for each ``(start_s, end_s)``. A record read in one direction only
    (``record.random_access`` False: a CSV file, which must be parsed from its start) is read in
    one pass over all the probes' stretches, not once per probe."""
    if getattr(record, "random_access", True):
        return [probe_segment(record, dut, reference, a, b, band_hz, max_samples) for a, b in segments]
    windows = [_window(record, a, b, max_samples) for a, b in segments]
    if not windows:
        return []
    chans = [dut] if reference == dut else [dut, reference]
    lo, hi = min(w[0] for w in windows), max(w[1] for w in windows)
    parts: list[dict[str, list[NDArray[np.float64]]]] = [{c: [] for c in chans} for _ in windows]
    pos = lo
    for blk in record.blocks(max_samples, chans, lo, hi):
        m = len(blk[chans[0]])
        for (i0, i1), part in zip(windows, parts):
            a, b = max(i0, pos), min(i1, pos + m)
            if b > a:
                for c in chans:
                    part[c].append(np.asarray(blk[c][a - pos : b - pos], dtype=np.float64))
        pos += m
    return [
        _probe_arrays(record.fs_hz, seg[0], seg[1], np.concatenate(part[dut]), np.concatenate(part[reference]), band_hz)
        for seg, part in zip(segments, parts)
    ]


def probe_segment(
    record: Record,
    dut: str,
    reference: str,
    start_s: float,
    end_s: float,
    band_hz: tuple[float, float],
    max_samples: int = PROBE_SAMPLES,
) -> SegmentProbe:
    """Look at the middle of one segment: the reference's spectrum, both channels' DC and rms.

    At most ``max_samples`` samples are read (one block). The spectrum is a Hann-windowed
    periodogram; a level's line fraction is the power in its strongest line (± 3 bins) over all
    its AC power (a sine below or above the test band is still a sine). The rms compared for
    units is taken at the line (±3 bins) when the level is a sine, else over the lowest in-band
    lines holding :data:`LOW_POWER_SHARE` of the reference's power.
    """
    i0, i1 = _window(record, start_s, end_s, max_samples)
    chans = [dut] if reference == dut else [dut, reference]
    block = next(iter(record.blocks(i1 - i0, chans, i0, i1)))
    return _probe_arrays(record.fs_hz, start_s, end_s, np.asarray(block[dut], dtype=np.float64),
                         np.asarray(block[reference], dtype=np.float64), band_hz)


@functools.lru_cache(maxsize=8)
def _probe_grid(n: int, fs: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(Hann window, rfft frequencies) of a probe of n samples at ``fs`` [Hz]: every level's probe
    of a record has the same length (a 2 h record's 120 probes each built the window anew).
    Read-only: shared between probes."""
    win, freqs = np.hanning(n), np.asarray(np.fft.rfftfreq(n, 1.0 / fs), dtype=np.float64)  # (no copy)
    win.flags.writeable = freqs.flags.writeable = False
    return win, freqs


def _probe_arrays(
    fs_hz: float, start_s: float, end_s: float, x_dut: NDArray[np.float64], x_ref: NDArray[np.float64],
    band_hz: tuple[float, float],
) -> SegmentProbe:
    fs = float(fs_hz)
    n = x_dut.size
    ref_dc, dut_dc = float(np.mean(x_ref)), float(np.mean(x_dut))
    win, freqs = _probe_grid(n, fs)
    p_ref = np.abs(np.fft.rfft((x_ref - ref_dc) * win)) ** 2
    p_dut = np.abs(np.fft.rfft((x_dut - dut_dc) * win)) ** 2
    f1, f2 = band_hz
    # A sine is one line wherever it is (a drive below the test band too): classify over the
    # whole spectrum but the mean's own main lobe; compare units in the band. The bins are
    # contiguous runs (the frequencies rise with the index), taken as slices.
    ac = slice(_LINE_HALF_WIDTH_BINS + 1, None)
    total_ac = float(p_ref[ac].sum())
    if total_ac <= 0:
        return SegmentProbe(start_s, end_s, math.nan, 0.0, 0.0, 0.0, ref_dc, dut_dc)
    k_peak = ac.start + int(np.argmax(p_ref[ac]))
    line = slice(max(0, k_peak - _LINE_HALF_WIDTH_BINS), k_peak + _LINE_HALF_WIDTH_BINS + 1)
    fraction = float(p_ref[line].sum()) / total_ac
    lo = max(ac.start, int(np.searchsorted(freqs, f1, side="left")))
    hi = int(np.searchsorted(freqs, f2, side="right"))
    ratio_hz = float(freqs[k_peak])
    sel = line
    if not (fraction >= SINE_LINE_FRACTION or hi <= lo or float(p_ref[lo:hi].sum()) <= 0):
        # the bottom of the reference's own band: the lowest in-band lines holding a tenth of
        # its power (at least 8 lines), where a DUT's low-pass or resonance has not yet acted
        total = float(p_ref[lo:hi].sum())
        n_low = max(8, int(np.searchsorted(np.cumsum(p_ref[lo:hi]), LOW_POWER_SHARE * total)) + 1)
        sel = slice(lo, min(lo + n_low, hi))
        ratio_hz = float((freqs[sel] * p_ref[sel]).sum() / p_ref[sel].sum()) if p_ref[sel].sum() > 0 else ratio_hz
    ref_rms = math.sqrt(float(p_ref[sel].sum()))
    dut_rms = math.sqrt(float(p_dut[sel].sum()))
    return SegmentProbe(start_s, end_s, float(freqs[k_peak]), fraction, ref_rms, dut_rms, ref_dc, dut_dc, ratio_hz)


def resolve_methods(requested: MethodRequest, probes: Sequence[SegmentProbe], accept: bool = False) -> list[Method]:
    """The method to reduce each level with.

    ``auto``: what each level shows; a level that is neither clearly a sine nor random is
    refused (name ``--method`` to decide). An explicit method is refused when a level clearly
    shows the other one, unless ``accept`` (the user insists on purpose).
    """
    if requested not in ("auto", "random", "sine"):
        raise ValueError(f"method must be one of auto, random, sine; got {requested!r}")
    out: list[Method] = []
    for p in probes:
        kind = p.kind
        if requested == "auto":
            if kind is None:
                raise ValueError(
                    f"level {p.start_s:.4g}-{p.end_s:.4g} s: the reference's strongest line ({p.peak_hz:.4g} Hz) holds "
                    f"{100 * p.line_fraction:.0f} % of the in-band power, neither a sine nor a random level: "
                    "give --method sine or --method random"
                )
            out.append(kind)
            continue
        if kind is not None and kind != requested and not accept:
            found = (
                f"one line at {p.peak_hz:.4g} Hz holding {100 * p.line_fraction:.0f} % of the in-band power"
                if kind == "sine"
                else f"a broadband spectrum (its strongest line, {p.peak_hz:.4g} Hz, holds {100 * p.line_fraction:.1f} % of the power)"
            )
            raise ValueError(
                f"--method {requested} does not fit the record: level {p.start_s:.4g}-{p.end_s:.4g} s shows {found}, "
                f"a {kind} level; use --method auto (or {kind}), or --accept-method to insist"
            )
        out.append(requested)
    return out


def _flat_ratios(probes: Sequence[tuple[str | None, float, float]]) -> list[float] | None:
    """DUT/reference ratios where a flat DUT's response is flat, from (kind, peak_hz, ratio) of
    each level: the sine levels at the lowest drive frequency (the likeliest to lie in the DUT's
    flat band: filters attenuate and resonances amplify above it), else every level. None when a
    level of those has no ratio (no reference vibration): nothing can be judged."""
    sines = [p for p in probes if p[0] == "sine"]
    if sines:
        f_low = min(p[1] for p in sines)
        probes = [p for p in sines if p[1] <= 1.01 * f_low]
    ratios = [p[2] for p in probes if math.isfinite(p[2]) and p[2] > 0]
    if not ratios or len(ratios) < len(probes):
        return None
    return ratios


def _is_slip(ratios: Sequence[float]) -> bool:
    limit = UNIT_RATIO_LIMIT
    return all(r > limit or r < 1.0 / limit for r in ratios)


def check_units(probes: Sequence[SegmentProbe], dut: str, reference: str, accept: bool = False) -> None:
    """Refuse when the DUT/reference rms ratio is beyond :data:`UNIT_RATIO_LIMIT` at every level
    (for sine levels: at every level of the lowest drive frequency, the likeliest to lie in the
    DUT's flat band; a record whose frequencies all lie above the DUT's bandwidth can trip it,
    and ``accept`` passes it on purpose). A campaign judges a channel over all its runs instead
    (:func:`check_units_over_runs`)."""
    if accept or not probes:
        return
    ratios = _flat_ratios([(p.kind, p.peak_hz, p.unit_ratio) for p in probes])
    if ratios and _is_slip(ratios):
        med = float(np.median(ratios))
        raise ValueError(
            f"DUT '{dut}' and reference '{reference}' vibration rms differ by a factor of {med:.3g} "
            f"(DUT/reference, median over {len(ratios)} level(s); a flat DUT agrees within a few per cent): "
            "check --dut-units/--dut-sensitivity and --reference-units/--reference-sensitivity, "
            "or --accept-unit-ratio to accept it"
        )


def check_units_over_runs(channel: str, probes: Sequence[tuple[str | None, float, float]]) -> str | None:
    """A campaign's units check of one DUT channel over every level of every run: the refusal
    (a message) or None.

    A unit or sensitivity slip is a constant factor (9.81, 1000, a sensitivity) on every run of
    a channel; a resonance's gain depends on frequency. So the channel is judged where its
    response is flat: the levels at the lowest drive frequency of all its runs (a sine sweep's
    run at the resonance, where DUT/reference rises to Q, is then not a slip). ``probes`` are
    (kind, peak_hz, DUT/reference ratio) of each level (:attr:`Reduction.unit_probes`).
    """
    ratios = _flat_ratios(probes)
    if not ratios or not _is_slip(ratios):
        return None
    med = float(np.median(ratios))
    sines = [p[1] for p in probes if p[0] == "sine"]
    where = f"at its lowest drive frequency {min(sines):.4g} Hz" if sines else "at every level"
    return (f"DUT channel '{channel}' and the reference differ by a factor of {med:.3g} {where} over the "
            f"campaign's runs (median of {len(ratios)} level(s); a flat DUT agrees within a few per cent): check "
            "the run's dut_units/dut_sensitivity and reference_units/reference_sensitivity")


# How far a DUT's response may depart from flat, as a DUT/reference rms ratio, when no sensor file
# gives it: a second-order resonance's |H(fn)| is Q (physics §1.3; the VRC, a mean of the square, rises
# by Q²), and the units check allows a resonance of Q up to this (the mounted resonance of an
# undamped piezoelectric accelerometer rises by about 30 dB; a gas-damped MEMS part's Q is a few),
# and as much attenuation above a low-pass. A stated default, not a measurement: give the campaign
# a sensor file (its `sensor` key) and the check holds each run to that sensor's own response.
DEFAULT_Q_MAX = 30.0
# A DUT at rest reads its static field (|g0| <= 1 g) plus an offset well inside its range; a
# vibration-off reading beyond this many times the DUT's range (two orders of magnitude) is a
# unit slip (LSB read as g: 256 000 g for a ±2 g part at 1 g), whatever the static field declared.
OFF_READING_RANGE_FACTOR = 100.0
# The DUT's range when neither a sensor file nor the run's rail_g gives it: the largest of the
# accelerometers VRE is measured on (navigation to industrial MEMS parts, ±2 g to ±200 g).
DEFAULT_RANGE_G = 200.0

UnitProbe = tuple[str | None, float, float]  # (kind, frequency [Hz], DUT/reference ratio) of a level


def run_units_ratio(probes: Sequence[UnitProbe]) -> tuple[str | None, float, float] | None:
    """One run's DUT/reference ratio where its DUT should be flattest, (kind, frequency [Hz],
    ratio): the median over its levels at its lowest sine frequency (every level for a random
    run, at their mean frequency). None when a level there has no ratio: nothing to judge."""
    ratios = _flat_ratios(probes)
    if not ratios:
        return None
    sines = [p for p in probes if p[0] == "sine"]
    kind = "sine" if sines else probes[0][0]
    freqs = [p[1] for p in (sines or probes) if math.isfinite(p[1])]
    f = min(freqs) if sines else (float(np.mean(freqs)) if freqs else math.nan)
    return kind, f, float(np.median(ratios))


def judge_runs_units(channel: str, runs: Sequence[tuple[int, Sequence[UnitProbe]]],
                     gain: Callable[[float], float] | None = None) -> dict[int, str]:
    """physics §4.1's units check of one DUT channel, run by run: {run index: the refusal}.

    A unit or sensitivity slip is a factor on one run's readings (mV read as V: 1000; LSB read as
    g: the sensitivity); a resonance's gain depends on frequency only. Each run's DUT/reference
    ratio ρ (:func:`run_units_ratio`) is divided by what the DUT's response gives at that
    frequency, ``gain(f)`` = |H(f)| from a sensor file, else 1 (flat); of that n = ρ/|H(f)|:

    * **against the response**: n beyond :data:`UNIT_RATIO_LIMIT` (either way) with a sensor
      file; without one, beyond ``UNIT_RATIO_LIMIT × DEFAULT_Q_MAX`` (a run at a resonance of Q
      up to :data:`DEFAULT_Q_MAX`, or as far down a low-pass, is no slip);
    * **against the channel's other runs**: n more than :data:`UNIT_RATIO_LIMIT` times off the
      median m of the other runs' n (with a sensor file, every other run: n is normalised by
      the response; without one, the other runs at the same frequency, whose response is the
      run's own), and further from the response than they are (|ln n| > |ln m|: of two runs
      that disagree, the one the response does not explain is the slip).

    ``runs`` are (run index, that run's level probes), those of a mount-angle run already
    divided by its |cos φ|. Without a sensor file, a slip smaller than the resonance allowance
    on a run whose frequency no other run shares cannot be told from a resonance, and passes
    (the channel-wide :func:`check_units_over_runs` still sees a slip common to all runs).
    """
    from vrelab.results import same_frequency

    limit = UNIT_RATIO_LIMIT
    allow = limit if gain is not None else limit * DEFAULT_Q_MAX
    judged: list[tuple[int, str | None, float, float, float]] = []  # (run, kind, f, ratio, n)
    for index, probes in runs:
        r = run_units_ratio(probes)
        if r is None:
            continue
        kind, f, ratio = r
        h = gain(f) if gain is not None and math.isfinite(f) else 1.0
        if not (math.isfinite(h) and h > 0):
            continue
        judged.append((index, kind, f, ratio, ratio / h))

    def where(f: float, kind: str | None) -> str:
        return f"at {f:.4g} Hz" if kind == "sine" else f"in the bottom of its random band (~{f:.4g} Hz)"

    fix = ("a unit or sensitivity slip (mV read as V, LSB read as g): check this run's dut_units/dut_sensitivity "
           "and reference_units/reference_sensitivity")
    out: dict[int, str] = {}
    for index, kind, f, ratio, n in judged:
        if n > allow or n < 1.0 / allow:
            bound = (f"the sensor file's response gives {ratio / n:.3g} there (a run may differ from it by a factor of "
                     f"{limit:g} either way)" if gain is not None else
                     f"no response explains a factor beyond {allow:g} either way (a resonance of Q up to "
                     f"{DEFAULT_Q_MAX:g}, times {limit:g}; a sensor file in the manifest's `sensor` key holds the run "
                     "to that sensor's own response)")
            out[index] = (f"units check: DUT channel {channel!r} reads {ratio:.4g} times the reference {where(f, kind)} "
                          f"in this run, and {bound}: {fix}")
    kept = [j for j in judged if j[0] not in out]
    for index, kind, f, ratio, n in kept:
        peers = [p for p in kept if p[0] != index and (gain is not None or (
            p[1] == kind == "sine" and same_frequency(p[2], f)))]
        if not peers:
            continue
        m = float(np.median([p[4] for p in peers]))
        if abs(math.log(n / m)) > math.log(limit) and abs(math.log(n)) > abs(math.log(m)):
            others = ", ".join(str(p[0]) for p in peers)
            what = ("the channel's other runs (run(s) " + others + "), each divided by the sensor file's response"
                    if gain is not None else f"the channel's other run(s) at that frequency (run(s) {others})")
            out[index] = (f"units check: DUT channel {channel!r} reads {ratio:.4g} times the reference {where(f, kind)} "
                          f"in this run, {n / m:.4g} times the median of {what}: {fix}")
    return out


def off_reading_slip(channel: str, reading_g: float | None, range_g: float | None, range_from: str) -> str | None:
    """The refusal when a DUT's vibration-off reading [g] lies beyond
    :data:`OFF_READING_RANGE_FACTOR` times its range (``range_g``, from ``range_from``; None: the
    :data:`DEFAULT_RANGE_G`): a unit slip whatever the static field declared; else None."""
    if reading_g is None or not math.isfinite(reading_g):
        return None
    if range_g is None:
        range_g, range_from = DEFAULT_RANGE_G, "the largest range VRE is measured on, no sensor file or rail_g giving it"
    if abs(reading_g) <= OFF_READING_RANGE_FACTOR * range_g:
        return None
    return (f"units check: DUT channel {channel!r} reads {reading_g:+.4g} g with vibration off, "
            f"{abs(reading_g) / range_g:.3g} times its range of ±{range_g:g} g ({range_from}): a part at rest reads "
            "its static field within its range, so this is a unit slip (LSB read as g, mV read as V): check this "
            "run's dut_units and dut_sensitivity")


# 1 g in m/s²: a channel read as g for want of a stated unit whose vibration-off baseline lies
# within 10 % of this reads m/s². No static test puts 8.8-10.8 g on an axis: the field is at
# most 1 g, and a tilt, an offset or a part's zero-g error moves that by a fraction of a g.
_MS2_BAND = (0.9 * G0, 1.1 * G0)


def check_assumed_g(baseline_dc_g: Sequence[float], channel: str, assumed: bool, option: str = "--dut-units") -> None:
    """Refuse a channel whose unit was assumed (the file states none: read as g) when its
    vibration-off baselines read 1 g in m/s² (9.81 "g"): a unit slip, never a static field."""
    if not assumed or not len(baseline_dc_g):
        return
    dc = float(np.mean(baseline_dc_g))
    if _MS2_BAND[0] <= abs(dc) <= _MS2_BAND[1]:
        raise ValueError(
            f"DUT {channel!r} reads {dc:+.4g} with vibration off, taken as g because the file states no unit: "
            f"no static field is {abs(dc):.3g} g, and {dc:+.4g} m/s² is {dc / G0:+.3g} g: give {option} m/s2 "
            f"(or {option} g if it is g)"
        )


def check_channels(baselines: Sequence[SegmentProbe], dut: str, reference: str, accept: bool = False) -> None:
    """Refuse when the reference reads a static field and the DUT none (channels swapped)."""
    if accept or not baselines or reference == dut:
        return
    ref_dc = float(np.mean([b.ref_dc_g for b in baselines]))
    dut_dc = float(np.mean([b.dut_dc_g for b in baselines]))
    if abs(ref_dc) >= STATIC_FIELD_G and abs(dut_dc) < _DUT_STATIC_FRACTION * abs(ref_dc):
        raise ValueError(
            f"reference '{reference}' reads a static field of {ref_dc:+.3g} g with vibration off and the DUT "
            f"'{dut}' {dut_dc:+.3g} g: a reference accelerometer has no DC response, so the channels look "
            "swapped (check --dut and --reference), or --accept-channels to accept it"
        )
