"""``vrelab compare``: which part, range and output rate holds a VRE or tilt budget in a vibration.

the CLI reference::

    vrelab compare --environment ENV --levels LIST (--budget-vre 1mg | --budget-tilt 0.05deg)
                   [--static G | --tilt-range A:B] [--candidates PART[:RANGE[:ODR[:AXIS]]],...]
                   [--mount-fn HZ --mount-q Q] [--json] [--html OUT] [--workers N | --scheduler ADDR]

``--json`` prints :meth:`vrelab.comparison.results.Comparison.to_dict`: ``kind`` "comparison",
``conditions`` (``environment``, ``band_hz``, ``levels_g``, ``static_g``, ``tilt_range_deg``,
``budget``, ``budget_kind``, ``budget_value``, ``mount``, ``coverage_k``), ``best`` (the first
candidate that passes, or null), ``counts`` by verdict, ``rows`` in rank order (each:
``candidate``, ``label``, ``part``, ``range_g``, ``odr_hz``, ``axis``, ``verdict`` pass |
undecided | fail | invalid, ``valid``, ``reason``, ``vre_g``, ``U_vre_g``, ``k``,
``vrc_ug_per_g2``, ``tilt_error_deg``, ``U_tilt_error_deg``, ``margin``, ``worst`` {``rms_g``,
``static_g``}, ``dominant_mechanism``, ``dominant_u`` {``source``, ``u_vre_g``}, ``points``,
``notes``) and ``notes``.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from vrelab.cli._common import add_mount_arguments, mount_overrides, positive_list, print_json

if TYPE_CHECKING:
    from vrelab.cli._common import Subparsers
    from vrelab.comparison.results import Comparison


def print_comparison(cmp: Comparison) -> None:
    """The ranked table, then each invalid or undecided candidate's reason and the notes."""
    d = cmp.to_dict()
    c = d["conditions"]
    static = (f"tilt {c['tilt_range_deg'][0]:g} to {c['tilt_range_deg'][1]:g} deg" if c["tilt_range_deg"]
              else f"static {c['static_g'][0]:g} g")
    mount = f"  mount {c['mount']['fn_hz']:g} Hz Q {c['mount']['q']:g}" if c["mount"] else ""
    print(f"environment {c['environment']} ({c['band_hz'][0]:g}-{c['band_hz'][1]:g} Hz) at "
          f"{', '.join(f'{x:g}' for x in c['levels_g'])} g rms, {static}{mount}; budget {c['budget']} "
          f"(pass: |VRE| + U <= budget, U = {c['coverage_k']:g}u)")
    rows = [r for r in d["rows"] if r["valid"]]
    width = max([len(r["label"]) for r in d["rows"]] + [9])
    print(f"{'#':>3} {'candidate':<{width}} {'verdict':<9} {'VRE ± U mg':>17} {'VRC ug/g^2':>11} "
          f"{'tilt ± U deg':>19} {'margin':>7}  mechanism     dominant u")
    for n, r in enumerate(rows, 1):
        # no u stated: no U ("?"), the row undecided with its reason below
        vre = f"{r['vre_g'] * 1e3:.3g} ± " + (f"{r['U_vre_g'] * 1e3:.2g}" if r["U_vre_g"] is not None else "?")
        tilt = "-" if r["tilt_error_deg"] is None else f"{r['tilt_error_deg']:.3g} ± " + (
            f"{r['U_tilt_error_deg']:.2g}" if r["U_tilt_error_deg"] is not None else "?")
        du = f"{r['dominant_u']['source']} ({r['dominant_u']['u_vre_g'] * 1e3:.2g} mg)" if r["dominant_u"] else "none stated"
        print(f"{n:>3} {r['label']:<{width}} {r['verdict']:<9} {vre:>17} {r['vrc_ug_per_g2']:>11.4g} {tilt:>19} "
              f"{r['margin']:>7.3g}  {r['dominant_mechanism'] or '-':<13} {du}")
    for r in d["rows"]:
        if r["reason"]:
            print(f"{r['verdict']}: {r['label']}: {r['reason']}")
    seen: dict[str, list[str]] = {}
    for r in d["rows"]:
        for note in r["notes"]:
            seen.setdefault(note, []).append(r["label"])
    for note, who in seen.items():
        print(f"warning: {note}" + (f" ({len(who)} candidates)" if len(who) > 1 else f" ({who[0]})"))
    best = d["best"]
    print(f"best: {best}" if best else "best: none passes (no candidate is shown to hold the budget with its U)")


