"""``vrelab predict``: analytic VRE of a sensor in a vibration environment, without simulating.

the CLI reference::

    vrelab predict --sensor S [--range G] [--axis x|y|z] [--odr HZ] [--static G]
                   [--k2 UG_PER_G2] [--k3 UG_PER_G3]
                   (--profile PROFILE --levels LIST | --freq HZ --levels LIST) [--json]
                   [--direction X,Y,Z | --mount-deg DEG [--mount-plane ip|io]] [--static-vector GX,GY,GZ]

``--json`` prints :meth:`vrelab.prediction.results.Prediction.to_dict` (``levels``: objects with
``rms_g``, ``vre_g``, ``tilt_error_deg``, shares by mechanism). The sensor options here are
shared with ``vrelab simulate``. With a direction, a mount angle or a static vector the
vibration is triaxial (physics §1.6): the profile or sine applied along that direction in the
part's frame (or a triaxial ``--profile``: ``PROFILE@dir=X,Y,Z``, ``PROFILE@z45x``, a triaxial
TOML file: :mod:`vrelab.triaxial.files`), the levels its total rms, and the prediction
:func:`vrelab.predict`'s off the input axis (the IEEE 1293 cross terms' shares
``cross_kip_g`` ... ``cross_g`` beside the single-axis ones). ``--static`` and
``--static-vector`` together are refused (:mod:`vrelab.cli._triaxial`, as ``vrelab simulate``).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from vrelab.cli._common import (
    Subparsers,
    add_sensor_arguments,
    positive_list,
    print_json,
    sensor_from_args,
)
from vrelab.cli._triaxial import (
    add_triaxial_arguments,
    along,
    direction_of,
    is_triaxial_profile,
    static_field,
    triaxial_profile,
)
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS

if TYPE_CHECKING:
    from vrelab.prediction.results import Prediction


def print_prediction(pred: Prediction) -> None:
    from vrelab._format import PREDICTION_RESOLUTION_MG, TILT_RESOLUTION_DEG, format_mg, format_value, format_value_u

    d = pred.to_dict()
    c = d["conditions"]
    odr = f"ODR {c['odr_hz']:g} Hz" if c.get("odr_hz") else "no ODR"
    print(f"sensor {c.get('sensor')}  range ±{c.get('range_g'):g} g  axis {c.get('axis')}  {odr}  "
          f"static {c.get('static_g'):g} g")
    print(f"vibration: {c.get('profile')}")
    extra = c.get("extra") or {}
    if "static_vector_g" in extra:  # triaxial (physics §1.6): the part's frame, the axis's triad and row
        t, k = extra["triad"], extra["cross_coupling_ug_per_g2"]
        print(f"static vector ({', '.join(f'{x:g}' for x in extra['static_vector_g'])}) g  triad i={t['input']} "
              f"p={t['pendulous']} o={t['output']}  sensitivity row ({', '.join(f'{x:g}' for x in extra['sensitivity_row'])})"
              "  " + " ".join(f"{n.capitalize()} {v:g}" for n, v in k.items()) + " ug/g^2")
    sine = any(lv.get("freq_hz") is not None for lv in d["levels"])
    with_u = any("u_vre_g" in lv for lv in d["levels"])
    vw = 18 if with_u else 10
    # the cross terms (triaxial): their sum, and each one that is not 0 at some level
    triax = any("cross_g" in lv["shares"] for lv in d["levels"])
    cross: list[str] = []
    if triax:
        from vrelab.prediction.triaxial import CROSS_SHARES

        cross = [k for k, _, _, _ in CROSS_SHARES if any(lv["shares"].get(k) for lv in d["levels"])]
    cross_head = "".join(f" {k[6:9].capitalize() + ' mg':>9}" for k in cross) + (f" {'cross mg':>9}" if triax else "")
    head = ("freq_hz " if sine else "") + (f"{'rms_g':>8} {'VRE mg':>{vw}} {'VRC ug/g^2':>{vw}} {'tilt deg':>10} "
                                           f"{'clip mg':>9} {'nonlin mg':>9} "
                                           f"{'overrange mg':>12}{cross_head}  valid")
    print(head)
    res = PREDICTION_RESOLUTION_MG

    def mg(x: float | None) -> str:
        return format_mg(x, signed=False, resolution_mg=res)

    for lv in d["levels"]:
        sh = lv["shares"]
        f = f"{lv['freq_hz']:7.4g} " if sine else ""
        vre = format_mg(lv["vre_g"], lv.get("u_vre_g"), signed=False, resolution_mg=res)
        # the level's VRC (VRE / rms², physics §1.2), what a datasheet quotes, beside its VRE
        # shown to the VRE's resolution carried over (res mg = 1e3·res µg, per rms²)
        vrc = format_value_u(lv.get("vrc_ug_per_g2"), lv.get("u_vrc_ug_per_g2"),
                             resolution=1e3 * res / lv["rms_g"] ** 2)
        print(
            f"{f}{lv['rms_g']:8.4g} {vre:>{vw}} {vrc:>{vw}} "
            f"{format_value(lv['tilt_error_deg'], resolution=TILT_RESOLUTION_DEG):>10} "
            f"{mg(sh.get('clip_g')):>9} {mg(sh.get('nonlinearity_g')):>9} "
            f"{mg(sh.get('overrange_g')):>12}"
            + "".join(f" {mg(sh.get(k)):>9}" for k in cross) + (f" {mg(sh.get('cross_g')):>9}" if triax else "")
            + f"  {'yes' if lv['valid'] else 'no'}"
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
    from vrelab import _validate as V
    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile

    levels = positive_list(args.levels, "--levels")
    spec = is_triaxial_profile(args.profile)
    directed = along(args)
    if spec and directed:
        raise ValueError("--direction and --mount-deg apply to a single-axis --profile, not to a triaxial one")
    static = static_field(args)
    triaxial = directed or spec or static is not None
    sensor = sensor_from_args(args)
    if spec:
        excitation: Any = triaxial_profile(args.profile)
    elif args.profile is not None:
        excitation = parse_profile(args.profile)
    else:
        excitation = float(V.frequency("--freq", V.positive_scalar("--freq", args.freq)))
    from vrelab.triaxial.profile import AXES

    if triaxial and sensor.axis not in AXES:
        raise ValueError(f"a triaxial vibration needs an axis x, y or z of the part, got --axis {sensor.axis!r}")
    # one predict (physics §1.6): along the input axis with --static, else along the direction or
    # mount angle given, a triaxial --profile as it is, the static vector where given
    pred = predict(sensor, excitation, levels, static_g=args.static_g if static is None else static, kind=args.kind,
                   direction=direction_of(args, sensor.triad) if directed else None)
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


def register(subparsers: Subparsers) -> None:
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
    add_triaxial_arguments(p)
    p.add_argument("--out", metavar="DIR", help="write DIR/prediction.json")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
