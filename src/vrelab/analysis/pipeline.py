"""Reduction of a recorded shaker test to VRE per level, and its fits (physics §4).

Steps, each over data streamed in blocks:

1. :func:`~vrelab.analysis.segmentation.window_pass`: per-window numbers (0.1 s windows, longer
   when the band starts below 20 Hz), the next block read in a background thread.
2. Segmentation: the user's schedule, else the one embedded in the record, else automatic from
   the reference's rms envelope; ``settle_s`` trimmed at both edges of every segment.
3. The physics §4.2 checks on a short probe of every level (:mod:`vrelab.analysis.plausibility`),
   which also decide the method per level with ``method="auto"``.
4. Baselines and levels (:mod:`vrelab.analysis.levels`; a sine level's second pass in
   :mod:`vrelab.analysis.sine`): VRE per level against the bracketing baselines.
5. Fits (:func:`vrelab.fits.fit_levels`) and, when asked, the GUM budget (:mod:`vrelab.gum`).

Public API: :func:`reduce_record` (levels and warnings, what the simulated test calls),
:func:`reduce` (everything, for the CLI's output files), :func:`analyze` (levels + fits as a
:class:`~vrelab.results.VreResult`), :func:`analyze_full` (both), :func:`analyze_channels`
(several DUTs of one file). Their options: :mod:`vrelab.analysis.options`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Collection, Iterator, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab._version import __version__
from vrelab.analysis import plausibility as P
from vrelab.analysis.baseline_windows import segment_any_band
from vrelab.analysis.levels import (
    FEW_WINDOWS_NOTE,
    MIN_SEGMENT_WINDOWS,
    SHORT_BASELINES_NOTE,
    Baseline,
    LevelContext,
    find_baselines,
    low_frequency,
    n_windows,
    off_stretches,
    reduce_level,
    segment_samples,
    short_baseline_u,
    short_baselines,
)
from vrelab.analysis.noise import channel_noise
from vrelab.analysis.options import (
    ACCEPTABLE,
    DEFAULT_BLOCK,
    BudgetOptions,
    FitOptions,
    ReductionOptions,
    default_band,
    from_keywords,
)
from vrelab.analysis.plausibility import MethodRequest
from vrelab.analysis.segmentation import (
    WindowStats,
    segment_windows,
    trim,
    window_pass,
    window_pass_many,
)
from vrelab.fits import fit_levels
from vrelab.record import WINDOW_S, ChannelView, Record, Schedule, Segment
from vrelab.results import (
    Conditions,
    FitResult,
    LevelResult,
    Method,
    NoiseResult,
    Notice,
    VreResult,
)


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
    # (kind, frequency [Hz], DUT/reference rms ratio) of each level probed, the frequency the ratio
    # was measured at (SegmentProbe.ratio_hz): a campaign judges a channel's units over all its
    # runs with them (plausibility.judge_runs_units, check_units_over_runs)
    unit_probes: list[tuple[str | None, float, float]] = field(default_factory=list)
    # the DUT's noise on the vibration-off stretches (physics §4.4; None: none to measure)
    noise: NoiseResult | None = None

    @property
    def static_g(self) -> float | None:
        """The DUT's mean reading with vibration off (static field plus its offset)."""
        if not self.baselines:
            return None
        return float(np.mean([b.mean_g for b in self.baselines]))


@dataclass(frozen=True)
class Given:
    """What a caller of :func:`analyze`, :func:`analyze_full` or :func:`analyze_channels` states
    beside the record and the three options (so that none takes more than 8 parameters; each
    field is also taken as a keyword of its own, as before).

    ``conditions``: the result's (default: those in the record's metadata); ``provenance``: added
    to the result's; ``stats``: the record's first pass when already made (one DUT channel's
    :class:`~vrelab.analysis.segmentation.WindowStats`); ``static_g`` (:func:`analyze_channels`
    only): each channel's static field [g], one number for all or a mapping name -> g (None:
    ``fit.static_g``, else each from its baselines).

    Examples
    --------
    >>> from vrelab import Conditions
    >>> from vrelab.analysis.pipeline import Given
    >>> given = Given(conditions=Conditions(sensor="adxl355", axis="z"), provenance={"operator": "example"})
    >>> given.conditions.sensor, dict(given.provenance)
    ('adxl355', {'operator': 'example'})
    """

    conditions: Conditions | None = None
    provenance: Mapping[str, Any] | None = None
    stats: WindowStats | None = None
    static_g: float | Mapping[str, float] | None = None