def run(args: argparse.Namespace) -> int:
    from vrelab.comparison import compare
    from vrelab.comparison.candidates import parse_budget, parse_tilt_range
    from vrelab.sweep.backends import check_backend_args

    levels = positive_list(args.levels, "--levels")
    budget = parse_budget(args.budget_vre, args.budget_tilt)
    tilt = parse_tilt_range(args.tilt_range) if args.tilt_range is not None else None
    mount = mount_overrides(args)
    check_backend_args(args.workers, args.scheduler)
    result = compare(args.environment, levels, budget, static_g=1.0 if args.static_g is None else args.static_g,
                     tilt_range_deg=tilt, candidates=args.candidates,
                     mount=(mount["mount_fn_hz"], mount["mount_q"]) if mount else None,
                     workers=args.scheduler if args.scheduler is not None else args.workers)
    if args.html:
        from vrelab.comparison.page import write_page

        write_page(result, args.html)
    if args.json:
        print_json(result.to_dict())
    else:
        print_comparison(result)
    return 0


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "compare",
        help="rank parts, ranges and output rates against a VRE or tilt budget in a vibration environment",
        description="Predict every candidate (each preset at each range and output rate, or a given list) in one "
        "vibration environment and rank them against a budget, guarded by the prediction's expanded "
        "uncertainty U (k = 2): pass when |VRE| + U <= budget, fail when |VRE| - U > budget, undecided between; "
        "a candidate whose prediction is not valid is listed last with its reason.",
    )
    p.add_argument("--environment", "--profile", dest="environment", required=True, metavar="ENV",
                   help="a named environment (vrelab environment list), a profile file, or a profile string "
                   "(flat:20-2000, F:P,F:P,..., +sine:F:PEAK tones)")
    p.add_argument("--levels", required=True, metavar="LIST", help="the environment's level(s) [g rms], e.g. 2 or 1,2,4")
    budget = p.add_mutually_exclusive_group(required=True)
    budget.add_argument("--budget-vre", metavar="VRE", help="the VRE allowed, with its unit: 1mg, 500ug, 0.002g")
    budget.add_argument("--budget-tilt", metavar="DEG",
                        help="the tilt error allowed [deg], e.g. 0.05deg: δθ ≈ VRE/(g·cos θ) at the static orientation")
    static = p.add_mutually_exclusive_group()
    static.add_argument("--static", dest="static_g", type=float, metavar="G",
                        help="static acceleration along the axis [g] (default 1: axis up)")
    static.add_argument("--tilt-range", metavar="A:B",
                        help="the axis's tilt range [deg], e.g. -30:30: judged at its ends, middle and 0, the worst deciding")
    p.add_argument("--candidates", metavar="LIST",
                   help="PART[:RANGE[:ODR[:AXIS]]] separated by commas, a part a preset or a sensor file "
                   "(e.g. adxl355:2g:4000,my_part.toml:8:500); default: every preset listing its ranges, at each "
                   "range and output rate")
    add_mount_arguments(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--html", metavar="OUT", help="write an HTML page: VRE ± U per candidate against the budget, "
                   "and VRE against level for the best few")
    par = p.add_mutually_exclusive_group()
    par.add_argument("--workers", type=int, metavar="N", help="evaluate the candidates on N processes")
    par.add_argument("--scheduler", metavar="ADDR", help="evaluate on a Dask scheduler (local or local:N: a local cluster)")
    p.set_defaults(func=run)
