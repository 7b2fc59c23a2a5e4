"""``vrelab model clip`` and ``vrelab model poly``: the analytic VRE models at a list of levels.

Argument parsing and printing only; the physics is :mod:`vrelab.models` (the CLI reference).
"""

from __future__ import annotations

import argparse
import math
from typing import Sequence

from vrelab._lists import number, parse_list
from vrelab.cli._common import Parser, Subparsers, print_json
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS

# The models (numpy, scipy.special) are imported by the command that runs them, so that the
# parser and `vrelab model --help` cost neither.

_CLIP_HELP = """\
Mean shift (VRE) caused by the sensor's range rails: in a static field the vibration reaches one
rail before the other, so the clipped output's mean moves.

  censored   (default) a sample beyond a rail reads as the rail: what a saturating sensor does.
  truncated  a sample beyond a rail is discarded: the article's model (mean of a truncated
             normal); it overstates the shift (-283 mg vs -83 mg at 1 g rms on +-2 g, 1 g field).

Gaussian vibration uses sigma = rms; a sine uses amplitude = rms * sqrt(2).
VRE = mean output with vibration - the vibration-off reading clip(mean) (physics §1.5; beyond a rail
that reading is itself clipped, and the output says so).
Example: vrelab model clip --mean 1 --rail 2 --rms 0.5:3:0.5
"""

_DASH_NOTE = (
    "A value that starts with '-' and is not a plain number (e.g. -1e-3 or a range -1:1:0.5) "
    "must be attached with '=': --mean=-1e-3."
)

_POLY_HELP = """\
VRE of a scale-factor nonlinearity y = a + k2*a^2 + k3*a^3 + k4*a^4 (a = static + vibration),
coefficients in ug/g^2, ug/g^3, ug/g^4 (k2 is the VRC; 1 ug/g^2 = 1 ppm/g):

  VRE = (k2 + 3*k3*g0)*rms^2 + k4*(6*g0^2*rms^2 + E[x^4]),  E[x^4] = 3 rms^4 (Gaussian), 1.5 rms^4 (sine)

referred to the vibration-off reading P(g0) (physics §1.5).

Example: vrelab model poly --k2 100 --k3 5 --static 1 --rms 0.5,1,2
"""

_LIST = "comma-separated values and ranges start:stop:step (inclusive), e.g. 0.5,1,2:4:0.5"


def _levels(text: str) -> list[float]:
    from vrelab import _validate as V

    values = parse_list(text, "--rms")
    bad = [v for v in values if v < 0]
    if bad:
        raise ValueError(f"--rms: levels must be >= 0 g rms, got {bad[0]:g}")
    if any(v > 0 for v in values):
        V.vibration_level("--rms", [v for v in values if v > 0])
    return values


def _reference_line(off_g: float) -> str:
    from vrelab.models.memoryless import REFERENCE

    return f"VRE referred to the {REFERENCE} ({off_g:.9g} g): mean output with vibration less that reading"


def _table(title: str, rms: Sequence[float], vre_g: Sequence[float]) -> str:
    lines = [title, f"  {'rms (g)':>10}  {'VRE (mg)':>14}"]
    for r, v in zip(rms, vre_g):
        shown = f"{v * 1e3:14.6g}" if math.isfinite(v) else f"{'n/a':>14}"
        lines.append(f"  {r:10.4g}  {shown}")
    return "\n".join(lines)


def _run_clip(args: argparse.Namespace) -> int:
    import numpy as np

    from vrelab import _validate as V
    from vrelab._format import finite_or_none
    from vrelab.models.design import clip_vre
    from vrelab.models.memoryless import REFERENCE, reference_note, vibration_off_reading

    mean = V.acceleration("--mean", number(args.mean, "--mean"))
    rail = number(args.rail, "--rail")
    rail_low = -rail if args.rail_low is None else number(args.rail_low, "--rail-low")
    if rail_low >= rail:
        raise ValueError(f"--rail-low ({rail_low:g} g) must be below --rail ({rail:g} g)")
    rms = _levels(args.rms)
    vre = np.atleast_1d(clip_vre(mean, np.array(rms), rail_low, rail, shape=args.shape, kind=args.kind))
    off = vibration_off_reading(mean, rail_low_g=rail_low, rail_high_g=rail)
    note = reference_note(mean, rail_low_g=rail_low, rail_high_g=rail)
    if args.json:
        print_json(
            {
                "command": "model clip",
                "mean_g": mean,
                "rail_g": rail,
                "rail_low_g": rail_low,
                "shape": args.shape,
                "kind": args.kind,
                "reference": REFERENCE,
                "vibration_off_g": off,
                "vibration_off_clipped": note is not None,
                "rms_g": rms,
                "vre_g": [finite_or_none(v) for v in vre],
                "notes": [note] if note else [],
            }
        )
    else:
        title = (
            f"Clipping VRE, {args.kind}: {args.shape} vibration, static {mean:g} g, "
            f"rails [{rail_low:g}, {rail:g}] g\n{_reference_line(off)}"
        )
        print(_table(title, rms, vre.tolist()))
        if note:
            print(f"note: {note}")
        if args.kind == "truncated" and not np.isfinite(vre).all():
            print("n/a: the whole sine lies beyond a rail, no sample is left to average")
    return 0


