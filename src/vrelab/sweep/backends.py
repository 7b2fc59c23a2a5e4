"""Where points run: anything with the ``concurrent.futures.Executor`` interface.

* :class:`SerialBackend`: an in-process executor (no pickling, no processes; a point that kills
  the process kills the sweep, but the checkpoint keeps what finished).
* :class:`ProcessBackend`: ``ProcessPoolExecutor`` on a ``spawn`` context (no fork: the parent
  may hold threads, locks and open HDF5 files that a forked child would inherit half-copied).
  After a worker dies the pool is broken for good; :meth:`ProcessBackend.reset` makes a new one.
* :class:`DaskBackend`: ``dask.distributed``: ``Client(address).get_executor()``, or a
  ``LocalCluster`` it starts itself (``address="local"`` or ``"local:N"``). dask is an optional
  extra, imported only here and only when asked for.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import TYPE_CHECKING, Any, Callable, ParamSpec, TypeVar

if TYPE_CHECKING:
    import distributed

_P = ParamSpec("_P")
_T = TypeVar("_T")


class SerialExecutor(Executor):
    """Runs each call at submit time, in this process, and returns a finished future."""

    def submit(self, fn: Callable[_P, _T], /, *args: _P.args, **kwargs: _P.kwargs) -> Future[_T]:
        fut: Future[_T] = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the caller reads it from the future, as from a pool
            if isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            fut.set_exception(exc)
        return fut


class Backend:
    """An executor plus what the engine needs around it: a name, a size, a way to start over."""

    name = "custom"

    def __init__(self, executor: Executor | None = None, n_workers: int = 1) -> None:
        self._executor = executor
        self.n_workers = n_workers

    @property
    def executor(self) -> Executor:
        if self._executor is None:
            raise ValueError("backend has no executor")
        return self._executor

    @property
    def can_reset(self) -> bool:
        return False

    def reset(self) -> None:
        """Replace a broken executor (a worker died); only pools that can be rebuilt do this."""
        raise RuntimeError(f"{self.name} backend cannot replace a broken executor")

    def close(self) -> None:
        pass

    def abort(self) -> None:
        """End now, on an interruption; by default as :meth:`close`."""
        self.close()

    def describe(self) -> dict[str, Any]:
        return {"backend": self.name, "n_workers": self.n_workers}

    def __enter__(self) -> Backend:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SerialBackend(Backend):
    name = "serial"

    def __init__(self) -> None:
        super().__init__(SerialExecutor(), 1)


class ProcessBackend(Backend):
    """``ProcessPoolExecutor(max_workers=n)`` on a spawn (default) or forkserver context."""

    name = "processes"

    def __init__(self, n_workers: int, context: str = "spawn") -> None:
        if isinstance(n_workers, bool) or not isinstance(n_workers, int) or n_workers < 1:
            raise ValueError(f"workers must be an integer >= 1, got {n_workers!r}")
        if context not in ("spawn", "forkserver"):
            raise ValueError(f"context must be spawn or forkserver, got {context!r}")
        super().__init__(None, n_workers)
        self.context = context
        self.resets = 0
        self._executor = self._new()

    def _new(self) -> ProcessPoolExecutor:
        from vrelab._pool import process_pool

        # a worker dies with the sweep (vrelab._pool); a point that must outlive it cannot exist
        return process_pool(self.n_workers, multiprocessing.get_context(self.context))

    @property
    def can_reset(self) -> bool:
        return True

    def reset(self) -> None:
        old = self._executor
        self._executor = self._new()
        self.resets += 1
        if old is not None:
            old.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    def abort(self) -> None:
        """Interrupted (Ctrl-C, SIGTERM): end the workers now instead of waiting for their points."""
        if self._executor is not None:
            from vrelab._pool import stop

            stop(self._executor)
            self._executor = None

    def describe(self) -> dict[str, Any]:
        return {"backend": self.name, "n_workers": self.n_workers, "context": self.context}


def _import_distributed() -> Any:
    try:
        import distributed
    except ImportError:
        raise ValueError(
            "--scheduler needs dask.distributed: pip install 'vrelab[dask]'"
        ) from None
    return distributed


# How long a scheduler address may take to answer as a Dask scheduler [s].
CONNECT_TIMEOUT_S = 10.0


class DaskBackend(Backend):
    """A ``dask.distributed`` client's executor.

    ``address``: a scheduler address (``tcp://host:8786``), or ``"local"`` / ``"local:N"`` for a
    ``LocalCluster`` of N single-threaded worker processes (default 2) that this backend owns and
    closes; or pass an existing ``client`` (not closed here).

    Tasks are submitted with ``pure=False``: dask would otherwise key a task by its arguments and
    hand back the old failed future when a point is retried. A worker that dies is replaced by its
    nanny and dask reruns its task elsewhere; a task that has killed
    ``distributed.scheduler.allowed-failures`` workers comes back as ``KilledWorker``, which the
    engine counts as one failed attempt of that point.
    """

    name = "dask"

    def __init__(self, address: str | None = None, *, client: distributed.Client | None = None) -> None:
        distributed = _import_distributed()
        self._cluster = None
        self._own_client = client is None
        if client is None:
            if address is None:
                raise ValueError("scheduler address is missing")
            n_local = local_workers(address)
            if n_local is not None:
                import dask

                # the workers' sampling profiler (every 10 ms) and GIL monitor (every 1 ms) take
                # CPU from the points, which shows on a 2-core machine; a sweep does not need them.
                # dashboard ":0": any free port (None still binds 8787, so two clusters clash)
                quiet = {"distributed.worker.profile.enabled": False, "distributed.admin.system-monitor.gil.enabled": False}
                with dask.config.set(quiet):
                    self._cluster = distributed.LocalCluster(
                        n_workers=n_local, threads_per_worker=1, processes=True, dashboard_address=":0"
                    )
                client = distributed.Client(self._cluster, set_as_default=False)
            else:
                try:
                    client = distributed.Client(address, timeout=f"{CONNECT_TIMEOUT_S:g}s", set_as_default=False)
                except Exception as exc:  # a port that is not a Dask scheduler fails in any of many ways
                    first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                    raise ValueError(
                        f"--scheduler {address}: no Dask scheduler answered within {CONNECT_TIMEOUT_S:g} s "
                        f"({type(exc).__name__}: {first})"
                    ) from None
        self.client = client
        n_workers = max(1, sum(client.nthreads().values()))
        super().__init__(client.get_executor(pure=False), n_workers)

    def close(self) -> None:
        if self._own_client:
            self.client.close()
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def describe(self) -> dict[str, Any]:
        scheduler = self.client.scheduler
        assert scheduler is not None  # a connected client's (typed optional: None before it starts)
        return {"backend": self.name, "n_workers": self.n_workers, "scheduler": scheduler.address}


def local_workers(address: str) -> int | None:
    """N of a ``"local"`` / ``"local:N"`` scheduler address (2 by default); None for others."""
    if address != "local" and not address.startswith("local:"):
        return None
    n = address.partition(":")[2] or "2"
    if not n.isdigit() or int(n) < 1:
        raise ValueError(f"--scheduler local:N needs N >= 1, got {address!r}")
    return int(n)


def check_backend_args(workers: int | None, scheduler: str | None) -> None:
    """Reject bad --workers / --scheduler values before anything is created."""
    if workers is not None and scheduler is not None:
        raise ValueError("give --workers or --scheduler, not both")
    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"--workers must be an integer >= 1, got {workers!r}")
        if workers > (os.cpu_count() or 1) * 4:
            raise ValueError(f"--workers must be at most 4 x the {os.cpu_count()} cores, got {workers}")
    if scheduler is not None:
        if not isinstance(scheduler, str) or not scheduler:
            raise ValueError(f"--scheduler must be an address, got {scheduler!r}")
        local_workers(scheduler)


def make_backend(workers: int | None = None, scheduler: str | None = None) -> Backend:
    """Serial (neither given), a process pool of ``workers``, or dask at ``scheduler``."""
    check_backend_args(workers, scheduler)
    if scheduler is not None:
        return DaskBackend(scheduler)
    if workers is not None:
        return ProcessBackend(workers)
    return SerialBackend()
