"""Triaxial recordings reduced per axis (physics §1.6, §4): a triaxial reference and up to three DUT axes.

Each DUT axis is reduced as one axis is today (:func:`vrelab.analysis.analyze_full`: baselines,
offset shift under vibration, batch-means uncertainty), against the reference channel of its own
axis, so the DUT/reference ratio check compares like with like. When that reference axis is
still (its rms under a tenth of the most moving axis's), the levels are read from the most
moving axis instead and the ratio check, which would then compare two axes, is skipped: said in
the channel's warnings.

Every DUT axis uses the same segments: found once from the most moving reference axis (or the
given or embedded schedule), so a still axis still has its levels.

The level of a triaxial vibration is its **total rms** (TRIAXIAL.md, physics §1.6), one number per
level for every DUT axis and for ``triaxial.levels``: the level the reduction reads from the
most moving reference axis ``d`` (the single-axis rule: the window FFTs' in-band power, its
batch-means u; the lock-in at the drive frequency for a sine) times ``sqrt(Σ_j m_j / m_d)``,
``m_j`` each reference axis's mean square in the band by the same window rule over the same
windows (:func:`_band_power`; at the drive line of the level's Welch cross-spectrum for a
sine). It is thus ``sqrt(Σ_j level_j²)`` of the three single-axis levels (to rounding), and
along one axis exactly the single-axis level; ``axis_rms_g`` is the total times
``sqrt(m_j / Σ m)``. ``u`` of the total: ``u(level_d)`` times the ratio: exact for a drive
along one direction (the axes' powers move together), conservative for incoherent axes (their
independent scatter partly averages out in the sum). The Welch band integral of the reported
cross-spectrum (``csd.rms_g``) is the spectrum's, not the level: its segments, sized for
the spectrum's resolution, may be few over a short level and weigh its samples unevenly (one
1 s Hann segment over a 1.5 s level: 1-8 % off the level, measured). The measured
cross-spectral matrix of each level (PSDs, coherences, phases, their uncertainty and number of
averages, :mod:`vrelab.triaxial.recording`) is reported.

The VRE of each axis and its u are the single-axis reduction's (:func:`vrelab.analysis.analyze_full`):
its u is the batch means of the DUT's smoothed window series when a level holds
``BATCH_WINDOWS`` (10) interior windows or more (a window is 0.1 s, or ``2/F1`` for a band
starting below 20 Hz); a shorter level (or baseline) has the scatter of its few smoothed windows
under their known correlation, with its few degrees of freedom (``dof``: ~4 for 8 windows), so
U = k(dof)·u covers (:func:`vrelab.analysis.levels.dut_mean_estimate`); a level of fewer than 3
interior windows, whose u is not calibrated, carries the single-axis flag ``few-windows`` and
its notice (:func:`vrelab.analysis.levels.few_windows`). Coverage:
tests/test_triaxial_analyze_coverage.py (±u 0.70, ±2u 0.955 over 800 draws of 13 interior windows).
:func:`vrelab.simulate` reduces a triaxial test's record through this module's
:func:`reduce_triaxial`, the triaxial case of :func:`vrelab.analyze` (:func:`analyze_triaxial`
its deprecated alias).

Fits: the VRC of each DUT axis against the total rms (``VRE = VRC·rms²`` holds for any quadratic
mechanism, cross terms included, when one shape is scaled). The clipping rail is **not** fitted:
an axis's rail sees the vibration sensed along that axis, not the total, and a rail fitted
against the total rms would be a confident wrong number; fit it from a single-axis run.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab._display import Shown
from vrelab.analysis.options import FitOptions, ReductionOptions
from vrelab.analysis.plausibility import MethodRequest
from vrelab.record import DEFAULT_SETTLE_S, WINDOW_S, ChannelView, Schedule, Segment
from vrelab.results import LevelResult, Notice, VreResult
from vrelab.triaxial.profile import AXES
from vrelab.triaxial.recording import CsdAccumulator, MeasuredCsd, band_csd, default_nperseg, record_blocks

__all__ = ["Caller", "TriaxialLevel", "analyze_triaxial", "reduce_triaxial"]

# A reference axis whose rms is under this fraction of the most moving axis's is still: its
# DUT axis's levels are read from the most moving axis.
STILL_FRACTION = 0.1
# Points per octave of the reported cross-spectrum of each level.
POINTS_PER_OCTAVE = 3.0


@dataclass(frozen=True, eq=False, repr=False)
class TriaxialLevel(Shown):
    """The reference's vibration at one level: total and per-axis rms [g] and its cross-spectrum.

    Examples
    --------
    One level of a triaxial reference: its time span, total and per-axis rms (here 1 g rms at 45°
    in x-z, as :func:`reduce_triaxial` would find it):

    >>> from vrelab.triaxial.analyze import TriaxialLevel
    >>> level = TriaxialLevel(2.0, 4.0, 1.0, (0.7071, 0.0, 0.7071), None)
    >>> print(f"{level.end_s - level.start_s:.1f} s at {level.rms_g:.1f} g rms", level.axis_rms_g)
    2.0 s at 1.0 g rms (0.7071, 0.0, 0.7071)
    """

    start_s: float
    end_s: float
    rms_g: float
    axis_rms_g: tuple[float, float, float]
    csd: MeasuredCsd | None  # random: the band-mean CSD; sine: None (see ``line``)
    line: Mapping[str, Any] | None = None  # sine: the drive line's amplitudes and phases
    u_rms_g: float | None = None  # u of rms_g (the module docstring)
    _SHOW = ("start_s", "end_s", "rms_g", "u_rms_g", "axis_rms_g")

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"start_s": self.start_s, "end_s": self.end_s, "rms_g": self.rms_g,
                             "u_rms_g": self.u_rms_g, "axis_rms_g": dict(zip(AXES, self.axis_rms_g))}
        if self.csd is not None:
            d["csd"] = self.csd.to_dict()
        if self.line is not None:
            d["line"] = dict(self.line)
        return d


def _ac_rms(record: Any, channels: Sequence[str], block: int) -> NDArray[np.float64]:
    """AC rms of each channel over the whole record (one streaming pass)."""
    s = np.zeros(len(channels))
    s2 = np.zeros(len(channels))
    n = 0
    for b in record_blocks(record, channels, 0, None, block):
        s += b.sum(axis=0)
        s2 += (b * b).sum(axis=0)
        n += b.shape[0]
    mean = s / max(n, 1)
    return np.asarray(np.sqrt(np.maximum(s2 / max(n, 1) - mean * mean, 0.0)), dtype=np.float64)


def _band_power(record: Any, refs: Sequence[str], seg: Segment, band: tuple[float, float],
                block: int) -> NDArray[np.float64]:
    """Each reference axis's mean square [g²] in the band over a level, by the reduction's own
    rule (:func:`vrelab.analysis.segmentation.window_pass`: the level's whole windows, each
    window's rfft weighed by :func:`~vrelab.analysis.segmentation.band_weights`, the windows'
    in-band powers averaged), so that the ratio of two axes' is the ratio of their single-axis
    levels. Written here because the window pass reads one reference channel; streamed in
    blocks of whole windows."""
    from vrelab.analysis.segmentation import band_weights, window_length

    fs = float(record.fs_hz)
    w = window_length(fs, band)
    per = w / fs
    k0 = int(math.ceil(seg.start_s / per - 1e-9))
    k1 = min(int(math.floor(seg.end_s / per + 1e-9)), record.n_samples // w)
    if k1 <= k0:
        return np.zeros(3)
    weights = band_weights(w, fs, band)[1]
    total = np.zeros(3)
    for b in record_blocks(record, refs, k0 * w, k1 * w, max(1, block // w) * w):
        spec = np.fft.rfft(b.T.reshape(3, -1, w), axis=2)
        total += ((spec.real ** 2 + spec.imag ** 2) @ weights).sum(axis=1)
    return np.asarray(total / ((k1 - k0) * w), dtype=np.float64)


def _reference_level(record: Any, refs: Sequence[str], seg: Segment, band: tuple[float, float],
                     freq_hz: float | None, block: int) -> tuple[NDArray[np.float64], TriaxialLevel]:
    """(mean square per axis [g²] in the band or at the line, the level's TriaxialLevel)."""
    from vrelab.analysis.levels import segment_samples

    fs = record.fs_hz
    i0, i1 = segment_samples(seg, fs, record.n_samples)
    if freq_hz is None:
        nper = default_nperseg(fs, band, POINTS_PER_OCTAVE)
    else:  # a sine: about 1 Hz resolution, the line summed over its bins
        nper = int(min(2 ** round(math.log2(fs)), 1 << 14))
    nper = max(8, min(nper, 2 ** int(math.log2(max(i1 - i0, 16)))))
    acc = CsdAccumulator(fs, nper)
    for b in record_blocks(record, refs, i0, i1, block):
        acc.add(b)
    s = acc.csd
    f = acc.freq_hz
    df = fs / nper
    if freq_hz is None:
        ms = _band_power(record, refs, seg, band, block)
        csd = band_csd(acc, band, POINTS_PER_OCTAVE)
        total = math.sqrt(float(ms.sum()))
        return ms, TriaxialLevel(seg.start_s, seg.end_s, total, (*map(float, np.sqrt(ms)),), csd)  # type: ignore[arg-type]
    sel = np.abs(f - freq_hz) <= max(3 * df, 0.02 * freq_hz)
    line = s[sel].sum(axis=0) * df
    ms = np.real(np.diagonal(line)).copy()
    total = math.sqrt(float(ms.sum()))
    phases = {AXES[j] + AXES[k]: (float(np.degrees(np.angle(line[j, k]))) if ms[j] > 0 and ms[k] > 0 else None)
              for j, k in ((0, 1), (0, 2), (1, 2))}
    info = {"freq_hz": freq_hz, "phase_deg": phases,
            "note": "the line's cross-spectrum summed over its Welch bins; phase positive when the second axis lags"}
    return ms, TriaxialLevel(seg.start_s, seg.end_s, total, (*map(float, np.sqrt(ms)),), None, info)  # type: ignore[arg-type]


Known = Callable[[str, list[LevelResult], list[Any]], tuple[list[LevelResult], list[Any]]]


@dataclass(frozen=True)
class Caller:
    """What the caller adds to a triaxial reduction.

    ``provenance``: added to every axis's result (as :func:`vrelab.analysis.analyze_full`
    does). ``known(axis, levels, warnings) -> (levels, warnings)``: what the caller knows better
    than the record shows, applied to each axis's reduced levels before the level and the fits
    (a simulation's saturation counts and a sine lattice's error,
    :func:`vrelab.triaxial.simulate.run_triaxial_test`).

    Examples
    --------
    What a caller adds to a triaxial reduction: provenance (and, for a simulation, what it knows
    better than the record):

    >>> from vrelab.triaxial.analyze import Caller
    >>> caller = Caller({"operator": "example"})
    >>> caller.provenance, caller.known
    ({'operator': 'example'}, None)
    """

    provenance: Mapping[str, Any] | None = None
    known: Known | None = None


# analyze_triaxial's former parameters after (record, reference, duts), in order
_FORMER = ("method", "schedule", "band_hz", "settle_s", "block_size", "rail_g", "fit_k4", "accept", "progress",
           "provenance", "known")


def analyze_triaxial(record: Any, reference: Mapping[str, str], duts: Mapping[str, str], *args: Any,
                     **keywords: Any) -> VreResult:
    """Deprecated alias of :func:`vrelab.analyze` with a triaxial reference (one release), bit for bit.

    ``analyze_triaxial(record, reference, duts, method, schedule, band_hz, settle_s, block_size,
    rail_g, fit_k4, accept, progress, provenance, known)`` is ``vrelab.analyze(record, dut=duts,
    reference=reference, method=method, schedule=schedule, options=ReductionOptions(band_hz=...,
    settle_s=..., rail_g=..., accept=..., block_size=..., progress=...), fit=FitOptions(k4=fit_k4),
    provenance=provenance)``.
    """
    import warnings

    from vrelab.analysis.options import FitOptions, ReductionOptions

    warnings.warn("analyze_triaxial() is deprecated and will be removed in the next release: call "
                  "vrelab.analyze(record, dut={axis: channel}, reference=(x, y, z), options=ReductionOptions(...))",
                  DeprecationWarning, stacklevel=2)
    if len(args) > len(_FORMER):
        raise TypeError(f"analyze_triaxial() takes at most {len(_FORMER) + 3} positional arguments")
    given = {**dict(zip(_FORMER, args)), **keywords}
    unknown = sorted(set(given) - set(_FORMER))
    if unknown:
        raise TypeError(f"analyze_triaxial() got an unexpected keyword argument {unknown[0]!r}")
    k = {"method": "auto", "schedule": None, "band_hz": None, "settle_s": DEFAULT_SETTLE_S, "block_size": 1 << 18,
         "rail_g": None, "fit_k4": False, "accept": (), "progress": False, **given}
    options = ReductionOptions(band_hz=k["band_hz"], settle_s=k["settle_s"], rail_g=k["rail_g"],
                               accept=frozenset(k["accept"]), block_size=k["block_size"], progress=k["progress"])
    return reduce_triaxial(record, reference, duts, k["method"], k["schedule"], options=options,
                           fit=FitOptions(k4=k["fit_k4"]), caller=Caller(k.get("provenance"), k.get("known")))


def _check_channels(record: Any, reference: Mapping[str, str], duts: Mapping[str, str]) -> list[str]:
    """The reference's channels in x, y, z order, once the record is seen to hold every channel named."""
    if sorted(reference) != list(AXES):
        raise ValueError(f"a triaxial reference needs three channels x, y, z, got {sorted(reference)!r}")
    if not duts or set(duts) - set(AXES):
        raise ValueError(f"DUT axes must be some of x, y, z, got {sorted(duts)!r}")
    for name, ch in {**{f"reference {a}": c for a, c in reference.items()},
                     **{f"DUT {a}": c for a, c in duts.items()}}.items():
        if ch not in record.channels:
            raise ValueError(f"{name}: record has no channel {ch!r}; channels: {', '.join(record.channels)}")
    refs = [reference[a] for a in AXES]
    if len(set(refs) | set(duts.values())) != len(refs) + len(duts):
        raise ValueError("the reference's and the DUT's channels must be distinct channels")
    return refs


def reduce_triaxial(
    record: Any,
    reference: Mapping[str, str],
    duts: Mapping[str, str],
    method: MethodRequest = "auto",
    schedule: Schedule | None = None,
    *,
    options: ReductionOptions | None = None,
    fit: FitOptions | None = None,
    caller: Caller | None = None,
) -> VreResult:
    """Reduce each DUT axis of a record with a triaxial reference (the module docstring): the
    triaxial case of :func:`vrelab.analyze`, which is the way to call it.

    Parameters
    ----------
    record : Record
        In g, holding the reference's three channels and the DUT axes' channels.
    reference : mapping "x", "y", "z" -> record channel
        All three axes.
    duts : mapping axis ("x", "y" or "z") -> record channel
        One to three DUT axes, named by the axis of the reference they are reduced against.
    method, schedule, options
        As :func:`vrelab.analysis.analyze_full` (``options``: band, settling trim, rail, checks
        accepted on purpose, block size, progress).
    fit : FitOptions, optional
        ``k4`` only: the VRC is fitted against the total rms; no rail is fitted (the module docstring).
    caller : Caller, optional
        The results' provenance and what the caller knows better than the record shows.

    Examples
    --------
    A simulated triaxial test written as a lab file (its DUT's z axis and the reference's three
    axes), reduced as a recorded one through :func:`vrelab.analyze`, which calls this:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000"), (1, 0, 1))
    >>> _ = vrelab.simulate(sensor, tri, [1.0], (0, 0, 1), seconds=2, seed=1, record_path="tri.h5")
    >>> from vrelab.analysis.readers import list_channels
    >>> [channel["name"] for channel in list_channels("tri.h5")["channels"]]
    ['dut_z', 'reference_x', 'reference_y', 'reference_z']
    >>> analysis = vrelab.analyze("tri.h5", dut={"z": "dut_z"}, reference=("reference_x", "reference_y", "reference_z"))
    >>> type(analysis).__name__, list(analysis.axes), [f"{g:.2f}" for g in analysis.reference_levels[0].axis_rms_g]
    ('VreResult', ['z'], ['0.71', '0.00', '0.71'])
    >>> level = analysis.levels[0]  # the one DUT axis's (analysis.axes["z"].levels[0])
    >>> print(f"{level.rms_g:.2f} g rms: VRE {level.vre.value * 1e3:.1f} ± {level.vre.u * 1e3:.1f} mg")
    1.01 g rms: VRE -4.1 ± 0.2 mg
    """
    from vrelab.analysis.options import FitOptions, ReductionOptions, default_band
    from vrelab.analysis.segmentation import auto_segment, window_pass
    from vrelab.triaxial.result import TriaxialPart

    options = ReductionOptions() if options is None else options
    fit = FitOptions() if fit is None else fit
    caller = Caller() if caller is None else caller
    refs = _check_channels(record, reference, duts)
    band = default_band(float(record.fs_hz), options.band_hz, None)
    options = dataclasses.replace(options, band_hz=band)
    rms = _ac_rms(record, refs, options.block_size)
    if not rms.max() > 0:
        raise ValueError("the triaxial reference does not move (every axis reads a constant)")
    dom = int(np.argmax(rms))
    first = next(iter(duts.values()))
    if schedule is None and getattr(record, "schedule", None) is None:
        stats0 = window_pass(ChannelView(record, first, refs[dom]), band, WINDOW_S, options.block_size,
                             options.rail_g, options.progress)
        schedule, _ = auto_segment(stats0)

    def reduce_pair(dut: str, r: int, acc: Sequence[str]) -> tuple[VreResult, Any]:
        from vrelab.analysis.pipeline import analyze_full

        return analyze_full(ChannelView(record, dut, refs[r]), method, schedule,
                            options=dataclasses.replace(options, accept=frozenset(acc)), provenance=caller.provenance)

    level_axis: dict[str, str] = {}
    reduced: list[tuple[str, VreResult, Any, list[LevelResult], list[Any], int]] = []
    for axis in (a for a in AXES if a in duts):
        j = AXES.index(axis)
        r = j if rms[j] >= STILL_FRACTION * rms[dom] else dom
        acc = list(options.accept)
        notes: list[Any] = []
        if r != j:
            acc = sorted(set(acc) | {"unit-ratio"})
            notes.append(Notice("triaxial", f"reference axis {axis} is still ({rms[j]:.3g} g rms against "
                                f"{rms[dom]:.3g} g on {AXES[dom]}): levels read from reference {AXES[dom]}, "
                                "the DUT/reference ratio check skipped (it would compare two axes)"))
        result, red = reduce_pair(duts[axis], r, acc)
        levels, warnings = list(result.levels), list(result.warnings) + notes
        if caller.known is not None:
            levels, warnings = caller.known(axis, levels, warnings)
        reduced.append((axis, result, red, levels, warnings, r))
        level_axis[axis] = AXES[r]
    # the level of each segment, one number for every axis: read from the most moving reference
    # axis (a DUT axis reduced against it, or the first DUT once more against it), made total
    # by the axes' in-band mean squares over the same windows (_band_power)
    own = next((red for *_, red, _, _, r in reduced if r == dom), None)
    if own is None:  # read for its levels only: the DUT's own checks ran against its own axis
        _, own = reduce_pair(first, dom, sorted(set(options.accept) | {"unit-ratio", "channels"}))
    levels_out, totals = _total_levels(record, refs, own, dom, band, options.block_size)
    channels = [_axis_channel(item[:5], totals, fit.k4, AXES[dom], level_axis[item[0]]) for item in reduced]
    part = TriaxialPart(tuple(levels_out.values()), dict(reference), AXES[dom], level_axis,
                        {name: red for name, _, red in channels})
    return VreResult.of_axes({name: result for name, result, _ in channels}, provenance=caller.provenance or {},
                             triaxial=part)


def __getattr__(name: str) -> Any:
    """The former result class, one release (its import warns: :mod:`vrelab.triaxial.result`)."""
    if name == "TriaxialAnalysis":
        from vrelab.triaxial.result import former_class

        return former_class(__name__, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _total_levels(
    record: Any, refs: Sequence[str], own: Any, dom: int, band: tuple[float, float], block: int,
) -> tuple[dict[tuple[float, float], TriaxialLevel], dict[tuple[float, float], tuple[float, float | None]]]:
    """Per level (start, end): its TriaxialLevel and (total rms, its u), from the most moving
    reference axis's reduction ``own`` made total (the module docstring)."""
    dom_levels = {(seg.start_s, seg.end_s): lv for seg, lv in zip(own.level_segments, own.levels)}
    levels_out: dict[tuple[float, float], TriaxialLevel] = {}
    totals: dict[tuple[float, float], tuple[float, float | None]] = {}
    for key, lv in dom_levels.items():
        seg = next(s for s in own.level_segments if (s.start_s, s.end_s) == key)
        ms, info = _reference_level(record, refs, seg, band, lv.freq_hz, block)
        ratio = math.sqrt(float(ms.sum()) / float(ms[dom])) if ms[dom] > 0 else math.nan
        total = lv.rms_g * ratio
        u_total = None if lv.u_rms_g is None else lv.u_rms_g * ratio
        share = np.sqrt(ms / ms.sum()) if ms.sum() > 0 else np.full(3, math.nan)
        totals[key] = (total, u_total)
        levels_out[key] = dataclasses.replace(info, rms_g=total, u_rms_g=u_total,
                                              axis_rms_g=(*map(float, total * share),))  # type: ignore[arg-type]
    return levels_out, totals


def _axis_channel(
    reduced: tuple[str, VreResult, Any, list[LevelResult], list[Any]],
    totals: Mapping[tuple[float, float], tuple[float, float | None]], fit_k4: bool, level_axis: str,
    reduced_against: str,
) -> tuple[str, VreResult, Any]:
    """One DUT axis's result from its reduction ``(axis, result, reduction, levels, warnings)``:
    its levels at the total rms, the VRC fitted against it."""
    from vrelab.fits import fit_levels

    axis, result, red, levels, warnings = reduced
    new: list[LevelResult] = []
    for seg, lv in zip(red.level_segments, levels):
        total, u_total = totals.get((seg.start_s, seg.end_s), (math.nan, None))
        new.append(dataclasses.replace(lv, rms_g=total, u_rms_g=u_total))
    nominal = [seg.freq_hz for seg in red.level_segments]
    fits, w = fit_levels(new, red.method, None, fit_k4=fit_k4, nominal_freqs_hz=nominal)
    notes = [Notice("triaxial", "levels are the reference's total rms; the VRC is fitted against it; the "
                    "clipping rail is not fitted (an axis's rail sees the vibration along it, not the total)")]
    extra = {**result.conditions.extra, "level": "total rms of the triaxial reference",
             "level_axis": level_axis, "reduced_against": reduced_against}
    cond = dataclasses.replace(result.conditions, extra=extra)
    return (axis, dataclasses.replace(result, levels=tuple(new), fits=tuple(fits), conditions=cond,
                                      warnings=tuple(warnings) + tuple(w) + tuple(notes)), red)
