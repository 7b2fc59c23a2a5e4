"""The virtual lab: a simulated shaker test of a sensor, reduced like a recorded one.

A test runs as a lab runs it (physics §4): a vibration-off baseline, a level, a baseline,
the next level, ..., each level bracketed by baselines. Three rooms:

* :class:`~vrelab.simulation.plan.TestPlan`: the test (method, levels, profile or frequencies,
  static field, durations, seed), validated once, within the stated budgets;
* :class:`~vrelab.simulation.record.SimulatedRecord`: its record, generated on demand block by
  block from the seed (the DUT sees ``static_g + drive(t)`` through
  :meth:`vrelab.sensor.Sensor.chain` at the rate of :func:`vrelab.rates.simulation_rate_hz`),
  so memory does not grow with the duration;
* this module: :func:`run_test` runs a plan, reduces its record exactly as a file recorded in a
  lab (:func:`vrelab.analysis.pipeline.reduce`) and fits it with the one fit policy
  (:func:`vrelab.fits.fit_levels`) that ``vrelab analyze`` applies to the same record.

:func:`run_random_test` / :func:`run_sine_test` (and ``plan_*``) are the keyword forms.
"""

from __future__ import annotations

import dataclasses
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Protocol, Sequence, Unpack

from vrelab._version import __version__
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.record import write_record_hdf5
from vrelab.results import Conditions, Estimate, FitResult, LevelResult, Method, Notice, VreResult
from vrelab.simulation.plan import PlanOptions, TestPlan, min_segment_seconds
from vrelab.simulation.plan import measurement_band as measurement_band  # its owner is the plan
from vrelab.simulation.record import SimulatedRecord

if TYPE_CHECKING:
    from vrelab.record import Schedule
    from vrelab.sensor import Sensor
    from vrelab.simulation.record import Stretch

__all__ = [
    "TestPlan",
    "SimulatedRecord",
    "min_segment_seconds",
    "plan_random_test",
    "plan_sine_test",
    "run_random_test",
    "run_sine_test",
    "run_test",
]


# --- running a test ---------------------------------------------------------------------------


def conditions(sensor: Sensor, profile_text: str, static_g: float, extra: Mapping[str, Any]) -> Conditions:
    """The sensor's conditions (range, axis, ODR, bandwidth, rails) plus the test's."""
    base: Conditions = sensor.conditions(static_g=float(static_g), profile=profile_text, model="simulation")
    return dataclasses.replace(base, extra={**dict(base.extra), **dict(extra)})


