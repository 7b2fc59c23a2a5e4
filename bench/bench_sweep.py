"""Benchmark the sweep engine: one 200-point sweep, serially, on 2 worker processes, on Dask.

Two workloads, each run on all three backends in this one process:

* ``simulate``: 200 simulated shaker tests (ADXL355, flat 50-2000 Hz, ``--seconds`` of vibration
  per level, the shaker's default baselines: about 50 ms each), a realistic point: the
  speed-up of 2 workers over serial;
* ``model``: 200 analytic model points (tens of µs each), so the wall time per point *is* the
  backend's per-point overhead (dispatch, pickling, the checkpoint's fsync), with one point per
  task and with ``--chunk`` points per task.

Backend start-up (spawning the pool, starting the LocalCluster) is timed apart from the runs.
Every backend's Dataset is checked identical (bitwise) to the serial one.

Usage: ``python bench/bench_sweep.py [--points 200] [--seconds 2] [--workers 2] [--json]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from vrelab.sweep import DaskBackend, ProcessBackend, SerialBackend, parse_spec, run_sweep


def _grid(n: int) -> dict[str, Any]:
    """n points: levels x static field (+1 g, -1 g) x ODR settings, trimmed to exactly n."""
    odrs = [4000.0, 2000.0, 1000.0, 500.0, 250.0]
    n_levels = math.ceil(n / (2 * len(odrs)))
    if n_levels * 2 * len(odrs) != n:
        raise ValueError(f"--points must be a multiple of {2 * len(odrs)}, got {n}")
    levels = [round(0.25 * (i + 1), 6) for i in range(n_levels)]
    return {"rms_g": levels, "static_g": [1.0, -1.0], "odr_hz": odrs}


def _specs(n: int, seconds: float) -> dict[str, Any]:
    """The two workloads at n points (n = 10 for the warm-up runs)."""
    g = _grid(n)
    simulate = parse_spec(
        {
            "name": "bench-simulate",
            "kind": "simulate",
            "seconds": seconds,
            "seed": 20161121,
            "fixed": {"sensor": "adxl355", "profile": "flat:50-2000"},
            "grid": g,
        }
    )
    model = parse_spec(
        {
            "name": "bench-model",
            "kind": "model",
            "seed": 1,
            # closed forms only (no resonance integral): tens of µs a point
            "fixed": {"range_g": 2.0, "k2_ug_per_g2": 50.0, "k3_ug_per_g3": 10.0},
            "grid": {"rms_g": g["rms_g"], "static_g": g["static_g"], "offset_g": [0.0, 0.01, 0.02, 0.03, 0.04]},
        }
    )
    return {"simulate": simulate, "model": model}


def _bits(ds: Any) -> bytes:
    return b"".join(np.ascontiguousarray(v.values).tobytes() for _, v in sorted(ds.data_vars.items()))


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=200)
    ap.add_argument("--seconds", type=float, default=2.0, help="vibration per simulated level [s]")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--chunk", type=int, default=20, help="points per task in the chunked overhead run")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args([] if argv is None else list(argv))  # run_all.py calls main() bare

    specs = _specs(args.points, args.seconds)
    out: dict[str, Any] = {
        "points": args.points,
        "workers": args.workers,
        "cores": os.cpu_count(),
        "seconds_per_level": args.seconds,
        "startup_s": {},
        "runs": {},
        # other work on the machine caps the speed-up: 2 workers on 2 cores need both free
        "loadavg_1min_before": os.getloadavg()[0],
    }
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        tmpd = Path(tmp)
        t0 = time.perf_counter()
        backends: dict[str, Any] = {"serial": SerialBackend()}
        out["startup_s"]["serial"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        backends["processes"] = ProcessBackend(args.workers)
        # a pool spawns its workers lazily: make them start now, so start-up is timed here
        list(backends["processes"].executor.map(abs, range(args.workers)))
        out["startup_s"]["processes"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        backends["dask"] = DaskBackend(f"local:{args.workers}")
        out["startup_s"]["dask"] = time.perf_counter() - t0
        try:
            ref: dict[str, bytes] = {}
            # warm each backend's workers (imports, caches, filter designs) so that the runs
            # time steady-state work; start-up is reported apart
            warm = _specs(10, args.seconds)
            for b in backends.values():
                for w in warm.values():
                    run_sweep(w, tmpd / "warm", backend=b, fresh=True)
            for workload, chunks in (("simulate", (1,)), ("model", (1, args.chunk))):
                spec = specs[workload]
                for chunk in chunks:
                    for name, b in backends.items():
                        if name == "serial" and chunk != 1:
                            continue
                        key = f"{workload}/{name}" + (f"/chunk{chunk}" if chunk != 1 else "")
                        t0 = time.perf_counter()
                        res = run_sweep(spec, tmpd / key.replace("/", "-"), backend=b, chunk=chunk, fresh=True)
                        wall = time.perf_counter() - t0
                        bits = _bits(res.dataset)
                        ref.setdefault(workload, bits)
                        engine = res.summary["elapsed_s"]  # without writing NetCDF/CSV at the end
                        compute = sum(r.elapsed_s for r in res.records.values())  # in the point function
                        cpu = sum(r.cpu_s for r in res.records.values())  # CPU time it got there
                        par = 1 if name == "serial" else args.workers
                        out["runs"][key] = {
                            "wall_s": wall,
                            "engine_s": engine,
                            "ms_per_point": 1e3 * engine / spec.n_points,
                            "compute_ms_per_point": 1e3 * compute / spec.n_points,
                            "cpu_ms_per_point": 1e3 * cpu / spec.n_points,
                            # time per point beyond the compute spread over the workers
                            "overhead_ms_per_point": 1e3 * (engine - compute / par) / spec.n_points,
                            "n_ok": res.summary["n_ok"],
                            "identical_to_serial": bits == ref[workload],
                        }
        finally:
            for b in backends.values():
                b.close()

    out["loadavg_1min_after"] = os.getloadavg()[0]
    runs = out["runs"]
    for workload in ("simulate", "model"):
        base = runs[f"{workload}/serial"]["engine_s"]
        for key, r in runs.items():
            if key.startswith(workload + "/"):
                r["speedup_vs_serial"] = base / r["engine_s"]
    out["overhead_ms_per_point"] = {
        k.split("/", 1)[1]: r["overhead_ms_per_point"] for k, r in runs.items() if k.startswith("model/")
    }
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(
            f"{args.points}-point sweeps, {args.workers} workers, {os.cpu_count()} cores, load average "
            f"{out['loadavg_1min_before']:.2f} before, {out['loadavg_1min_after']:.2f} after"
        )
        print("start-up: " + ", ".join(f"{k} {v:.2f} s" for k, v in out["startup_s"].items()))
        print(
            f"{'run':<26}{'wall s':>8}{'engine s':>10}{'ms/pt':>8}{'compute':>9}{'cpu':>7}{'overhead':>10}"
            f"{'speed-up':>10}  same bits"
        )
        for key, r in runs.items():
            print(
                f"{key:<26}{r['wall_s']:8.2f}{r['engine_s']:10.2f}{r['ms_per_point']:8.2f}"
                f"{r['compute_ms_per_point']:9.2f}{r['cpu_ms_per_point']:7.2f}{r['overhead_ms_per_point']:10.2f}"
                f"{r['speedup_vs_serial']:10.2f}  {r['identical_to_serial']}"
            )
        print("(ms per point; compute = wall time inside the point function, cpu = the CPU time it")
        print(" got there: compute well above cpu means the workers waited for a core; overhead =")
        print(" the rest, per point, with the compute spread over the workers; engine = without")
        print(" the final NetCDF/CSV)")
        print("overhead per point (ms): " + ", ".join(f"{k} {v:.2f}" for k, v in out["overhead_ms_per_point"].items()))
    return out


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
