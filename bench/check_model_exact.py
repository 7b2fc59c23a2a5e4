"""Same numbers from two checkouts: predict, its memoryless and spectral models, and identify.

A speed-up of the analytic models must not move their numbers. This runs a varied set of cases
on the source first on ``PYTHONPATH`` and, in a subprocess, on ``--baseline SRC`` (a ``src``
directory of another checkout, e.g. ``git archive`` of main), and prints the largest relative
difference per group:

* ``memoryless``: :func:`vrelab.models.memoryless.poly_clip_vre` over shapes (Gaussian, sine,
  sine-on-random), kinds, rails at one side, both sides and none, static levels beyond a rail,
  quartic polynomials and offsets; ``linear_part``, ``hermite_rms``;
* ``spectral``: :func:`vrelab.models.dynamics.effective_rms` and ``zero_crossing_rate_hz``;
* ``predict``: ``predict(...).to_dict()`` (every number in it) for the ideal sensor and the
  ADXL355 preset, random, sine and sine-on-random, censored and truncated, rails at the output
  (filters between polynomial and rails) and at the proof mass;
* ``triaxial``: one axis under a triaxial vibration (SPEC 1.6): ``to_dict()`` of
  :func:`vrelab.predict` with a TriaxialProfile/TriaxialSine and a static vector, and with a
  single-axis profile or sine along a ``direction=`` (on a checkout before issue 31,
  ``predict_triaxial`` of the same vibration): several directions, static vectors, cross terms
  and cross-axis rows, random (along a direction and per axis with coherences) and sine,
  filtered rails and over-range;
* ``identify``: each parameter's value and u for four drawn parts of tests/test_identify.py
  (differences in units of the parameter's u: least squares may end at a different last step);
* ``example``: the README's designer path, every number of ``identify --json`` on the example
  campaign and of ``predict --json`` with the sensor file it writes.

    PYTHONPATH=src python bench/check_model_exact.py --baseline /tmp/base/src

Pass: predict, memoryless and spectral within 1e-12 relative (1e-300 absolute; ``--rel`` and
``--abs`` to change), identify within 1e-6 of each parameter's u.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

TESTS = Path(__file__).resolve().parent.parent / "tests"


def _memoryless() -> list[Any]:
    from vrelab.models import memoryless as M

    out: list[Any] = []
    polys = [(0.0, 0.0, 0.0, 0.0), (3e-3, 0.0, 0.0, 0.0), (2.5e-3, -4e-4, 0.0, 0.01), (-1e-3, 2e-4, 5e-5, -0.02),
             (0.05, 0.02, 0.0, 0.0), (0.02, -0.03, 0.01, 0.0), (0.0, 0.0, 0.2, 0.0), (-0.3, 0.1, -0.05, 0.1)]
    rails = [(-math.inf, math.inf), (-2.0, 2.0), (-2.0, math.inf), (-math.inf, 2.0), (-1.5, 2.3), (-8.0, 8.0)]
    for k in polys:
        for lo, hi in rails:
            for g0 in (0.0, 1.0, -1.0, 1.9, 2.5, -2.6):
                for rms in (0.0, 0.05, 0.4, 1.0, 2.5):
                    for shape in ("gaussian", "sine"):
                        for kind in ("censored", "truncated"):
                            try:
                                v: Any = M.poly_clip_vre(g0, rms, *k, rail_low_g=lo, rail_high_g=hi, shape=shape,
                                                         kind=kind)
                            except ValueError as err:
                                v = str(err)
                            out.append(v)
                    for peaks in ((0.5,), (1.2, 0.3)) if rms >= 0.4 else ():
                        for kind in ("censored", "truncated"):
                            try:
                                v = M.poly_clip_vre(g0, rms, *k, rail_low_g=lo, rail_high_g=hi,
                                                    kind=kind, tone_peaks_g=peaks)
                            except ValueError as err:
                                v = str(err)
                            out.append(v)
                    if (lo, hi) == rails[0]:
                        out.append(list(M.linear_part(g0, rms, *k[:3])))
                        out.append(list(M.linear_part(g0, rms, *k[:3], shape="sine")))
                        out.append(list(M.linear_part(g0, rms, *k[:3], tone_peaks_g=(0.5,))))
                        out.append(M.hermite_rms(g0, rms, *k[:3]))
    for bad in (dict(static_g=math.nan, rms_g=1.0), dict(static_g=0.0, rms_g=-1.0),
                dict(static_g=0.0, rms_g=1.0, rail_low_g=2.0, rail_high_g=-2.0),
                dict(static_g=0.0, rms_g=1.0, shape="square"), dict(static_g=0.0, rms_g=1.0, kind="folded"),
                dict(static_g=0.0, rms_g=1.0, shape="sine", tone_peaks_g=(0.5,)),
                dict(static_g=0.0, rms_g=0.0, tone_peaks_g=(0.5,))):
        try:
            out.append(M.poly_clip_vre(**bad))  # type: ignore[arg-type]
        except ValueError as err:
            out.append(str(err))
    return out


def _spectral() -> list[Any]:
    from vrelab.models import dynamics as D
    from vrelab.profiles import parse_profile

    out: list[Any] = []
    for spec in ("navmat-p9492", "flat:50-2000", "flat:20-5000"):
        p = parse_profile(spec)
        psd = (p.freq_hz, p.psd_g2_per_hz)
        for fn, q in ((2400.0, 7.4), (1200.0, 3.0), (800.0, 40.0)):
            h = D.resonator(fn, q)
            out.append(D.effective_rms(psd, [h], *p.band))
            out.append(D.zero_crossing_rate_hz(psd, [h], *p.band))
            out.append(D.effective_rms(psd, [h], *p.band, points_hz=[fn]))
    return out


def _predict() -> list[Any]:
    import dataclasses

    import numpy as np

    try:
        from vrelab.prediction import predict
    except ImportError:  # a checkout before issue 31 (the module vrelab.predict)
        from vrelab.predict import predict  # type: ignore[no-redef]
    from vrelab.profiles import RandomProfile, parse_profile
    from vrelab.sensor import load_sensor

    ideal = load_sensor("ideal")
    poly = dataclasses.replace(ideal, k2_per_g=3e-3, k3_per_g2=-4e-4, k4_per_g3=1e-4, offset_g=0.01)
    adxl = load_sensor("adxl355", range_g=2, axis="z")
    adxl_x = load_sensor("adxl355", range_g=8, axis="x")
    adxl_pm = dataclasses.replace(adxl, clip_position="proof-mass")
    nonlin = dataclasses.replace(adxl, k2_per_g=2e-3, k3_per_g2=-3e-4)
    part = load_sensor("adxl354", range_g=2)
    navmat, sor = parse_profile("navmat-p9492"), parse_profile("navmat-p9492+sine:120:0.5")
    flat = parse_profile("flat:50-2000")
    sor2 = parse_profile("flat:50-2000+sine:80:0.4+sine:160:0.3")
    cases = []
    for s in (ideal, poly, adxl, adxl_pm, nonlin, part):
        for exc in (navmat, sor, flat, [80.0, 1500.0], [2400.0]):
            for g0 in (1.0, -1.0, 0.0):
                for kind in ("censored", "truncated"):
                    cases.append((s, exc, [0.3, 1.0, 2.0, 3.0], g0, kind))
    cases += [(s, exc, [0.5, 1.5], 2.5, "censored") for s in (ideal, poly, adxl) for exc in (flat, [80.0])]  # beyond a rail
    cases += [(adxl_x, navmat, [1.0, 4.0], 1.0, "censored"), (nonlin, sor2, [0.5, 1.5], 1.0, "censored"),
              (poly, sor2, [0.5, 1.5], -1.0, "truncated")]
    # a measured PSD: a dense table (over 64 corners: the vectorised Gauss-Legendre path)
    f = np.geomspace(20.0, 2000.0, 120)
    dense = RandomProfile(f, 1e-3 * np.exp(np.random.default_rng(7).normal(0.0, 0.5, f.size)), name="dense")
    cases += [(s, dense, [0.5, 2.0], 1.0, "censored") for s in (ideal, poly, adxl, nonlin)]
    out: list[Any] = []
    for s, exc, levels, g0, kind in cases:
        try:
            out.append(predict(s, exc, levels, g0, kind).to_dict())
        except ValueError as err:
            out.append(str(err))
    return out


def _triaxial_calls() -> tuple[Any, Any]:
    """(a triaxial vibration, a profile along a direction) -> the prediction: the one
    ``vrelab.predict`` of this checkout, or ``predict_triaxial`` on one before issue 31."""
    try:
        from vrelab.prediction.front import predict
    except ImportError:  # before issue 31: predict_triaxial (its static_g a vector, as here)
        from vrelab.triaxial.predict import predict_triaxial
        from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

        def along(s: Any, v: Any, d: Any, lv: Any, g: Any, k: Any) -> Any:
            tri = TriaxialProfile.along(v, d) if hasattr(v, "psd_g2_per_hz") else TriaxialSine(v, tuple(d), 1.0)
            return predict_triaxial(s, tri, lv, static_g=g, kind=k)

        return (lambda s, tri, lv, g, k: predict_triaxial(s, tri, lv, static_g=g, kind=k)), along
    return ((lambda s, tri, lv, g, k: predict(s, tri, lv, static_g=g, kind=k)),
            (lambda s, v, d, lv, g, k: predict(s, v, lv, static_g=g, kind=k, direction=d)))


def _triaxial() -> list[Any]:
    import dataclasses

    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine, direction

    tri_call, along_call = _triaxial_calls()
    # the z axis: the cross-axis row below (cross_axis_x, cross_axis_y) is an off-axis one, which
    # the loader refuses on the axis it names (the ideal part's default axis is x)
    ideal = load_sensor("ideal", range_g=2, axis="z")
    cross = dataclasses.replace(ideal, kip_per_g=5e-3, kio_per_g=-2e-3, kpp_per_g=1e-3, koo_per_g=4e-4,
                                kpo_per_g=-6e-4, k2_per_g=2e-3, cross_axis_x=0.01, cross_axis_y=-0.02)
    adxl = load_sensor("adxl355", range_g=2, axis="z")
    adxl_cross = dataclasses.replace(adxl, kip_per_g=3e-3, kpo_per_g=1e-3)
    adxl_x = dataclasses.replace(load_sensor("adxl355", range_g=8, axis="x"), kio_per_g=2e-3)
    flat, navmat = parse_profile("flat:20-500"), parse_profile("navmat-p9492")
    axes = TriaxialProfile.from_axes({"x": parse_profile("flat:20-2000"), "y": parse_profile("flat:20-2000"),
                                      "z": navmat}, coherence={("x", "z"): (0.6, 30.0), ("x", "y"): (0.3, -90.0)})
    statics = [(0.0, 0.0, 1.0), (0.0, 0.5, 0.866), (0.3, -0.2, 0.9), (0.0, 0.0, 0.0)]
    dirs = [(0.0, 0.0, 1.0), tuple(direction("z", "x", 30)), (1.0, 1.0, 1.0), (0.0, 1.0, 0.0)]
    out: list[Any] = []

    def run(f: Any, *a: Any) -> None:
        try:
            out.append(f(*a).to_dict())
        except ValueError as err:
            out.append(str(err))

    for s in (ideal, cross, adxl, adxl_cross):
        for g in statics[:3]:
            for d in dirs:
                run(along_call, s, flat, d, [0.5, 1.5], g, "censored")
            run(along_call, s, 200.0, dirs[1], [0.5, 1.5], g, "censored")
            run(tri_call, s, axes, [0.5, 1.5], g, "censored")
            run(tri_call, s, TriaxialSine(2400.0, (0.0, 1.0, 1.0), 1.0), [1.0], g, "truncated")
    for s in (cross, adxl_x):
        run(tri_call, s, TriaxialProfile.along(navmat, dirs[2]), [1.0, 4.0], statics[3], "censored")
        run(along_call, s, navmat, dirs[1], [2.0], statics[0], "truncated")
    return out


def _identify() -> list[Any]:
    sys.path.insert(0, str(TESTS))
    import test_identify as T
    from vrelab.identification import identify
    from vrelab.sensor import load_sensor

    out: list[Any] = []
    for seed in (1, 6, 11, 17):
        t = T._draw(seed)
        with tempfile.TemporaryDirectory() as d:
            sensor = load_sensor(str(T._part(t, Path(d))))
            doc = T.campaign_document(sensor, T._design(t), seed=seed, seconds=2.0, settle_s=0.2)
        ch = identify(doc, "ideal").channels[0]
        out.append({n: None if e is None else [e.value, e.u] for n, e in ch.parameters.items()})
    return out


def _example() -> list[Any]:
    """The README's designer path: the example campaign identified, and predict with its sensor file."""
    import contextlib
    import io

    from vrelab.cli import main

    out: list[Any] = []
    with tempfile.TemporaryDirectory() as d:
        camp, ident = Path(d) / "camp", Path(d) / "ident"
        example = TESTS.parent / "examples" / "campaign" / "campaign.toml"
        with contextlib.redirect_stdout(io.StringIO()):
            main(["campaign", str(example), "--out", str(camp)])
        for argv in (["identify", str(camp), "--base-sensor", "ideal", "--range", "2.048", "--out", str(ident), "--json"],
                     ["predict", "--sensor", str(ident / "sensor.toml"), "--axis", "sn1", "--profile", "flat:50-2000",
                      "--levels", "1,2", "--static", "1", "--json"]):
            text = io.StringIO()
            with contextlib.redirect_stdout(text):
                main(argv)
            out.append(json.loads(text.getvalue().replace(d, "<tmp>")))  # the paths differ from run to run
    return out


