"""``vrelab predict``: analytic VRE of a sensor in a vibration environment, without simulating.

SPEC section 5::

    vrelab predict --sensor S [--range G] [--axis x|y|z] [--odr HZ] [--static G]
                   [--k2 UG_PER_G2] [--k3 UG_PER_G3]
                   (--profile PROFILE --levels LIST | --freq HZ --levels LIST) [--json]

``--json`` prints :meth:`vrelab.predict.Prediction.to_dict` (``levels``: objects with
``rms_g``, ``vre_g``, ``tilt_error_deg``, shares by mechanism). The sensor options here are
shared with ``vrelab simulate``.
"""

from __future__ import annotations

import argparse
from typing import Any

from vrelab import _validate as V
from vrelab._format import PREDICTION_RESOLUTION_MG, TILT_RESOLUTION_DEG, format_mg, format_value
from vrelab.cli._common import (
    add_sensor_arguments,
    positive_list,
    print_json,
    sensor_from_args,
)
from vrelab.models.clipping import KINDS
from vrelab.models.kinds import DEFAULT_CLIP_KIND


def print_prediction(pred: Any) -> None:
    d = pred.to_dict()
    c = d["conditions"]
    odr = f"ODR {c['odr_hz']:g} Hz" if c.get("odr_hz") else "no ODR"
    print(f"sensor {c.get('sensor')}  range ±{c.get('range_g'):g} g  axis {c.get('axis')}  {odr}  "
          f"static {c.get('static_g'):g} g")
    print(f"vibration: {c.get('profile')}")
    sine = any(lv.get("freq_hz") is not None for lv in d["levels"])
    with_u = any("u_vre_g" in lv for lv in d["levels"])
    vw = 18 if with_u else 10
    head = ("freq_hz " if sine else "") + f"{'rms_g':>8} {'VRE mg':>{vw}} {'tilt deg':>10} {'clip mg':>9} {'nonlin mg':>9} {'overrange mg':>12}  valid"
    print(head)
    res = PREDICTION_RESOLUTION_MG

    def mg(x: Any) -> str:
        return format_mg(x, signed=False, resolution_mg=res)

    for lv in d["levels"]:
        sh = lv["shares"]
        f = f"{lv['freq_hz']:7.4g} " if sine else ""
        vre = format_mg(lv["vre_g"], lv.get("u_vre_g"), signed=False, resolution_mg=res)
        print(
            f"{f}{lv['rms_g']:8.4g} {vre:>{vw}} {format_value(lv['tilt_error_deg'], resolution=TILT_RESOLUTION_DEG):>10} "
            f"{mg(sh.get('clip_g')):>9} {mg(sh.get('nonlinearity_g')):>9} "
            f"{mg(sh.get('overrange_g')):>12}  {'yes' if lv['valid'] else 'no'}"
        )
    # why a level is not valid: each distinct reason once, with the levels it concerns
    reasons: dict[str, list[str]] = {}
    for lv in d["levels"]:
        for note in lv["notes"]:
            where = f"{lv['rms_g']:.4g} g rms" + (f" at {lv['freq_hz']:g} Hz" if lv.get("freq_hz") is not None else "")
            reasons.setdefault(note, []).append(where)
    for note, wheres in reasons.items():
        print(f"level {', '.join(wheres)}: {note}")
    for note in d["notes"]:
        print(f"note: {note}")


def run(args: argparse.Namespace) -> int:
    from vrelab.predict import predict
    from vrelab.profiles import parse_profile

    levels = positive_list(args.levels, "--levels")
    sensor = sensor_from_args(args)
    if args.profile is not None:
        excitation: Any = parse_profile(args.profile)
    else:
        excitation = float(V.frequency("--freq", V.positive_scalar("--freq", args.freq)))
    pred = predict(sensor, excitation, levels, static_g=args.static_g, kind=args.kind)
    if args.out:
        from vrelab._io import output_dir, write_json
        from vrelab.cli._common import input_paths

        with output_dir(args.out, inputs=input_paths(args.sensor, args.profile)) as stage:
            write_json(stage / "prediction.json", pred.to_dict())
    if args.json:
        print_json(pred.to_dict())
    else:
        print_prediction(pred)
    return 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "predict",
        help="analytic VRE of a sensor in a sine or random vibration, with shares by mechanism",
        description="Predict VRE analytically (clipping, nonlinearity, over-range) and say where "
        "the approximations stop holding (then use `vrelab simulate`).",
    )
    add_sensor_arguments(p)
    ex = p.add_mutually_exclusive_group(required=True)
    ex.add_argument("--profile", metavar="PROFILE",
                    help="random profile: a name (vrelab environment list), file, F:P,F:P,... or flat:F1-F2, "
                    "optionally +sine:F:PEAK,... tones (Hz:g peak); scaled to each level, tones with the PSD")
    ex.add_argument("--freq", type=float, metavar="HZ", help="sine frequency [Hz]")
    p.add_argument("--levels", required=True, metavar="LIST",
                   help="vibration levels [g rms], e.g. 0.5,1,2 or 0.5:3:0.5; with tones, the overall rms "
                   "(random and tones), reached by scaling the PSD by the ratio squared and each tone by the ratio")
    p.add_argument("--kind", choices=KINDS, default=DEFAULT_CLIP_KIND,
                   help="clipping model: censored (a saturating sensor, default) or truncated (the article's)")
    p.add_argument("--out", metavar="DIR", help="write DIR/prediction.json")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
