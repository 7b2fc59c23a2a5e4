"""``vrelab demo [--out DIR]``: the article's ADXL355 case study, simulated, with its report."""

from __future__ import annotations

import argparse

from vrelab.cli._common import Subparsers, print_json


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "demo",
        help="the article's ADXL355 case study, simulated, with its report",
        description="Rerun the article's ADXL355 case study (Figures 1-4, the datasheet VRE limit, the sine "
        "method) on the simulated sensor; one sub-folder per result (results.json, levels.csv) and one "
        "combined DIR/report.html. Progress: one line per study on stderr.",
    )
    p.add_argument("--out", default="demo-out", metavar="DIR", help="output folder (default demo-out)")
    p.add_argument("--quick", action="store_true", help="shortest levels the reduction accepts and fewer of them: seconds, not tens")
    p.add_argument("--seconds", type=float, metavar="S", help="duration of each random level [s] (default 16; u scales as 1/sqrt(S))")
    p.add_argument("--seed", type=int, default=2017, metavar="N", help="root random seed (default 2017)")
    p.add_argument("--metadata", metavar="FILE.toml",
                   help="laboratory, item, equipment, procedure and approval for the test report (as `vrelab report "
                        "--metadata`)")
    p.add_argument("--json", action="store_true", help="print the report path and headline numbers as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from vrelab.demo import run_demo

    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    outcome = run_demo(args.out, quick=args.quick, seconds=args.seconds, seed=args.seed, metadata=args.metadata)
    if args.json:
        numbers = {k: (v if v == v and abs(v) != float("inf") else None) for k, v in outcome.numbers.items()}
        print_json({"report": str(outcome.report), "folders": list(outcome.folders), "numbers": numbers, "elapsed_s": outcome.elapsed_s})
    else:
        print(f"report: {outcome.report}  ({len(outcome.folders)} result folders, {outcome.elapsed_s:.1f} s)")
    return 0
