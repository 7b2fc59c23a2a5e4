"""Benchmark: start-up of the command line and of ``import vrelab``, each a whole process.

Times, as separate processes of this interpreter (CPU = user + system of the child, from
``os.wait4``; wall from ``time.perf_counter``), in interleaved rounds so that load drifts alike
for every case:

* ``python -c pass`` (the interpreter alone: the floor every case pays),
* ``python -c "import vrelab"``,
* ``python -m vrelab --help``,
* ``python -m vrelab model clip --mean 1 --rail 2 --rms 1`` (a small closed-form command),
* ``python -m vrelab model poly --k2 100 --rms 1,2`` (a polynomial closed form: numpy only; it
  imported scipy.special through :mod:`vrelab.models.memoryless` before issue 29's second round),
* ``python -c "import numpy, scipy.special"``: the floor of ``model clip`` (its closed forms need
  ``scipy.special``'s ``ndtr`` and ``erfcx``, whose import alone costs about 0.3-0.4 s of CPU:
  SciPy >= 1.16 loads its array-API layer, which pulls ``numpy.f2py``, ``numpy.testing`` and
  ``numpy.ma`` in, and rewrites the docstring of every array-API-aware function, parsing it
  with its vendored numpydoc), run with one BLAS thread as the command line runs them,
* the same with OpenBLAS's thread pools (no ``OPENBLAS_NUM_THREADS``: what a bare interpreter
  pays, and ``vrelab`` paid before it defaulted its BLAS to one thread; numpy and SciPy each
  load their own OpenBLAS, each starts a thread per core; with OpenBLAS 0.3.31 a pool thread
  costs about 0.01 s of CPU at start-up, read from ``/proc/self/task``: within the noise of
  this benchmark on two cores),
* ``python -c "import numpy"``: the floor of ``model poly`` (one BLAS thread),

and prints each case's median and its ratio to ``python -c pass`` measured in the same run, then
each model command's ratio to its floor. The ``vrelab`` cases run without the BLAS variables
(``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``: the command line's own
default decides), the floors with them set to 1.

Issue 29's goal: ``--help`` at most 0.3 s and a small command at most 0.5 s of CPU. ``model
clip`` cannot meet it where its floor, the import of numpy and ``scipy.special``, costs more
than 0.5 s by itself (0.45-0.75 s of CPU on the loaded 2-core machine of issue 29's second
round, against 0.5-0.85 s for ``model clip``): what is vrelab's there is the difference,
printed as ``model clip - floor`` (0.03-0.1 s: the models' modules, about 0.015 s of CPU
measured in one process, the parser and the computation, about 0.01 s each).

With ``--baseline SRC`` (the ``src`` folder of another checkout, e.g. ``git -C /work/main archive
HEAD src | tar -x -C /tmp/base-startup`` then ``--baseline /tmp/base-startup/src``) every case
also runs from there (``PYTHONPATH=SRC``) in the same rounds, and the ratio this/baseline is
printed. A first round is run and discarded (bytecode compiled and written, files cached).

    python bench/bench_startup.py [--repeat 9] [--baseline SRC]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Sequence

SRC = str(Path(__file__).resolve().parent.parent / "src")

CASES: dict[str, list[str]] = {
    "python -c pass": ["-c", "pass"],
    "import vrelab": ["-c", "import vrelab"],
    "vrelab --help": ["-m", "vrelab", "--help"],
    "vrelab model clip": ["-m", "vrelab", "model", "clip", "--mean", "1", "--rail", "2", "--rms", "1"],
    "vrelab model poly": ["-m", "vrelab", "model", "poly", "--k2", "100", "--rms", "1,2"],
    "numpy+scipy.special": ["-c", "import numpy, scipy.special"],
    "  with BLAS pools": ["-c", "import numpy, scipy.special"],
    "numpy": ["-c", "import numpy"],
}
GOALS_CPU_S = {"vrelab --help": 0.3, "vrelab model clip": 0.5, "vrelab model poly": 0.5}
# each model command's floor: the imports it cannot do without, with one BLAS thread as it runs
FLOORS = {"vrelab model clip": "numpy+scipy.special", "vrelab model poly": "numpy"}
BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
# the cases run with one BLAS thread set in their environment; the others with none of the variables
ONE_BLAS_THREAD = frozenset(FLOORS.values())


def run_once(args: list[str], src: str, one_blas_thread: bool = False) -> tuple[float, float]:
    """CPU (user + system) and wall seconds of one process ``python ARGS`` importing from ``src``,
    with :data:`BLAS_VARIABLES` set to 1 (``one_blas_thread``) or unset.

    Bytecode is written and read (``PYTHONDONTWRITEBYTECODE`` dropped), as for an installed
    package: otherwise a checkout without ``__pycache__`` compiles every module at every run."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE" and k not in BLAS_VARIABLES}
    env["PYTHONPATH"] = src
    if one_blas_thread:
        env.update(dict.fromkeys(BLAS_VARIABLES, "1"))
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    if proc.returncode != 0:
        raise RuntimeError(f"python {' '.join(args)} (from {src}) exited {proc.returncode}: {err.strip()}")
    return usage.ru_utime + usage.ru_stime, wall