def _own(groups: list[str]) -> dict[str, Any]:
    run = {"memoryless": _memoryless, "spectral": _spectral, "predict": _predict, "identify": _identify,
           "example": _example, "triaxial": _triaxial}
    return {g: run[g]() for g in groups}


def flatten(x: Any, path: str = "") -> list[tuple[str, Any]]:
    """A nested result as (path, leaf) pairs in a fixed order (also check_analysis_exact's)."""
    if isinstance(x, dict):
        return [kv for k in sorted(x) for kv in flatten(x[k], f"{path}.{k}")]
    if isinstance(x, (list, tuple)):
        return [kv for i, v in enumerate(x) for kv in flatten(v, f"{path}[{i}]")]
    return [(path, x)]


def _compare(ours: Any, base: Any, abs_tol: float = 0.0) -> tuple[int, float, str, list[str]]:
    """(numbers compared, the largest relative difference, where, what differs otherwise).

    A difference within ``abs_tol`` counts as none: a number that is the rounding residue of a
    difference of 1 g quantities has no relative digits to compare."""
    a, b = flatten(ours), flatten(base)
    # a key the baseline does not have (a new result, such as a level's VRC) is no moved number:
    # compare on the baseline's keys, and say which are new
    known = {k for k, _ in b}
    new = sorted({k.rsplit(".", 1)[-1] for k, _ in a if k not in known})
    a = [(k, x) for k, x in a if k in known]
    if [k for k, _ in a] != [k for k, _ in b]:
        return 0, math.inf, "", ["the structure differs"]
    worst, where, n, other = 0.0, "", 0, []
    for (k, x), (_, y) in zip(a, b):
        if isinstance(x, float) and isinstance(y, float) and not isinstance(x, bool):
            n += 1
            if math.isnan(x) and math.isnan(y) or x == y or abs(x - y) <= abs_tol:
                continue
            d = abs(x - y) / max(abs(x), abs(y), 1e-300)
            if not d <= worst:
                worst, where = d, k
        elif x != y:
            other.append(f"{k}: {x!r} != {y!r}")
    if new:
        print(f"    (keys new in this checkout, not compared: {', '.join(new)})")
    return n, worst, where, other


