"""``vrelab campaign MANIFEST``: reduce every run of a shaker campaign (physics §4.1, the CLI reference).

::

    vrelab campaign MANIFEST [--out DIR] [--workers N] [--json]

The manifest (TOML) names each run's file, DUT channels, reference, static field, units; see
:mod:`vrelab.campaign`. It is validated whole before any run is reduced.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vrelab.cli._common import print_json, printable

if TYPE_CHECKING:
    from vrelab.cli._common import Subparsers

_EXAMPLE = """example MANIFEST (paths relative to it):

  name = "ADXL355 SN 1234, ±2 g, ODR 4 kHz"
  sensor = "adxl355"                # optional, a preset or sensor file (or a table per channel):
                                    # the units check holds each run to its response
  [defaults]                        # any run key; a run's own value wins
  reference = "ref"
  reference_units = "mv"
  reference_sensitivity = 10.0      # mV/g
  dut_units = "lsb"
  dut_sensitivity = 256000          # LSB/g, or a table {x = 256100, z = 255900}
  [[run]]
  file = "runs/z_up_80hz.tdms"
  dut = {sn1_z = "shaker/dut1_z", sn2_z = "shaker/dut2_z"}   # campaign name = file channel
  static_g = 1.0                    # or a table per channel
  label = "Z up, 80 Hz"
  [[run]]
  file = "runs/z_down_80hz.csv"
  dut = ["sn1_z", "sn2_z"]          # the file's names are the campaign's
  static_g = -1.0

  [[run]]                           # IEEE 1293 mount angle (physics §1.6): input axis at 45° to the
  file = "runs/ip_plus45.csv"       # vibration, tilted toward its pendulous axis (io: output axis)
  dut = ["sn1_z"]
  mount_deg = 45
  mount_plane = "ip"
  static_g = [0.7071, 0.7071, 0]    # the whole static field [i, p, o]: vertical shaker, along it

run keys: file dut reference method static_g label fs_hz time dut_units dut_sensitivity
reference_units reference_sensitivity schedule profile band settle_s rail_g
u_reference_pct u_dut_pct u_static_g u_thermal_g mount_deg mount_plane

file: a recorded test in one of these formats (by magic bytes, else by extension):
  %(formats)s
"""


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "campaign",
        help="reduce every run of a shaker campaign (a TOML manifest): VRC by frequency, k2/k3, rail per channel",
        description=textwrap.fill(
            "Reduce every run of a campaign described in a TOML manifest: each run's DUT channels against its "
            "reference; per channel the VRC at every sine frequency and orientation, k2 and k3 from the "
            "orientations (VRC(g0) = k2 + 3*k3*g0), the effective rail from the random runs. A run that fails is "
            "reported with its error and the others are kept. Exit status 0 when every run was reduced, 1 when "
            "some failed (they are in the outputs with their errors), 2 on a bad manifest.",
            width=88,
        ),
        epilog=_EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("manifest", metavar="MANIFEST", help="campaign manifest (TOML)")
    p.add_argument("--out", metavar="DIR",
                   help="write results.json, levels.csv (every level of every run) and runs/NN-label/ per run; "
                   "then `vrelab report DIR`")
    p.add_argument("--workers", type=int, default=1, metavar="N", help="reduce N runs at once in processes (default 1)")
    p.add_argument("--limit", type=float, metavar="G",
                   help="VRE limit [g]: each level pass/fail/indeterminate under guarded acceptance (physics §4.3)")
    p.add_argument("--json", action="store_true", help="print the campaign as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from vrelab import _io
    from vrelab.campaigns import (
        RunResult,
        campaign_doc,
        combine,
        read_manifest,
        run_campaign,
        write_campaign,
    )

    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    if args.limit is not None and not args.limit > 0:
        raise ValueError(f"--limit must be > 0 [g], got {args.limit}")
    manifest = read_manifest(args.manifest)
    command = shlex.join(["vrelab", "campaign", args.manifest]
                         + (["--out", args.out] if args.out else []) + ["--workers", str(args.workers)])

    def done(rr: RunResult) -> None:
        if not args.json and sys.stderr.isatty():
            sys.stderr.write(f"run {rr.run.index}/{len(manifest.runs)} {'ok' if rr.ok else 'FAILED'}\n")

    if args.out:
        from vrelab.cli._common import input_paths

        with _io.output_dir(args.out, inputs=input_paths(manifest)) as stage:
            results = run_campaign(manifest, args.workers, Path(stage), done, args.limit)
            summaries = combine(results, manifest.channels)
            doc = campaign_doc(manifest, results, summaries, command)
            write_campaign(Path(stage), manifest, results, summaries, doc)
    else:
        results = run_campaign(manifest, args.workers, None, done, args.limit)
        summaries = combine(results, manifest.channels)
        doc = campaign_doc(manifest, results, summaries, command)
    if args.json:
        print_json(doc)
    else:
        _print(doc)
        if args.out:
            print(f"wrote {args.out}/results.json, levels.csv, runs/; `vrelab report {args.out}` makes the report")
    failed = [r for r in doc["runs"] if r["status"] != "ok"]
    for r in failed:
        sys.stderr.write(printable(f"vrelab: run {r['index']} ({r['label']}) failed: {r['error']}") + "\n")
    return 1 if failed else 0


def _print(doc: dict[str, Any]) -> None:
    from vrelab._format import format_value_u

    print(f"campaign {doc['name']!r}: {doc['n_runs']} run(s), {doc['n_failed']} failed")
    for r in doc["runs"]:
        chans = ", ".join(c["channel"] for c in r["channels"])
        state = "ok" if r["status"] == "ok" else f"FAILED: {r['error']}"
        print(f"  run {r['index']:>2} {r['label']:<28} {r['method']:<6} {chans:<24} {state}")
    for c in doc["channels"]:
        print(f"channel {c['channel']}:")
        for v in c["vrc_by_freq"]:
            e = v["vrc_ug_per_g2"]
            print(f"  VRC at {v['freq_hz']:8.4g} Hz, {v['static_g']:+.3g} g: {format_value_u(e['value'], e['u'], unit='µg/g²')}")
        for v in c.get("vrc_by_mount") or ():  # IEEE 1293 mount-angle runs (physics §1.6)
            e = v["vrc_ug_per_g2"]
            print(f"  VRE/rms² at {v['freq_hz']:8.4g} Hz, mounted {v['mount_deg']:+g}° {v['mount_plane'].upper()}: "
                  f"{format_value_u(e['value'], e['u'], unit='µg/g²')}")
        for key, unit in (("k2_ug_per_g2", "µg/g²"), ("k3_ug_per_g3", "µg/g³"), ("rail_g", "g")):
            e = c[key]
            text = "not determined (see the notes)" if e is None else format_value_u(e["value"], e["u"], unit=unit)
            print(f"  {key.split('_')[0]}: {text}")
        for n in c["notes"]:
            print(f"  note: {n}")
