"""The article's ADXL355 case study, simulated end to end, with its report (``vrelab demo``).

Each study runs the simulated shaker (:mod:`vrelab.shaker`) on a sensor preset, reduces the
record like a lab file, fits the models, and becomes one section of a combined report:

1. Figure 1: asymmetric clipping of a ±2 g sensor in a 1 g field, 0.3 and 1 g rms (time series).
2. Figure 2: ADXL355 ±2 g, Z axis, random 50 Hz–2 kHz sweep: effective-rail fit, departure; the
   drive's PSD against the profile (±3 dB) and a time history of the over-range hold.
3. Figure 3: ADXL355 ±8 g, X axis (Q 7.4) against Z axis (Q 1.5), both tabulated; a time history.
4. Figure 4: ADXL355 ±2 g, Y axis, 125 Hz against 1 kHz bandwidth, both tabulated; time histories.
5. The datasheet's VRE limit: |VRE| < 0.4 g at 2.5 g rms (±2 g, 1 g orientation, ODR 4 kHz).
6. The IEEE 1293 sine method: VRC against frequency shows the resonance.

Every level is bracketed by vibration-off baselines; each VRE has a standard uncertainty from
the record's own noise (batch means), which scales as 1/√(seconds per level): the quick mode's
2 s levels have about 2.8× the uncertainty of the default 16 s.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from vrelab import _validate as V
from vrelab import folder as F
from vrelab._format import finite_or_none, format_mg_text, format_value, format_value_u
from vrelab._io import output_dir, write_json
from vrelab.report import plots
from vrelab.report.html import ReportFigure, ReportSection, write_report
from vrelab.report.metadata import ReportMetadata, load_metadata
from vrelab.results import VreResult
from vrelab.simulation.durations import DEFAULT_BASELINE_S, DEFAULT_LEVEL_S
from vrelab.units import UG_PER_G

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from vrelab.profiles import Profile
    from vrelab.sensor import Sensor
    from vrelab.simulation.record import SimulatedRecord

# The article's numbers the demo holds itself against (seed article, physics §1.1 and 2).
ARTICLE_FIG1_VRE_G = -0.100  # "VRE about -100 mg" at 1 g rms on a ±2 g sensor in 1 g
ARTICLE_RAIL_G = 2.5  # Figure 2: truncated-model fit "to a 2.5 g truncation"
ARTICLE_DEPARTURE_RMS_G = 2.5  # Figure 2: departs from the model above about 2.5 g rms
DATASHEET_LIMIT = (2.5, 0.4)  # ADXL355 Rev. D: |VRE| < 0.4 g at 2.5 g rms, ±2 g, 1 g, ODR 4 kHz
PROFILE = "flat:50-2000"  # the article's random profile, 50 Hz–2 kHz


def min_seconds() -> float:
    """Shortest segment the simulated test accepts at its default settling time, rounded up to
    0.1 s (the rule belongs to :func:`vrelab.shaker.min_segment_seconds`)."""
    from vrelab.shaker import min_segment_seconds

    return math.ceil(min_segment_seconds() * 10 - 1e-6) / 10


@dataclass(frozen=True)
class DemoConfig:
    """Durations of the simulated test [s] and the root seed."""

    seconds: float = 16.0  # per vibration level
    baseline_s: float = DEFAULT_BASELINE_S  # per vibration-off baseline
    sine_seconds: float = DEFAULT_LEVEL_S  # per sine level
    seed: int = 2017
    quick: bool = False

    @classmethod
    def make(cls, quick: bool = False, seconds: float | None = None, seed: int = 2017) -> DemoConfig:
        lo = min_seconds()
        if seconds is not None:
            seconds = V.positive_scalar("--seconds", seconds)
            if seconds < lo:
                raise ValueError(f"--seconds must be >= {lo:g} s (settling trim at both edges plus 4 averaging windows), got {seconds:g}")
        if quick:
            s = seconds or lo
            return cls(seconds=s, baseline_s=lo, sine_seconds=s, seed=seed, quick=True)
        s = seconds or cls.seconds
        return cls(seconds=s, baseline_s=max(lo, DEFAULT_BASELINE_S), sine_seconds=max(lo, s / 2), seed=seed)


@dataclass(frozen=True)
class DemoOutcome:
    """Where the report is and the headline numbers of each study (in g unless named)."""

    report: Path
    numbers: Mapping[str, float]
    folders: tuple[str, ...]
    elapsed_s: float


@dataclass
class _Study:
    key: str
    section: ReportSection
    results: dict[str, VreResult] = field(default_factory=dict)  # sub-folder -> result
    predictions: dict[str, Mapping[str, Any]] = field(default_factory=dict)
    numbers: dict[str, float] = field(default_factory=dict)


def _levels(quick: bool, full: Sequence[float], short: Sequence[float]) -> list[float]:
    return list(short if quick else full)


def _vre_at(result: VreResult, rms_g: float) -> tuple[float, float]:
    """VRE [g] and u at the level closest to ``rms_g`` (levels are measured, not nominal)."""
    lv = min(result.levels, key=lambda x: abs(x.rms_g - rms_g))
    return lv.vre.value, lv.vre.u


def _nearest(key: str, result: VreResult, rms_g: float) -> dict[str, float]:
    """The level nearest ``rms_g`` as numbers for the summary: ``key_near`` (VRE [g]),
    ``key_near_u`` (its u) and ``key_near_rms`` (its measured rms): a measured VRE with its
    uncertainty beside an interpolated one, which has none."""
    lv = min(result.levels, key=lambda x: abs(x.rms_g - rms_g))
    return {f"{key}_near": lv.vre.value, f"{key}_near_u": lv.vre.u, f"{key}_near_rms": lv.rms_g}


def _interp_vre(result: VreResult, rms_g: float) -> float:
    pts = sorted((x.rms_g, x.vre.value) for x in result.levels if math.isfinite(x.vre.value))
    return float(np.interp(rms_g, [p[0] for p in pts], [p[1] for p in pts]))


def _rail(result: VreResult) -> Any:
    return next((f for f in result.fits if "rail_g" in f.params), None)


def _fig(fig: Figure, caption: str) -> ReportFigure:
    return ReportFigure.from_figure(fig, caption)


def _random_run(sensor: Sensor, profile: Profile, levels: Sequence[float], cfg: DemoConfig,
                seed: int) -> tuple[VreResult, SimulatedRecord]:
    """The random-method test of a study and its record (the same plan: the record's blocks are
    regenerated from the seed, sample for sample what the run reduced)."""
    from vrelab import shaker
    from vrelab.simulation.plan import TestPlan

    plan = TestPlan.random(sensor, profile, levels, static_g=1.0, seconds=cfg.seconds, baseline_s=cfg.baseline_s, seed=seed)
    return shaker.run_test(plan), plan.record()


def _level_samples(record: SimulatedRecord, rms_g: float) -> tuple[float, dict[str, np.ndarray]]:
    """The reference and DUT samples [g] of the vibration level nearest ``rms_g`` (nominal) of a
    simulated record, and the level's nominal rms."""
    seg = min((s for s in record.schedule.segments if not s.is_baseline), key=lambda s: abs(s.nominal_rms_g - rms_g))
    a, b = int(round(seg.start_s * record.fs_hz)), int(round(seg.end_s * record.fs_hz))
    parts: dict[str, list[np.ndarray]] = {"reference": [], "dut": []}
    for blk in record.blocks(1 << 16, tuple(parts), a, b):
        for c in parts:
            parts[c].append(blk[c])
    return seg.nominal_rms_g, {c: np.concatenate(v) for c, v in parts.items()}