def _given(given: Given | None, keywords: dict[str, Any], own: Sequence[str] = ("conditions", "provenance")) -> Given:
    """``given`` with the fields given as keywords of their own (popped from ``keywords``; one
    given both ways is refused, not silently preferred)."""
    given = Given() if given is None else given
    changes = {k: v for k in own if k in keywords and (v := keywords.pop(k)) is not None}
    for k in changes:
        if getattr(given, k) is not None:
            raise TypeError(f"{k} given twice: as given.{k} and as {k}=")
    return replace(given, **changes) if changes else given



def _resolve_schedule(
    record: Record, schedule: Schedule | None, stats: WindowStats, settle_s: float
) -> tuple[Schedule, list[str]]:
    warnings: list[str] = []
    if schedule is None and getattr(record, "schedule", None) is not None:
        schedule = record.schedule
        warnings.append(Notice("schedule", "segments from the schedule embedded in the record"))
    if schedule is None:  # its baselines over 0.1 s windows whatever the band
        schedule, w = segment_any_band(record, stats)
        warnings += w
    trimmed, w = trim(schedule, settle_s)
    return trimmed, warnings + w



def reduce(
    record: Record,
    schedule: Schedule | None = None,
    method: MethodRequest = "auto",
    *,
    options: ReductionOptions | None = None,
    stats: WindowStats | None = None,
    **keywords: Any,
) -> Reduction:
    """Reduce a record; see the module docstring. :func:`reduce_record` is the short form.

    Parameters
    ----------
    record : Record
        Channels ``dut`` (and ``reference``, both in g) streamed in blocks.
    schedule : Schedule, optional
        Segments (``nominal_rms_g == 0`` for vibration off). Default: the record's embedded
        schedule, else automatic segmentation from the reference's rms envelope.
    method : {"auto", "random", "sine"}
        "auto" reduces each level as its reference spectrum shows (one line: sine; broad:
        random); an explicit method that a level contradicts is refused.
    options : ReductionOptions, optional
        Band, settling trim, rail, profile, the checks accepted on purpose, block size.
    stats : WindowStats, optional
        The record's first pass when already made (:func:`analyze_channels` makes one pass for
        all the DUTs of a file).

    Before any number is made the record is held against physics §4.2
    (:mod:`vrelab.analysis.plausibility`): a units or sensitivity slip, swapped channels, a
    method that does not fit; ``options.accept`` names the checks to pass on purpose.
    ``keywords``: the former flat options (deprecated, see :func:`~vrelab.analysis.options.from_keywords`).

    Examples
    --------
    >>> from vrelab.analysis import open_record
    >>> from vrelab.analysis.readers import Scale
    >>> record = open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", reference="shaker/ref",
    ...                      dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10))
    >>> from vrelab.analysis import reduce
    >>> with record:
    ...     reduction = reduce(record)
    >>> [f"{level.rms_g:.1f}" for level in reduction.levels]
    ['0.2', '0.4', '0.6']
    """
    if keywords:
        options = from_keywords("reduce", keywords, options)[0]
    opt = options if options is not None else ReductionOptions()
    V.one_of("method", method, ("auto", "random", "sine"))
    fs = V.positive_scalar("fs_hz", record.fs_hz)
    band = default_band(fs, opt.band_hz, opt.profile)
    if stats is None:
        stats = window_pass(record, band, WINDOW_S, opt.block_size, opt.rail_g, opt.progress)
    elif stats.band_hz != band or stats.n_samples != record.n_samples:
        raise ValueError("reduce: the given window stats were made for another band or record")
    warnings: list[str] = []
    if stats.reference == "dut":
        warnings.append(Notice("reference", "no reference channel: levels and segmentation from the DUT's AC part"))
    sched, w = _resolve_schedule(record, schedule, stats, opt.settle_s)
    warnings += w
    sat, rail_notes = stats.saturated()
    warnings += rail_notes

    baselines = find_baselines(stats, sched, sat, warnings, record)
    if not baselines:
        raise ValueError("no vibration-off baseline in the record (or schedule): VRE cannot be referred to one")
    dut_file = (record.meta or {}).get("channels", {}).get("dut", "dut")
    P.check_assumed_g([b.mean_g for b in baselines], dut_file, dut_file in (record.meta or {}).get("units_assumed", ()))
    kind, probes = _plausible_method(record, sched, stats, band, method, baselines, opt.accept)
    ctx = LevelContext(record, stats, sat, baselines, low_frequency(baselines), opt.block_size)

    levels: list[LevelResult] = []
    level_segs: list[Segment] = []
    times: list[float] = []
    thirds: list[tuple[tuple[float, float], ...] | None] = []
    psds: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []
    for seg in (g for g in sched.segments if not g.is_baseline):
        if n_windows(stats, seg) < MIN_SEGMENT_WINDOWS:
            warnings.append(Notice("segment", f"level {seg.start_s:.4g}-{seg.end_s:.4g} s too short, ignored"))
            continue
        level, t_c, w, th = reduce_level(ctx, seg, kind)
        warnings += w
        thirds.append(th)
        levels.append(level)
        level_segs.append(seg)
        times.append(t_c)
        if opt.psd and kind == "random":
            psds.append(_level_psd(record, seg, stats))
    if not levels:
        raise ValueError("no vibration level found in the record (or schedule)")
    levels = short_baseline_u(levels, times, thirds, baselines, ctx.low_frequency)
    n_sat_levels = sum(1 for lv in levels if lv.n_saturated)
    if n_sat_levels:
        warnings.append(Notice("saturated-levels", f"{n_sat_levels} level(s) with saturated DUT samples (flagged 'saturated')"))
    short = [(b, seg.end_s - seg.start_s) for seg, t in zip(level_segs, times)
             if (b := short_baselines(t, seg.end_s - seg.start_s, baselines)) is not None]
    if short:
        warnings.append(Notice("short-baselines", SHORT_BASELINES_NOTE.format(
            n=len(short), base=max(b for b, _ in short), level=min(d for _, d in short))))
    n_few = sum(1 for lv in levels if "few-windows" in lv.flags)
    if n_few:
        warnings.append(Notice("few-windows", FEW_WINDOWS_NOTE.format(n=n_few)))
    if opt.profile is not None and kind == "random":
        warnings += _tolerance_checks(record, level_segs, levels, stats, opt.profile)
    noise = channel_noise(off_stretches(stats, baselines), stats.window / stats.fs_hz)
    return Reduction(levels, warnings, stats, sched, baselines, level_segs, times, psds, method=kind,
                     unit_probes=[(p.kind, p.ratio_hz, p.unit_ratio) for p in probes], noise=noise)


