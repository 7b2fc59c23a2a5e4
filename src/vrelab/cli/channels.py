"""``vrelab channels``: every channel of a recorded file, the first step with a new file.

::

    vrelab channels FILE [--json]

For each channel: the exact name to pass to ``--dut``/``--reference``, its sample rate, number
of samples, duration, the unit the file states (or none) and what the reader noticed.
``--json`` prints ``{"file", "format", "notes", "unlisted", "channels": [{"name", "rate_hz",
"n_samples", "duration_s", "unit", "unit_source", "notes", "data"}]}``
(:func:`vrelab.analysis.readers.list_channels`): ``unit_source`` is ``file``, ``header``,
``assumed`` (no unit stated: read as g) or ``none`` (integer counts); ``data`` says where the
samples live, ``{"kind": "file" | "external" | "virtual", "files": [...]}`` (samples in other
files are listed, never read).
"""

from __future__ import annotations

import argparse
from typing import Any

from vrelab.cli._common import Subparsers, print_json, printable, with_formats


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "channels",
        help="list a recorded file's channels: the names --dut/--reference take, rates, units",
        description="List every channel of a recorded file (any format analyze reads) with the exact name to "
        "pass to --dut/--reference, its sample rate, samples, duration, the unit the file states and the "
        "reader's notes.",
    )
    with_formats(p.add_argument("file", metavar="FILE", help="recorded file, one of: %(formats)s"))
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def _num(x: float | None, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def _unit(c: dict[str, Any]) -> str:
    """The unit as the table shows it, with where it comes from when not the file's metadata."""
    src = c.get("unit_source")
    if c["unit"]:
        return f"{c['unit']} (header)" if src == "header" else str(c["unit"])
    return {"assumed": "g (assumed)", "none": "- (counts)"}.get(str(src), "-")


def run(args: argparse.Namespace) -> int:
    from vrelab.analysis.readers import list_channels

    listing = list_channels(args.file)
    if args.json:
        print_json(listing)
        return 0
    # each cell as it will be shown (escapes and all), so the widths line up
    rows = [tuple(printable(v) for v in (str(c["name"]), _num(c["rate_hz"], ".9g"), _num(c["n_samples"], "d"),
                                          _num(c["duration_s"], ".6g"), _unit(c), "; ".join(c["notes"])))
            for c in listing["channels"]]
    head = ("channel", "rate_hz", "samples", "duration_s", "unit", "notes")
    widths = [max(len(r[i]) for r in rows + [head]) for i in range(5)]
    print(f"{listing['file']} ({listing['format'].upper()})")
    for r in [head] + rows:
        print("  ".join(f"{v:<{w}}" for v, w in zip(r[:5], widths)) + ("  " + r[5] if r[5] else ""))
    for n in listing["notes"]:
        print(f"note: {n}")
    return 0
