"""Reducing a campaign's runs: each run's record read and analysed (in processes with
``workers``), a failed run kept with its error; the units check over the runs."""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

from vrelab import _validate as V
from vrelab._io import sha256_file
from vrelab.results import VreResult

if TYPE_CHECKING:
    from vrelab.sensor import Sensor

from vrelab.campaigns.manifest import Manifest, ManifestContradiction, Mount, Run, check_static, run_scales


@dataclass
class RunResult:
    """One run reduced (``error`` set when it failed): per channel its result.

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import reduce_run
    >>> result = reduce_run(read_manifest("examples/campaign/one-run.toml").runs[0])
    >>> name, vre_result = result.results[0]
    >>> print(name, len(vre_result.levels), result.error)
    sn1 3 None
    """

    run: Run
    results: list[tuple[str, VreResult]] = field(default_factory=list)
    error: str | None = None
    folder: str | None = None  # sub-folder of the campaign folder, when written
    # channel -> (kind, frequency, DUT/reference ratio) of each level: the campaign's units check
    unit_probes: dict[str, list[tuple[str | None, float, float]]] = field(default_factory=dict)
    # channel -> the DUT's mean vibration-off reading [g]: the units check's range test
    off_reading_g: dict[str, float | None] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.error is None


def reduce_run(run: Run, out: Path | None = None, progress: bool = False, limit_g: float | None = None) -> RunResult:
    """Reduce one run: its record opened with every DUT, each reduced against the reference
    (:func:`vrelab.analysis.pipeline.analyze_channels`). With ``out`` the run's folder is
    written there (a ``results.json`` of its channels and a sub-folder per channel).

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import reduce_run
    >>> result = reduce_run(read_manifest("examples/campaign/one-run.toml").runs[0])
    >>> result.error, [name for name, _ in result.results]
    (None, ['sn1'])
    """
    from vrelab.analysis.options import BudgetOptions, ReductionOptions
    from vrelab.analysis.pipeline import analyze_channels
    from vrelab.analysis.readers import open_record
    from vrelab.gum import TypeB
    from vrelab.profiles import parse_profile
    from vrelab.record import DEFAULT_SETTLE_S, Schedule

    dut_scales, ref_scale = run_scales(run)
    profile = parse_profile(run.profile) if run.profile else None
    schedule = Schedule.read_csv(run.schedule) if run.schedule else None
    prov = {"input_file": run.file.name, "input_sha256": sha256_file(run.file), "run": run.index, "label": run.label}
    with open_record(run.file, dict(run.dut), run.reference, run.fs_hz, dut_scales, ref_scale, run.time) as rec:
        reduced = analyze_channels(
            rec, None, run.method, schedule, static_g=dict(run.static_g),
            options=ReductionOptions(
                band_hz=run.band, rail_g=run.rail_g, progress=progress, profile=profile,
                settle_s=DEFAULT_SETTLE_S if run.settle_s is None else run.settle_s,
                # the units are judged per channel over all runs (run_campaign), not run by run: a
                # sweep's run at the DUT's resonance has DUT/reference = Q, and is not a slip
                accept=frozenset({"unit-ratio"}),
            ),
            budget=BudgetOptions(TypeB.from_mapping(run.budget) if run.budget else None, limit_g),
            provenance=prov,
        )  # fmt: skip
    for name, _, red in reduced:
        check_static(run, name, red.static_g)
    res = RunResult(run, [(name, result) for name, result, _ in reduced],
                    unit_probes={name: list(red.unit_probes) for name, _, red in reduced},
                    off_reading_g={name: red.static_g for name, _, red in reduced})
    if out is not None:
        from vrelab import folder as F
        from vrelab.results import channels_to_dict

        F.write_channels(out, res.results, channels_to_dict(res.results, prov))
    return res


def _reduce_safely(run: Run, out: Path | None, limit_g: float | None = None) -> RunResult:
    try:
        return reduce_run(run, out, limit_g=limit_g)
    except ManifestContradiction:
        raise  # the manifest is wrong: the whole campaign is refused
    except MemoryError:
        return RunResult(run, error="out of memory")
    except Exception as exc:  # a run's failure is reported with the others kept
        from vrelab._io import is_disk_full

        if is_disk_full(exc):  # not the run's failure: the whole campaign stops, nothing written
            raise OSError(28, "No space left on device") from None
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if not isinstance(exc, (ValueError, OSError)):
            msg = f"internal error: {type(exc).__name__}: {msg}"
        return RunResult(run, error=msg)


def run_campaign(manifest: Manifest, workers: int = 1, out: Path | None = None,
                 on_done: Callable[[RunResult], None] | None = None, limit_g: float | None = None) -> list[RunResult]:
    """Reduce every run (``workers`` processes; 1: here, in order). A failing run is kept with
    its error; a run whose record contradicts the manifest (:class:`ManifestContradiction`)
    refuses the campaign. With ``out``, run ``i`` is written to ``out/runs/<NN-label>``. Each run's budget
    keys (physics §4.3) give its levels and fits their Type B terms; ``limit_g`` decides each level.

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import run_campaign
    >>> results = run_campaign(read_manifest("examples/campaign/one-run.toml"))
    >>> [(r.run.index, r.error) for r in results]
    [(1, None)]
    """
    workers = V.integer("workers", workers, 1)
    subs = run_folders(manifest)
    dests = [None if out is None else out / "runs" / subs[r.index] for r in manifest.runs]
    results: list[RunResult]
    if workers == 1 or len(manifest.runs) == 1:
        results = []
        for run, dest in zip(manifest.runs, dests):
            results.append(_reduce_safely(run, dest, limit_g))
            if on_done:
                on_done(results[-1])
    else:
        from vrelab._pool import worker_pool  # workers die with this process (Ctrl-C, SIGTERM, SIGKILL)

        with worker_pool(min(workers, len(manifest.runs))) as pool:
            futures = [pool.submit(_reduce_safely, run, dest, limit_g) for run, dest in zip(manifest.runs, dests)]
            results = []
            for fut in futures:
                results.append(fut.result())
                if on_done:
                    on_done(results[-1])
    slipped = judge_units(results, manifest.sensors)
    for r, dest in zip(results, dests):
        if dest is not None and r.ok:
            r.folder = f"runs/{dest.name}"
        elif dest is not None and any(r is s for s in slipped) and dest.exists():
            shutil.rmtree(dest)  # written before the campaign's units check refused it
    return results


