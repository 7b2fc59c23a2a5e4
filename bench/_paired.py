"""The paired rounds bench_predict.py and bench_quad.py share: our workloads in this process, the
baseline's (a ``--baseline`` src directory) in a subprocess running the same script with
``--own``, interleaved so that load drifts alike; the best of each kept, and the ratios printed."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Any, Callable


def forget_caches() -> None:
    """Empty vrelab's functools caches (what a first call in a fresh process meets)."""
    for name, module in list(sys.modules.items()):
        if name == "vrelab" or name.startswith("vrelab."):
            for value in list(vars(module).values()):
                if callable(getattr(value, "cache_clear", None)):
                    value.cache_clear()


def best_time(fn: Callable[[], Any], number: int, repeat: int, cold: bool = False,
              clock: Callable[[], float] = time.perf_counter) -> float:
    """The best over ``repeat`` rounds of the mean time of ``number`` calls of ``fn`` (after one
    untimed call); ``cold`` empties vrelab's caches before each call (:func:`forget_caches`)."""
    fn()
    best = float("inf")
    for _ in range(repeat):
        elapsed = 0.0
        for _ in range(number):
            if cold:
                forget_caches()
            t0 = clock()
            fn()
            elapsed += clock() - t0
        best = min(best, elapsed / number)
    return best


def paired(script: str, own: Callable[[], dict[str, float]], baseline: str | None,
           own_argv: list[str]) -> dict[str, Any]:
    """Best times [s] of ours and of the baseline's over interleaved rounds (ours, baseline, ours,
    baseline), and their ratios. ``own_argv`` is what the baseline's subprocess is given after
    ``--own`` (its ``--repeat`` and options)."""
    ours: dict[str, float] = {}
    base: dict[str, float] = {}
    # interleaved rounds (ours, baseline, ours, ...), the best of each: load drifts on a shared machine
    for _ in range(2 if baseline else 1):
        for k, v in own().items():
            ours[k] = min(ours.get(k, v), v)
        if baseline:
            env = {**os.environ, "PYTHONPATH": baseline}
            out = subprocess.run([sys.executable, script, "--own", *own_argv], env=env,
                                 check=True, capture_output=True, text=True).stdout
            for k, v in json.loads(out).items():
                base[k] = min(base.get(k, v), v)
    return {"ours_s": ours, "baseline_s": base or None,
            "ratio": {k: ours[k] / base[k] for k in ours if k in base} or None}


def show(result: dict[str, Any], as_json: bool, width: int, digits: int, ratio_digits: int) -> None:
    """The result as JSON, or a line per workload: ours [ms], the baseline's and the ratio."""
    if as_json:
        print(json.dumps(result, indent=1))
        return
    base = result["baseline_s"] or {}
    for k, v in result["ours_s"].items():
        line = f"{k:{width}s} {1e3 * v:9.{digits}f} ms"
        if k in base:
            line += f"   baseline {1e3 * base[k]:9.{digits}f} ms   ratio {v / base[k]:.{ratio_digits}f}"
        print(line)
