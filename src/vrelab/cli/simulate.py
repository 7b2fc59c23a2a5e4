"""``vrelab simulate``: the virtual shaker test of a sensor (random or sine method).

the CLI reference::

    vrelab simulate --sensor S [--range G] [--axis A] [--odr HZ] [--static G] [--k2] [--k3]
                    (--profile PROFILE | --freq LIST) --levels LIST [--seconds S] [--seed N]
                    [--ramp S] [--drift G_PER_S] [--out DIR] [--record] [--json] [--progress]

``--ramp S`` brings each level up and down over S seconds (raised cosine, outside the
``--seconds`` at level; the record's schedule leaves the ramps out); ``--drift`` adds a slow
linear drift of the sensor's output [g/s] (both default 0).

Both run :func:`vrelab.simulate`. A triaxial test (physics §1.6): ``--direction
X,Y,Z`` (or IEEE 1293's mount angle ``--mount-deg DEG [--mount-plane ip|io]`` of the first DUT
axis) runs the random ``--profile`` (or one ``--freq`` sine) along that direction, or
``--profile`` names a triaxial vibration (``PROFILE@dir=X,Y,Z``, ``PROFILE@z45x``, a triaxial
TOML file); ``--axes x,y,z`` are the DUT axes (default ``--axis``), ``--static-vector X,Y,Z``
the static acceleration in the part's frame (default ``--static`` along the first DUT axis; the
two together are refused, as by ``vrelab predict``: :mod:`vrelab.cli._triaxial`). It prints,
and ``--json`` or ``--out`` writes, one result per axis (a several-channel document).

``--json`` prints :meth:`vrelab.results.VreResult.to_dict` (``levels``: ``rms_g``, ``vre_g``,
``u_vre_g``, ``freq_hz`` for sine; ``fit``). ``--out DIR`` writes ``results.json``,
``levels.csv``, ``prediction.json`` (the analytic prediction for the same conditions) and, with
``--record``, the raw record ``record.h5`` — all of them or none.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vrelab.cli import _triaxial as tri
from vrelab.cli._common import (
    Subparsers,
    add_sensor_arguments,
    mount_overrides,
    positive_list,
    print_json,
    print_levels,
    sensor_from_args,
)
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS
from vrelab.simulation.durations import DEFAULT_BASELINE_S, DEFAULT_LEVEL_S

if TYPE_CHECKING:
    from vrelab.results import VreResult


def print_result(result: VreResult) -> None:
    c = result.conditions
    odr = f"ODR {c.odr_hz:g} Hz" if c.odr_hz else "no ODR"
    print(f"simulated {result.method} test: sensor {c.sensor}  range ±{c.range_g:g} g  axis {c.axis}  "
          f"{odr}  static {c.static_g:g} g")
    print(f"vibration: {c.profile}")
    print_levels(result)


def _is_triaxial(args: argparse.Namespace, static: list[float] | None) -> bool:
    directed = tri.along(args)
    return static is not None or directed or args.axes is not None or tri.is_triaxial_profile(args.profile)


def _run_triaxial(args: argparse.Namespace, static: list[float] | None, levels: list[float], seconds: float,
                  baseline_s: float, progress: bool) -> int:
    """``vrelab simulate`` of a triaxial vibration: one result per DUT axis."""
    from vrelab import _validate as V
    from vrelab._api import simulate as simulate_test
    from vrelab.profiles import RandomProfile, parse_profile
    from vrelab.sensor import load_sensor
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

    for opt, bad in (("--drive", args.drive != "gaussian"), ("--clip-sigma", args.clip_sigma is not None),
                     ("--kurtosis", args.kurtosis is not None), ("--ramp", bool(args.ramp))):
        if bad:
            raise ValueError(f"{opt} does not apply to a triaxial test (a Gaussian drive with its CSD, no ramp)")
    base = sensor_from_args(args)
    names = [a.strip() for a in args.axes.split(",")] if args.axes is not None else [base.axis]
    if not names or any(not a for a in names) or len(set(names)) != len(names):
        raise ValueError(f"--axes must name distinct axes, e.g. x,y,z; got {args.axes!r}")
    drift = float(V.finite_scalar("--drift", args.drift))
    sensors = []
    for a in names:
        s = load_sensor(args.sensor, range_g=args.range_g, axis=a, odr_hz=args.odr_hz,
                        k2_ug_per_g2=args.k2_ug_per_g2, k3_ug_per_g3=args.k3_ug_per_g3, overrides=mount_overrides(args))
        if drift:
            s = dataclasses.replace(s, drift_g_per_s=drift,
                                    facts={**dict(s.facts), "drift_g_per_s": f"set by the user: {drift:g} g/s"})
        sensors.append(s)
    d = tri.direction_of(args, sensors[0].triad)  # a mount angle: the first DUT axis's
    excitation: Any
    if args.freq is not None:
        freqs = positive_list(args.freq, "--freq")
        if d is None or len(freqs) != 1:
            raise ValueError("a triaxial sine is one --freq F along a --direction X,Y,Z (or a --mount-deg)")
        excitation, d = TriaxialSine(freqs[0], (d[0], d[1], d[2])), None
    elif tri.is_triaxial_profile(args.profile):
        if d is not None:
            raise ValueError("--direction and --mount-deg apply to a single-axis --profile, not to a triaxial one")
        excitation = tri.triaxial_profile(args.profile)
    else:
        if d is None:
            raise ValueError("a triaxial test needs --direction X,Y,Z or --mount-deg DEG (or a triaxial --profile)")
        excitation = parse_profile(args.profile)
        if not isinstance(excitation, RandomProfile):
            raise ValueError("a sine-on-random --profile along a --direction is not supported (its tones would need "
                             "a direction of their own)")
    g = tri.static_vector(static, args.static_g, sensors[0].triad[0])
    from vrelab.prediction.checks import mount_note

    # the fixture rule, as for one axis (run): every DUT axis sits on the one mount
    band = excitation.band if hasattr(excitation, "band") else (excitation.freq_hz, excitation.freq_hz)
    warning = mount_note(sensors[0], (float(band[0]), float(band[1])))
    if warning:
        print(f"warning: {warning}", file=sys.stderr)

    def simulate(record_path: Path | None) -> Any:
        return simulate_test(sensors, excitation, levels, g, direction=d, seconds=seconds, baseline_s=baseline_s,
                             settle_s=args.settle, seed=args.seed, record_path=record_path, progress=progress)

    if args.out:
        from vrelab import folder
        from vrelab._io import output_dir
        from vrelab.cli._common import input_paths

        with output_dir(args.out, inputs=input_paths(args.sensor, args.profile)) as stage:
            result = simulate(stage / folder.RECORD if args.record else None)
            doc = result.to_dict()
            if args.record:
                doc["triaxial"]["record"] = folder.RECORD
            folder.write_channels(stage, list(result.axes.items()), doc)
    else:
        result = simulate(None)
    if args.json:
        print_json(result.to_dict())
        return 0
    c = next(iter(result.axes.values())).conditions
    part = result.triaxial
    odr = f"ODR {c.odr_hz:g} Hz" if c.odr_hz else "no ODR"
    print(f"simulated triaxial {result.method} test: sensor {c.sensor}  range ±{c.range_g:g} g  {odr}  "
          f"static vector ({', '.join(f'{x:g}' for x in part.static_g)}) g")
    exc = part.excitation  # a random profile is scaled to each level: its shape, not its own rms
    shape = exc.describe_shape() if isinstance(exc, TriaxialProfile) else exc.describe()
    print(f"vibration: {shape}; level = {part.conditions['level']}")
    for a, res in result.axes.items():
        print(f"axis {a}:")
        print_levels(res)
    return 0


def run(args: argparse.Namespace) -> int:
    from vrelab import _validate as V
    from vrelab._api import simulate as simulate_test
    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile

    levels = positive_list(args.levels, "--levels")
    seconds = V.positive_scalar("--seconds", args.seconds)
    baseline_s = V.positive_scalar("--baseline", args.baseline)
    if args.settle is not None and not (math.isfinite(args.settle) and args.settle >= 0):
        raise ValueError(f"--settle must be >= 0, got {args.settle}")
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    if args.freq is not None and (args.clip_sigma is not None or args.kurtosis is not None or args.drive != "gaussian"):
        raise ValueError("--drive, --clip-sigma and --kurtosis apply to a random --profile, not to --freq")
    if args.record and not args.out:
        raise ValueError("--record needs --out DIR (the record is written as DIR/record.h5)")
    ramp_s = float(V.non_negative("--ramp", args.ramp))
    progress = bool(args.progress or sys.stderr.isatty())
    static = tri.static_field(args)  # --static and --static-vector together are refused
    if _is_triaxial(args, static):
        return _run_triaxial(args, static, levels, seconds, baseline_s, progress)
    drift = float(V.finite_scalar("--drift", args.drift))
    sensor = sensor_from_args(args)
    if drift:
        facts = {**dict(sensor.facts), "drift_g_per_s": f"set by the user: {drift:g} g/s"}
        sensor = dataclasses.replace(sensor, drift_g_per_s=drift, facts=facts)
    profile = parse_profile(args.profile) if args.profile is not None else None
    freqs = V.frequency("--freq", positive_list(args.freq, "--freq")).tolist() if args.freq is not None else None
    excitation = profile if profile is not None else freqs
    assert excitation is not None  # --profile or --freq: the parser requires one
    from vrelab.prediction.checks import mount_note

    warning = mount_note(sensor, profile.band if profile is not None else (min(freqs or [0.0]), max(freqs or [0.0])))
    if warning:  # the fixture rule, applied in planning: the test is run as asked
        print(f"warning: {warning}", file=sys.stderr)

    def simulate(record_path: Path | None) -> Any:
        common = dict(seconds=seconds, baseline_s=baseline_s, settle_s=args.settle, seed=args.seed,
                      record_path=record_path, progress=progress, ramp_s=ramp_s)
        if profile is not None:
            return simulate_test(sensor, profile, levels, float(args.static_g), clip_kind=args.kind,
                                 drive_method=args.drive, clip_sigma=args.clip_sigma, kurtosis=args.kurtosis, **common)
        return simulate_test(sensor, None, levels, float(args.static_g), freq_hz=freqs, **common)

    if args.out:
        from vrelab import folder
        from vrelab._io import output_dir
        from vrelab.cli._common import input_paths

        with output_dir(args.out, inputs=input_paths(args.sensor, args.profile)) as stage:
            result = simulate(stage / folder.RECORD if args.record else None)
            pred = predict(sensor, excitation, levels, static_g=args.static_g,
                           kind=args.kind)
            folder.write_result(stage, result, pred.to_dict())
    else:
        result = simulate(None)
    if args.json:
        print_json(result.to_dict())
    else:
        print_result(result)
    return 0


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="simulated shaker test of a sensor (random or sine method), reduced like a lab record",
        description="Run the virtual shaker: baselines and vibration levels through the sensor's "
        "signal chain, then the same reduction and fits as `vrelab analyze`.",
    )
    add_sensor_arguments(p)
    ex = p.add_mutually_exclusive_group(required=True)
    ex.add_argument("--profile", metavar="PROFILE",
                    help="random method: a name (vrelab environment list), file, F:P,F:P,... or flat:F1-F2, "
                    "optionally +sine:F:PEAK,... tones (Hz:g peak, random phases from --seed); scaled to each level")
    ex.add_argument("--freq", metavar="LIST", help="sine method: frequencies [Hz], e.g. 100,1000")
    p.add_argument("--levels", required=True, metavar="LIST",
                   help="vibration levels [g rms]; with tones, the overall rms (random and tones), reached by "
                   "scaling the PSD by the ratio squared and each tone by the ratio")
    p.add_argument("--seconds", type=float, default=DEFAULT_LEVEL_S, metavar="S",
                   help=f"duration of each level [s] (default {DEFAULT_LEVEL_S:g})")
    p.add_argument("--baseline", type=float, default=DEFAULT_BASELINE_S, metavar="S",
                   help=f"duration of each vibration-off baseline [s] (default {DEFAULT_BASELINE_S:g})")
    p.add_argument("--settle", type=float, metavar="S",
                   help="settling time trimmed at each segment edge [s] (default: the reduction's, 0.5)")
    p.add_argument("--seed", type=int, default=0, metavar="N", help="random seed (default 0)")
    p.add_argument("--ramp", type=float, default=0.0, metavar="S",
                   help="ramp each level up and down over S seconds, as a shaker controller does (default 0)")
    p.add_argument("--drift", type=float, default=0.0, metavar="G_PER_S",
                   help="slow linear drift of the sensor's output [g/s] (default 0)")
    p.add_argument("--kind", choices=KINDS, default=DEFAULT_CLIP_KIND,
                   help="clipping model of the effective-rail fit and the prediction (default censored)")
    p.add_argument("--drive", choices=("gaussian", "multisine"), default="gaussian",
                   help="random drive: a Gaussian process (default) or a random-phase multisine")
    p.add_argument("--clip-sigma", type=float, metavar="K",
                   help="clip the random drive at ±K·σ, as shaker controllers do (with tones: the random part)")
    p.add_argument("--kurtosis", type=float, metavar="K", help="non-Gaussian random drive with this kurtosis (> 3)")
    tri.add_triaxial_arguments(p, axes=True)
    p.add_argument("--out", metavar="DIR", help="write results.json, levels.csv, prediction.json (and record.h5)")
    p.add_argument("--record", action="store_true", help="with --out: also write the raw record DIR/record.h5")
    p.add_argument("--progress", action="store_true", help="progress bar on stderr even when it is not a terminal")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
