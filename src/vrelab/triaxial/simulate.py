"""A triaxial shaker test, simulated: the drive along x, y, z and each DUT axis's output (physics §1.6).

The table moves along x, y and z (the part's frame); an ideal triaxial reference accelerometer
records the vibration ``x(t)`` (3 channels, no gravity) and each DUT axis sees the total
acceleration ``g + x(t)`` (``g`` the static vector) through its triaxial chain
(:mod:`vrelab.triaxial.chain`). Everything streams in blocks: memory does not grow with the
record.

* :func:`direction_blocks`: a single-axis drive (today's synthesis,
  :func:`vrelab.synthesis.random_blocks` or :func:`~vrelab.synthesis.sine_blocks`) applied
  along a unit direction ``d``: ``x(t) = d · s(t)`` (an IEEE 1293 mount angle, a
  :class:`~vrelab.triaxial.profile.TriaxialSine`).
* :func:`simulate_direction`: that drive plus the static vector through one or more DUT axes,
  block by block: (reference (3, n), {axis: output}).
* :func:`run_triaxial_test`: a whole simulated test, the triaxial case of :func:`vrelab.simulate`
  (:func:`simulate_triaxial` its deprecated alias; the single-axis test's plan: baselines,
  levels, seeds, rates), the drive a :class:`~vrelab.triaxial.profile.TriaxialProfile`
  (:mod:`vrelab.triaxial.synthesis`) or a sine along a direction, written as an HDF5 record
  (``reference_x``, ``reference_y``, ``reference_z``, ``dut_<axis>``) and reduced per DUT axis
  from the file; the level of each is the total rms. Along one axis it is
  :func:`vrelab.shaker.run_random_test` exactly.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Mapping, Sequence, TypedDict, Unpack

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _keywords
from vrelab import _validate as V
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.record import write_record_hdf5
from vrelab.results import LevelResult, VreResult
from vrelab.simulation.durations import DEFAULT_BASELINE_S, DEFAULT_LEVEL_S
from vrelab.synthesis import Method as DriveMethod
from vrelab.triaxial.chain import TriaxialRun, triaxial_chain
from vrelab.triaxial.profile import AXES, TriaxialProfile, TriaxialSine
from vrelab.triaxial.result import LEVEL_TEXT
from vrelab.triaxial.synthesis import direction_blocks

if TYPE_CHECKING:
    from vrelab.sensor import Sensor

FloatArray = NDArray[np.float64]

__all__ = ["simulate_direction", "DirectionBlock", "axis_runs", "run_triaxial_test",
           "simulate_triaxial", "LEVEL_TEXT"]

# Internal samples per simulated block (as vrelab.simulation.record.BLOCK_INTERNAL).
BLOCK = 1 << 16


@dataclass(frozen=True)
class DirectionBlock:
    """One block of a simulated triaxial test: the reference (3, n) at the internal rate (the
    vibration along x, y, z, no gravity) and each DUT axis's output at its output rate.

    Examples
    --------
    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> from vrelab.triaxial.simulate import simulate_direction
    >>> block = next(iter(simulate_direction(sensor, vrelab.TriaxialSine(100.0, (1.0, 0.0, 1.0)), 64000, seed=1)))
    >>> block.reference.shape[0], list(block.dut)
    (3, ['z'])
    """

    reference: FloatArray
    dut: Mapping[str, FloatArray]


def _axis_sensors(sensors: Any) -> dict[str, Any]:
    """{axis name: Sensor} from one Sensor or a sequence of them (one per axis)."""
    seq = [sensors] if hasattr(sensors, "stages") else list(sensors)
    if not seq:
        raise ValueError("simulate needs at least one DUT axis (a Sensor)")
    out: dict[str, Any] = {}
    for s in seq:
        if not hasattr(s, "stages") or not hasattr(s, "triad"):
            raise ValueError(f"a DUT axis must be a vrelab Sensor, got {type(s).__name__}")
        _ = s.triad  # raises for an axis not named x, y or z
        if s.axis in out:
            raise ValueError(f"DUT axis {s.axis} given twice")
        out[s.axis] = s
    return out


def axis_runs(sensors: Mapping[str, Any], fs_hz: float, seed: np.random.SeedSequence) -> dict[str, TriaxialRun]:
    """A triaxial run per DUT axis; axis ``a`` of (x, y, z) takes child ``AXES.index(a)`` of ``seed``
    (its noise is independent of the other axes' and does not change with which axes run).

    Examples
    --------
    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> import numpy as np
    >>> from vrelab.triaxial.simulate import axis_runs
    >>> runs = axis_runs({"z": sensor}, 64000.0, np.random.SeedSequence(1))
    >>> list(runs), type(runs["z"]).__name__
    (['z'], 'TriaxialRun')
    """
    ents = seed
    runs = {}
    for a, s in sensors.items():
        child = np.random.SeedSequence(entropy=ents.entropy, spawn_key=(*ents.spawn_key, AXES.index(a)))
        runs[a] = triaxial_chain(s, fs_hz).start(fs_hz, child)
    outs = {r.fs_out_hz for r in runs.values()}
    if len(outs) > 1:
        raise ValueError(f"the DUT axes must share one output rate at {fs_hz:g} Hz, got {sorted(outs)} Hz")
    return runs


class DirectionDrive(TypedDict, total=False):
    """How :func:`simulate_direction` draws its drive: ``seed`` (default 0), ``method``
    (default ``"gaussian"``) and ``block_size`` (default :data:`BLOCK`), its parameters' docs."""

    seed: int
    method: DriveMethod
    block_size: int


def simulate_direction(
    sensors: Sensor | Sequence[Sensor],
    excitation: RandomProfile | SineOnRandom | TriaxialSine,
    n_samples: int,
    *,
    direction: ArrayLike | None = None,
    static_g: ArrayLike | None = None,
    fs_hz: float | None = None,
    **drive: Unpack[DirectionDrive],
) -> Iterator[DirectionBlock]:
    """A single-axis drive along a direction, plus the static vector, through each DUT axis.

    Parameters
    ----------
    sensors : Sensor or sequence of Sensors
        The DUT axes (one Sensor per axis, e.g. ``load_sensor(..., axis=a)`` for a of x, y, z).
    excitation, direction, method : as :func:`direction_blocks`.
    n_samples : int
        Record length at the internal rate [samples] (a multiple of the decimation keeps the
        output's length exact).
    static_g : array_like (3,), optional
        Static acceleration (x, y, z) [g]; default 1 g along +z.
    fs_hz : float, optional
        Internal rate; default the one rate rule (:func:`vrelab.rates.simulation_rate_hz`) of
        the first axis for the drive's highest frequency.
    seed : int
        Root of every random draw: ``SeedSequence(seed)`` spawns the chains' seed (each axis a
        child of it, see :func:`axis_runs`) and the drive's.

    Yields
    ------
    DirectionBlock
        Blocks of ``block_size`` internal samples (the last may be shorter).

    Examples
    --------
    The ADXL355's z axis under a 1 g rms sine at 100 Hz along 45° in x-z, axis up:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> from vrelab.triaxial.simulate import simulate_direction
    >>> blocks = list(simulate_direction(sensor, vrelab.TriaxialSine(100.0, (1.0, 0.0, 1.0)), 64000, seed=1))
    >>> type(blocks[0]).__name__, sorted(blocks[0].dut)
    ('DirectionBlock', ['z'])
    """
    axes = _axis_sensors(sensors)
    g = np.array([0.0, 0.0, 1.0]) if static_g is None else V.static_vector(static_g)
    n = V.integer("n_samples", n_samples, 0)
    _keywords.merged("simulate_direction", list(DirectionDrive.__annotations__), (), drive)  # an unknown keyword: TypeError
    bs = V.integer("block_size", drive.get("block_size", BLOCK), 1)
    sd = V.integer("seed", drive.get("seed", 0), 0)
    f_max = excitation.freq_hz if isinstance(excitation, TriaxialSine) else excitation.band[1]
    if isinstance(excitation, SineOnRandom):
        f_max = max(f_max, max(t.freq_hz for t in excitation.tones))
    first = next(iter(axes.values()))
    fs = float(first.internal_rate_hz(f_max)) if fs_hz is None else V.positive_scalar("fs_hz", fs_hz)
    chain_seed, drive_seed = np.random.SeedSequence(sd).spawn(2)
    runs = axis_runs(axes, fs, chain_seed)
    drive_int = int(drive_seed.generate_state(1, np.uint32)[0])
    for x in direction_blocks(excitation, fs, n, bs, drive_int, direction, drive.get("method", "gaussian")):
        a = x + g[:, None]
        yield DirectionBlock(x, {ax: r.process(a) for ax, r in runs.items()})



# --- the simulated triaxial shaker test -------------------------------------------------------


def _excitation(excitation: Any, direction: ArrayLike | None) -> TriaxialProfile | TriaxialSine:
    """The triaxial vibration a test runs: a TriaxialProfile or TriaxialSine as given, or a
    single-axis RandomProfile along ``direction``."""
    if isinstance(excitation, (TriaxialProfile, TriaxialSine)):
        if direction is not None:
            raise ValueError("direction applies to a single-axis profile; a triaxial one carries its own axes")
        return excitation
    if isinstance(excitation, RandomProfile):
        if direction is None:
            raise ValueError("a single-axis profile needs a direction (x, y, z) to run on a triaxial table")
        return TriaxialProfile.along(excitation, direction)
    if isinstance(excitation, SineOnRandom):
        raise ValueError("a sine-on-random profile along a direction is not supported by the triaxial test "
                         "(its tones would need a direction of their own)")
    raise ValueError(f"excitation must be a TriaxialProfile, TriaxialSine or RandomProfile, got {type(excitation).__name__}")


@dataclass
class _Counts:
    """Per segment, what the simulation knows of one DUT axis (the shaker's saturation truth):
    the fields :func:`vrelab.shaker.with_simulated_saturation` and :func:`~vrelab.shaker.with_lattice_u`
    read of a :class:`~vrelab.simulation.record.SimulatedRecord` (:class:`vrelab.shaker.SimulationTruth`),
    the axis's sensor among them (its quantiser step bounds a smooth sine level's lattice error)."""

    sensor: Any
    schedule: Any
    stretches: Any
    saturated: list[int]
    clipped: list[int]
    overrange_events: list[int]
    dut_span: list[float]
    fs_hz: float


# TestPlan keywords a triaxial test takes besides seconds and seed (the rest, a drive's
# distortion or ramps, does not apply to a Gaussian drive of a prescribed CSD)
PLAN_KEYWORDS = {"baseline_s": DEFAULT_BASELINE_S, "settle_s": None, "fs_internal_hz": None, "progress": False}


def simulate_triaxial(sensors: Sensor | Sequence[Sensor], excitation: Any, levels_g: Sequence[float], **keywords: Any) -> VreResult:
    """Deprecated alias of :func:`vrelab.simulate` (one release): the same test, bit for bit.

    ``simulate_triaxial(sensors, excitation, levels_g, direction=..., static_g=(gx, gy, gz), ...)``
    is ``vrelab.simulate(sensors, excitation, levels_g, direction=..., static_g=(gx, gy, gz), ...)``;
    its default static field (``static_g`` None) is 1 g along +z of the part's frame.
    """
    import warnings

    warnings.warn("simulate_triaxial() is deprecated and will be removed in the next release: call "
                  "vrelab.simulate(sensors, vibration, levels, static_g=(gx, gy, gz), direction=...)",
                  DeprecationWarning, stacklevel=2)
    # vrelab.simulate's triaxial case, called here directly (the front door imports this module):
    # a keyword given as None is its default, as there
    static_g = keywords.pop("static_g", None)
    return run_triaxial_test(sensors, excitation, levels_g, static_g,
                             **{k: v for k, v in keywords.items() if v is not None})


def __getattr__(name: str) -> Any:
    """The former result class, one release (its import warns: :mod:`vrelab.triaxial.result`)."""
    if name == "TriaxialTest":
        from vrelab.triaxial.result import former_class

        return former_class(__name__, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def run_triaxial_test(
    sensors: Sensor | Sequence[Sensor],
    excitation: TriaxialProfile | TriaxialSine | RandomProfile,
    levels_g: Sequence[float],
    static_g: ArrayLike | None = None,
    *,
    direction: ArrayLike | None = None,
    seconds: float | None = None,
    record_path: str | Path | None = None,
    **plan: Any,
) -> VreResult:
    """Simulate a triaxial shaker test and reduce each DUT axis as a lab record (the triaxial case
    of :func:`vrelab.simulate`, which is the way to call it).

    Parameters
    ----------
    sensors : Sensor or sequence of Sensors
        The DUT axes, one Sensor per axis (``load_sensor(..., axis=a)``), sharing one ODR.
    excitation : TriaxialProfile, TriaxialSine or RandomProfile
        The vibration (a RandomProfile runs along ``direction``); scaled to each level.
    levels_g : sequence of float
        Levels [g], each the total rms of the vibration (its rms along the direction).
    static_g : array_like (3,), optional
        Static acceleration (x, y, z) [g] in the part's frame; default 1 g along +z.
    direction : array_like (3,), optional
        For a single-axis RandomProfile only.
    seconds : float, optional
        Duration of each level [s]; default 4 (``DEFAULT_LEVEL_S``), random and sine.
    record_path : path, optional
        Write the record there (HDF5, channels ``reference_x/y/z`` and ``dut_<axis>``);
        otherwise it goes to a temporary file, removed afterwards. Either way each axis is
        reduced from the file, as a lab's recording is.
    **plan
        ``seed`` (0), ``baseline_s`` (2, ``DEFAULT_BASELINE_S``), ``settle_s``, ``fs_internal_hz``, ``progress``: as
        :class:`vrelab.simulation.plan.TestPlan` (the same baselines, settling trim, seeds (every
        draw from ``SeedSequence(seed)``: each level's drive seed and the chains' seed, each axis
        a child of it, :func:`axis_runs`) and the one rate rule).

    Returns
    -------
    VreResult
        Each DUT axis's result (``axes``), and ``triaxial``
        (:class:`~vrelab.triaxial.result.TriaxialPart`): the vibration, the static vector, the
        levels asked for, the reference's levels as the reduction measured them.

    Notes
    -----
    The test is :class:`~vrelab.simulation.plan.TestPlan`'s (a baseline, each level followed
    by a baseline; the plan is made for the first axis, and its rates serve every axis); the
    drive is :func:`vrelab.triaxial.synthesis.triaxial_random_blocks` of the profile scaled to
    each level (a sine: the plan's drive frequency and phase along the sine's direction); each
    axis sees ``static_g + drive`` through :func:`vrelab.triaxial.chain.triaxial_chain`. The
    record is reduced from the file by :func:`vrelab.analyze` with a triaxial reference (what
    ``vrelab analyze FILE --triaxial --band F1:F2`` gives for it, ``conditions.extra.band_hz``
    the band: the profile's widened an octave, as :func:`vrelab.shaker.run_test` does), its
    saturation flags taken from the simulation's counts and a sine's lattice error added to u,
    as the single-axis test does; the level is the total rms of the triaxial reference (that
    function's rule).

    Examples
    --------
    The ADXL355's z axis, upright in 1 g, under 1 g rms of flat 50-2000 Hz random vibration along
    45° in x-z, 2 s (the triaxial case of :func:`vrelab.simulate`, which is the way to call it):

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> from vrelab.triaxial.simulate import run_triaxial_test
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000"), (1, 0, 1))
    >>> test = run_triaxial_test(sensor, tri, [1.0], (0, 0, 1), seconds=2, seed=1)
    >>> level = test.axes["z"].levels[0]
    >>> print(f"{level.rms_g:.2f} g rms total: VRE {level.vre.value * 1e3:.1f} ± {level.vre.u * 1e3:.1f} mg")
    1.01 g rms total: VRE -4.1 ± 0.2 mg
    """
    import tempfile

    axes = _axis_sensors(sensors)
    g = np.array([0.0, 0.0, 1.0]) if static_g is None else V.static_vector(static_g)
    exc = _excitation(excitation, direction)
    unknown = sorted(set(plan) - set(PLAN_KEYWORDS) - {"seed"})
    if unknown:
        raise ValueError(f"a triaxial test does not take {', '.join(unknown)} (a Gaussian drive of a prescribed "
                         f"CSD, no ramp); it takes seconds, seed, {', '.join(PLAN_KEYWORDS)}")
    opts = {**PLAN_KEYWORDS, **plan}
    test_plan, band_profile = _plan(axes, g, exc, levels_g, seconds, opts)
    base = test_plan.record()
    rates = base.rates
    runs = axis_runs(axes, rates.fs_internal_hz, base.chain_seed)
    fs_out = next(iter(runs.values())).fs_out_hz
    if abs(fs_out * rates.decimation - rates.fs_internal_hz) > 1e-9 * rates.fs_internal_hz:
        raise ValueError(f"the DUT axes' output rate {fs_out:g} Hz does not divide the internal rate "
                         f"{rates.fs_internal_hz:g} Hz of the plan")
    meta = dict(base.meta)
    meta["triaxial"] = {"excitation": exc.to_dict(), "static_vector_g": g.tolist(), "axes": list(axes),
                        "level": LEVEL_TEXT, "reference_channels": [f"reference_{a}" for a in AXES],
                        "dut_channels": {a: f"dut_{a}" for a in axes}}
    n = len(base.stretches)
    counts = {a: _Counts(axes[a], base.schedule, base.stretches, [0] * n, [0] * n, [0] * n, [0.0] * n, rates.fs_record_hz)
              for a in axes}
    blocks = _record_blocks(exc, base, g, axes, runs, counts)
    with tempfile.TemporaryDirectory(prefix="vrelab-triaxial-") as tmp:
        path = Path(record_path) if record_path is not None else Path(tmp) / "record.h5"
        write_record_hdf5(path, rates.fs_record_hz, blocks, schedule=base.schedule, meta=meta)
        from vrelab import shaker

        band = shaker.measurement_band(band_profile) if band_profile is not None else shaker.sine_band(base)
        assert test_plan.settle_s is not None  # TestPlan.__post_init__ sets the default
        analysis = _reduce_axes(path, axes, counts, test_plan, band, bool(opts["progress"]))
    return _test_result(axes, exc, g, test_plan, base.meta["simulation"], analysis,
                        None if record_path is None else str(record_path))


def _plan(axes: Mapping[str, Any], g: FloatArray, exc: TriaxialProfile | TriaxialSine, levels_g: Sequence[float],
          seconds: float | None, opts: Mapping[str, Any]) -> tuple[Any, RandomProfile | None]:
    """The single-axis test plan a triaxial test runs (made for the first axis) and, for a random
    test, the single-axis profile of its total PSD (the measurement band's)."""
    from vrelab.simulation.plan import TestPlan

    first = next(iter(axes.values()))
    # the plan's saturation check (which sine levels need every phase sampled) sees the axis
    # whose static reading is largest
    static_plan = max((float(s.sensitivity_row @ g) for s in axes.values()), key=abs)
    fs_internal_hz = opts["fs_internal_hz"]
    if fs_internal_hz is None:
        # the one rate rule, for the axis that needs the fastest rate (the plan applies it to the
        # first axis only; the axes of one part share their ODR, so every rule's rate is a multiple of it)
        f_max = exc.freq_hz if isinstance(exc, TriaxialSine) else exc.band[1]
        rates_needed = {float(s.internal_rate_hz(f_max)) for s in axes.values()}
        if len(rates_needed) > 1:
            fs_internal_hz = max(rates_needed)
    common = dict(static_g=static_plan, baseline_s=opts["baseline_s"], settle_s=opts["settle_s"],
                  seed=opts.get("seed", 0), fs_internal_hz=fs_internal_hz)
    if isinstance(exc, TriaxialSine):
        return TestPlan.sine(first, [exc.freq_hz], levels_g, seconds=DEFAULT_LEVEL_S if seconds is None else seconds,
                             **common), None
    proxy = RandomProfile(exc.freq_hz, exc.axis_psd_g2_per_hz.sum(axis=1), name=exc.name)
    return TestPlan.random(first, proxy, levels_g, seconds=DEFAULT_LEVEL_S if seconds is None else seconds, **common), proxy


def _test_result(axes: Mapping[str, Any], exc: TriaxialProfile | TriaxialSine, g: FloatArray, plan: Any,
                 simulation: Mapping[str, Any], analysis: VreResult, record_path: str | None) -> VreResult:
    """The result of the reduced axes: each axis's with the simulation's conditions, the
    analysis's triaxial part with the simulation's vibration, static vector and levels."""
    from vrelab import shaker

    first = next(iter(axes.values()))
    conditions = {"sensor": first.name, "axes": list(axes), "static_vector_g": g.tolist(),
                  "excitation": exc.describe(), "level": LEVEL_TEXT, **simulation}
    out = {}
    for a, result in analysis.axes.items():
        s = axes[a]
        cond = shaker.conditions(s, exc.describe(), float(s.sensitivity_row @ g),
                                  {**simulation, "static_vector_g": g.tolist(), "level": LEVEL_TEXT,
                                   "triaxial": True, "excitation": exc.to_dict(),
                                   "band_hz": result.conditions.extra.get("band_hz"),
                                   "settle_s": plan.settle_s})
        out[a] = dataclasses.replace(result, conditions=cond, kind="simulation",
                                     provenance=shaker.provenance("vrelab.triaxial.simulate_triaxial", s))
    assert analysis.triaxial is not None  # reduce_triaxial's result has its part
    part = dataclasses.replace(analysis.triaxial, excitation=exc, levels_g=tuple(plan.levels_g),
                               static_g=(float(g[0]), float(g[1]), float(g[2])), conditions=conditions,
                               record_path=record_path)
    return VreResult.of_axes(out, kind="simulation", triaxial=part)


def _record_blocks(
    exc: TriaxialProfile | TriaxialSine,
    base: Any,
    g: FloatArray,
    axes: Mapping[str, Any],
    runs: Mapping[str, TriaxialRun],
    counts: Mapping[str, _Counts],
) -> Iterator[dict[str, FloatArray]]:
    """The record's channel blocks at the record rate, by the block rule of ``base`` (the plan's
    :class:`~vrelab.simulation.record.SimulatedRecord`: its stretches, block length, a sine's
    drive; the reference, band-limited by construction, kept at every step-th internal sample;
    each DUT output held over its ODR period), counting what the simulation knows per segment
    and axis. The random drive is the triaxial one of the profile's CSD, with each stretch's seed."""
    from vrelab.simulation.record import rail_window
    from vrelab.triaxial.synthesis import triaxial_random_blocks

    rates = base.rates
    step, hold, block = rates.step, rates.hold, base.block_internal
    rails = {a: rail_window(s) for a, s in axes.items()}
    for k, seg in enumerate(base.stretches):
        drive: Iterator[FloatArray]
        if seg.rms_g == 0:
            drive = (np.zeros((3, min(block, seg.n_internal - i))) for i in range(0, seg.n_internal, block))
        elif isinstance(exc, TriaxialSine):
            d = np.asarray(exc.direction)
            drive = (d[:, None] * s[None, :] for s in base.level_blocks(seg))
        else:
            drive = triaxial_random_blocks(exc.scaled_to(seg.rms_g), rates.fs_internal_hz, seg.n_internal, block,
                                           seg.seed)
        before = {a: r.stats for a, r in runs.items()}
        span = {a: (math.inf, -math.inf) for a in axes}
        for x in drive:
            acc = x + g[:, None]
            out: dict[str, FloatArray] = {f"reference_{c}": x[j, ::step].copy() for j, c in enumerate(AXES)}
            for a, r in runs.items():
                y = r.process(acc)
                low, high = rails[a]
                counts[a].saturated[k] += int(np.count_nonzero((y <= low) | (y >= high)))
                if y.size:
                    span[a] = (min(span[a][0], float(y.min())), max(span[a][1], float(y.max())))
                out[f"dut_{a}"] = np.repeat(y, hold) if hold > 1 else y
            yield out
        for a, r in runs.items():
            after = r.stats
            counts[a].clipped[k] = after.clipped_samples - before[a].clipped_samples
            counts[a].overrange_events[k] = after.overrange_events - before[a].overrange_events
            counts[a].dut_span[k] = span[a][1] - span[a][0] if span[a][1] >= span[a][0] else 0.0


def _reduce_axes(
    path: Path,
    axes: Mapping[str, Any],
    counts: Mapping[str, _Counts],
    plan: Any,
    band: tuple[float, float] | None,
    progress: bool,
) -> VreResult:
    """The record reduced from the file by :func:`vrelab.triaxial.analyze.reduce_triaxial` (the
    reduction ``vrelab analyze FILE --triaxial`` runs: one owner of the VRE, its u and the total
    level), with what the simulation knows better than the record shows: the saturation counts
    and a sine lattice's error (as :func:`vrelab.shaker.run_test` does)."""
    from vrelab import shaker
    from vrelab.analysis.options import ACCEPTABLE, ReductionOptions
    from vrelab.analysis.readers import open_record
    from vrelab.triaxial.analyze import Caller, reduce_triaxial

    def known(axis: str, levels: list[LevelResult], warnings: list[Any]) -> tuple[list[LevelResult], list[Any]]:
        levels, warnings = shaker.with_simulated_saturation(counts[axis], levels, warnings)
        return shaker.with_lattice_u(counts[axis], levels), warnings

    names = {**{a: f"dut_{a}" for a in axes}, **{f"reference-{c}": f"reference_{c}" for c in AXES}}
    options = ReductionOptions(band_hz=band, settle_s=plan.settle_s, accept=frozenset(ACCEPTABLE), progress=progress)
    with open_record(path, names, None) as rec:
        return reduce_triaxial(rec, {c: f"dut:reference-{c}" for c in AXES}, {a: f"dut:{a}" for a in axes},
                               plan.method, rec.schedule, options=options, caller=Caller(known=known))