def measure(repeat: int, sources: dict[str, str]) -> dict[str, dict[str, dict[str, float]]]:
    """Median CPU and wall of every case from every source, ``repeat`` interleaved rounds."""
    samples: dict[tuple[str, str], list[tuple[float, float]]] = {(s, c): [] for s in sources for c in CASES}
    for r in range(repeat + 1):
        for case, args in CASES.items():
            for label, src in sources.items():
                cpu, wall = run_once(args, src, case in ONE_BLAS_THREAD)
                if r:  # round 0 warms up: bytecode compiled, files in the page cache
                    samples[(label, case)].append((cpu, wall))
    return {label: {case: {"cpu_s": statistics.median(c for c, _ in samples[(label, case)]),
                           "wall_s": statistics.median(w for _, w in samples[(label, case)])}
                    for case in CASES}
            for label in sources}


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=9, help="rounds (medians; default 9)")
    p.add_argument("--baseline", metavar="SRC", help="src folder of another checkout, measured in the same rounds")
    args = p.parse_args(argv)
    sources = {"this": SRC}
    if args.baseline:
        sources["baseline"] = str(Path(args.baseline).resolve())
    med = measure(args.repeat, sources)
    floor = med["this"]["python -c pass"]["cpu_s"]
    print(f"start-up, medians of {args.repeat} rounds (whole processes; CPU = user + sys; python -c pass: "
          f"{floor:.3f} s CPU)")
    head = f"{'case':<20} {'CPU s':>7} {'wall s':>7} {'x pass':>7}"
    if args.baseline:
        head += f" {'base CPU s':>10} {'x pass':>7} {'this/base':>9}"
    print(head + "  goal")
    result: dict[str, Any] = {"repeat": args.repeat, "python_pass_cpu_s": round(floor, 4), "cases": {}}
    for case in CASES:
        this = med["this"][case]
        row = f"{case:<20} {this['cpu_s']:7.3f} {this['wall_s']:7.3f} {this['cpu_s'] / floor:7.1f}"
        entry = {"cpu_s": round(this["cpu_s"], 4), "wall_s": round(this["wall_s"], 4),
                 "ratio_to_python": round(this["cpu_s"] / floor, 2)}
        if args.baseline:
            base = med["baseline"][case]
            base_floor = med["baseline"]["python -c pass"]["cpu_s"]
            row += f" {base['cpu_s']:10.3f} {base['cpu_s'] / base_floor:7.1f} {this['cpu_s'] / base['cpu_s']:9.2f}"
            entry.update(baseline_cpu_s=round(base["cpu_s"], 4), ratio_to_baseline=round(this["cpu_s"] / base["cpu_s"], 2))
        goal = GOALS_CPU_S.get(case)
        if goal is not None:
            row += f"  <= {goal} s CPU: {'met' if this['cpu_s'] <= goal else 'NOT met'}"
        print(row)
        result["cases"][case] = entry
    for case, floor_case in FLOORS.items():
        cpu, base = med["this"][case]["cpu_s"], med["this"][floor_case]["cpu_s"]
        print(f"{case}: {cpu / base:.2f}x its floor `{' '.join(CASES[floor_case][1:])}` ({base:.3f} s CPU, one BLAS "
              f"thread); {case} - floor = {cpu - base:+.3f} s")
        result["cases"][case].update(floor_cpu_s=round(base, 4), ratio_to_floor=round(cpu / base, 2))
    return result


if __name__ == "__main__":
    main()
