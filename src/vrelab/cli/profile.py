"""``vrelab profile``: show a random vibration profile, its grms and its breakpoint table.

the CLI reference::

    vrelab profile PROFILE [--grms G] [--json] [--write FILE]
    vrelab profile --list          (or: vrelab profile list)

``PROFILE`` is a named profile, a .csv/.toml file, an inline ``F:P,F:P,...`` list or
``flat:F1-F2``, any of them with ``+sine:F:PEAK,...`` tones (see
:func:`vrelab.profiles.parse_profile`). ``--json`` prints the profile's ``to_dict``: ``grms``
(tones included: a tone's rms is peak/√2), ``breakpoints`` ([f_hz, psd_g2_per_hz] pairs of the
random part), ``band_hz``, ``slopes_db_per_oct``, ``name``, ``source``; and for sine-on-random
``random_grms`` and ``tones`` ({``freq_hz``, ``peak_g``, ``rms_g``}).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, TypedDict

from vrelab.cli._common import Subparsers, print_json, profile_table


class _Listed(TypedDict):
    """One named profile in ``vrelab profile list`` (a JSON object with ``--json``)."""

    name: str
    grms: float
    band_hz: list[float]
    source: str | None


def _list(as_json: bool) -> int:
    from vrelab.profiles import load_named_profile, named_profiles

    items: list[_Listed] = []
    for name in named_profiles():
        prof = load_named_profile(name)
        items.append(
            {"name": name, "grms": prof.grms, "band_hz": list(prof.band), "source": prof.source}
        )
    if as_json:
        print_json({"profiles": items})
    else:
        width = max((len(it["name"]) for it in items), default=0)
        for it in items:
            lo, hi = it["band_hz"]
            print(f"{it['name']:<{width}} {lo:g}-{hi:g} Hz, {it['grms']:.3g} g rms  [{it['source']}]")
    return 0


def run(args: argparse.Namespace) -> int:
    from vrelab import _validate as V
    from vrelab.profiles import parse_profile, write_profile

    spec = args.profile
    if args.list or (spec == "list" and not Path(spec).exists()):
        return _list(args.json)
    if spec is None:
        raise ValueError("profile: give PROFILE (a name, file, F:P,F:P,... or flat:F1-F2) or --list")
    from vrelab.triaxial.files import is_triaxial_spec

    if is_triaxial_spec(spec):
        return _triaxial(args)
    prof = parse_profile(spec)
    if args.grms is not None:
        prof = prof.scaled_to(V.positive_scalar("--grms", args.grms))
    if args.write is not None:
        write_profile(prof, args.write)
    return _show(args, prof.to_dict(), profile_table(prof))


def _show(args: argparse.Namespace, doc: dict[str, Any], text: str) -> int:
    """Print a profile (one JSON object with --json, else its text) and where --write wrote it."""
    if args.json:
        if args.write is not None:
            doc["written"] = str(args.write)
        print_json(doc)
    else:
        print(text)
        if args.write is not None:
            print(f"written: {args.write}")
    return 0


def _triaxial(args: argparse.Namespace) -> int:
    """A triaxial vibration (PROFILE@dir=X,Y,Z, PROFILE@z45x, sine:F@..., a triaxial .toml)."""
    from vrelab import _validate as V
    from vrelab.triaxial.files import parse_triaxial, write_triaxial
    from vrelab.triaxial.profile import TriaxialProfile

    prof = parse_triaxial(args.profile)
    if args.grms is not None:
        prof = prof.scaled_to(V.positive_scalar("--grms", args.grms))
    if args.write is not None:
        if not isinstance(prof, TriaxialProfile):
            raise ValueError("--write: a sine along a direction has no profile file; give it as sine:F@... where used")
        write_triaxial(prof, args.write)
    return _show(args, prof.to_dict(), prof.describe())


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "profile",
        help="show a random vibration profile: grms and breakpoints",
        description="Show a random vibration profile (breakpoints interpolated log-log): its "
        "grms, band, breakpoint table and slopes in dB/oct. PROFILE is a named profile "
        "(see --list), a .csv/.toml file, an inline list F:P,F:P,... (Hz:g²/Hz) or flat:F1-F2; "
        "+sine:F:PEAK,... adds sine tones (Hz:g peak), e.g. navmat-p9492+sine:120:0.5,240:0.2. A triaxial "
        "vibration: PROFILE@dir=X,Y,Z or PROFILE@z45x (along a direction or IEEE 1293 mount angle: axis z at 45 "
        "degrees toward x), sine:F@..., or a triaxial .toml ([x], [y], [z] breakpoints, [pair.xz] coherence and "
        "phase_deg); --write FILE.toml writes it.",
    )
    p.add_argument("profile", nargs="?", metavar="PROFILE", help="profile, or 'list'")
    p.add_argument("--grms", type=str, metavar="G",
                   help="scale the profile to this overall level [g rms]; with tones, the PSD by the ratio squared "
                   "and every tone amplitude by the ratio (tones included in the level)")
    p.add_argument("--list", action="store_true", help="list the named profiles")
    p.add_argument("--write", metavar="FILE", help="write the (scaled) profile to FILE (.csv or .toml)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
