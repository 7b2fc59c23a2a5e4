"""The engine: evaluate a point function over many points on any executor, losing nothing.

A *point function* is ``f(params: Mapping[str, Any], seed: numpy.random.SeedSequence) ->
Mapping[str, float]``: plain data in, plain numbers out, and all its randomness from ``seed``.
The engine sends ``(function, [(index, params, seed), ...])`` tasks to the executor, keeps at
most a few tasks per worker in flight, and hands every finished point to ``on_records`` (the
checkpoint) as it arrives.

Failures:

* a point that raises: the exception is caught *in the worker* (so an unpicklable exception or
  a half-dead worker cannot take its neighbours along), and the point is retried up to
  ``retries`` times; then it is recorded with ``status="failed"`` and the error. A
  ``ValueError`` is bad input by the library's convention and would fail the same way again:
  it is recorded at once.
* a worker that dies (``os._exit``, segfault, OOM-kill): a process pool then fails every pending
  future with ``BrokenProcessPool`` and cannot say which point did it. The engine rebuilds the
  pool and reruns the points that were in flight *one at a time*, so a crash is pinned on the
  point that caused it before it counts as an attempt; innocent neighbours are never charged.
  dask reports such a point as ``KilledWorker`` after its own restarts, which counts as one
  attempt.
"""

from __future__ import annotations

import asyncio
import importlib
import math
import time
from collections import deque
from concurrent.futures import (
    FIRST_COMPLETED,
    BrokenExecutor,
    CancelledError,
    Future,
    wait,
)
from typing import Any, Callable, Literal, Mapping, Sequence, TypedDict, Unpack

import numpy as np

from vrelab import _keywords
from vrelab.sweep.backends import Backend
from vrelab.sweep.checkpoint import PointRecord

PointFunction = Callable[[Mapping[str, Any], np.random.SeedSequence], Mapping[str, float]]
# (index, params, (entropy, spawn_key))
Item = tuple[int, Mapping[str, Any], tuple[int, tuple[int, ...]]]

# (index, outcome, the point's values when "ok" else the error's line, wall s, CPU s): run_task's
# result for one point
TaskResult = tuple[int, Literal["ok", "error", "invalid"], dict[str, float] | str, float, float]

_resolved: dict[str, PointFunction] = {}


class SweepAborted(RuntimeError):
    """The executor itself failed (not a point): the sweep stops, resumable from its checkpoint."""


def resolve(func: str | PointFunction) -> PointFunction:
    """``"package.module:name"`` -> the function (imported once per process)."""
    if callable(func):
        return func
    if func not in _resolved:
        mod, _, attr = func.partition(":")
        try:
            obj: Any = importlib.import_module(mod)
            for part in attr.split("."):
                obj = getattr(obj, part)
        except (ImportError, AttributeError) as exc:
            raise ValueError(f"function {func!r} cannot be imported: {exc}") from None
        if not callable(obj):
            raise ValueError(f"function {func!r} is not callable")
        _resolved[func] = obj
    return _resolved[func]


def _as_values(out: object) -> dict[str, float]:
    if not isinstance(out, Mapping):
        raise TypeError(f"point function must return a mapping of name -> number, got {type(out).__name__}")
    return {str(k): float(v) for k, v in out.items()}


def run_task(func: str | PointFunction, items: Sequence[Item]) -> list[TaskResult]:
    """Worker side: evaluate each point; return (index, outcome, values-or-error, wall seconds,
    CPU seconds of the worker process) per point, outcome "ok", "error" (worth retrying) or "invalid" (a ValueError: by the library's
    convention, bad input, which fails the same way every time)."""
    f = resolve(func)
    out: list[TaskResult] = []
    for index, params, (entropy, key) in items:
        t0, c0 = time.perf_counter(), time.process_time()
        values: dict[str, float] | str
        outcome: Literal["ok", "error", "invalid"]
        try:
            values = _as_values(f(params, np.random.SeedSequence(entropy, spawn_key=key)))
            outcome = "ok"
        except Exception as exc:  # recorded, not raised: one bad point must not stop the lot
            values = f"{type(exc).__name__}: {exc}".splitlines()[0]
            outcome = "invalid" if isinstance(exc, ValueError) else "error"
        out.append((index, outcome, values, time.perf_counter() - t0, time.process_time() - c0))
    return out