def _plausible_method(
    record: Record,
    sched: Schedule,
    stats: WindowStats,
    band: tuple[float, float],
    method: MethodRequest,
    baselines: Sequence[Baseline],
    accept: Collection[str],
) -> tuple[Method, list[Any]]:
    """The method the record's levels are reduced with, after physics §4.2's checks on a short probe
    of every level (:mod:`vrelab.analysis.plausibility`); levels of both kinds are refused. With
    it, the probes (empty when nothing was checked)."""
    if method != "auto" and set(ACCEPTABLE) <= set(accept):
        return method, []  # nothing to check: no probe (a simulated record re-runs for one)
    # levels the reduction will skip as too short are not probed (their method is moot)
    usable = [g for g in sched.segments if not g.is_baseline and n_windows(stats, g) >= MIN_SEGMENT_WINDOWS]
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
            if k1 - k0 < MIN_SEGMENT_WINDOWS:  # averaged over short windows (find_baselines): its samples
                parts = list(_segment_blocks(record, b.segment, ref))
                ref_dc = float(sum(x.sum() for x in parts) / max(sum(len(x) for x in parts), 1))
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
    i0, i1 = segment_samples(seg, record.fs_hz, record.n_samples)
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


def band_power_ratio(freq_hz: NDArray[np.float64], psd: NDArray[np.float64], band_hz: tuple[float, float],
                     scale: float) -> float:
    """P(f1·scale, f2·scale) / P(f1, f2): the band power of a PSD with the band's edges moved by
    ``scale``, each power the trapezoid integral of the PSD, interpolated linearly between bins
    at the edges (a shift of 0.3 % moves a 50 Hz edge by 0.15 Hz, well inside a 1 Hz bin)."""
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (psd[1:] + psd[:-1]) * np.diff(freq_hz))))

    def power(lo: float, hi: float) -> float:
        return float(np.interp(hi, freq_hz, cum) - np.interp(lo, freq_hz, cum))

    f1, f2 = band_hz
    base = power(f1, f2)
    return power(f1 * scale, f2 * scale) / base if base > 0 else math.nan


