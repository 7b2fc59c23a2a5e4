"""Process pools whose workers never outlive the run.

Every pool of vrelab (``campaign --workers``, ``identify --workers``, a sweep's process backend)
is made here, so its workers:

* die with their parent, however it ends. SIGKILL leaves the parent no chance to stop them, and
  a worker waiting for work holds its own end of the task queue, so it would wait forever. The
  worker initializer asks Linux for ``PR_SET_PDEATHSIG`` (SIGKILL when the parent goes; through
  ``ctypes``: the standard library has no binding) and, everywhere, starts a thread that polls
  the parent's id (what remains when prctl is missing). PR_SET_PDEATHSIG fires when the *thread*
  that created the worker ends; our pools create workers from the thread that submits and uses
  them (``ProcessPoolExecutor`` spawns in ``submit`` unless ``max_tasks_per_child`` is set, never
  used here), which outlives them.
* leave SIGINT to the parent (Ctrl-C reaches the whole process group: the parent decides) and
  take SIGTERM's default action (a forked worker would inherit the command line's handler).
* run their BLAS on one thread (the workers are the parallelism);
* are terminated, not waited for, when the parent is interrupted: :func:`worker_pool` ends
  them on any exception (Ctrl-C, SIGTERM, an error) before the caller's staging is removed.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from typing import TYPE_CHECKING, Iterator

if TYPE_CHECKING:
    from multiprocessing.context import BaseContext

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def worker_init(parent_pid: int, period_s: float = 0.5, deathsig: bool = True) -> None:
    """Pool-worker initializer: ignore SIGINT, default SIGTERM, exit when the parent is gone,
    one BLAS thread."""
    # The pool's processes are the parallelism: a worker's BLAS (OpenBLAS starts a thread per
    # core in every process, inherited through fork) would put 2 x n_workers busy threads on the
    # cores, and the small solves of a reduction or a fit wake them all. threadpoolctl sets the
    # loaded BLAS's own limit (an environment variable is read only when the library loads, in
    # the parent, before the fork). bench/bench_campaign.py, 2 workers: 4.5 s -> 2.2 s.
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if deathsig and sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):  # no libc prctl: the polling thread below remains
            pass
    if os.getppid() != parent_pid:  # the parent died before the request took effect
        os._exit(1)

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(period_s)
        os._exit(1)

    threading.Thread(target=watch, name="vrelab-parent-watch", daemon=True).start()


def process_pool(n_workers: int, mp_context: BaseContext | None = None, deathsig: bool = True) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` of ``n_workers`` whose workers run :func:`worker_init`."""
    return ProcessPoolExecutor(max_workers=n_workers, mp_context=mp_context, initializer=worker_init,
                               initargs=(os.getpid(), 0.5, deathsig))


def stop(pool: Executor, timeout_s: float = 5.0) -> None:
    """End a pool now: pending work cancelled, running workers terminated (SIGTERM, then
    SIGKILL after ``timeout_s``) and reaped. ``shutdown(wait=True)`` would wait for each
    running task to finish: minutes of a campaign's run after the user pressed Ctrl-C."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # private, there since Python 3.2
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + timeout_s
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join(1.0)


@contextmanager
def worker_pool(n_workers: int, mp_context: BaseContext | None = None) -> Iterator[ProcessPoolExecutor]:
    """:func:`process_pool` as a context: shut down normally on success, :func:`stop`-ped (its
    workers terminated) when anything propagates, Ctrl-C and SIGTERM included."""
    pool = process_pool(n_workers, mp_context)
    try:
        yield pool
    except BaseException:
        stop(pool)
        raise
    pool.shutdown(wait=True)