class _Progress:
    def __init__(self, total: int, initial: int, enabled: bool, desc: str) -> None:
        self._bar = None
        if enabled:
            from tqdm import tqdm

            from vrelab._format import progress_stream

            self._bar = tqdm(total=total, initial=initial, desc=desc, unit="pt", file=progress_stream(), dynamic_ncols=True)

    def update(self, n: int, failed: int) -> None:
        if self._bar is not None:
            self._bar.update(n)
            if failed:
                self._bar.set_postfix(failed=failed)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


class PointPolicy(TypedDict, total=False):
    """How :func:`run_points` runs its points (its parameters' docs): ``retries`` (default 1),
    ``chunk`` (1), ``run`` (0: the checkpoint's run number each record carries), ``progress``
    (False), ``total`` (``len(items)``), ``window`` (4 tasks per worker)."""

    retries: int
    chunk: int
    run: int
    progress: bool
    total: int | None
    window: int | None


def run_points(
    func: str | PointFunction,
    items: Sequence[Item],
    backend: Backend,
    *,
    on_records: Callable[[list[PointRecord]], None] | None = None,
    **policy: Unpack[PointPolicy],
) -> dict[int, PointRecord]:
    """Evaluate ``func`` at every item on ``backend``; return index -> record (ok or failed).

    Parameters
    ----------
    func : "module:name" or callable
        The point function; a name is imported in each worker (nothing to pickle but a string).
    items : sequence of (index, params, (entropy, spawn_key))
        The points still to compute; the seed of each travels with it.
    retries : int
        Extra attempts for a point that raises or kills its worker (default 1).
    chunk : int
        Points per task: above 1 when a point costs less than the executor's per-task overhead.
    on_records : callable, optional
        Called in this process with each batch of finished records, as they finish.
    progress : bool
        A tqdm bar on stderr; ``total`` (default ``len(items)``) lets it count resumed points.
    window : int, optional
        Tasks in flight at once (default 4 per worker): bounds memory and the points a worker
        crash can strand.

    ``retries``, ``chunk``, ``run``, ``progress``, ``total`` and ``window`` are keywords, as
    before (:class:`PointPolicy`).
    """
    _keywords.merged("run_points", list(PointPolicy.__annotations__), (), policy)  # an unknown keyword: TypeError
    retries, chunk = policy.get("retries", 1), policy.get("chunk", 1)
    if retries < 0 or chunk < 1:
        raise ValueError(f"retries must be >= 0 and chunk >= 1, got retries={retries}, chunk={chunk}")
    return _PointRun(func, items, backend, on_records, policy).run_all()