def library_rate_notice(record: Record, red: Reduction, fs_lib_hz: float, band_hz: Any) -> Notice:
    """What reading the record at the file library's rate ``fs_lib_hz`` instead of the rate used
    would change, level by level, judged against each level's u.

    All frequencies scale by ``q = fs_lib / fs``: a mean of samples (the VRE, the baselines) and a
    sine's amplitude hold no time scale, so the VRE and a sine level's rms do not move; only the
    sine frequencies (by q - 1) and a random level's band do. The band [f1, f2] at the library's
    rate is [f1/q, f2/q] at the rate used: the level's reference power becomes ``P·ratio``
    (:func:`band_power_ratio` on the level's reference PSD), its rms ``rms·√ratio``. With VRE ∝ rms²
    (physics §1.2) the same reading then belongs to a VRC off by ``1/ratio``; at the level's rms that is
    a VRE of ``VRE·(1/ratio - 1)``, the shift compared with the level's u(VRE)."""
    q = fs_lib_hz / record.fs_hz
    head = f"the file library's sample rate {fs_lib_hz:.9g} Hz is {100 * (q - 1):+.3g} % off the {record.fs_hz:.9g} Hz used"
    if red.method == "sine" or not band_hz:
        return Notice("rate", f"{head}: sine levels' VRE and rms hold no time scale (a mean and an amplitude) and do not "
                              f"change; their drive frequencies would read {100 * (q - 1):+.3g} %")
    band = (float(band_hz[0]), float(band_hz[1]))
    worst, over = 0.0, []
    for seg, lv in zip(red.level_segments, red.levels):
        f, p = _level_psd(record, seg, red.stats)
        if len(f) == 0 or not (math.isfinite(lv.vre.value) and math.isfinite(lv.vre.u)):
            continue
        ratio = band_power_ratio(f, p, band, 1.0 / q)
        shift = abs(lv.vre.value * (1.0 / ratio - 1.0))
        if not math.isfinite(shift):
            continue
        rel = shift / lv.vre.u if lv.vre.u > 0 else math.inf
        worst = max(worst, rel)
        if rel > 1.0:
            over.append(f"{lv.rms_g:.4g}")
    verdict = (f"beyond u at {len(over)} level(s) ({', '.join(over[:5])} g rms): their VRC depends on which rate is "
               "right" if over else "within u at every level")
    return Notice("rate", f"{head}: at that rate each random level's band [{band[0]:g}, {band[1]:g}] Hz would move "
                          f"by that much, its rms with it; the VRE shift this means is up to {worst:.2g} u: {verdict}")


def _tolerance_checks(
    record: Record, segs: Sequence[Segment], levels: list[LevelResult], stats: WindowStats, profile: Any
) -> list[str]:
    """Reference PSD against the profile (physics §3: ±3 dB, rms ±10 %) for each random level."""
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
    *,
    options: ReductionOptions | None = None,
    **keywords: Any,
) -> tuple[list[LevelResult], list[str]]:
    """Reduce a record to VRE per level (:func:`reduce`, its levels and warnings only).

    Returns
    -------
    levels : list of LevelResult
        In time order; ``vre`` in g with its standard uncertainty; ``flags`` has "saturated"
        when the DUT sat on a rail.
    warnings : list of str

    Examples
    --------
    >>> from vrelab.analysis import open_record
    >>> from vrelab.analysis.readers import Scale
    >>> record = open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", reference="shaker/ref",
    ...                      dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10))
    >>> from vrelab.analysis import reduce_record
    >>> with record:
    ...     levels, warnings = reduce_record(record)
    >>> for level in levels:
    ...     print(f"{level.freq_hz:.0f} Hz, {level.rms_g:.1f} g rms: VRE {level.vre.value * 1e3:.2f} ± {level.vre.u * 1e3:.2f} mg")
    80 Hz, 0.2 g rms: VRE 0.10 ± 0.03 mg
    80 Hz, 0.4 g rms: VRE 0.47 ± 0.03 mg
    80 Hz, 0.6 g rms: VRE 1.02 ± 0.04 mg
    """
    if keywords:
        options = from_keywords("reduce_record", keywords, options)[0]
    red = reduce(record, schedule, method, options=options)
    return red.levels, red.warnings


