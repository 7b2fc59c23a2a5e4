"""Benchmark the spectral integrals (issue: the quadrature vectorised) in a README prediction and its propagation.

Run: ``.venv/bin/python bench/run_all.py quad`` or ``.venv/bin/python bench/bench_quad.py
[--baseline SRC] [--repeat 3]``.

Workloads (each the best of ``--repeat`` runs after one warm-up, vrelab's caches emptied before
each run: a first prediction in a fresh process, and a propagation whose draws move the
resonance and the filters, so that its integrals are never remembered):

* ``spectral``: σ and ν0 of navmat-p9492 through the ADXL355's resonance and filters
  (:func:`vrelab.models.dynamics.effective_rms`, ``zero_crossing_rate_hz``), per call;
* ``predict-flat``: ``vrelab predict --sensor adxl355 --profile flat:50-2000 --levels
  0.5,1,2,3,4`` as the API call, the preset's assumed u propagated inside;
* ``propagation``: that propagation alone (:func:`vrelab.prediction.propagation.propagation`);
* ``cli-flat``: the same command as a process (start-up and printing included), one run.

With ``--baseline SRC`` (a ``src`` directory of another checkout, e.g. ``git archive`` of main),
the same workloads run in a subprocess on that source, interleaved with ours, and the ratio
ours/baseline is printed: a ratio against a baseline measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))  # run as a script or by run_all.py
from _paired import best_time, paired, show  # noqa: E402

CLI = ["predict", "--sensor", "adxl355", "--profile", "flat:50-2000", "--levels", "0.5,1,2,3,4"]


def _cli() -> None:
    subprocess.run([sys.executable, "-c", "import sys; from vrelab.cli import main; sys.exit(main())", *CLI],
                   check=True, capture_output=True, env=os.environ)


def _workloads() -> dict[str, tuple[Callable[[], Any], int]]:
    from vrelab.models.dynamics import effective_rms, zero_crossing_rate_hz
    from vrelab.prediction import predict
    from vrelab.prediction.propagation import propagation
    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor

    adxl = load_sensor("adxl355", range_g=2, axis="z")
    navmat, flat = parse_profile("navmat-p9492"), parse_profile("flat:50-2000")
    levels = [0.5, 1.0, 2.0, 3.0, 4.0]
    table = (navmat.freq_hz, navmat.psd_g2_per_hz)
    responses = adxl.linear_responses("output")
    peaks = [s.fn_hz for s in adxl.stages() if hasattr(s, "fn_hz")]

    def spectral() -> None:
        effective_rms(table, responses, *navmat.band, points_hz=peaks)
        zero_crossing_rate_hz(table, responses, *navmat.band, points_hz=peaks)

    return {
        "spectral": (spectral, 5),
        "predict-flat": (lambda: predict(adxl, flat, levels, 1.0), 1),
        "propagation": (lambda: propagation(adxl, flat, levels, 1.0, predictor=predict), 1),
        "cli-flat": (_cli, 1),
    }


def _own(repeat: int) -> dict[str, float]:
    return {name: best_time(fn, number, repeat, cold=True) for name, (fn, number) in _workloads().items()}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="src directory of the baseline checkout")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--own", action="store_true", help=argparse.SUPPRESS)  # the subprocess's mode
    args = ap.parse_args(argv)
    if args.own:
        print(json.dumps(_own(args.repeat)))
        return {}
    result = paired(__file__, lambda: _own(args.repeat), args.baseline, ["--repeat", str(args.repeat)])
    show(result, args.json, 14, 1, 3)
    return result


if __name__ == "__main__":
    main()
