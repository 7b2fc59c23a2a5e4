"""``vrelab sensor``: the parts library (the presets, or a sensor file) with every number's source.

::

    vrelab sensor list [--json]
    vrelab sensor show NAME|FILE [--range G] [--axis A] [--odr HZ] [--json]

``list --json`` prints ``{"sensors": [...]}``, each {``name``, ``origin``, ``description``,
``source``, ``ranges_g``, ``odrs_hz``, ``vre_statement``, ``vre_statement_text``}
(:func:`vrelab.sensor.catalog.part_summary`). ``show --json`` adds the chosen ``range_g``,
``axis``, ``odr_hz``, ``facts`` (every number: field, value, kind, fact), ``assumptions`` (every
assumed standard uncertainty: parameter, value, u, unit, reason) and ``unstated`` (assumptions
without a u, which predict names) (:func:`vrelab.sensor.catalog.part_details`).
"""

from __future__ import annotations

import argparse

from vrelab.cli._common import Subparsers, print_json


def _list(as_json: bool) -> int:
    from vrelab.sensor.catalog import part_summary
    from vrelab.sensor.loader import list_presets

    parts = [part_summary(name) for name in list_presets()]
    if as_json:
        print_json({"sensors": parts})
        return 0
    width = max(len(p["name"]) for p in parts)
    for p in parts:
        ranges = "/".join(f"±{r:g}" for r in p["ranges_g"]) + " g"
        lo, hi = (min(p["odrs_hz"]), max(p["odrs_hz"])) if p["odrs_hz"] else (0.0, 0.0)
        odrs = "no ODR modelled" if not p["odrs_hz"] else f"ODR {hi:g} Hz" if lo == hi else f"ODR {lo:g}-{hi:g} Hz"
        print(f"{p['name']:<{width}}  {ranges}; {odrs}; {p['description']}")
        print(f"{'':<{width}}  VRE statement: {p['vre_statement_text'] or 'none in its datasheet (or not found)'}")
    return 0


def _show(args: argparse.Namespace) -> int:
    from vrelab.sensor.catalog import part_details

    d = part_details(args.name, range_g=args.range, axis=args.axis, odr_hz=args.odr)
    if args.json:
        print_json(d)
        return 0
    odr = f"ODR {d['odr_hz']:g} Hz" if d["odr_hz"] is not None else "no ODR"
    print(f"{d['name']}: {d['description']}")
    print(f"source: {d['source']} ({d['origin']})")
    print(f"shown for: ±{d['range_g']:g} g, axis {d['axis']}, {odr} "
          f"(ranges {', '.join(f'{r:g}' for r in d['ranges_g'])} g)")
    print(f"VRE statement: {d['vre_statement_text'] or 'none in its datasheet (or not found)'}")
    st = d["vre_statement"]
    if st and not st["reproducible"]:
        print(f"  not reproduced by this preset: {st['why_not']}")
    print("\nfacts (every number and where it comes from):")
    for f in d["facts"]:
        v = f["value"]
        shown = "absent" if v is None else ", ".join(f"{x:g}" for x in v) if isinstance(v, list) else f"{v:g}"
        print(f"  {f['field']} = {shown}  [{f['kind']}] {f['fact']}")
    print("\nassumed standard uncertainties (what the datasheet leaves open):")
    for a in d["assumptions"]:
        print(f"  {a['parameter']} = {a['value']:g} ± {a['u']:.4g} {a['unit']}".rstrip() + f"  because: {a['reason']}")
    if d["unstated"]:
        print("\nassumptions without a u (predict names them and may mark a level not valid):")
        for a in d["unstated"]:
            print(f"  {a['parameter']} = {a['value']:g}  {a['fact']}")
    return 0


def register(subparsers: Subparsers) -> None:
    from vrelab.cli._common import Parser

    sensor = subparsers.add_parser(
        "sensor",
        help="the parts library: presets with their datasheet facts, assumptions and VRE statements",
        description="List the sensor presets (ranges, output rates, the VRE statement of the datasheet) or "
        "show one preset or sensor file: every number with its source, every assumption with its standard "
        "uncertainty and the reason.",
    )
    sub = sensor.add_subparsers(dest="sensor_command", metavar="ACTION", parser_class=Parser)
    sub.required = True
    lst = sub.add_parser("list", help="every preset: ranges, ODRs, the datasheet's VRE statement",
                         description="Every sensor preset with its description, ranges, output data rates and "
                         "the VRE statement of its datasheet (if it has one).")
    lst.add_argument("--json", action="store_true", help="print one JSON object: {\"sensors\": [...]}")
    lst.set_defaults(func=lambda args: _list(args.json))
    show = sub.add_parser("show", help="one preset or sensor file: facts, sources, assumptions and their u",
                          description="One preset (or a sensor TOML file): every number with its fact (datasheet "
                          "or assumption), every assumed standard uncertainty with its reason, the assumptions "
                          "without a u, and the datasheet's VRE statement.")
    show.add_argument("name", metavar="NAME", help="a preset (see `vrelab sensor list`) or a sensor TOML file")
    show.add_argument("--range", type=float, default=None, metavar="G", help="the range [g] (default: the file's)")
    show.add_argument("--axis", default=None, help="the axis (default: the file's)")
    show.add_argument("--odr", type=float, default=None, metavar="HZ", help="the output data rate [Hz]")
    show.add_argument("--json", action="store_true", help="print one JSON object")
    show.set_defaults(func=_show)