# --------------------------------------------------------------------------- analyze


def analyze_full(
    record: Record,
    method: MethodRequest = "auto",
    schedule: Schedule | None = None,
    *,
    options: ReductionOptions | None = None,
    fit: FitOptions | None = None,
    budget: BudgetOptions | None = None,
    given: Given | None = None,
    **keywords: Any,
) -> tuple[VreResult, Reduction]:
    """:func:`analyze`, also returning the :class:`Reduction` (envelope, segments, PSDs).

    ``given`` (:class:`Given`, or its fields as keywords ``conditions=``, ``provenance=``,
    ``stats=``): ``conditions`` default those in the record's metadata; ``provenance`` is added
    to the result's (version, rate, samples, the file's source and channels); ``stats`` the
    record's first pass when already made (:func:`analyze_channels`).

    Examples
    --------
    >>> from vrelab.analysis import open_record
    >>> from vrelab.analysis.readers import Scale
    >>> record = open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", reference="shaker/ref",
    ...                      dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10))
    >>> from vrelab.analysis import analyze_full
    >>> with record:
    ...     result, reduction = analyze_full(record)
    >>> len(result.levels), type(reduction).__name__
    (3, 'Reduction')
    """
    given = _given(given, keywords, ("conditions", "provenance", "stats"))
    if given.static_g is not None:
        raise ValueError("given.static_g is analyze_channels's (one per channel): give fit=FitOptions(static_g=...)")
    opt, fit, budget = from_keywords("analyze_full", keywords, options, fit, budget)
    conditions, provenance = given.conditions, given.provenance
    red = reduce(record, schedule, method, options=opt, stats=given.stats)
    method = red.method
    g0 = fit.static_g if fit.static_g is not None else red.static_g
    nominal = [seg.freq_hz for seg in red.level_segments]
    fits, w = fit_levels(red.levels, method, g0, fit.clip_kind, fit.k4, fit.rail_with_vrc, nominal_freqs_hz=nominal)
    levels = list(red.levels)
    if budget.wanted:
        levels, fits = with_budget(levels, fits, method, g0, nominal, fit, budget)
    meta = dict(getattr(record, "meta", None) or {})
    if conditions is None:
        given = meta.get("conditions")
        conditions = Conditions.from_dict(given) if isinstance(given, Mapping) else Conditions()
    extra = dict(conditions.extra)
    extra.setdefault("band_hz", list(default_band(record.fs_hz, opt.band_hz, opt.profile)) if method == "random" else None)
    extra.setdefault("settle_s", opt.settle_s)
    extra.setdefault("static_g_from", "given" if fit.static_g is not None else "mean DUT reading at the baselines")
    if budget.typeb is not None:
        extra["type_b"] = budget.typeb.to_dict()
    if budget.limit_g is not None:
        from vrelab.gum import DECISION_RULE

        extra["limit_g"] = budget.limit_g
        extra["decision_rule"] = DECISION_RULE
    desc = conditions.profile
    if desc is None and opt.profile is not None and hasattr(opt.profile, "describe_shape"):
        # The shape, never its unit level: the levels are the ones the run reached (its levels).
        desc = opt.profile.describe_shape()
    conditions = Conditions(
        **{
            **{k: getattr(conditions, k) for k in conditions.__dataclass_fields__ if k != "extra"},
            "model": conditions.model or "measured",
            "profile": desc,
            "static_g": conditions.static_g if conditions.static_g is not None else g0,
        },
        extra=extra,
    )
    prov: dict[str, Any] = {"vrelab_version": __version__, "fs_hz": record.fs_hz, "n_samples": int(record.n_samples)}
    for key in ("source", "format", "channels", "fs_from", "fs_library_hz"):
        if key in meta:
            prov[key] = meta[key]
    prov.update(dict(provenance or {}))
    fs_lib = meta.get("fs_library_hz")
    if isinstance(fs_lib, (int, float)) and fs_lib > 0 and fs_lib != record.fs_hz:
        w = w + [library_rate_notice(record, red, float(fs_lib), extra.get("band_hz"))]
    result = VreResult(
        method=method,
        conditions=conditions,
        levels=tuple(levels),
        fits=tuple(fits),
        warnings=tuple(list(meta.get("reader_notes") or []) + red.warnings + w),
        provenance=prov,
        kind="measurement",
        noise=red.noise,
    )
    return result, red


