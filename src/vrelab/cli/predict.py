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
import math
from typing import Any

from vrelab import _validate as V
from vrelab.cli import print_json
from vrelab._lists import parse_list


def add_sensor_arguments(p: argparse.ArgumentParser) -> None:
    """The sensor options common to ``predict`` and ``simulate`` (SPEC 5)."""
    p.add_argument("--sensor", required=True, metavar="S", help="preset (adxl355, adxl354, adxl357, ideal) or a sensor file")
    p.add_argument("--range", dest="range_g", type=float, metavar="G", help="measurement range [g], e.g. 2, 4, 8")
    p.add_argument("--axis", choices=("x", "y", "z"), help="sensing axis (sets fn and Q)")
    p.add_argument("--odr", dest="odr_hz", type=float, metavar="HZ", help="output data rate [Hz] (sets the digital low-pass)")
    p.add_argument("--static", dest="static_g", type=float, default=1.0, metavar="G",
                   help="static acceleration along the axis [g] (default 1: axis up in a 1 g field)")
    p.add_argument("--k2", dest="k2_ug_per_g2", type=float, metavar="UG_PER_G2", help="second-order nonlinearity [µg/g²]")
    p.add_argument("--k3", dest="k3_ug_per_g3", type=float, metavar="UG_PER_G3", help="third-order nonlinearity [µg/g³]")


def sensor_from_args(args: argparse.Namespace) -> Any:
    from vrelab.sensor import load_sensor

    V.finite_scalar("--static", args.static_g)
    return load_sensor(
        args.sensor,
        range_g=args.range_g,
        axis=args.axis,
        odr_hz=args.odr_hz,
        k2_ug_per_g2=args.k2_ug_per_g2,
        k3_ug_per_g3=args.k3_ug_per_g3,
    )


def positive_list(text: str, name: str) -> list[float]:
    """A LIST option whose values must all be > 0 (levels, frequencies)."""
    values = parse_list(text, name)
    for x in values:
        if not x > 0:
            raise ValueError(f"{name}: values must be > 0, got {x:g}")
    return values


def _fmt_mg(x: float | None) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x * 1e3:.4g}"


def print_prediction(pred: Any) -> None:
    d = pred.to_dict()
    c = d["conditions"]
    odr = f"ODR {c['odr_hz']:g} Hz" if c.get("odr_hz") else "no ODR"
    print(f"sensor {c.get('sensor')}  range ±{c.get('range_g'):g} g  axis {c.get('axis')}  {odr}  "
          f"static {c.get('static_g'):g} g")
    print(f"vibration: {c.get('profile')}")
    sine = any(lv.get("freq_hz") is not None for lv in d["levels"])
    head = ("freq_hz " if sine else "") + f"{'rms_g':>8} {'VRE mg':>10} {'tilt deg':>10} {'clip mg':>9} {'nonlin mg':>9} {'overrange mg':>12}  valid"
    print(head)
    for lv in d["levels"]:
        sh = lv["shares"]
        f = f"{lv['freq_hz']:7.4g} " if sine else ""
        print(
            f"{f}{lv['rms_g']:8.4g} {_fmt_mg(lv['vre_g']):>10} {lv['tilt_error_deg']:10.3g} "
            f"{_fmt_mg(sh.get('clip_g')):>9} {_fmt_mg(sh.get('nonlinearity_g')):>9} "
            f"{_fmt_mg(sh.get('overrange_g')):>12}  {'yes' if lv['valid'] else 'no'}"
        )
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
        excitation = V.positive_scalar("--freq", args.freq)
    pred = predict(sensor, excitation, levels, static_g=args.static_g, kind=args.kind)
    if args.out:
        from vrelab._io import output_dir, write_json

        with output_dir(args.out) as stage:
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
    ex.add_argument("--profile", metavar="PROFILE", help="random profile: file, F:P,F:P,... or flat:F1-F2; scaled to each level")
    ex.add_argument("--freq", type=float, metavar="HZ", help="sine frequency [Hz]")
    p.add_argument("--levels", required=True, metavar="LIST", help="vibration levels [g rms], e.g. 0.5,1,2 or 0.5:3:0.5")
    p.add_argument("--kind", choices=("censored", "truncated"), default="censored",
                   help="clipping model: censored (a saturating sensor, default) or truncated (the article's)")
    p.add_argument("--out", metavar="DIR", help="write DIR/prediction.json")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
