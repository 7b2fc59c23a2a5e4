"""Parameter sweeps and Monte Carlo lots, on one core, a process pool or a Dask cluster.

A sweep file (:mod:`vrelab.sweep.spec`) names a *point kind* (an analytic ``model`` point, a
``predict`` point, a simulated shaker test ``simulate``, or any ``python`` function), a grid of
parameters and/or a Monte Carlo lot, and a seed. :func:`run_sweep` evaluates every point on a
backend (:mod:`vrelab.sweep.backends`) through the engine (:mod:`vrelab.sweep.engine`), writes
each finished point to a checkpoint in the output folder as it finishes
(:mod:`vrelab.sweep.checkpoint`), and at the end writes the labelled result, an xarray
Dataset as NetCDF plus a flat CSV (:mod:`vrelab.sweep.dataset`), complete or not at all.

Rerunning an interrupted sweep with the same output folder resumes it: finished points (failed
ones included) are read back, not recomputed. Results depend only on the sweep file: each point
gets its own ``SeedSequence`` from its index, so serial, process-pool and Dask runs agree to the
bit.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence, TypedDict, Unpack, cast

from vrelab import _io, _keywords
from vrelab._display import Shown
from vrelab.folder import SWEEP_RESULT
from vrelab.sweep.backends import (
    Backend,
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    SerialExecutor,
    check_backend_args,
    make_backend,
)
from vrelab.sweep.checkpoint import CHECKPOINT_NAME, Checkpoint, PointRecord
from vrelab.sweep.engine import (
    Item,
    PointFunction,
    PointPolicy,
    SweepAborted,
    resolve,
    run_points,
    run_task,
)
from vrelab.sweep.spec import SweepSpec, load_spec, parse_spec

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "Backend",
    "CHECKPOINT_NAME",
    "Checkpoint",
    "DaskBackend",
    "PointFunction",
    "PointRecord",
    "ProcessBackend",
    "SerialBackend",
    "SerialExecutor",
    "SweepAborted",
    "SweepResult",
    "SweepSpec",
    "load_spec",
    "make_backend",
    "parse_spec",
    "point_function",
    "run_points",
    "run_sweep",
    "run_task",
]

POINT_FUNCTIONS = {
    "model": "vrelab.sweep.points:model_point",
    "predict": "vrelab.sweep.points:predict_point",
    "simulate": "vrelab.sweep.points:simulate_point",
}
RESULT_NC = SWEEP_RESULT  # the name vrelab.folder owns
RESULT_CSV = "result.csv"
RESULT_ZARR = "result.zarr"
SUMMARY = "sweep.json"


def check_time_budget(spec: SweepSpec) -> None:
    """Refuse, before anything starts, a ``simulate`` sweep whose points together are beyond the
    time budget (:func:`vrelab._budget.check_simulation`, the owner ``vrelab simulate`` refuses
    by): each point's internal samples from its plan (:func:`vrelab.sweep.points.simulate_plan`),
    summed over every point (compute time, whatever the workers). A point whose plan is invalid
    counts nothing here (it fails as a point). Plans are sized once per distinct set of the
    parameters that change their size (a random test's length does not depend on its level)."""
    if spec.kind != "simulate":
        return
    from vrelab import _budget
    from vrelab.sweep.points import simulate_plan

    units = [spec.unit_params(u) for u in range(spec.units or 0)]
    sizes: dict[Any, float] = {}
    total = 0.0
    for params in (spec.point_params(i, units) for i in range(spec.n_points)):
        level_free = "profile" in params  # a random plan's samples: seconds x rate, whatever the level
        key = tuple(sorted((k, repr(v)) for k, v in params.items() if not (level_free and k in ("rms_g", "static_g"))))
        if key not in sizes:
            try:
                sizes[key] = simulate_plan(params).internal_samples()
            except ValueError:
                sizes[key] = 0.0
        total += sizes[key]
    _budget.check_simulation(f"sweep: {spec.n_points} simulate point(s)", total)


def point_function(spec: SweepSpec) -> str:
    """The importable name of the point function of ``spec`` (checked here, not in a worker)."""
    ref = spec.function if spec.kind == "python" else POINT_FUNCTIONS[spec.kind]
    assert ref is not None
    resolve(ref)
    return ref


@dataclass(frozen=True, repr=False)
class SweepResult(Shown):
    """What :func:`run_sweep` produced: the Dataset, every point's record, a summary, the files."""

    spec: SweepSpec
    dataset: Any  # xarray.Dataset
    records: Mapping[int, PointRecord]
    summary: Mapping[str, Any]
    files: Mapping[str, Path]

    def display_fields(self) -> list[tuple[str, Any]]:  # the Dataset has its own repr and to_dataframe()
        return [("points", len(self.records)), ("summary", self.summary), ("files", ", ".join(self.files))]


class SweepRunOptions(TypedDict, total=False):
    """The keywords of :func:`run_sweep` that choose a backend and override the file's run
    settings: ``workers``, ``scheduler``, ``retries``, ``chunk``, ``retry_failed`` (its
    parameters' docs)."""

    workers: int | None
    scheduler: str | None
    retries: int | None
    chunk: int | None
    retry_failed: bool


def run_sweep(
    spec: SweepSpec,
    out_dir: str | Path,
    *,
    backend: Backend | None = None,
    fresh: bool = False,
    progress: bool = False,
    inputs: Sequence[str | Path] = (),
    **options: Unpack[SweepRunOptions],
) -> SweepResult:
    """Run (or resume) ``spec`` with its checkpoint and outputs in ``out_dir``.

    Parameters
    ----------
    spec : SweepSpec
        From :func:`load_spec` / :func:`parse_spec`.
    out_dir : path
        Holds ``checkpoint.jsonl`` (appended as points finish), then ``result.nc``,
        ``result.csv`` (and ``result.zarr`` if asked) and ``sweep.json``, written together at
        the end.
    backend : Backend, optional
        Where to run; else ``workers`` (a process pool) or ``scheduler`` (a dask address, or
        ``"local[:N]"``), else serially in this process. A backend made here is closed here.
    fresh : bool
        Discard an existing checkpoint instead of resuming from it.
    retries, chunk : int, optional
        Override the file's values (they do not change the results).
    retry_failed : bool
        On resume, compute again the points the checkpoint holds as failed (after fixing what
        made them fail); finished ``ok`` points are still never recomputed.
    inputs : paths, optional
        Files the sweep reads besides those its points name (the sweep file): ``out_dir`` must
        not hold them (:func:`vrelab._io.check_output`; the points' sensor and profile files
        are added here).

    ``workers``, ``scheduler``, ``retries``, ``chunk`` and ``retry_failed`` are taken as
    keywords, as before (:class:`SweepRunOptions`).
    """
    o = cast(SweepRunOptions, _keywords.merged("run_sweep", list(SweepRunOptions.__annotations__), (), options))
    workers, scheduler = o.get("workers"), o.get("scheduler")
    func = point_function(spec)
    check_time_budget(spec)
    if "zarr" in spec.formats:  # fail now, not after the last point
        from vrelab.sweep.dataset import require_zarr

        require_zarr()
    retries, chunk = _run_settings(spec, o.get("retries"), o.get("chunk"))
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out exists and is not a folder: {out}")
    own = backend is None
    if own:
        check_backend_args(workers, scheduler)
    from vrelab.profiles import split_tones
    from vrelab.sweep.checkpoint import QUARANTINE_NAME

    reads = [*inputs, *(split_tones(n)[0].strip() for n in spec.inputs())]
    # the folder must be new, empty or a vrelab one holding none of the inputs; it is marked
    # vrelab's before the checkpoint is written into it, so an interrupted sweep can resume
    _io.claim(out, reads, entries=[CHECKPOINT_NAME, QUARANTINE_NAME])
    units = [spec.unit_params(u) for u in range(spec.units or 0)]
    with Checkpoint(out, spec.fingerprint(), spec.n_points, lambda i: spec.point_key(i, units), fresh=fresh,
                    inputs=spec.inputs()) as ck:
        quarantined = [{"line": n, "why": why} for n, _, why in ck.quarantined]
        keep = {i for i, r in ck.records.items() if r.status == "ok" or not o.get("retry_failed", False)}
        resumed = len(keep)
        items = [(i, spec.point_params(i, units), spec.point_seed(i)) for i in range(spec.n_points) if i not in keep]
        t0 = time.perf_counter()
        if own:
            backend = make_backend(workers, scheduler) if items else SerialBackend()
        assert backend is not None
        described = _compute(func, items, backend, own, ck, retries=retries, chunk=chunk, run=ck.run,
                             progress=progress, total=spec.n_points)
        elapsed = time.perf_counter() - t0
        records = dict(ck.records)
        run = ck.run

    from vrelab.sweep import dataset as D

    ds = D.to_dataset(spec, records)
    n_failed = sum(r.status == "failed" for r in records.values())
    summary: dict[str, Any] = {
        "name": spec.name,
        "kind": spec.kind,
        "fingerprint": spec.fingerprint(),
        "out": str(out),
        "n_points": spec.n_points,
        "n_ok": len(records) - n_failed,
        "n_failed": n_failed,
        "n_computed": len(items),
        "n_resumed": resumed,
        "n_quarantined": len(quarantined),
        "quarantined": quarantined[:20],
        "run": run,
        "dims": dict(zip(spec.dims, spec.shape)),
        "variables": D.variable_names(spec, records),
        **described,
        "elapsed_s": elapsed,
        "points_per_s": len(items) / elapsed if items and elapsed > 0 else None,
        "failed": [{"index": i, "error": r.error} for i, r in sorted(records.items()) if r.status == "failed"][:20],
        "spec": spec.to_dict(),
    }
    return SweepResult(spec, ds, records, summary, _write_outputs(spec, ds, records, summary, out, reads))


def _run_settings(spec: SweepSpec, retries: int | None, chunk: int | None) -> tuple[int, int]:
    """(retries, chunk): the caller's overrides, else the sweep file's; checked."""
    retries = spec.retries if retries is None else retries
    chunk = spec.chunk if chunk is None else chunk
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise ValueError(f"retries must be an integer >= 0, got {retries!r}")
    if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
        raise ValueError(f"chunk must be an integer >= 1, got {chunk!r}")
    return retries, chunk


def _compute(func: str, items: Sequence[Item], backend: Backend, own: bool, ck: Checkpoint,
             **policy: Unpack[PointPolicy]) -> dict[str, Any]:
    """Run the points still to compute into the checkpoint; the backend's description for the
    summary. A backend made by :func:`run_sweep` (``own``) is ended on an interrupt (Ctrl-C,
    SIGTERM: the workers are ended, the checkpoint kept) and closed in any case."""
    try:
        run_points(func, items, backend, on_records=ck.append, **policy)
        # nothing to compute (every point from the checkpoint): say so, claim no backend
        return backend.describe() if items else {"backend": "none: nothing computed", "n_workers": 0}
    except BaseException:
        if own:
            backend.abort()
        raise
    finally:
        if own:
            backend.close()


def _write_outputs(spec: SweepSpec, ds: xr.Dataset, records: Mapping[int, PointRecord], summary: dict[str, Any],
                   out: Path, reads: Sequence[str | Path]) -> dict[str, Path]:
    """Write the result files the spec asks for and the summary, together (one staged
    directory), into ``out``; the files by format, and ``summary``."""
    from vrelab.sweep import dataset as D

    names = {"netcdf": RESULT_NC, "csv": RESULT_CSV, "zarr": RESULT_ZARR}
    files = {f: out / names[f] for f in spec.formats}
    summary["files"] = {f: str(p) for f, p in files.items()}
    with _io.output_dir(out, replace=False, inputs=reads) as stage:
        if "netcdf" in spec.formats:
            D.write_netcdf(ds, stage / RESULT_NC)
        if "csv" in spec.formats:
            D.write_csv(spec, records, stage / RESULT_CSV)
        if "zarr" in spec.formats:
            D.write_zarr(ds, stage / RESULT_ZARR)
        _io.write_json(stage / SUMMARY, summary)
    files["summary"] = out / SUMMARY
    return files