def dut_range(run: Run, channel: str, sensor: Sensor | None) -> tuple[float | None, str]:
    """The DUT's range [g] and where it comes from: the sensor file's full scale, else the run's
    ``rail_g``, else None (unknown).

    Examples
    --------
    Neither a sensor file nor a range in the manifest: the range is not known (None, no source),
    and the checks that need it say so:

    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import dut_range
    >>> dut_range(read_manifest("examples/campaign/one-run.toml").runs[0], "sn1", None)
    (None, '')
    """
    if sensor is not None:
        return sensor.full_scale_g, f"the sensor file {sensor.name!r}"
    if run.rail_g is not None:
        return run.rail_g, "the run's rail_g"
    return None, ""


def judge_units(results: Sequence[RunResult], sensors: Mapping[str, Sensor] | None = None) -> list[RunResult]:
    """physics §4.1/4.2's units check of every DUT channel over its runs; the runs it refuses are
    failed with the reason (their results dropped) and returned. In order:

    1. a run whose DUT reads, with vibration off, orders of magnitude beyond its range
       (:func:`vrelab.analysis.plausibility.off_reading_slip`);
    2. a run whose DUT/reference ratio departs from what the DUT's response allows at its
       frequency, or from the channel's other runs
       (:func:`vrelab.analysis.plausibility.judge_runs_units`; ``sensors`` gives a channel's
       response, else the stated default);
    3. a slip common to every run of a channel, judged where its response is flat
       (:func:`vrelab.analysis.plausibility.check_units_over_runs`): every run holding it fails.

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import judge_units, run_campaign
    >>> results = judge_units(run_campaign(read_manifest("examples/campaign/one-run.toml")))
    >>> [r.error for r in results]
    []
    """
    from vrelab.analysis.plausibility import check_units_over_runs, judge_runs_units, off_reading_slip

    sensors = sensors or {}
    failed: list[RunResult] = []

    def fail(r: RunResult, msg: str) -> None:
        r.error = msg
        r.results = []
        failed.append(r)

    for r in results:
        if not r.ok:
            continue
        for ch, reading in r.off_reading_g.items():
            msg = off_reading_slip(ch, reading, *dut_range(r.run, ch, sensors.get(ch)))
            if msg is not None:
                fail(r, msg)
                break
    channels = list(dict.fromkeys(ch for r in results for ch in r.unit_probes))
    for ch in channels:
        sensor = sensors.get(ch)
        gain = None if sensor is None else _gain(sensor)
        runs = [(r.run.index, _mount_probes(r.run.mount.get(ch), r.unit_probes[ch]))
                for r in results if r.ok and ch in r.unit_probes]
        refused = judge_runs_units(ch, runs, gain)
        for r in results:
            if r.ok and r.run.index in refused:
                fail(r, refused[r.run.index])
    for ch in channels:
        probes = [p for r in results if r.ok and ch in r.unit_probes
                  for p in _mount_probes(r.run.mount.get(ch), r.unit_probes[ch])]
        msg = check_units_over_runs(ch, probes)
        if msg is None:
            continue
        for r in results:
            if r.ok and ch in r.unit_probes:
                fail(r, msg)
    return failed


def _gain(sensor: Sensor) -> Callable[[float], float]:
    """|H(f)| of the sensor's output (every linear stage: resonance, filters)."""
    return lambda f: float(abs(sensor.response(f)))


# A DUT mounted at φ sees cos φ of the vibration along its input axis: its DUT/reference ratio is
# judged divided by |cos φ| where that is at least this (a 90° run reads the cross-axis feed only).
_MOUNT_PROBE_COS = 0.5


def _mount_probes(mount: Mount | None, probes: Sequence[tuple[str | None, float, float]]
                  ) -> list[tuple[str | None, float, float]]:
    """A run's units probes of one channel as the units check reads them: a mount-angle run's
    DUT/reference ratio divided by its expected |cos φ|; none where |cos φ| < ``_MOUNT_PROBE_COS``."""
    if mount is None:
        return list(probes)
    c = abs(mount.direction[0])
    return [] if c < _MOUNT_PROBE_COS else [(k, f, ratio / c) for k, f, ratio in probes]


def run_folders(manifest: Manifest) -> dict[int, str]:
    """Run index -> its sub-folder name, ``NN-<label>``.

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import run_folders
    >>> run_folders(read_manifest("examples/campaign/one-run.toml"))
    {1: '01-01_z_up_80hz.tdms'}
    """
    from vrelab.folder import channel_folder_names

    names = channel_folder_names([f"{r.index:02d}-{r.label}" for r in manifest.runs])
    return {r.index: names[f"{r.index:02d}-{r.label}"] for r in manifest.runs}
