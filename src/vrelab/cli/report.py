"""``vrelab report DIR``: write DIR/report.html from an output folder (parsing and printing only)."""

from __future__ import annotations

import argparse
import sys

from vrelab.cli._common import Subparsers, print_json


def register(sub: Subparsers) -> None:
    p = sub.add_parser(
        "report",
        help="write DIR/report.html from a simulate/analyze or sweep output folder",
        description="Build one self-contained HTML report (figures embedded, no network needed) from "
        "DIR/results.json and, when present, prediction.json, record.h5, envelope.csv and psd.csv; "
        "or, for a sweep folder (DIR/result.nc, no results.json), VRE against the grid, the spread "
        "of a Monte Carlo lot and the failed points. The report is laid out as a test report (test item, "
        "equipment, conditions, procedure, results, decisions, approval) and prints on A4 (letter when the "
        "metadata says paper = \"letter\"); "
        "--metadata fills in what no record holds (laboratory, item, equipment, who signs).",
    )
    p.add_argument("dir", metavar="DIR", help="output folder of simulate/analyze/sweep --out")
    p.add_argument("--title", help="report title")
    p.add_argument("--metadata", metavar="FILE.toml",
                   help="laboratory, item, equipment, procedure and approval for the test report (TOML; tables "
                        "[laboratory] [customer] [item] [items.CHANNEL] [equipment] [conditions] [procedure] "
                        "[approval], top-level report_number and paper); missing fields say 'not given'")
    p.add_argument("--json", action="store_true", help="print {\"report\": PATH} on stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from vrelab.report import load_metadata, report_dir

    # Validated before the folder is read: a bad metadata file writes nothing.
    meta = load_metadata(args.metadata) if args.metadata else None
    path = report_dir(args.dir, argv=["vrelab", *sys.argv[1:]], title=args.title, metadata=meta)
    if args.json:
        print_json({"report": str(path)})
    else:
        print(f"report written: {path}")
    return 0
