"""``vrelab environment``: the named vibration environments and where they come from (the environments page).

::

    vrelab environment list [--json]
    vrelab environment show NAME [--json]

``list --json`` prints ``{"environments": [...]}``, each {``name``, ``title``, ``source``,
``grms``, ``band_hz``, ``stated_grms``, ``reproduced_from``, ``note``}: ``grms`` is the log-log
area of the breakpoints (physics §3), ``stated_grms`` what the standard (or the public reproduction
named) states. ``show --json`` adds ``profile`` (what ``vrelab profile NAME --json`` prints).
Any environment is also a profile: ``--profile NAME`` in ``predict``, ``simulate``, ``sweep``.
"""

from __future__ import annotations

from vrelab.cli._common import Subparsers, print_json, profile_table


def _list(as_json: bool) -> int:
    from vrelab.profiles import environments

    envs = environments()
    if as_json:
        print_json({"environments": [e.to_dict() for e in envs]})
        return 0
    width = max(len(e.name) for e in envs)
    print(f"{'name':<{width}}  {'band Hz':>10}  {'g rms':>6}  {'stated':>6}  title")
    for e in envs:
        lo, hi = e.band_hz
        stated = f"{e.stated_grms}" if e.stated_grms is not None else "-"
        print(f"{e.name:<{width}}  {f'{lo:g}-{hi:g}':>10}  {e.grms:6.3g}  {stated:>6}  {e.title}")
    return 0


def _show(name: str, as_json: bool) -> int:
    from vrelab.profiles import load_environment

    env = load_environment(name)
    if as_json:
        print_json({**env.to_dict(), "profile": env.profile.to_dict()})
        return 0
    print(f"{env.name}: {env.title}")
    print(f"source: {env.source}")
    if env.reproduced_from:
        print(f"breakpoints as reproduced in: {env.reproduced_from}")
    stated = f"{env.stated_grms} g rms" if env.stated_grms is not None else "not stated"
    print(f"grms: {env.grms:.4g} by the log-log area of the breakpoints; the source states {stated}")
    if env.note:
        print(f"note: {env.note}")
    print(profile_table(env.profile))
    return 0


def register(subparsers: Subparsers) -> None:
    from vrelab.cli._common import Parser

    env = subparsers.add_parser(
        "environment",
        help="the named vibration environments (standards' profiles) with their sources",
        description="List the named vibration environments (MIL-STD-810H, NAVMAT P-9492, GEVS, ...) "
        "with their source, overall level and band, or show one with its breakpoints. Each name is "
        "also a PROFILE for `profile`, `predict`, `simulate` and `sweep`.",
    )
    sub = env.add_subparsers(dest="environment_command", metavar="ACTION", parser_class=Parser)
    sub.required = True
    lst = sub.add_parser("list", help="every named environment: source, band, grms",
                         description="Every named environment with its source, band, overall level (log-log area "
                         "of the breakpoints) and the level the source states.")
    lst.add_argument("--json", action="store_true", help="print one JSON object: {\"environments\": [...]}")
    lst.set_defaults(func=lambda args: _list(args.json))
    show = sub.add_parser("show", help="one environment: its source, note and breakpoints",
                          description="One named environment: its source and where its breakpoints were "
                          "reproduced, the stated and computed grms, any note, and the breakpoint table.")
    show.add_argument("name", metavar="NAME", help="the environment (see `vrelab environment list`)")
    show.add_argument("--json", action="store_true", help="print one JSON object (the profile under 'profile')")
    show.set_defaults(func=lambda args: _show(args.name, args.json))
