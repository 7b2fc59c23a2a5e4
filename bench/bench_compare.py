"""Benchmark ``vrelab compare`` (issue 32): one candidate's prediction and a comparison over several.

Run: ``.venv/bin/python bench/run_all.py compare`` or ``.venv/bin/python bench/bench_compare.py
[--baseline SRC] [--repeat 2] [--all]``.

Workloads (CPU seconds of this process, ``time.process_time``: the machine is shared and its
wall clock follows the load; each the best of ``--repeat`` runs after one warm-up, vrelab's
caches emptied before each run, as a fresh ``vrelab compare`` meets them):

* ``candidate-adxl354``, ``candidate-adxl355``, ``candidate-adxl357``: one candidate of the
  default set (:func:`vrelab.comparison.run.candidate_point`: its prediction at three levels of
  the truck-bed environment on an axis tilted 30°, the preset's assumed u propagated inside);
* ``compare-12``: :func:`vrelab.compare` over twelve candidates, serial (every range of the
  ADXL355 at two rates, the ADXL354, ADXL357 and ADXL380);
* ``compare-default`` (with ``--all``): every preset × range × output rate, the default set
  (minutes of CPU: not run by default).

With ``--baseline SRC`` (a ``src`` directory of another checkout, e.g. ``git archive`` of main),
the same workloads run in a subprocess on that source, interleaved with ours, and the ratio
ours/baseline is printed: a ratio against a baseline measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))  # run as a script or by run_all.py
from _paired import best_time, paired, show  # noqa: E402

ENVIRONMENT = "mil-std-810h-common-carrier-vertical"
LEVELS = [1.08, 2.0, 3.0]
STATIC_G = 0.5  # an axis tilted 30°
CANDIDATES = ("adxl355:2g:4000,adxl355:4g:4000,adxl355:8g:4000,adxl355:2g:125,adxl355:8g:125,"
              "adxl354:2g,adxl354:8g,adxl357:10g:4000,adxl357:40g:500,adxl380:4g:8000,adxl380:16g:8000,ideal:8g")


def _workloads(everything: bool) -> dict[str, Callable[[], Any]]:
    import vrelab
    from vrelab.comparison.run import candidate_point

    def candidate(part: str, range_g: float, odr_hz: float | None) -> Callable[[], Any]:
        params = {"part": part, "range_g": range_g, "odr_hz": odr_hz, "environment": ENVIRONMENT,
                  "levels": LEVELS, "static_g": [STATIC_G]}
        return lambda: candidate_point(params, None)

    out: dict[str, Callable[[], Any]] = {
        "candidate-adxl354": candidate("adxl354", 2.0, None),
        "candidate-adxl355": candidate("adxl355", 2.0, 4000.0),
        "candidate-adxl357": candidate("adxl357", 10.0, 4000.0),
        "compare-12": lambda: vrelab.compare(ENVIRONMENT, LEVELS, "0.05deg", static_g=STATIC_G, candidates=CANDIDATES),
    }
    if everything:
        out["compare-default"] = lambda: vrelab.compare(ENVIRONMENT, LEVELS, "0.05deg", static_g=STATIC_G)
    return out


def _own(repeat: int, everything: bool) -> dict[str, float]:
    return {name: best_time(fn, 1, repeat, cold=True, clock=time.process_time)
            for name, fn in _workloads(everything).items()}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="src directory of the baseline checkout")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--all", action="store_true", help="also the default candidate set (minutes of CPU)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--own", action="store_true", help=argparse.SUPPRESS)  # the subprocess's mode
    args = ap.parse_args(argv)
    if args.own:
        print(json.dumps(_own(args.repeat, args.all)))
        return {}
    more = ["--all"] if args.all else []
    result = paired(__file__, lambda: _own(args.repeat, args.all), args.baseline,
                    ["--repeat", str(args.repeat), *more])
    show(result, args.json, 18, 0, 3)
    return result


if __name__ == "__main__":
    main()
