"""A triaxial shaker test, simulated: the drive along x, y, z and each DUT axis's output (SPEC 1.6).

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
* :func:`simulate_triaxial`: a whole simulated test (the single-axis test's plan: baselines,
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
from typing import Any, Iterator, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as V
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.record import write_record_hdf5
from vrelab.results import LevelResult, Method, VreResult
from vrelab.simulation.durations import DEFAULT_BASELINE_S, DEFAULT_LEVEL_S
from vrelab.synthesis import Method as DriveMethod
from vrelab.triaxial.chain import TriaxialRun, triaxial_chain
from vrelab.triaxial.profile import AXES, TriaxialProfile, TriaxialSine
from vrelab.triaxial.synthesis import direction_blocks

FloatArray = NDArray[np.float64]

__all__ = ["simulate_direction", "DirectionBlock", "static_vector", "axis_runs",
           "simulate_triaxial", "TriaxialTest", "LEVEL_TEXT"]

# Internal samples per simulated block (as vrelab.simulation.record.BLOCK_INTERNAL).
BLOCK = 1 << 16


def static_vector(value: ArrayLike | None) -> FloatArray:
    """The static acceleration (x, y, z) [g] in the part's frame; None: 1 g along +z (the part
    flat on the table, z up)."""
    if value is None:
        return np.array([0.0, 0.0, 1.0])
    g = np.asarray(value, dtype=np.float64).ravel()
    if g.size != 3 or not np.isfinite(g).all():
        raise ValueError(f"static vector must be three finite numbers (x, y, z) in g, got {value!r}")
    return g


@dataclass(frozen=True)
class DirectionBlock:
    """One block of a simulated triaxial test: the reference (3, n) at the internal rate (the
    vibration along x, y, z, no gravity) and each DUT axis's output at its output rate."""

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
    (its noise is independent of the other axes' and does not change with which axes run)."""
    ents = seed
    runs = {}
    for a, s in sensors.items():
        child = np.random.SeedSequence(entropy=ents.entropy, spawn_key=(*ents.spawn_key, AXES.index(a)))
        runs[a] = triaxial_chain(s, fs_hz).start(fs_hz, child)
    outs = {r.fs_out_hz for r in runs.values()}
    if len(outs) > 1:
        raise ValueError(f"the DUT axes must share one output rate at {fs_hz:g} Hz, got {sorted(outs)} Hz")
    return runs


def simulate_direction(
    sensors: Any,
    excitation: RandomProfile | SineOnRandom | TriaxialSine,
    n_samples: int,
    *,
    direction: ArrayLike | None = None,
    static_g: ArrayLike | None = None,
    fs_hz: float | None = None,
    seed: int = 0,
    method: DriveMethod = "gaussian",
    block_size: int = BLOCK,
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
    """
    axes = _axis_sensors(sensors)
    g = static_vector(static_g)
    n = V.integer("n_samples", n_samples, 0)
    bs = V.integer("block_size", block_size, 1)
    sd = V.integer("seed", seed, 0)
    f_max = excitation.freq_hz if isinstance(excitation, TriaxialSine) else excitation.band[1]
    if isinstance(excitation, SineOnRandom):
        f_max = max(f_max, max(t.freq_hz for t in excitation.tones))
    first = next(iter(axes.values()))
    fs = float(first.internal_rate_hz(f_max)) if fs_hz is None else V.positive_scalar("fs_hz", fs_hz)
    chain_seed, drive_seed = np.random.SeedSequence(sd).spawn(2)
    runs = axis_runs(axes, fs, chain_seed)
    drive_int = int(drive_seed.generate_state(1, np.uint32)[0])
    for x in direction_blocks(excitation, fs, n, bs, drive_int, direction, method):
        a = x + g[:, None]
        yield DirectionBlock(x, {ax: r.process(a) for ax, r in runs.items()})



# --- the simulated triaxial shaker test -------------------------------------------------------

# Level definition of a triaxial test (TRIAXIAL.md): the total rms of the vibration vector.
LEVEL_TEXT = "total rms of the triaxial reference, sqrt(rms_x² + rms_y² + rms_z²)"


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


@dataclass(frozen=True)
class TriaxialTest:
    """A simulated triaxial shaker test, reduced per DUT axis.

    ``axes[a]`` is axis a's :class:`~vrelab.results.VreResult`: per level the VRE (DC shift of
    the axis's output against its interpolated vibration-off readings, SPEC 4) with the
    reduction's statistical u, and ``rms_g`` the level as the total rms of the triaxial
    reference (:data:`LEVEL_TEXT`), all as :func:`vrelab.triaxial.analyze.analyze_triaxial`
    gives them for the record (its VRC fit against the total rms; no rail fit).
    """

    method: Method
    excitation: TriaxialProfile | TriaxialSine
    levels_g: tuple[float, ...]
    static_g: tuple[float, float, float]
    axes: Mapping[str, VreResult]
    conditions: Mapping[str, Any]
    record_path: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The document of several DUT channels (``channels``: each axis's whole
        :meth:`VreResult.to_dict` with ``channel`` its axis, as ``vrelab analyze`` writes for a
        file with several DUTs, so ``vrelab report`` reads it) plus the triaxial conditions."""
        chans = [{"channel": a, **r.to_dict()} for a, r in self.axes.items()]
        first = next(iter(self.axes.values()), None)
        return {"kind": "simulation", "method": self.method, "channels": chans,
                "triaxial": {"excitation": self.excitation.to_dict(), "level": LEVEL_TEXT,
                             "levels_g": list(self.levels_g), "static_vector_g": list(self.static_g),
                             "conditions": dict(self.conditions), "record": self.record_path},
                "provenance": dict(first.provenance) if first is not None else {}}


@dataclass
class _Counts:
    """Per segment, what the simulation knows of one DUT axis (the shaker's saturation truth)."""

    schedule: Any
    _segments: Any
    saturated: list[int]
    clipped: list[int]
    overrange_events: list[int]
    dut_span: list[float]
    fs_hz: float


def simulate_triaxial(
    sensors: Any,
    excitation: TriaxialProfile | TriaxialSine | RandomProfile,
    levels_g: Sequence[float],
    *,
    direction: ArrayLike | None = None,
    static_g: ArrayLike | None = None,
    seconds: float | None = None,
    baseline_s: float = DEFAULT_BASELINE_S,
    settle_s: float | None = None,
    seed: int = 0,
    fs_internal_hz: float | None = None,
    record_path: str | Path | None = None,
    progress: bool = False,
) -> TriaxialTest:
    """Simulate a triaxial shaker test and reduce each DUT axis as a lab record.

    Parameters
    ----------
    sensors : Sensor or sequence of Sensors
        The DUT axes, one Sensor per axis (``load_sensor(..., axis=a)``), sharing one ODR.
    excitation : TriaxialProfile, TriaxialSine or RandomProfile
        The vibration (a RandomProfile runs along ``direction``); scaled to each level.
    levels_g : sequence of float
        Levels [g], each the total rms of the vibration (its rms along the direction).
    direction : array_like (3,), optional
        For a single-axis RandomProfile only.
    static_g : array_like (3,), optional
        Static acceleration (x, y, z) [g] in the part's frame; default 1 g along +z.
    seconds, baseline_s, settle_s, seed, fs_internal_hz :
        As :class:`vrelab.simulation.plan.TestPlan` (``seconds`` default 4):
        the same baselines, level durations, settling trim, seeds (every draw from
        ``SeedSequence(seed)``: each level's drive seed and the chains' seed, each axis a child
        of it, :func:`axis_runs`) and the one rate rule.
    record_path : path, optional
        Write the record there (HDF5, channels ``reference_x/y/z`` and ``dut_<axis>``);
        otherwise it goes to a temporary file, removed afterwards. Either way each axis is
        reduced from the file, as a lab's recording is.

    Returns
    -------
    TriaxialTest

    Notes
    -----
    The test is :class:`~vrelab.simulation.plan.TestPlan`'s (a baseline, each level followed
    by a baseline; the plan is made for the first axis, and its rates serve every axis); the
    drive is :func:`vrelab.triaxial.synthesis.triaxial_random_blocks` of the profile scaled to
    each level (a sine: the plan's drive frequency and phase along the sine's direction); each
    axis sees ``static_g + drive`` through :func:`vrelab.triaxial.chain.triaxial_chain`. The
    record is reduced from the file by :func:`vrelab.triaxial.analyze.analyze_triaxial` (what
    ``vrelab analyze FILE --triaxial --band F1:F2`` gives for it, ``conditions.extra.band_hz``
    the band: the profile's widened an octave, as :func:`vrelab.shaker.run_test` does), its
    saturation flags taken from the simulation's counts and a sine's lattice error added to u,
    as the single-axis test does; the level is the total rms of the triaxial reference (that
    function's rule).
    """
    import tempfile

    from vrelab import shaker
    from vrelab.simulation.plan import TestPlan

    axes = _axis_sensors(sensors)
    g = static_vector(static_g)
    exc = _excitation(excitation, direction)
    first = next(iter(axes.values()))
    # the plan's saturation check (which sine levels need every phase sampled) sees the axis
    # whose static reading is largest
    static_plan = max((float(s.sensitivity_row @ g) for s in axes.values()), key=abs)
    if fs_internal_hz is None:
        # the one rate rule, for the axis that needs the fastest rate (the plan applies it to the
        # first axis only; the axes of one part share their ODR, so every rule's rate is a multiple of it)
        f_max = exc.freq_hz if isinstance(exc, TriaxialSine) else exc.band[1]
        rates_needed = {float(s.internal_rate_hz(f_max)) for s in axes.values()}
        if len(rates_needed) > 1:
            fs_internal_hz = max(rates_needed)
    common = dict(static_g=static_plan, baseline_s=baseline_s, settle_s=settle_s, seed=seed,
                  fs_internal_hz=fs_internal_hz)
    method: Method
    if isinstance(exc, TriaxialSine):
        method = "sine"
        plan = TestPlan.sine(first, [exc.freq_hz], levels_g, seconds=DEFAULT_LEVEL_S if seconds is None else seconds, **common)
        band_profile = None
    else:
        method = "random"
        proxy = RandomProfile(exc.freq_hz, exc.axis_psd_g2_per_hz.sum(axis=1), name=exc.name)
        plan = TestPlan.random(first, proxy, levels_g, seconds=DEFAULT_LEVEL_S if seconds is None else seconds, **common)
        band_profile = proxy
    base = plan.record()
    rates, segs = base.rates, base._segments
    runs = axis_runs(axes, rates.fs_internal_hz, base._chain_seed)
    fs_out = next(iter(runs.values())).fs_out_hz
    if abs(fs_out * rates.decimation - rates.fs_internal_hz) > 1e-9 * rates.fs_internal_hz:
        raise ValueError(f"the DUT axes' output rate {fs_out:g} Hz does not divide the internal rate "
                         f"{rates.fs_internal_hz:g} Hz of the plan")
    meta = dict(base.meta)
    meta["triaxial"] = {"excitation": exc.to_dict(), "static_vector_g": g.tolist(), "axes": list(axes),
                        "level": LEVEL_TEXT, "reference_channels": [f"reference_{a}" for a in AXES],
                        "dut_channels": {a: f"dut_{a}" for a in axes}}
    counts = {a: _Counts(base.schedule, segs, [0] * len(segs), [0] * len(segs), [0] * len(segs),
                         [0.0] * len(segs), rates.fs_record_hz) for a in axes}
    blocks = _record_blocks(exc, segs, rates, g, axes, runs, counts)
    with tempfile.TemporaryDirectory(prefix="vrelab-triaxial-") as tmp:
        path = Path(record_path) if record_path is not None else Path(tmp) / "record.h5"
        write_record_hdf5(path, rates.fs_record_hz, blocks, schedule=base.schedule, meta=meta)
        band: tuple[float, float] | None
        if method == "random":
            assert band_profile is not None
            band = shaker.measurement_band(band_profile)
        else:
            band = shaker.sine_band(base)
        assert plan.settle_s is not None
        analysis = _reduce_axes(path, axes, counts, method, band, plan.settle_s, progress)
    conditions = {"sensor": first.name, "axes": list(axes), "static_vector_g": g.tolist(),
                  "excitation": exc.describe(), "level": LEVEL_TEXT, **base.meta["simulation"]}
    out = {}
    for a, result, _ in analysis.channels:
        s = axes[a]
        cond = shaker.conditions(s, exc.describe(), float(s.sensitivity_row @ g),
                                  {**base.meta["simulation"], "static_vector_g": g.tolist(), "level": LEVEL_TEXT,
                                   "triaxial": True, "excitation": exc.to_dict(),
                                   "band_hz": result.conditions.extra.get("band_hz"),
                                   "settle_s": plan.settle_s})
        out[a] = dataclasses.replace(result, conditions=cond, kind="simulation",
                                     provenance=shaker.provenance("vrelab.triaxial.simulate_triaxial", s))
    return TriaxialTest(method, exc, tuple(plan.levels_g), (float(g[0]), float(g[1]), float(g[2])), out, conditions,
                        None if record_path is None else str(record_path))


def _record_blocks(
    exc: TriaxialProfile | TriaxialSine,
    segs: Sequence[Any],
    rates: Any,
    g: FloatArray,
    axes: Mapping[str, Any],
    runs: Mapping[str, TriaxialRun],
    counts: Mapping[str, _Counts],
) -> Iterator[dict[str, FloatArray]]:
    """The record's channel blocks at the record rate (SimulatedRecord's rule: the reference,
    band-limited by construction, kept at every step-th internal sample; each DUT output held
    over its ODR period), counting what the simulation knows per segment and axis."""
    from vrelab import synthesis
    from vrelab.simulation.record import BLOCK_INTERNAL, rail_window
    from vrelab.triaxial.synthesis import triaxial_random_blocks

    fs = rates.fs_internal_hz
    step, hold = rates.step, rates.hold
    block = max(1, BLOCK_INTERNAL // rates.decimation) * rates.decimation
    rails = {a: rail_window(s) for a, s in axes.items()}
    for k, seg in enumerate(segs):
        drive: Iterator[FloatArray]
        if seg.rms_g == 0:
            drive = (np.zeros((3, min(block, seg.n_internal - i))) for i in range(0, seg.n_internal, block))
        elif isinstance(exc, TriaxialSine):
            d = np.asarray(exc.direction)
            hz = seg.freq_hz if seg.drive_hz is None else seg.drive_hz
            drive = (d[:, None] * s[None, :] for s in synthesis.sine_blocks(hz, seg.rms_g, fs, seg.n_internal, block,
                                                                             phase_rad=seg.phase_rad))
        else:
            drive = triaxial_random_blocks(exc.scaled_to(seg.rms_g), fs, seg.n_internal, block, seg.seed)
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
    method: Method,
    band: tuple[float, float] | None,
    settle_s: float,
    progress: bool,
) -> Any:
    """The record reduced from the file by :func:`vrelab.triaxial.analyze.analyze_triaxial` (the
    reduction ``vrelab analyze FILE --triaxial`` runs: one owner of the VRE, its u and the total
    level), with what the simulation knows better than the record shows: the saturation counts
    and a sine lattice's error (as :func:`vrelab.shaker.run_test` does)."""
    from vrelab import shaker
    from vrelab.analysis.readers import open_record
    from vrelab.analysis.reduction import ACCEPTABLE
    from vrelab.triaxial.analyze import analyze_triaxial

    def known(axis: str, levels: list[LevelResult], warnings: list[Any]) -> tuple[list[LevelResult], list[Any]]:
        levels, warnings = shaker.with_simulated_saturation(counts[axis], levels, warnings)  # type: ignore[arg-type]
        return shaker.with_lattice_u(counts[axis], levels), warnings  # type: ignore[arg-type]

    names = {**{a: f"dut_{a}" for a in axes}, **{f"reference-{c}": f"reference_{c}" for c in AXES}}
    with open_record(path, names, None) as rec:
        return analyze_triaxial(rec, {c: f"dut:reference-{c}" for c in AXES}, {a: f"dut:{a}" for a in axes},
                                method, rec.schedule, band, settle_s, accept=ACCEPTABLE, progress=progress,
                                known=known)
