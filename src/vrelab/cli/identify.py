"""``vrelab identify``: the sensor's VRE model from a campaign, as a sensor file (physics §6.1, the CLI reference).

::

    vrelab identify (MANIFEST | CAMPAIGN_DIR) [--base-sensor S] [--range G] [--odr HZ]
                    [--base-axis A] [--kind censored|truncated] [--workers N]
                    [--u-reference-pct P ...] --out DIR [--json]

A MANIFEST is reduced first (as ``vrelab campaign`` does); a CAMPAIGN_DIR is the folder
``vrelab campaign --out`` wrote. DIR receives ``sensor.toml`` (use it as ``--sensor`` with
``--axis <channel>``) and ``identification.json`` (what ``--json`` prints); ``vrelab report DIR``
makes its report.
"""

from __future__ import annotations

import argparse
import shlex
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vrelab._names import IDENTIFICATION as DOCUMENT  # the names only: vrelab.folder brings numpy
from vrelab._names import IDENTIFIED_SENSOR as SENSOR_FILE
from vrelab.cli._common import add_budget_arguments, print_json, printable, typeb_from_args
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS

if TYPE_CHECKING:
    from vrelab.cli._common import Subparsers


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "identify",
        help="identify each channel's VRE model (k2, k3, fn, Q, rails, over-range) from a campaign: a sensor file",
        description=textwrap.fill(
            "Fit the physical model of physics §1 to every level of every run of each channel of a campaign at once "
            "(weighted by each level's uncertainty; each level evaluated with the analytic model `vrelab predict` "
            "uses): k2 and k3 from the orientations, fn and Q from VRC(f) across the sine frequencies, the "
            "physical rails from the random runs through the identified dynamics, the over-range threshold where "
            "the data reach it. What the campaign cannot determine is null with its reason and comes from the base "
            "sensor, marked so. Writes DIR/sensor.toml (one [axes.<channel>] per channel, every number's source, "
            "the covariance) for predict, simulate and sweep (--sensor DIR/sensor.toml --axis <channel>).",
            width=88,
        ),
        epilog="example: vrelab identify examples/campaign/campaign.toml --out ident && "
               "vrelab predict --sensor ident/sensor.toml --axis sn1 --profile mil-std-810h-514.8-c17 --levels 1,2",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("source", metavar="MANIFEST|CAMPAIGN_DIR",
                   help="a campaign manifest (TOML; its runs are reduced first) or a `vrelab campaign --out` folder")
    p.add_argument("--base-sensor", default="ideal", metavar="S",
                   help="what the campaign cannot determine comes from here: a preset or a sensor file "
                   "(default ideal: no resonance, rails at ±range, no filters); its filters, ODR and over-range "
                   "hold time are part of the model")
    p.add_argument("--range", dest="range_g", type=float, metavar="G",
                   help="the range the parts were tested on [g] (default: the base sensor's default_range_g)")
    p.add_argument("--odr", dest="odr_hz", type=float, metavar="HZ",
                   help="the ODR they were tested at [Hz] (default: the base sensor's default_odr_hz)")
    p.add_argument("--base-axis", metavar="A",
                   help="the base sensor's axis whose values the channels start from (default: its default_axis)")
    p.add_argument("--kind", choices=KINDS, default=DEFAULT_CLIP_KIND, help="clipping model (default censored)")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="reduce runs (a manifest) and identify channels N at a time in processes (default 1)")
    p.add_argument("--prefer-base", action="store_true",
                   help="replace fn and Q that the runs determine poorly (relative u above 50 %%) by the base sensor's "
                   "(default: kept with their value, u and correlations)")
    add_budget_arguments(p)
    p.add_argument("--out", required=True, metavar="DIR", help=f"write {SENSOR_FILE} and {DOCUMENT} there")
    p.add_argument("--json", action="store_true", help="print the identification as one JSON object")
    p.set_defaults(func=run)


def _campaign_doc(source: str, workers: int) -> dict[str, Any]:
    """The campaign document of a manifest (reduced here) or of a campaign folder."""
    path = Path(source)
    if path.is_dir():
        from vrelab.folder import read_folder

        rf = read_folder(path)
        if rf.kind != "campaign" or rf.doc is None:
            raise ValueError(f"identify: {path} is not a campaign folder (`vrelab campaign MANIFEST --out {path}` "
                             "writes one)")
        return dict(rf.doc)
    from vrelab.campaigns import campaign_doc, combine, read_manifest, run_campaign

    manifest = read_manifest(path)
    results = run_campaign(manifest, workers)
    return campaign_doc(manifest, results, combine(results, manifest.channels))


def run(args: argparse.Namespace) -> int:
    from vrelab import _io
    from vrelab.identification import IdentifyOptions, identify, write_sensor_file

    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    typeb = typeb_from_args(args)
    command = shlex.join(["vrelab", "identify", args.source, "--base-sensor", args.base_sensor, "--out", args.out])
    from vrelab.cli._common import input_paths

    source = Path(args.source)
    if source.is_file():  # a manifest: its records are inputs too
        from vrelab.campaigns import read_manifest

        inputs = input_paths(read_manifest(source), args.base_sensor)
    else:  # a campaign folder
        inputs = input_paths(args.source, args.base_sensor)
    # a bad --out (the campaign folder itself, or one holding it) is refused before any work
    with _io.output_dir(args.out, inputs=inputs) as stage:
        doc = _campaign_doc(args.source, args.workers)
        options = IdentifyOptions(args.kind, typeb if typeb.declared else None, args.workers, args.prefer_base)
        ident = identify(doc, args.base_sensor, args.range_g, args.odr_hz, args.base_axis, options)
        write_sensor_file(Path(stage) / SENSOR_FILE, ident)
        out = ident.to_dict(sensor_file=str(Path(args.out) / SENSOR_FILE))
        out["provenance"] = {"command": command, "campaign_provenance": doc.get("provenance")}
        _io.write_json(Path(stage) / DOCUMENT, out)
    import sys

    for line in ident.notes:  # a failed run is never silent, whatever the output format
        sys.stderr.write(printable(f"vrelab identify: {line}") + "\n")
    if args.json:
        print_json(out)
    else:
        _print(out)
    return 0


def _print(doc: dict[str, Any]) -> None:
    from vrelab._format import format_value_u

    b = doc["base_sensor"]
    print(f"campaign {doc['campaign']!r} identified on base sensor {b['spec']} (±{b['range_g']:g} g)")
    for c in doc["channels"]:
        chi2 = c["chi2_reduced"]
        print(f"channel {c['channel']}: chi2/dof = {'-' if chi2 is None else f'{chi2:.3g}'} ({c['dof']} dof)")
        for name, e in c["parameters"].items():
            if e is None:
                print(f"  {name:<22} null: {c['null_reasons'].get(name, '')}")
            else:
                print(f"  {name:<22} {format_value_u(e['value'], e['u'], unit=e['unit'])}")
        for x in c["cross_check_2f"]:
            a, d = x["vrc_2f_ug_per_g2"], x["vrc_dc_ug_per_g2"]
            print(f"  2f check, run {x['run']} ({x['freq_hz']:.4g} Hz, {x['static_g']:+g} g): "
                  f"2f {format_value_u(a['value'], a['u'], unit='µg/g²')} vs DC {format_value_u(d['value'], d['u'], unit='µg/g²')}")
        for n in c["notes"]:
            print(f"  note: {n}")
    print(f"wrote {doc['sensor_file']}: use it as --sensor {doc['sensor_file']} --axis <channel>; "
          "`vrelab report` on the folder makes its report")