class _PointRun:
    """One call of :func:`run_points`: its queues, attempts and results, and the steps of its loop
    (submit a window of tasks, collect what finished, recover from a broken pool)."""

    def __init__(self, func: str | PointFunction, items: Sequence[Item], backend: Backend,
                 on_records: Callable[[list[PointRecord]], None] | None, policy: PointPolicy) -> None:
        self.func, self.backend, self.on_records = func, backend, on_records
        self.retries, self.chunk, self.run = policy.get("retries", 1), policy.get("chunk", 1), policy.get("run", 0)
        self.by_index = {it[0]: it for it in items}
        self.todo: deque[int] = deque(self.by_index)
        self.suspects: deque[int] = deque()  # rerun alone after a worker crash, to find the culprit
        self.attempts: dict[int, int] = {}
        self.results: dict[int, PointRecord] = {}
        self.inflight: dict[Future[list[TaskResult]], list[int]] = {}
        self.window = policy.get("window") or max(2, 4 * backend.n_workers)
        total = policy.get("total")
        n_total = total if total is not None else len(items)
        self.bar = _Progress(n_total, n_total - len(items), policy.get("progress", False), "sweep")
        self.n_failed = 0
        self.isolated: Future[list[TaskResult]] | None = None  # the lone task run after a crash, to pin the crash on it
        self.pending: list[PointRecord] = []  # finished in this turn of the loop: one checkpoint write

    def run_all(self) -> dict[int, PointRecord]:
        try:
            while self.todo or self.suspects or self.inflight:
                self.step()
        finally:
            self.flush()  # whatever finished before an interrupt still reaches the checkpoint
            self.bar.close()
        return self.results

    def finish(self, recs: list[PointRecord]) -> None:
        self.pending.extend(recs)

    def flush(self) -> None:
        recs = self.pending[:]
        self.pending.clear()
        if not recs:
            return
        for r in recs:
            self.results[r.index] = r
        self.n_failed += sum(r.status == "failed" for r in recs)
        if self.on_records is not None:
            self.on_records(recs)
        self.bar.update(len(recs), self.n_failed)

    def attempt_failed(
        self, i: int, error: str, elapsed: float, queue: deque[int], final: bool = False
    ) -> PointRecord | None:
        self.attempts[i] = self.attempts.get(i, 0) + 1
        if final or self.attempts[i] > self.retries:
            return PointRecord(i, "failed", {}, error, self.attempts[i], elapsed, self.run)
        queue.appendleft(i)
        return None

    def submit(self, idx: list[int]) -> Future[list[TaskResult]]:
        try:
            fut = self.backend.executor.submit(run_task, self.func, [self.by_index[i] for i in idx])
        except BrokenExecutor as exc:  # the pool broke since the last wait: handled as a crash below
            fut = Future()
            fut.set_exception(exc)
        self.inflight[fut] = idx
        return fut

    def collect(self, fut: Future[list[TaskResult]], idx: list[int], crashed: list[int]) -> None:
        try:
            out = fut.result()
        except BrokenExecutor:
            crashed.extend(idx)
            return
        except (CancelledError, asyncio.CancelledError):
            # not the point's doing: the executor shut down or lost its scheduler. Recording
            # these points as failed would make a resume skip them; stop instead.
            raise SweepAborted(
                f"{self.backend.name} executor cancelled its tasks (shut down or disconnected); "
                "finished points are in the checkpoint: rerun to resume"
            ) from None
        except Exception as exc:  # KilledWorker, an unpicklable argument or result...
            if len(idx) > 1:  # a whole chunk failed: rerun its points alone to find which one
                self.suspects.extend(idx)
                return
            msg = f"{type(exc).__name__}: {exc}".splitlines()[0]
            self.finish([r for r in [self.attempt_failed(idx[0], msg, math.nan, self.todo)] if r is not None])
            return
        recs = []
        for i, outcome, payload, dt, cpu in out:
            if isinstance(payload, dict):  # outcome "ok" (run_task gives values exactly then)
                recs.append(PointRecord(i, "ok", payload, None, self.attempts.get(i, 0) + 1, dt, self.run, cpu))
            elif (r := self.attempt_failed(i, payload, dt, self.todo, final=outcome == "invalid")) is not None:
                recs.append(r)
        self.finish(recs)

    def step(self) -> None:
        """Submit (the next suspect alone, or a window of tasks), wait for the first to finish,
        collect what finished, and recover if the pool broke."""
        if self.suspects:
            if not self.inflight:
                self.isolated = self.submit([self.suspects.popleft()])
        else:
            while self.todo and len(self.inflight) < self.window:
                self.submit([self.todo.popleft() for _ in range(min(self.chunk, len(self.todo)))])
        done, _ = wait(list(self.inflight), return_when=FIRST_COMPLETED)
        crashed: list[int] = []
        for fut in sorted(done, key=lambda f: self.inflight[f][0]):  # index order when several land
            self.collect(fut, self.inflight.pop(fut), crashed)
        self.flush()
        if crashed:
            self.recover(crashed, done)

    def recover(self, crashed: list[int], done: set[Future[list[TaskResult]]]) -> None:
        """The pool is broken: every other pending future fails too. Gather them all, then
        replace the pool and pin the crash on the lone task, or rerun the crashed points alone."""
        culprit = crashed[0] if self.isolated is not None and self.isolated in done else None
        for fut in list(self.inflight):
            wait([fut])
            self.collect(fut, self.inflight.pop(fut), crashed)
        self.isolated = None
        if not self.backend.can_reset:
            self.flush()  # the crashed points stay unfinished: a resume computes them
            raise SweepAborted(f"{self.backend.name} executor broke (a worker died) and cannot be replaced")
        self.backend.reset()
        if culprit is not None:
            msg = "worker process died while computing this point (BrokenProcessPool)"
            self.finish([r for r in [self.attempt_failed(culprit, msg, math.nan, self.suspects)] if r is not None])
        else:
            self.suspects.extend(sorted(crashed))
        self.flush()