def _overrange_at(x: Mapping[str, np.ndarray], fs_hz: float, hold_s: float) -> int | None:
    """Where to look for the over-range protection: the first stretch of at least one hold time
    (the sensor's ``overrange_hold_s``) in which the output stays within 10 mg of 0 g, where the
    output floats during a hold; a low-passed output crossing zero stays there for a sample or
    two of its ODR, far less. Only where to centre a plot: None if there is no such stretch."""
    near = np.abs(x["dut"]) < 0.010
    n = max(2, int(np.ceil(hold_s * fs_hz)))
    run = np.convolve(near.astype(np.int64), np.ones(n, dtype=np.int64), mode="valid")
    hit = np.flatnonzero(run == n)
    return int(hit[0] + n // 2) if hit.size else None


def _window(label: str, fs_hz: float, x: Mapping[str, np.ndarray], centre: int | None, width_s: float) -> plots.TimeWindow:
    """``width_s`` of a level's samples around ``centre`` (default the level's middle), time [s]
    from the level's start."""
    n = min(int(round(width_s * fs_hz)), x["dut"].size)
    c = x["dut"].size // 2 if centre is None else centre
    i0 = int(np.clip(c - n // 2, 0, x["dut"].size - n))
    t = (i0 + np.arange(n)) / fs_hz
    return plots.TimeWindow(label, t, x["reference"][i0 : i0 + n], x["dut"][i0 : i0 + n])


def _drive_psd_figure(record: SimulatedRecord, profile: Any, rms_g: float, what: str) -> tuple[ReportFigure, str]:
    # profile Any: parse_profile's RandomProfile | SineOnRandom, and the tolerance check takes a RandomProfile (the
    # demo's flat profile is one)
    """The reference (drive) PSD of one level against the profile scaled to it, with the ±3 dB
    band (the tolerance check of physics §3, :func:`vrelab.spectra.psd_tolerance_check`), and one
    line of its verdict."""
    from vrelab.spectra import psd_tolerance_check

    nominal, x = _level_samples(record, rms_g)
    tol = psd_tolerance_check(x["reference"], record.fs_hz, profile.scaled_to(nominal))
    verdict = (f"{'within' if tol.passed else 'OUTSIDE'} ±{tol.tol_db:g} dB: deviation {tol.min_dev_db:+.2f} to "
               f"{tol.max_dev_db:+.2f} dB over {tol.band_hz[0]:g}–{tol.band_hz[1]:g} Hz, rms {tol.rms_g:.4g} g "
               f"({100 * (tol.rms_ratio - 1):+.1f} % of {nominal:g} g rms; ±{100 * tol.rms_tol:g} % allowed)")
    fig = plots.plot_psd(tol.freq_hz, tol.psd_measured, tol.psd_profile, tol_db=tol.tol_db, band_hz=tol.band_hz,
                         label=f"reference PSD, Welch {tol.resolution_hz:.3g} Hz, {tol.n_segments} segments",
                         title=f"Drive check: reference PSD at {nominal:g} g rms against the profile ({what})")
    cap = (f"The shaker's drive as the reference measured it during the {nominal:g} g rms level, against the profile "
           f"scaled to {nominal:g} g rms and its ±{tol.tol_db:g} dB tolerance band (physics §3): {verdict}. Bins within two "
           "bin widths of the band's edges are not judged (the Hann window straddles the edge).")
    return ReportFigure.from_figure(fig, cap), verdict


# --------------------------------------------------------------------------- studies
def study_fig1(cfg: DemoConfig, stage: Path) -> _Study:
    """Asymmetric clipping: a ±2 g sensor with exact rails (the ``ideal`` preset) in a 1 g field."""
    from vrelab import shaker
    from vrelab.models.clipping import censored_mean_shift, truncated_mean_shift
    from vrelab.profiles import parse_profile
    from vrelab.sensor.loader import load_sensor

    sensor = load_sensor("ideal", range_g=2)
    (stage / "fig1-clipping").mkdir()
    rec = stage / "fig1-clipping" / F.RECORD
    res = shaker.run_random_test(
        sensor, parse_profile(PROFILE), [0.3, 1.0], static_g=1.0, seconds=cfg.seconds, baseline_s=cfg.baseline_s, seed=cfg.seed, record_path=rec
    )
    vre1, u1 = _vre_at(res, 1.0)
    rms1 = min(res.levels, key=lambda x: abs(x.rms_g - 1.0)).rms_g
    cens = float(censored_mean_shift(1.0, rms1, -2.0, 2.0))
    trunc = float(truncated_mean_shift(1.0, rms1, -2.0, 2.0))
    vre03, u03 = _vre_at(res, 0.3)
    env = plots.record_envelope(rec, n_bins=3000)
    figs = [
        _fig(
            plots.plot_time_series(env, rails_g=sensor.rails_g, static_g=1.0, title="Figure 1: a ±2 g sensor in a 1 g field, 0.3 then 1 g rms random vibration"),
            "Top: the sensor output (blue, min/max per bin) is cut at +2 g, where the input (grey) goes on; its negative peaks never reach −2 g. "
            "Bottom: its mean steps down only when the vibration reaches the upper rail.",
        )
    ]
    sec = ReportSection(
        title="Figure 1 — asymmetric rails: clipping in a 1 g field",
        what=(
            f"In a 1 g field a ±2 g sensor has 1 g of headroom upwards and 3 g downwards, so 1 g rms vibration is clipped on one side "
            f"and its mean moves by {format_mg_text(vre1, u1)}; at 0.3 g rms the rail is 3.3 σ away, a few samples touch it and the mean does not move ({format_mg_text(vre03, u03)})."
        ),
        result=res,
        figures=figs,
        facts=[
            ("VRE at 1 g rms, simulated", format_mg_text(vre1, u1)),
            (f"censored (saturating) model at {rms1:.3g} g rms", format_mg_text(cens)),
            (f"truncated (article's) model at {rms1:.3g} g rms", format_mg_text(trunc)),
            ("article, Figure 1", f"≈ {ARTICLE_FIG1_VRE_G * 1e3:+.0f} mg (read off a plot of a measurement; the censored model is what a saturating output does)"),
            ("VRE at 0.3 g rms, simulated", format_mg_text(vre03, u03)),
        ],
    )
    return _Study("fig1-clipping", sec, {"fig1-clipping": res}, numbers={"fig1_vre_1g": vre1, "fig1_u_1g": u1, "fig1_censored_model": cens, "fig1_vre_03g": vre03})


def _predict(sensor: Sensor, profile: Profile, levels: Sequence[float]) -> Mapping[str, Any] | None:
    import dataclasses

    from vrelab.prediction import predict

    try:
        # the simulated part is the preset itself: its assumptions are exact for it, and the
        # prediction is held against that simulation, model against model (no assumed u: the
        # propagation would be most of the demo's time)
        return predict(dataclasses.replace(sensor, uncertainty={}), profile, levels, static_g=1.0).to_dict()
    except ImportError:
        # The prediction's models are built in parallel with this demo; the simulation does
        # not need them, so the demo runs (without the shares table) while they are missing.
        return None


def study_fig2(cfg: DemoConfig) -> _Study:
    """ADXL355 ±2 g Z axis, random 50 Hz–2 kHz, levels up to 4 g rms: rail fit and departure."""
    from vrelab.profiles import parse_profile
    from vrelab.sensor.loader import load_sensor

    sensor = load_sensor("adxl355", range_g=2, axis="z")
    profile = parse_profile(PROFILE)
    levels = _levels(cfg.quick, [round(0.25 * i, 2) for i in range(1, 17)], [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0])
    res, record = _random_run(sensor, profile, levels, cfg, cfg.seed + 2)
    pred = _predict(sensor, profile, levels)
    rail = _rail(res)
    rail_txt = format_value_u(rail.params['rail_g'].value, rail.params['rail_g'].u, unit="g") if rail else "no fit"
    dep = rail.departure_rms_g if rail else None
    # the article's 2.5 g is a truncated-model fit: compare like with like, on the levels the
    # censored fit keeps (below the departure)
    from vrelab.fits import fit_rail

    kept = [lv for lv in res.levels if dep is None or lv.rms_g < dep]
    try:
        trunc = fit_rail(kept, 1.0, kind="truncated")
        trunc_txt = format_value_u(trunc.params["rail_g"].value, trunc.params["rail_g"].u, unit="g")
    except ValueError:
        trunc, trunc_txt = None, "no fit"
    curves = plots.model_curves(res, rms_max_g=4.2)
    figs = [
        _fig(
            plots.plot_vre_vs_rms([plots.Series("ADXL355 Z, ±2 g, simulated", res, tuple(curves))], title="Figure 2: clipping-model fit to the VRE of the ADXL355 Z axis (±2 g, 1 g field)"),
            "Hollow points: the over-range protection tripped during the level. Lines: the censored and truncated models at the fitted effective rail.",
        )
    ]
    psd_fig, psd_verdict = _drive_psd_figure(record, profile, DATASHEET_LIMIT[0], "the datasheet's level")
    figs.append(psd_fig)
    nominal, x = _level_samples(record, 3.5)
    assert sensor.overrange_hold_s is not None  # the ADXL355 preset has its over-range protection
    at = _overrange_at(x, record.fs_hz, float(sensor.overrange_hold_s))
    figs.append(
        _fig(
            plots.plot_time_windows([_window(f"{nominal:g} g rms, 20 ms" + (" around an over-range event" if at is not None else ""),
                                             record.fs_hz, x, at, 0.020)],
                                    static_g=1.0, rails_g=sensor.rails_g,
                                    title=f"Time history: ADXL355 Z, ±2 g, at {nominal:g} g rms"),
            "The output (blue) is flat at +2.048 g where the input goes beyond it (clipping)"
            + ("; in the middle, where the proof mass has passed the ±8 g over-range threshold, the output sits at 0 g for "
               "the 0.5 ms hold (re-triggered while the peaks go on): the pull toward 0 g the clipping model leaves out."
               if at is not None else "; no stretch of this level shows the over-range hold."),
        )
    )
    v1, u1 = _vre_at(res, 1.0)
    facts = [
        ("effective rail (censored fit)", rail_txt + f": not comparable with the article's {ARTICLE_RAIL_G:g} g, a truncated-model fit"),
        ("effective rail (truncated fit, the article's model)", f"{trunc_txt} against the article's {ARTICLE_RAIL_G:g} g: the simulated "
         "part rectifies less than the article's (whose truncated 2.5 g rail would give −0.71 g at 2.5 g rms, beyond the "
         "data sheet's 0.4 g limit; physics §1.1)"),
        ("VRE at 1 g rms", f"{format_mg_text(v1, u1)}, against −83 mg for a sensor with bare ±2 g rails (Figure 1): the output clip sits after the 1 kHz low-pass"),
        ("data leave the model above", f"{dep:.3g} g rms" if dep else "not within the levels run"),
        ("article", f"departs above ≈ {ARTICLE_DEPARTURE_RMS_G:g} g rms: ±8 g over-range protection with a Gaussian crest factor ≈ 3"),
        (f"drive at {DATASHEET_LIMIT[0]:g} g rms", psd_verdict),
    ]
    sec = ReportSection(
        title="Figure 2 — ADXL355 ±2 g, Z axis: random 50 Hz–2 kHz sweep and the clipping model",
        what=(
            f"The rail that explains the data is {rail_txt}, not the ±2.048 g full scale: the 1 kHz output low-pass shrinks the vibration that reaches "
            "the output clip; at the highest levels the over-range protection (proof-mass peaks beyond ±8 g) pulls the output toward 0 g and the data leave the model."
        ),
        result=res,
        figures=figs,
        facts=facts,
        prediction=pred,
    )
    nums = {
        "fig2_rail_g": rail.params["rail_g"].value if rail else math.nan,
        "fig2_u_rail_g": rail.params["rail_g"].u if rail else math.nan,
        "fig2_departure_rms_g": dep if dep else math.nan,
        "fig2_rail_truncated_g": trunc.params["rail_g"].value if trunc else math.nan,
    }
    nums["fig2_vre_at_2p5"] = _interp_vre(res, 2.5)
    st = _Study("fig2-z-2g", sec, {"fig2-z-2g": res}, numbers=nums)
    if pred:
        st.predictions["fig2-z-2g"] = pred
    return st


def study_fig3(cfg: DemoConfig) -> _Study:
    """ADXL355 ±8 g: X axis (Q 7.4) against Z axis (Q 1.5)."""
    from vrelab.profiles import parse_profile
    from vrelab.sensor.loader import load_sensor

    profile = parse_profile(PROFILE)
    levels = _levels(cfg.quick, [1, 2, 2.5, 3, 3.5, 4, 4.5, 5, 6, 7, 8], [2, 4, 5, 6, 8])
    out: dict[str, VreResult] = {}
    samples: dict[str, tuple[float, float, float, dict[str, np.ndarray]]] = {}
    for axis in ("x", "z"):
        sensor = load_sensor("adxl355", range_g=8, axis=axis)
        out[f"fig3-{axis}-8g"], record = _random_run(sensor, profile, levels, cfg, cfg.seed + 3)
        assert sensor.overrange_hold_s is not None  # the ADXL355 preset has its over-range protection
        samples[axis] = (record.fs_hz, float(sensor.overrange_hold_s), *_level_samples(record, 5.0))
    rx, rz = out["fig3-x-8g"], out["fig3-z-8g"]
    at = 5.0
    vx, vz = _interp_vre(rx, at), _interp_vre(rz, at)
    series = [plots.Series("X axis, Q 7.4", rx, ()), plots.Series("Z axis, Q 1.5", rz, ())]
    figs = [
        _fig(
            plots.plot_vre_vs_rms(series, curves=[], show_fits=False, title="Figure 3: ADXL355 ±8 g, 1 kHz bandwidth: high-Q (X) against low-Q (Z) axis"),
            "Same sensor, range, profile and seed; only the axis (its resonance Q) differs.",
        )
    ]
    fs, hold, nominal, xs = samples["x"]
    centre = _overrange_at(xs, fs, hold)
    wins = [_window(f"{name}, {nominal:g} g rms", fs_a, x_a, centre, 0.020)
            for name, (fs_a, _, _, x_a) in (("X axis, Q 7.4", samples["x"]), ("Z axis, Q 1.5", samples["z"]))]
    figs.append(
        _fig(
            plots.plot_time_windows(wins, static_g=1.0, rails_g=(-8.192, 8.192),
                                    title=f"Time history: ADXL355 ±8 g at {nominal:g} g rms, the same 20 ms of drive"),
            "The same drive through both axes"
            + (", centred on an over-range hold of the X axis: its resonance (Q 7.4) lifts the proof mass past the ±16 g "
               "threshold and the output sits at 0 g for the 0.5 ms hold, where the Z axis (Q 1.5) goes on."
               if centre is not None else ": no stretch of the X axis's level shows the over-range hold."),
        )
    )
    sec = ReportSection(
        title="Figure 3 — resonance Q: X/Y axis (Q 7.4) against Z axis (Q 1.5), ±8 g",
        what=(
            f"The high-Q X axis amplifies vibration near its 2.4 kHz resonance, so its over-range protection trips and its VRE grows sooner: "
            f"at {at:g} g rms it reads {format_mg_text(vx)} against {format_mg_text(vz)} for the Z axis. "
            "Not reproduced: the article's X/Y curve peaks near 3 g rms and then falls; here the X axis's |VRE| keeps "
            "growing with the level, as the over-range holds (output to 0 g in a +1 g field) take more of the time. "
            "Nothing in the preset turns it back: that needs a positive share growing faster than the holds' pull, e.g. a "
            "positive k2 of several thousand µg/g² on X/Y (an assumption; the 0.1 % FS nonlinearity bounds k2 near "
            "1000 µg/g²), or a hold that does not pull toward 0 g; the article names no mechanism."
        ),
        results=[("X axis (Q 7.4)", rx), ("Z axis (Q 1.5)", rz)],
        figures=figs,
        facts=[(f"VRE at {at:g} g rms, X axis (Q 7.4)", format_mg_text(vx)), (f"VRE at {at:g} g rms, Z axis (Q 1.5)", format_mg_text(vz))],
    )
    return _Study("fig3", sec, out, numbers={"fig3_x_at_5": vx, "fig3_z_at_5": vz, **_nearest("fig3_x", rx, at),
                                             **_nearest("fig3_z", rz, at)})


def study_fig4(cfg: DemoConfig) -> _Study:
    """ADXL355 ±2 g Y axis: ODR 4 kHz (1 kHz bandwidth) against ODR 500 Hz (125 Hz bandwidth)."""
    from vrelab.profiles import parse_profile
    from vrelab.sensor.loader import load_sensor

    profile = parse_profile(PROFILE)
    levels = _levels(cfg.quick, [0.5, 0.75, 1, 1.25, 1.5, 1.75, 2, 2.25, 2.5, 2.75, 3], [1, 2, 3])
    out: dict[str, VreResult] = {}
    wins = []
    for odr, key, name in ((4000.0, "fig4-y-1khz", "1 kHz bandwidth (ODR 4 kHz)"), (500.0, "fig4-y-125hz", "125 Hz bandwidth (ODR 500 Hz)")):
        sensor = load_sensor("adxl355", range_g=2, axis="y", odr_hz=odr)
        out[key], record = _random_run(sensor, profile, levels, cfg, cfg.seed + 4)
        nominal, x = _level_samples(record, 2.0)
        wins.append(_window(f"{name}, {nominal:g} g rms", record.fs_hz, x, None, 0.040))
    hi, lo = out["fig4-y-1khz"], out["fig4-y-125hz"]
    at = 2.0
    vh, vl = _interp_vre(hi, at), _interp_vre(lo, at)
    series = [plots.Series("1 kHz bandwidth (ODR 4 kHz)", hi, ()), plots.Series("125 Hz bandwidth (ODR 500 Hz)", lo, ())]
    figs = [
        _fig(
            plots.plot_vre_vs_rms(series, curves=[], show_fits=False, title="Figure 4: ADXL355 Y axis, ±2 g, 1 g field: 125 Hz against 1 kHz bandwidth"),
            "The output clip sits after the digital low-pass: a narrower bandwidth lets less of the 50 Hz–2 kHz vibration reach it.",
        ),
        _fig(
            plots.plot_time_windows(wins, static_g=1.0, rails_g=(-2.048, 2.048),
                                    title="Time history: ADXL355 Y, ±2 g, 40 ms in the middle of the 2 g rms level"),
            "With a 1 kHz bandwidth the output follows the input to the +2.048 g rail and sits there; with 125 Hz the "
            "low-pass has removed most of the 50 Hz–2 kHz vibration before the rail. (The two runs' records have their own "
            "rates, so their drives are not the same samples.)",
        ),
    ]
    sec = ReportSection(
        title="Figure 4 — bandwidth: 125 Hz against 1 kHz (ADXL355 Y axis, ±2 g)",
        what=(
            f"Filtering before the output rail shrinks what it clips: at {at:g} g rms the 125 Hz setting reads {format_mg_text(vl)} against {format_mg_text(vh)} at 1 kHz. "
            "Choose the narrowest bandwidth the application allows."
        ),
        results=[("1 kHz bandwidth", hi), ("125 Hz bandwidth", lo)],
        figures=figs,
        facts=[(f"VRE at {at:g} g rms, 1 kHz bandwidth", format_mg_text(vh)), (f"VRE at {at:g} g rms, 125 Hz bandwidth", format_mg_text(vl))],
    )
    return _Study("fig4", sec, out, numbers={"fig4_1khz_at_2": vh, "fig4_125hz_at_2": vl, **_nearest("fig4_1khz", hi, at),
                                             **_nearest("fig4_125hz", lo, at)})


def study_limit(fig2: _Study) -> _Study:
    """The datasheet's VRE limit, read off the Figure 2 run (same conditions as the datasheet)."""
    from vrelab.models.clipping import censored_mean_shift, truncated_mean_shift

    res = fig2.results["fig2-z-2g"]
    # The article's fitted 2.5 g rail under both models at the datasheet's 2.5 g rms (physics §1.1:
    # -0.33 g censored, -0.71 g truncated).
    art_cens = float(censored_mean_shift(1.0, DATASHEET_LIMIT[0], -ARTICLE_RAIL_G, ARTICLE_RAIL_G))
    art_trunc = float(truncated_mean_shift(1.0, DATASHEET_LIMIT[0], -ARTICLE_RAIL_G, ARTICLE_RAIL_G))
    rms, lim = DATASHEET_LIMIT
    v = _interp_vre(res, rms)
    near = min(res.levels, key=lambda x: abs(x.rms_g - rms))
    ok = abs(v) < lim
    figs = [
        _fig(
            plots.plot_vre_vs_rms([plots.Series("ADXL355 Z, ±2 g, ODR 4 kHz", res, ())], curves=[], limit=(rms, -lim), show_fits=False, title="Datasheet limit: |VRE| < 0.4 g at 2.5 g rms"),
            "The star marks the data sheet's bound; the simulated sensor must stay above the dashed line at 2.5 g rms.",
        )
    ]
    sec = ReportSection(
        title="Datasheet VRE limit: |VRE| < 0.4 g at 2.5 g rms",
        what=(
            f"Under the datasheet's conditions (±2 g, 1 g orientation, random 50 Hz–2 kHz, ODR 4 kHz) the simulated ADXL355 reads {format_mg_text(v)} at {rms:g} g rms "
            f"({'below' if ok else 'ABOVE'} the {lim * 1e3:.0f} mg limit in magnitude: a comparison of a simulation, not a decision on a "
            f"part; see 6 Decisions). The article's 2.5 g rail gives {format_mg_text(art_cens)} with the censored model "
            f"but {format_mg_text(art_trunc)} with its truncated one: only the censored model is consistent with the data sheet. "
            "This is the Z axis (Q 1.5). The preset's X/Y axes (Q 7.4) at the nominal ±8 g over-range threshold give about "
            "−0.45 g here, beyond the limit; with the threshold at the upper end of its ±25 % data-sheet tolerance (10 g) "
            "about −0.34 g, inside it (README, What the demo shows): the part's threshold, not given more closely, decides."
        ),
        figures=figs,
        facts=[
            (f"VRE at {rms:g} g rms (interpolated)", format_mg_text(v)),
            (f"nearest level: {near.rms_g:.3g} g rms", format_mg_text(near.vre.value, near.vre.u)),
            ("datasheet limit", f"|VRE| < {lim * 1e3:.0f} mg"),
            ("article's 2.5 g rail, censored / truncated", f"{format_mg_text(art_cens)} / {format_mg_text(art_trunc)}"),
            ("comparison (not a decision: no limit was given to the result)", "|VRE| below the limit" if ok else "|VRE| above the limit"),
        ],
    )
    return _Study("limit", sec, numbers={"limit_vre_at_2p5": v, "limit_article_truncated": art_trunc, "limit_article_censored": art_cens,
                                         **_nearest("limit", res, rms)})


def study_sine(cfg: DemoConfig) -> _Study:
    """IEEE 1293 sine method on the ±8 g X axis: VRC(f) = k2·|H(f)|² shows the 2.4 kHz resonance."""
    from vrelab import shaker
    from vrelab.sensor.loader import load_sensor

    sensor = load_sensor("adxl355", range_g=8, axis="x")
    # Two bands, as a lab plans them: well below fn the proof mass follows the drive and large
    # levels (peaks clear of the ±8.192 g rails at +1 g) resolve a VRC of tens of µg/g²; near
    # and above fn the levels must keep Q·peak under the 16 g over-range threshold.
    low_f = [300.0, 1000.0] if cfg.quick else [100.0, 300.0, 1000.0]
    high_f = [2000.0, 2400.0, 3000.0] if cfg.quick else [1600.0, 2000.0, 2200.0, 2400.0, 2600.0, 3000.0]
    runs = [
        shaker.run_sine_test(sensor, fs, lv, static_g=1.0, seconds=cfg.sine_seconds, baseline_s=cfg.baseline_s, seed=cfg.seed + 6 + k)
        for k, (fs, lv) in enumerate(((low_f, [1.0, 2.0, 3.0]), (high_f, [0.3, 0.6, 0.9])))
    ]
    res = _merge_sine(runs, low_f + high_f)
    freqs = low_f + high_f
    f = np.geomspace(min(freqs) / 1.2, max(freqs) * 1.2, 300)
    k2_ug = sensor.k2_per_g * UG_PER_G
    assert sensor.fn_hz is not None and sensor.q is not None  # the ADXL355 preset has its resonance
    from vrelab.models.dynamics import vrc_at_frequency

    # The analytic model (physics §1.3), not the simulated chain: the plot holds one against the other.
    model = plots.Curve(
        f"k2·|H(f)|², k2 = {k2_ug:g} µg/g², fn {sensor.fn_hz:g} Hz, Q {sensor.q:g}",
        f,
        np.asarray(vrc_at_frequency(k2_ug, f, sensor.fn_hz, sensor.q), dtype=np.float64),
        "--",
    )
    figs = [
        _fig(plots.plot_vrc_vs_freq(res, fn_hz=sensor.fn_hz, model=model, title="VRC against frequency, ADXL355 X axis (Q 7.4), ±8 g, sine method"), "Each point is a least-squares VRC through the origin at one frequency (IEEE Std 1293-1998)."),
        _fig(plots.plot_vre_vs_rms2(res), "VRE against rms² at each frequency: the slopes are the VRCs."),
    ]
    vrc = {fit.freq_hz: fit.params["vrc_ug_per_g2"] for fit in res.fits}
    lo, pk = vrc.get(1000.0), vrc.get(2400.0)
    h2 = {fq: float(vrc_at_frequency(1.0, fq, sensor.fn_hz, sensor.q)) for fq in (1000.0, 2400.0)}
    sec = ReportSection(
        title="Sine method (IEEE 1293): VRC against frequency",
        what=(
            f"The nonlinearity acts on the proof mass, so vibration near the 2.4 kHz resonance is rectified about Q² ≈ 55 times more: "
            f"VRC {format_value_u(pk.value, pk.u, unit='µg/g²')} at 2.4 kHz against {format_value_u(lo.value, lo.u, unit='µg/g²')} at 1 kHz "
            f"(the preset's k2 = {k2_ug:g} µg/g² is an assumption, not a datasheet value)."
            if lo and pk
            else "VRC against frequency."
        ),
        result=res,
        figures=figs,
        facts=[
            ("VRC at 2.4 kHz (fn)", f"{format_value_u(pk.value, pk.u, unit='µg/g²')}; model k2·|H|² = {format_value(k2_ug * h2[2400.0], unit='µg/g²')}") if pk else ("VRC at 2.4 kHz", "–"),
            ("VRC at 1 kHz", f"{format_value_u(lo.value, lo.u, unit='µg/g²')}; model k2·|H|² = {format_value(k2_ug * h2[1000.0], unit='µg/g²')}") if lo else ("VRC at 1 kHz", "–"),
            ("levels", "1, 2, 3 g rms up to 1 kHz; 0.3, 0.6, 0.9 g rms from 1.6 kHz (Q·peak under the 16 g over-range threshold)"),
        ],
    )
    nums = {
        "sine_vrc_1000": lo.value if lo else math.nan,
        "sine_vrc_2400": pk.value if pk else math.nan,
        "sine_u_vrc_2400": pk.u if pk else math.nan,
        "sine_k2_ug": k2_ug,
        "sine_model_vrc_2400": k2_ug * h2[2400.0],
    }
    return _Study("sine-x-8g", sec, {"sine-x-8g": res}, numbers=nums)


def _merge_sine(runs: Sequence[VreResult], freqs: Sequence[float]) -> VreResult:
    """One sine-sweep result from runs of the same sensor over different frequency bands."""
    import dataclasses

    first = runs[0]
    cond = dataclasses.replace(
        first.conditions,
        profile=f"sine {', '.join(f'{f:g}' for f in freqs)} Hz",
        extra=dict(first.conditions.extra, levels_note="1, 2, 3 g rms up to 1 kHz; 0.3, 0.6, 0.9 g rms from 1.6 kHz"),
    )
    return dataclasses.replace(
        first,
        conditions=cond,
        levels=tuple(lv for r in runs for lv in r.levels),
        fits=tuple(f for r in runs for f in r.fits),
        warnings=tuple(dict.fromkeys(w for r in runs for w in r.warnings)),
    )


def summary_section(n: Mapping[str, float]) -> ReportSection:
    """The article's claims against the simulation, one row per study."""

    def g(key: str) -> float:
        return n.get(key, math.nan)

    def near(key: str) -> str:
        """The nearest level's VRE ± u (an interpolation between levels has no u)."""
        return format_mg_text(g(key + "_near"), g(key + "_near_u"))

    def at(key: str) -> str:
        return f"simulated at {g(key + '_near_rms'):.3g} g rms (the nearest level)"

    dep = g("fig2_departure_rms_g")
    rows = [
        (
            "Figure 1: VRE at 1 g rms, ±2 g, 1 g field",
            f"article ≈ {ARTICLE_FIG1_VRE_G * 1e3:+.0f} mg · censored model {format_mg_text(g('fig1_censored_model'))} · simulated {format_mg_text(g('fig1_vre_1g'), g('fig1_u_1g'))}",
        ),
        ("Figure 2: effective rail, ±2 g Z", f"article {ARTICLE_RAIL_G:g} g (truncated fit) · simulated, same truncated model, "
         f"{g('fig2_rail_truncated_g'):.3g} g: not reproduced (the censored fit, a different model, gives "
         f"{format_value_u(g('fig2_rail_g'), g('fig2_u_rail_g'), unit='g')})"),
        (
            "Figure 2: data leave the model above",
            f"article ≈ {ARTICLE_DEPARTURE_RMS_G:g} g rms · simulated " + (f"{dep:.3g} g rms" if math.isfinite(dep) else "no departure within the levels run"),
        ),
        ("Figure 3: VRE at 5 g rms, ±8 g", f"article: X/Y worse than Z · {at('fig3_x')} X {near('fig3_x')}, Z {near('fig3_z')}; "
         "the article's X/Y peak near 3 g rms: not reproduced"),
        ("Figure 4: VRE at 2 g rms, ±2 g Y", f"article: 125 Hz well below 1 kHz · {at('fig4_125hz')} 125 Hz {near('fig4_125hz')}, 1 kHz {near('fig4_1khz')}"),
        ("Datasheet: VRE at 2.5 g rms", f"limit |VRE| < {DATASHEET_LIMIT[1] * 1e3:.0f} mg · {at('limit')} {near('limit')}"),
        (
            "Sine method: VRC at fn = 2.4 kHz",
            f"model k2·Q² = {format_value(g('sine_model_vrc_2400'), unit='µg/g²')} · simulated {format_value_u(g('sine_vrc_2400'), g('sine_u_vrc_2400'), unit='µg/g²')}",
        ),
    ]
    return ReportSection(
        title="At a glance: the article against the simulation",
        what="Each row is one of the article's figures (or the data sheet's limit) and what the simulated sensor gives under the same conditions; the sections below show how.",
        facts=rows,
    )


# --------------------------------------------------------------------------- driver
def run_demo(
    out: str | Path = "demo-out",
    quick: bool = False,
    seconds: float | None = None,
    seed: int = 2017,
    log: Callable[[str], None] | None = None,
    metadata: ReportMetadata | str | Path | None = None,
) -> DemoOutcome:
    """Run every study, write one sub-folder per result and the combined ``report.html``.

    Parameters
    ----------
    out : path
        Output folder; written completely or not at all (staged, then moved in).
    quick : bool
        Short levels (the shaker's minimum, 2 s) and fewer of them: a few seconds in all, for tests.
    seconds : float, optional
        Duration of each random level [s] (default 16, quick: the minimum). VRE uncertainty scales as
        1/√seconds.
    log : callable, optional
        Receives one progress line per study (default: print on stderr).
    metadata : ReportMetadata or path, optional
        The test report's laboratory, item, equipment and approval
        (:func:`vrelab.report.metadata.load_metadata`); read and validated before anything runs.
    """
    t0 = time.monotonic()
    meta = load_metadata(metadata) if isinstance(metadata, (str, Path)) else metadata
    cfg = DemoConfig.make(quick, seconds, seed)
    say = log or (lambda s: print(s, file=sys.stderr, flush=True))
    studies: list[_Study] = []
    steps: list[tuple[str, Callable[[Path], _Study]]] = [
        ("Figure 1: asymmetric clipping, ±2 g sensor in a 1 g field", lambda st: study_fig1(cfg, st)),
        ("Figure 2: ADXL355 ±2 g Z axis, random sweep and rail fit", lambda st: study_fig2(cfg)),
        ("Figure 3: ADXL355 ±8 g, X (Q 7.4) vs Z (Q 1.5)", lambda st: study_fig3(cfg)),
        ("Figure 4: ADXL355 ±2 g Y axis, 125 Hz vs 1 kHz bandwidth", lambda st: study_fig4(cfg)),
        ("Datasheet limit: |VRE| < 0.4 g at 2.5 g rms", lambda st: study_limit(studies[1])),
        ("Sine method: VRC against frequency, ±8 g X axis", lambda st: study_sine(cfg)),
    ]
    numbers: dict[str, float] = {}
    folders: list[str] = []
    with output_dir(out, inputs=[metadata] if isinstance(metadata, (str, Path)) else ()) as stage:
        for i, (label, fn) in enumerate(steps, 1):
            t = time.monotonic()
            st = fn(stage)
            studies.append(st)
            for key, res in st.results.items():
                F.write_result(stage / key, res, st.predictions.get(key))
                folders.append(key)
            numbers.update(st.numbers)
            say(f"vrelab demo: [{i}/{len(steps)}] {label}: done in {time.monotonic() - t:.1f} s")
        intro = (
            "The Analog Devices article's case study of vibration rectification in the ADXL355, rerun on the simulated sensor: "
            "every level is a simulated shaker test (baseline, level, baseline) through the sensor's signal chain, reduced like a lab record. "
            f"Each random level lasts {cfg.seconds:g} s ({'quick mode' if cfg.quick else 'default'}); the standard uncertainty of each VRE "
            "scales as 1/√duration, so 4× longer levels (--seconds) halve it. Numbers not on the data sheet (k2, the exact over-range threshold) are "
            "preset assumptions, listed in each result's provenance."
        )
        report = write_report(
            stage / F.REPORT,
            [summary_section(numbers)] + [s.section for s in studies],
            title="Vibration rectification in the ADXL355: the article's case study, simulated",
            intro=intro,
            provenance={"demo_seed": cfg.seed, "seconds_per_level": cfg.seconds, "sub_folders": ", ".join(folders)},
            metadata=meta,
        )
        write_json(stage / F.SUMMARY, {k: finite_or_none(v) for k, v in numbers.items()})
    final = Path(out) / report.name
    return DemoOutcome(final, numbers, tuple(folders), time.monotonic() - t0)