def _identify_compare(ours: list[Any], base: list[Any]) -> tuple[float, list[str]]:
    """The largest |Δvalue|/u and |Δu|/u over the parameters; parameters null in one only."""
    worst, other = 0.0, []
    for i, (a, b) in enumerate(zip(ours, base)):
        for n in a:
            if (a[n] is None) != (b[n] is None):
                other.append(f"part {i} {n}: {a[n]} vs {b[n]}")
            elif a[n] is not None:
                u = b[n][1]
                worst = max(worst, abs(a[n][0] - b[n][0]) / u, abs(a[n][1] - b[n][1]) / u)
    return worst, other


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="src directory of the baseline checkout")
    ap.add_argument("--groups", default="memoryless,spectral,predict,triaxial,identify,example")
    ap.add_argument("--save", help="write this checkout's numbers to this JSON file")
    ap.add_argument("--against", help="compare with numbers saved by --save instead of running a baseline")
    ap.add_argument("--rel", type=float, default=1e-12,
                    help="pass within this relative difference (predict, memoryless, spectral); a quadrature "
                         "that changes its rule moves results within its own tolerance (1e-10): pass 1e-9 then, "
                         "as tests/test_predict_stages.py does")
    ap.add_argument("--abs", type=float, default=0.0,
                    help="a difference below this absolute size counts as none (tests/test_predict_stages.py: "
                         "1e-14 g, a few ulps of the 1 g quantities a residue is the difference of)")
    ap.add_argument("--own", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    groups = args.groups.split(",")
    ours = json.loads(json.dumps(_own(groups)))  # as JSON carries them: tuples as lists
    if args.own:
        print(json.dumps(ours))
        return 0
    if args.save:
        Path(args.save).write_text(json.dumps(ours))
    if args.against:
        base = json.loads(Path(args.against).read_text())
    elif args.baseline:
        env = {**os.environ, "PYTHONPATH": args.baseline}
        base = json.loads(subprocess.run([sys.executable, __file__, "--own", "--groups", args.groups], env=env,
                                         check=True, capture_output=True, text=True).stdout)
    else:
        return 0
    ok = True
    for g in groups:
        if g == "identify":
            worst, other = _identify_compare(ours[g], base[g])
            good = worst <= 1e-6 and not other
            print(f"{g:11s} {len(ours[g])} parts: largest |Δ|/u {worst:.3g}   {'ok' if good else 'DIFFERS'}")
        else:
            n, worst, where, other = _compare(ours[g], base[g], args.abs)
            good = worst <= args.rel and not other
            print(f"{g:11s} {n:6d} numbers: largest relative difference {worst:.3g} {where}   "
                  f"{'ok' if good else 'DIFFERS'}")
        for line in other[:10]:
            print("   ", line)
        ok = ok and good
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