def provenance(function: str, sensor: Sensor) -> dict[str, Any]:
    prov: dict[str, Any] = {
        "software": f"vrelab {__version__}",
        "function": function,
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    to_dict = getattr(sensor, "to_dict", None)
    if callable(to_dict):
        prov["sensor"] = to_dict()
    return prov


def _reduce_and_fit(
    record: SimulatedRecord,
    method: Method,
    band_hz: tuple[float, float] | None,
    settle_s: float,
    record_path: str | Path | None,
    progress: bool,
    clip_kind: ClipKind = DEFAULT_CLIP_KIND,
) -> tuple[list[LevelResult], list[FitResult], list[str]]:
    """Reduce the record as a lab file (saturation counts and over-range flags from the
    simulation's truth), then fit it with the one fit policy (:func:`vrelab.fits.fit_levels`)
    that ``vrelab analyze`` applies to the same record."""
    from vrelab.analysis.options import ACCEPTABLE, ReductionOptions
    from vrelab.analysis.pipeline import reduce
    from vrelab.fits import fit_levels

    source: Any = record
    if record_path is not None:
        # One simulation pass writes the file; the analysis then reads the file back, which
        # costs far less than simulating twice and closes the loop the way a lab does.
        write_record_hdf5(
            record_path,
            record.fs_hz,
            record.blocks(1 << 16, record.channels),
            schedule=record.schedule,
            meta=record.meta,
        )
        from vrelab.analysis.readers import open_record

        source = open_record(record_path, dut="dut", reference="reference")
    # The simulation's own progress bar covers the pass that generates the record; the
    # reduction shows one only when it reads the file back.
    # physics §4.2's checks guard against a lab's slips, which a simulation cannot make: it writes
    # both channels in g on the channels it names, with the method it ran (and a sine run above
    # the sensor's bandwidth legitimately shows a DUT far smaller than its reference). Probing
    # would re-run the simulation for each segment, so nothing is checked here.
    red = reduce(
        source, record.schedule, method,
        options=ReductionOptions(band_hz=band_hz, settle_s=settle_s, progress=progress and record_path is not None,
                                 accept=frozenset(ACCEPTABLE)),
    )
    levels, warnings = with_simulated_saturation(record, list(red.levels), list(red.warnings))
    levels = with_lattice_u(record, levels)
    nominal = [seg.freq_hz for seg in red.level_segments]
    fits, notes = fit_levels(levels, method, red.static_g, clip_kind, nominal_freqs_hz=nominal)
    return levels, fits, warnings + notes


class SimulationTruth(Protocol):
    """What :func:`with_simulated_saturation` and :func:`with_lattice_u` read of a simulation:
    its sensor, schedule and stretches, and per segment the DUT samples at a rail, the samples
    the chain clipped, its over-range episodes and the DUT output's span. A
    :class:`~vrelab.simulation.record.SimulatedRecord` is one; so is each DUT axis's count of a
    triaxial test (:mod:`vrelab.triaxial.simulate`), which mypy now checks against this."""

    @property
    def sensor(self) -> Sensor: ...
    @property
    def schedule(self) -> Schedule: ...
    @property
    def stretches(self) -> Sequence[Stretch]: ...
    @property
    def saturated(self) -> Sequence[int] | None: ...
    @property
    def clipped(self) -> Sequence[int] | None: ...
    @property
    def overrange_events(self) -> Sequence[int] | None: ...
    @property
    def dut_span(self) -> Sequence[float] | None: ...


def with_simulated_saturation(
    record: SimulationTruth, levels: list[LevelResult], warnings: list[str]
) -> tuple[list[LevelResult], list[str]]:
    # The simulation knows exactly which DUT samples sat on a rail and where the chain clipped
    # or tripped its over-range protection; the reduction can only guess rails from the
    # record (a noise-free sine repeats its peak value every period and looks like a rail).
    # Replace its saturation guess by the truth, keep its other flags.
    warnings = [w for w in warnings if getattr(w, "code", None) not in ("rail-found", "saturated-levels")]
    on = [i for i, s in enumerate(record.schedule.segments) if not s.is_baseline]
    if record.saturated is None or len(levels) != len(on):
        warnings.append(Notice("simulation", "saturation counts of the simulation could not be matched to the levels"))
        return levels, warnings
    n_flagged = 0
    for j, i in enumerate(on):
        flags = tuple(f for f in levels[j].flags if f not in ("saturated", "overrange"))
        n_sat = record.saturated[i]
        if n_sat or (record.clipped and record.clipped[i]):
            flags += ("saturated",)
            n_flagged += 1
        if record.overrange_events and record.overrange_events[i]:
            flags += ("overrange",)
        levels[j] = dataclasses.replace(levels[j], n_saturated=n_sat, flags=flags)
    if n_flagged:
        warnings.append(Notice("saturated-levels", f"{n_flagged} level(s) reached a rail of the sensor (flagged 'saturated')"))
    return levels, warnings


# Highest power of the sensor's polynomial nonlinearity (k2..k4, physics §1.2; with_lattice_u).
_MAX_POLYNOMIAL_DEGREE = 4


def with_lattice_u(record: SimulationTruth, levels: list[LevelResult]) -> list[LevelResult]:
    """Sine levels with the error of their phase lattice in u.

    Every batch of a sine level samples the output on the same L equally spaced phases of the
    cycle (:func:`vrelab.simulation.plan.sine_drive`), so each batch mean is the same lattice
    rule and its error, the same in every batch, is in no scatter. For an output y(θ) whose
    derivative has total variation V over a cycle, the rule's error is at most
    ``Σ_j 2·|c_{jL}|`` with ``|c_h| <= V/(2π·h²)``, i.e. ``V/(12·L²)``; V is taken as 24·span
    (span the output's peak-to-peak over the level: a clipped sine's V is a few spans), so the
    bound is ``2·span/L²``; with over-range events (a held output jumps: |c_h| ~ 1/h) ``span/L``. A rectangular bound, so u = bound/√3; added with
    infinite degrees of freedom (the dof scale by (u_new/u_old)⁴, Welch-Satterthwaite).

    A level the chain neither clipped nor tripped (no clipped or saturated sample, no
    over-range event) passes the sine through linear filters and a polynomial only: its output
    is a trigonometric polynomial of the degree of the nonlinearity (4 at most), which a lattice
    rule of L > degree phases averages exactly; only a quantiser (step q, an error within ±q/2
    of that smooth output, on the lattice and over the cycle alike) can move the lattice mean,
    by at most q. The bound is then q (0 without a quantiser), not the clipped output's
    ``2·span/L²`` (2e-6 g for a linear ADXL355 at 1 kHz, whose error is 1e-15 g).
    """
    if record.dut_span is None:
        return levels
    on = [i for i, s in enumerate(record.schedule.segments) if not s.is_baseline]
    if len(on) != len(levels):
        return levels
    out = []
    for lv, i in zip(levels, on):
        stretch = record.stretches[i]
        if not stretch.lattice or not math.isfinite(lv.vre.u):
            out.append(lv)
            continue
        span, n = record.dut_span[i], stretch.lattice
        jumps = bool(record.overrange_events and record.overrange_events[i])
        smooth = not jumps and not (record.clipped and record.clipped[i]) and not (record.saturated and record.saturated[i])
        if smooth and n > _MAX_POLYNOMIAL_DEGREE:
            u_l = float(getattr(record.sensor, "lsb_g", None) or 0.0) / math.sqrt(3.0)
        else:
            u_l = (span / n if jumps else 2.0 * span / n**2) / math.sqrt(3.0)
        u = math.hypot(lv.vre.u, u_l)
        dof = lv.dof
        if dof is not None and math.isfinite(dof) and lv.vre.u > 0:
            dof = dof * (u / lv.vre.u) ** 4
            dof = math.inf if dof > 1e6 else dof  # the bound (exact: no dof) dominates
        out.append(dataclasses.replace(lv, vre=Estimate(lv.vre.value, u, lv.vre.unit), dof=dof))
    return out


def plan_random_test(
    sensor: Sensor, profile: RandomProfile | SineOnRandom, levels_grms: Sequence[float], static_g: float = 1.0, *,
    progress: bool = False, **plan: Unpack[PlanOptions],
) -> SimulatedRecord:
    """The record of a random-method test, not yet run (see :func:`run_random_test`).

    Examples
    --------
    Two levels, each after a vibration-off baseline, and a last baseline:

    >>> import vrelab
    >>> from vrelab.shaker import plan_random_test
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> record = plan_random_test(sensor, vrelab.parse_profile("flat:50-2000"), [1.0, 2.0], seconds=2.0, seed=1)
    >>> len(record.stretches)
    5
    """
    return TestPlan.random(sensor, profile, levels_grms, static_g=static_g, **plan).record(progress)


def run_random_test(
    sensor: Sensor,
    profile: RandomProfile | SineOnRandom,
    levels_grms: Sequence[float],
    static_g: float = 1.0,
    *,
    record_path: str | Path | None = None,
    progress: bool = False,
    clip_kind: ClipKind = DEFAULT_CLIP_KIND,
    **plan: Unpack[PlanOptions],
) -> VreResult:
    """Simulate the random method (physics §4) on ``sensor`` and reduce it like a lab record.

    Parameters
    ----------
    sensor : vrelab.sensor.Sensor
        The device under test.
    profile : RandomProfile or SineOnRandom
        PSD shape [g²/Hz], with sine tones for sine-on-random; scaled to each level
        (``profile.scaled_to(grms)``: the tones with the PSD, their rms counted in the level).
    levels_grms : sequence of float
        Vibration levels [g rms], each > 0, run in the order given.
    static_g : float
        Static acceleration along the axis [g] (+1: axis up in a 1 g field).
    record_path : path, optional
        Write the record there (HDF5) and reduce the file, as a lab would.
    progress : bool
        Progress bars on stderr.
    clip_kind : {"censored", "truncated"}
        Clipping model of the effective-rail fit.
    **plan
        The rest of the test, as :class:`~vrelab.simulation.plan.TestPlan` fields: ``seconds``
        (default 4), ``baseline_s`` (2), ``settle_s`` (the reduction's), ``seed`` (0: every
        random draw, drive and sensor noise, comes from it), ``drive_method``, ``clip_sigma``,
        ``kurtosis`` (:func:`vrelab.synthesis.random_blocks`), ``fs_internal_hz``, ``ramp_s``.

    Returns
    -------
    VreResult
        Per level ``vre`` (value, standard uncertainty), ``rms_g``, saturation counts and flags
        ("saturated", "overrange"); fits and conditions (internal and record rates, seed).

    Notes
    -----
    The test (:class:`~vrelab.simulation.plan.TestPlan`): a vibration-off baseline, then each
    level followed by a baseline. Each level's drive is an independent realisation
    (``SeedSequence(seed)`` children) of the profile scaled to its grms; the sensor sees
    ``static_g + drive``. The reduction (physics §4) gives ``VRE = mean(DUT over the level) −
    baseline interpolated between the bracketing off-segments``, its standard uncertainty from
    the record's own scatter, and ``vib_rms`` = reference rms over the profile's band widened by
    an octave on each side (the drive has no power outside the band, and the band-pass edges
    then do not bias it). Fits: the one policy :func:`vrelab.fits.fit_levels`, as ``vrelab
    analyze`` applies it to the same record: the effective rail of the clipping model (physics
    §1.1, at the static reading of the baselines, with the level where the data depart from it),
    then ``VRE = VRC·rms²`` (physics §1.2) over levels whose 4σ peaks stay inside the fitted rails.
    A sine-on-random test is reduced by the random method, stated explicitly (its reference is
    neither one line nor broad): level = reference rms over that band, tones included.

    References
    ----------
    .. [1] docs/physics.md §1 and §4; the ADI article's random method (ADXL355, 50 Hz-2 kHz).
    .. [2] IEEE Std 1293-1998 (vibration rectification test procedure).

    Examples
    --------
    The ADXL355 at ±2 g, axis up, under 1.5 g rms of flat 50-2000 Hz random vibration for 2 s:

    >>> import vrelab
    >>> from vrelab.shaker import run_random_test
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = run_random_test(sensor, vrelab.parse_profile("flat:50-2000"), [1.5], static_g=1.0, seconds=2.0, seed=1)
    >>> level = result.levels[0]
    >>> print(f"{level.rms_g:.2f} g rms: VRE {level.vre.value * 1e3:.0f} ± {level.vre.u * 1e3:.0f} mg")
    1.52 g rms: VRE -97 ± 1 mg
    """
    plan_ = TestPlan.random(sensor, profile, levels_grms, static_g=static_g, **plan)
    return run_test(plan_, record_path=record_path, progress=progress, clip_kind=clip_kind)


def run_test(
    plan: TestPlan,
    record_path: str | Path | None = None,
    progress: bool = False,
    clip_kind: ClipKind = DEFAULT_CLIP_KIND,
) -> VreResult:
    """Run a :class:`~vrelab.simulation.plan.TestPlan`: simulate its record, reduce it as a lab
    file (writing it to ``record_path`` first when given) and fit it with the one fit policy.

    Examples
    --------
    >>> import vrelab
    >>> from vrelab.shaker import TestPlan, run_test
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = run_test(TestPlan.sine(sensor, [100.0], [0.5], static_g=1.0, seconds=2.0, seed=1))
    >>> print(f"VRE {result.levels[0].vre.value * 1e3:.3f} mg, {result.kind}")
    VRE 0.045 mg, simulation
    """
    record = plan.record(progress)
    assert plan.settle_s is not None  # TestPlan.__post_init__ sets the default
    band = measurement_band(plan.profile) if plan.method == "random" else sine_band(record)  # type: ignore[arg-type]
    levels, fits, warnings = _reduce_and_fit(record, plan.method, band, plan.settle_s, record_path, progress,
                                             clip_kind)
    if plan.method == "sine":
        warnings += _sine_drive_notes(plan, record)
    if isinstance(plan.profile, SineOnRandom) and fits:
        warnings.append(Notice("sine-on-random-fit", "the fits' clipping model (effective rail) assumes a Gaussian "
                                "drive; this one carries sine tones, so a fitted rail is approximate"))
    return VreResult(
        method=plan.method,
        conditions=conditions(plan.sensor, plan.profile_text, plan.static_g, record.meta["simulation"]),
        levels=tuple(levels),
        fits=tuple(fits),
        warnings=tuple(warnings),
        provenance=provenance(f"vrelab.shaker.run_{plan.method}_test", plan.sensor),
        kind="simulation",
    )


def _sine_drive_notes(plan: TestPlan, record: SimulatedRecord) -> list[Notice]:
    """Say where a sine ran off its nominal frequency so that the sensor's samples cover the
    cycle (:func:`vrelab.simulation.plan.sine_drive`)."""
    from vrelab.simulation.plan import DRIVE_TOLERANCE

    out = []
    fs_out = record.rates.fs_internal_hz / record.rates.decimation
    for f, fd in zip(plan.freqs_hz, record.meta["simulation"].get("sine_drive_hz", [])):
        if abs(fd - f) > DRIVE_TOLERANCE * f:
            out.append(Notice("sine-drive", (
                f"sine {f:g} Hz driven at {fd:.6g} Hz: whole periods then take a whole number of the "
                f"sensor's {fs_out:g} Hz output samples that fall on every phase of the cycle, as a shaker "
                f"and a sensor on independent clocks do (a drive that divides the output rate samples a few "
                f"phases only); the levels give the frequency measured, and a VRE that depends on frequency is that frequency's")))
    return out


def sine_band(record: SimulatedRecord) -> tuple[float, float] | None:
    """The reduction's default band (50-2000 Hz) unless the record rate cannot hold it; then
    an octave around the drive frequencies, below the record's Nyquist frequency. (For the
    sine method the band only serves the window statistics: levels come from the lock-in.)"""
    nyquist = record.fs_hz / 2
    if 50.0 < 0.9 * nyquist:
        return None
    freqs = [s.freq_hz for s in record.schedule.segments if s.freq_hz]
    return min(freqs) / 2, min(2 * max(freqs), 0.9 * nyquist)


def plan_sine_test(
    sensor: Sensor, freqs_hz: Sequence[float], levels_rms_g: Sequence[float], static_g: float = 1.0, *,
    progress: bool = False, **plan: Unpack[PlanOptions],
) -> SimulatedRecord:
    """The record of a sine-method test, not yet run (see :func:`run_sine_test`).

    Examples
    --------
    One level at each of two frequencies, between vibration-off baselines:

    >>> import vrelab
    >>> from vrelab.shaker import plan_sine_test
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> record = plan_sine_test(sensor, [100.0, 300.0], [1.0], seconds=2.0, seed=1)
    >>> len(record.stretches)
    5
    """
    return TestPlan.sine(sensor, freqs_hz, levels_rms_g, static_g=static_g, **plan).record(progress)


def run_sine_test(
    sensor: Sensor,
    freqs_hz: Sequence[float],
    levels_rms_g: Sequence[float],
    static_g: float = 1.0,
    *,
    record_path: str | Path | None = None,
    progress: bool = False,
    **plan: Unpack[PlanOptions],
) -> VreResult:
    """Simulate the sine method (IEEE Std 1293-1998; physics §4) and fit VRC at each frequency.

    At each frequency in ``freqs_hz`` every level of ``levels_rms_g`` [g rms] runs for
    ``seconds`` (default 4; rounded to whole periods of the drive after the settling trim),
    bracketed by vibration-off baselines. ``VRE = VRC·vib_rms²`` is fitted by weighted least
    squares through the origin at each frequency (:func:`vrelab.fits.fit_levels`): ``VRC(f)``
    shows the resonance (``VRC·|H(f)|²``, physics §1.3). Other parameters (``ramp_s`` too) as in
    :func:`run_random_test`; with a ramp the sine's amplitude rises and falls, its phase runs on.

    Examples
    --------
    The ADXL355 at ±2 g, axis up, at 1 g rms and 100 Hz: peaks of 2.41 g reach past the +2.048 g
    rail (:func:`vrelab.predict` gives -57.1 ± 0.8 mg).

    >>> import vrelab
    >>> from vrelab.shaker import run_sine_test
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = run_sine_test(sensor, [100.0], [1.0], static_g=1.0, seconds=2.0, seed=1)
    >>> print(f"VRE {result.levels[0].vre.value * 1e3:.1f} mg")
    VRE -57.1 mg
    """
    plan_ = TestPlan.sine(sensor, freqs_hz, levels_rms_g, static_g=static_g, **plan)
    return run_test(plan_, record_path=record_path, progress=progress)