def _run_poly(args: argparse.Namespace) -> int:
    import numpy as np

    from vrelab import _validate as V
    from vrelab._format import finite_or_none
    from vrelab.models.memoryless import REFERENCE, vibration_off_reading
    from vrelab.models.nonlinearity import vre_poly
    from vrelab.units import from_ug

    k2 = number(args.k2, "--k2")
    k3 = number(args.k3, "--k3")
    k4 = number(args.k4, "--k4")
    static = V.acceleration("--static", number(args.static, "--static"))
    rms = _levels(args.rms)
    # the levels and field are bounded; a coefficient is not (any value is a model), so the
    # product is checked: a VRE beyond float64 is refused, not printed as inf after a warning
    with np.errstate(over="ignore", invalid="ignore"):
        vre = np.atleast_1d(vre_poly(np.array(rms), from_ug(k2), from_ug(k3), from_ug(k4), static_g=static, shape=args.shape))
    if not np.isfinite(vre).all():
        raise ValueError(f"model poly: the VRE overflows float64 (k2 = {k2:g}, k3 = {k3:g}, k4 = {k4:g} at "
                         f"{max(rms):g} g rms, static {static:g} g): coefficients or levels out of any real range")
    with np.errstate(over="ignore", invalid="ignore"):
        off = vibration_off_reading(static, from_ug(k2), from_ug(k3), from_ug(k4))
    if args.json:
        print_json(
            {
                "command": "model poly",
                "k2_ug_per_g2": k2,
                "k3_ug_per_g3": k3,
                "k4_ug_per_g4": k4,
                "static_g": static,
                "shape": args.shape,
                "reference": REFERENCE,
                "vibration_off_g": finite_or_none(off),
                "rms_g": rms,
                "vre_g": [finite_or_none(v) for v in vre],
            }
        )
    else:
        title = (
            f"Nonlinearity VRE: k2 = {k2:g} ug/g^2, k3 = {k3:g} ug/g^3, k4 = {k4:g} ug/g^4, "
            f"static {static:g} g, {args.shape} vibration\n{_reference_line(off)}"
        )
        print(_table(title, rms, vre.tolist()))
    return 0


def register(subparsers: Subparsers) -> None:
    model = subparsers.add_parser(
        "model",
        help="analytic VRE models: clipping at the rails, polynomial nonlinearity",
        description="Analytic VRE models (no simulation): clipping at the range rails and "
        "scale-factor nonlinearity, evaluated at a list of vibration levels.",
    )
    sub = model.add_subparsers(dest="model_command", metavar="MODEL", parser_class=Parser)
    sub.required = True

    fmt = argparse.RawDescriptionHelpFormatter
    clip = sub.add_parser("clip", help="VRE from clipping at the rails", description=_CLIP_HELP, epilog=_DASH_NOTE, formatter_class=fmt)
    clip.add_argument("--mean", required=True, metavar="G", help="static acceleration on the axis, g (+1: axis up in 1 g)")
    clip.add_argument("--rail", required=True, metavar="G", help="upper rail, g (the range, e.g. 2 for +-2 g)")
    clip.add_argument("--rail-low", metavar="G", help="lower rail, g (default: -RAIL)")
    clip.add_argument("--rms", required=True, metavar="LIST", help=f"vibration levels, g rms: {_LIST}")
    clip.add_argument("--shape", choices=("gaussian", "sine"), default="gaussian", help="vibration shape (default gaussian)")
    clip.add_argument(
        "--kind",
        choices=KINDS,
        default=DEFAULT_CLIP_KIND,
        help="censored: beyond-rail samples read as the rail (default); truncated: they are discarded (article's model)",
    )
    clip.add_argument("--json", action="store_true", help="print one JSON object (keys rms_g, vre_g, ...)")
    clip.set_defaults(func=_run_clip)

    poly = sub.add_parser("poly", help="VRE from a polynomial nonlinearity (VRC)", description=_POLY_HELP, epilog=_DASH_NOTE, formatter_class=fmt)
    poly.add_argument("--k2", required=True, metavar="UG_PER_G2", help="quadratic coefficient = VRC, ug/g^2")
    poly.add_argument("--k3", default="0", metavar="UG_PER_G3", help="cubic coefficient, ug/g^3 (default 0)")
    poly.add_argument("--k4", default="0", metavar="UG_PER_G4", help="quartic coefficient, ug/g^4 (default 0)")
    poly.add_argument("--static", default="0", metavar="G", help="static acceleration on the axis, g (default 0)")
    poly.add_argument("--rms", required=True, metavar="LIST", help=f"vibration levels, g rms: {_LIST}")
    poly.add_argument("--shape", choices=("gaussian", "sine"), default="gaussian", help="vibration shape (default gaussian)")
    poly.add_argument("--json", action="store_true", help="print one JSON object (keys rms_g, vre_g, ...)")
    poly.set_defaults(func=_run_poly)