def with_budget(
    levels: list[LevelResult],
    fits: list[FitResult],
    method: Method,
    g0: float | None,
    nominal_freqs_hz: list[float | None],
    fit: FitOptions,
    budget: BudgetOptions,
) -> tuple[list[LevelResult], list[FitResult]]:
    """Levels and fits with the GUM budget of :mod:`vrelab.gum` (Type B terms by their
    sensitivity coefficients; fits refitted with each input perturbed, by ``fit``'s policy);
    ``g0`` the static field the fits used, ``nominal_freqs_hz`` the levels' scheduled frequencies."""
    from vrelab import gum

    typeb = budget.typeb if budget.typeb is not None else gum.TypeB()
    coeff = _static_coefficients(levels, fits, g0)
    out = [gum.level_budget(lv, typeb, c, budget.limit_g) for lv, c in zip(levels, coeff)]
    if not typeb.declared:
        return out, fits

    def refit_for(f0: FitResult) -> Callable[[dict[str, float]], FitResult | None]:
        def refit(delta: dict[str, float]) -> FitResult | None:
            lv = gum.perturb_levels(levels, delta.get("rms_rel", 0.0), delta.get("vre_rel", 0.0),
                                    delta.get("offset_g", 0.0))
            g = None if g0 is None else g0 + delta.get("static_g", 0.0)
            again, _ = fit_levels(lv, method, g, fit.clip_kind, fit.k4, fit.rail_with_vrc,
                                  nominal_freqs_hz=nominal_freqs_hz)
            same = [f for f in again if f.model.name == f0.model.name and f.freq_hz == f0.freq_hz]
            return same[0] if same else None
        return refit

    return out, [gum.fit_budget(f, refit_for(f), typeb) for f in fits]


def _static_coefficients(levels: Sequence[LevelResult], fits: Sequence[FitResult], g0: float | None
                         ) -> list[float | None]:
    """∂VRE/∂g0 per level from the fitted clipping model (central difference of its Gaussian
    mean shift at the level's rms), None where no fitted model gives it."""
    rms = [lv.rms_g for lv in levels]
    found = (f.model.static_coefficients(rms, g0) for f in fits) if g0 is not None else iter(())
    return next((c for c in found if c is not None), [None] * len(levels))


def analyze(
    record: Record,
    method: MethodRequest = "auto",
    schedule: Schedule | None = None,
    *,
    options: ReductionOptions | None = None,
    fit: FitOptions | None = None,
    budget: BudgetOptions | None = None,
    given: Given | None = None,
    **keywords: Any,
) -> VreResult:
    """Reduce a record and fit it: the whole test station in one call.

    Parameters
    ----------
    record : Record
        Channels ``dut`` (and ``reference``) in g, streamed in blocks.
    method : {"auto", "random", "sine"}
        How each level is reduced (see :func:`reduce`).
    schedule : Schedule, optional
        The segments; default the record's embedded schedule, else found from the envelope.
    options : ReductionOptions, optional
        Band, settling trim, rail, profile (default band, and the reference PSD is checked
        against it), checks accepted on purpose, block size.
    fit : FitOptions, optional
        Static field for the rail fit (default: the DUT's mean reading at the baselines),
        clipping model, k4 term, joint rail + VRC fit (:func:`vrelab.fits.fit_rail`).
    budget : BudgetOptions, optional
        Type B terms (physics §4.3) and a decision limit.
    given : Given, optional
        The result's ``conditions`` (default: those in the record's metadata) and
        ``provenance`` (added to the result's); also taken as keywords ``conditions=``,
        ``provenance=``.

    Returns
    -------
    VreResult
        ``kind="measurement"``; fits by :func:`vrelab.fits.fit_levels`: "vrc" per frequency for
        sine; for random "clip-<kind>" (``rail_g``, ``departure_rms_g``), then "vrc".

    Examples
    --------
    A run of the example campaign (sensor sn1 axis up, sines at 80 Hz), opened with its channels'
    units and reduced. The part was simulated with k2 = 2000 µg/g² and k3 = 300 µg/g³, a VRC of
    k2 + 3·k3 = 2900 µg/g² at +1 g:

    >>> from vrelab.analysis import open_record
    >>> from vrelab.analysis.readers import Scale
    >>> record = open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", reference="shaker/ref",
    ...                      dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10))
    >>> from vrelab.analysis import analyze
    >>> with record:
    ...     result = analyze(record)
    >>> result.method, len(result.levels), [fit.model.name for fit in result.fits]
    ('sine', 3, ['vrc'])
    >>> vrc = result.fits[0].params["vrc_ug_per_g2"]
    >>> print(f"VRC {vrc.value:.0f} ± {vrc.u:.0f} µg/g²")
    VRC 2853 ± 87 µg/g²
    """
    given = _given(given, keywords)
    opt, fit, budget = from_keywords("analyze", keywords, options, fit, budget)
    return analyze_full(record, method, schedule, options=opt, fit=fit, budget=budget, given=given)[0]


