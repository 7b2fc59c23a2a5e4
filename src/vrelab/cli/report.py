"""``vrelab report DIR``: write DIR/report.html from an output folder (parsing and printing only)."""

from __future__ import annotations

import argparse
import sys

from vrelab.cli._common import print_json


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report",
        help="write DIR/report.html from a simulate/analyze or sweep output folder",
        description="Build one self-contained HTML report (figures embedded, no network needed) from "
        "DIR/results.json and, when present, prediction.json, record.h5, envelope.csv and psd.csv; "
        "or, for a sweep folder (DIR/result.nc, no results.json), VRE against the grid, the spread "
        "of a Monte Carlo lot and the failed points.",
    )
    p.add_argument("dir", metavar="DIR", help="output folder of simulate/analyze/sweep --out")
    p.add_argument("--title", help="report title")
    p.add_argument("--json", action="store_true", help="print {\"report\": PATH} on stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from vrelab.report import report_dir

    path = report_dir(args.dir, argv=["vrelab", *sys.argv[1:]], title=args.title)
    if args.json:
        print_json({"report": str(path)})
    else:
        print(f"report written: {path}")
    return 0
