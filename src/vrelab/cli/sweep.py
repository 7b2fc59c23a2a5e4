"""``vrelab sweep FILE``: run or resume a parameter sweep / Monte Carlo lot described in TOML."""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
from pathlib import Path

from vrelab.cli._common import Subparsers

_EXAMPLE = """example FILE (see vrelab.sweep.spec for every field):

  kind = "predict"                # model | predict | simulate | python
  seed = 1
  [fixed]
  sensor = "adxl355"
  profile = "flat:50-2000"
  [grid]
  rms_g = "0.5:3:0.5"
  range_g = [2, 4, 8]
  odr_hz = [4000, 1000, 125]
  static_g = [1, -1]
  [montecarlo]                    # optional: a lot of units, one draw each
  units = 20
  q = {dist = "normal", mean = 7.4, sd = 0.7}
  k2_ug_per_g2 = {dist = "uniform", low = -100, high = 100}
"""


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "sweep",
        help="parameter sweep or Monte Carlo lot from a TOML file (serial, processes or Dask)",
        description=textwrap.fill(
            "Evaluate a grid of parameters and/or a Monte Carlo lot described in a TOML "
        "file; checkpointed in --out so that rerunning the same command resumes an interrupted "
        "sweep. Writes DIR/result.nc (xarray/NetCDF), DIR/result.csv and DIR/sweep.json. "
        "Exit status 0 when every point is ok, 1 when some failed (they are in the outputs "
        "with their errors; --retry-failed computes them again), 2 on bad input, 3 when the "
        "executor itself failed (rerun to resume), 130 on Ctrl-C (rerun to resume).",
            width=88,
        ),
        epilog=_EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", metavar="FILE", help="sweep description (TOML)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N", help="run on N local worker processes")
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a dask.distributed scheduler (tcp://host:port), or 'local[:N]' for a local cluster",
    )
    p.add_argument("--out", metavar="DIR", help="output and checkpoint folder (default: ./<FILE stem>-sweep)")
    p.add_argument("--fresh", action="store_true", help="discard the checkpoint in DIR instead of resuming")
    p.add_argument("--retry-failed", action="store_true", help="on resume, compute failed points again")
    p.add_argument("--retries", type=int, metavar="N", help="extra attempts for a failing point (default: file, 1)")
    p.add_argument("--chunk", type=int, metavar="N", help="points per task (default: file, 1)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--json", action="store_true", help="print the summary and every point as JSON")
    p.add_argument("--allow-python", action="store_true",
                   help="run a sweep of kind 'python': it imports the module its 'function' names and calls it "
                   "(code from the environment, chosen by the file); refused without this option")
    p.set_defaults(func=run)


def _json_num(x: object) -> object:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def run(args: argparse.Namespace) -> int:
    from vrelab.cli._common import print_json, printable
    from vrelab.sweep import SweepAborted, load_spec, run_sweep
    from vrelab.sweep.dataset import flat_rows

    spec = load_spec(args.file)
    if spec.kind == "python" and not args.allow_python:
        raise ValueError(f"{args.file}: kind 'python' imports and calls {spec.function!r}: a sweep file chooses "
                         "code to run only when you say so, with --allow-python")
    out = Path(args.out) if args.out else Path(f"{Path(args.file).stem}-sweep")
    try:
        res = run_sweep(
            spec,
            out,
            workers=args.workers,
            scheduler=args.scheduler,
            fresh=args.fresh,
            progress=not args.no_progress,
            retries=args.retries,
            chunk=args.chunk,
            retry_failed=args.retry_failed,
            inputs=[args.file],
        )
    except SweepAborted as exc:
        sys.stderr.write(printable(f"vrelab: sweep stopped: {exc}") + "\n")
        return 3
    s = res.summary
    if args.json:
        _, rows = flat_rows(spec, res.records)
        doc = {k: v for k, v in s.items() if k != "spec"}
        doc["points"] = [{k: _json_num(v) for k, v in row.items()} for row in rows]
        print_json(doc)
    else:
        where = (f"on {s['backend']} in {s['elapsed_s']:.2f} s" if s["n_computed"]
                 else "nothing computed: every point came from the checkpoint")
        print(
            f"{s['name']}: {s['n_ok']}/{s['n_points']} points ok, {s['n_failed']} failed "
            f"({s['n_computed']} computed, {s['n_resumed']} from the checkpoint) {where} "
            f"-> {', '.join(s['files'].values())}"
        )
        if s.get("n_quarantined"):
            print(f"vrelab: {s['n_quarantined']} bad checkpoint line(s) moved to checkpoint.quarantine.jsonl "
                  f"and their points recomputed (first: line {s['quarantined'][0]['line']}, "
                  f"{s['quarantined'][0]['why']})", file=sys.stderr)
        for f in s["failed"][:5]:
            print(printable(f"  point {f['index']} failed: {f['error']}"), file=sys.stderr)
    return 1 if s["n_failed"] else 0