def analyze_channels(
    record: Record,
    duts: Sequence[str] | None = None,
    method: MethodRequest = "auto",
    schedule: Schedule | None = None,
    *,
    options: ReductionOptions | None = None,
    fit: FitOptions | None = None,
    given: Given | None = None,
    **keywords: Any,
) -> list[tuple[str, VreResult, Reduction]]:
    """Several DUT channels of one record, each reduced against one reference.

    One streaming pass makes every DUT's window sums beside the reference's
    (:func:`~vrelab.analysis.segmentation.window_pass_many`); the segmentation comes from the
    reference, so every channel has the same levels; each channel's static field is its own
    (``given.static_g``, or the keyword ``static_g=``: a number for all, a mapping name -> g, or
    None: ``fit.static_g``, else each from its baselines). ``duts`` are record channels
    (``dut:<name>`` from :func:`vrelab.analysis.readers.open_record` with several DUTs; default:
    all of them). Returns (name, result, reduction) per channel, in order. The other arguments
    are :func:`analyze_full`'s (``budget=``, a :class:`~vrelab.analysis.options.BudgetOptions`,
    as a keyword).

    Examples
    --------
    Both parts of the example campaign's 80 Hz run, each against the one reference:

    >>> from vrelab.analysis import analyze_channels, open_record
    >>> from vrelab.analysis.readers import Scale
    >>> duts = {"sn1": "shaker/sn1_z", "sn2": "shaker/sn2_z"}
    >>> with open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut=duts, reference="shaker/ref",
    ...                  dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10)) as record:
    ...     results = analyze_channels(record)
    >>> for name, result, _reduction in results:
    ...     print(name, f"{result.levels[-1].vre.value * 1e3:.2f} mg at {result.levels[-1].rms_g:.1f} g rms")
    sn1 1.02 mg at 0.6 g rms
    sn2 -0.36 mg at 0.6 g rms
    """
    given = _given(given, keywords, ("conditions", "provenance", "static_g"))
    budget = keywords.pop("budget", None)
    if budget is not None and not isinstance(budget, BudgetOptions):
        raise TypeError(f"analyze_channels(): budget must be a BudgetOptions, got {type(budget).__name__}")
    opt, fit, budget = from_keywords("analyze_channels", keywords, options, fit, budget)
    static_g = given.static_g
    if duts is None:
        duts = [c for c in record.channels if c == "dut" or c.startswith("dut:")]
    duts = list(duts)
    if len(duts) > 1 and "reference" not in record.channels:
        raise ValueError("several DUT channels need a reference channel: their levels and segments come from it")
    band = default_band(V.positive_scalar("fs_hz", record.fs_hz), opt.band_hz, opt.profile)
    stats = window_pass_many(record, band, duts, WINDOW_S, opt.block_size, opt.rail_g, opt.progress)
    out: list[tuple[str, VreResult, Reduction]] = []
    for d in duts:
        name = d[4:] if d.startswith("dut:") else d
        g0: float | None
        if isinstance(static_g, Mapping):
            if name not in static_g:
                raise ValueError(f"no static field for DUT channel {name!r}")
            g0 = static_g[name]
        else:
            g0 = static_g if static_g is not None else fit.static_g
        view = record if d == "dut" else ChannelView(record, d)
        result, red = analyze_full(view, method, schedule, options=opt, fit=replace(fit, static_g=g0), budget=budget,
                                   given=replace(given, static_g=None, stats=stats[d]))
        out.append((name, result, red))
    return out


__all__ = [
    "ACCEPTABLE",
    "DEFAULT_BLOCK",
    "Given",
    "Reduction",
    "analyze",
    "analyze_channels",
    "analyze_full",
    "reduce",
    "reduce_record",
    "with_budget",
]
