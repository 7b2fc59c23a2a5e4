"""Benchmark predict (and the sweep's analytic ``model`` point) on preset workloads.

Run: ``.venv/bin/python bench/run_all.py predict`` or ``.venv/bin/python bench/bench_predict.py
[--baseline SRC] [--repeat 5]``.

Workloads (each the best of ``--repeat`` runs, after one warm-up):

* ``adxl355-navmat``: ADXL355 ±2 g Z, navmat-p9492, 3 levels, 1 g field (resonance, polynomial,
  over-range, filters, output rails; the assumed over-range threshold's u propagated);
* ``adxl355-sor``: the same under navmat-p9492 + a 120 Hz tone (phase averages);
* ``adxl355-sine``: sines at 80 and 1500 Hz, 3 levels;
* ``ideal-flat``: the ideal ±2 g sensor, flat 50-2000 Hz, 3 levels;
* ``model-point``: one sweep ``model`` point (polynomial and rails), per point.

With ``--baseline SRC`` (a ``src`` directory of another checkout, e.g. ``git archive`` of a
commit), the same workloads run in a subprocess on that source, interleaved with ours, and the
ratio ours/baseline is printed: a ratio against a baseline in the same run.

With ``--cold`` vrelab's functools caches are emptied before each call: without it a repeated
call finds its spectral integrals remembered (predict keeps them by their exact inputs), which is
what a fit or a propagation meets, not what a first prediction in a fresh process does.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))  # run as a script or by run_all.py
from _paired import best_time, paired, show  # noqa: E402


def _workloads() -> dict[str, tuple[Callable[[], Any], int]]:
    import dataclasses

    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor
    from vrelab.sweep.points import model_point

    adxl = load_sensor("adxl355", range_g=2, axis="z")
    ideal = dataclasses.replace(load_sensor("ideal"), k2_per_g=1e-3)
    navmat, sor = parse_profile("navmat-p9492"), parse_profile("navmat-p9492+sine:120:0.5")
    flat = parse_profile("flat:50-2000")
    levels = [1.0, 2.0, 3.0]
    point = {"rms_g": 1.0, "static_g": 1.0, "k2_ug_per_g2": 300.0, "k3_ug_per_g3": -80.0}
    return {
        "adxl355-navmat": (lambda: predict(adxl, navmat, levels, 1.0), 1),
        "adxl355-sor": (lambda: predict(adxl, sor, levels, 1.0), 1),
        "adxl355-sine": (lambda: predict(adxl, [80.0, 1500.0], levels, 1.0), 1),
        "ideal-flat": (lambda: predict(ideal, flat, levels, 1.0), 1),
        "model-point": (lambda: model_point(point, None), 200),  # type: ignore[arg-type]
    }


def _own(repeat: int, cold: bool = False) -> dict[str, float]:
    return {name: best_time(fn, number, repeat, cold) for name, (fn, number) in _workloads().items()}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="src directory of the baseline checkout")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--cold", action="store_true",
                    help="empty vrelab's caches before each call (a repeated call otherwise finds its spectral "
                         "integrals remembered: a fit's or a propagation's case, not a first prediction's)")
    ap.add_argument("--own", action="store_true", help=argparse.SUPPRESS)  # the subprocess's mode
    args = ap.parse_args(argv)
    if args.own:
        print(json.dumps(_own(args.repeat, args.cold)))
        return {}
    result = paired(__file__, lambda: _own(args.repeat, args.cold), args.baseline, ["--repeat", str(args.repeat), *(["--cold"] if args.cold else [])])
    show(result, args.json, 16, 2, 2)
    return result


if __name__ == "__main__":
    main()
