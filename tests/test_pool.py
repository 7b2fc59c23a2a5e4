"""vrelab's process pools (vrelab._pool): the workers are the parallelism, so each runs its BLAS
on one thread. OpenBLAS starts a thread per core in every process (inherited through fork), and
two workers' small solves then woke four threads on two cores: `campaign --workers 2` took as
long as one process (bench/bench_campaign.py: 4.5 s with 2 workers, 3.8 s with 1; 2.2 s with
the limit)."""

from __future__ import annotations

from threadpoolctl import threadpool_info, threadpool_limits

from vrelab._pool import worker_pool


def _blas_threads() -> list[int]:
    import numpy as np

    np.linalg.svd(np.eye(3))  # the BLAS is loaded and used
    return [int(i["num_threads"]) for i in threadpool_info() if i.get("user_api") == "blas"]


def test_a_pool_worker_runs_its_blas_on_one_thread():
    # the parent's BLAS on two threads, as on a 2-core machine by default (`make test` sets one
    # for its own workers, which would hide a worker that keeps what it inherits)
    with threadpool_limits(limits=2, user_api="blas"):
        assert set(_blas_threads()) == {2}
        with worker_pool(2) as pool:
            per_worker = [pool.submit(_blas_threads).result() for _ in range(2)]
    assert all(threads and all(t == 1 for t in threads) for threads in per_worker), per_worker
