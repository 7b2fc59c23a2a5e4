"""Same bits from two checkouts: ``vrelab analyze --json`` and ``vrelab campaign`` results.

A speed-up of the analysis must not move its numbers. This runs a varied set of analyses on
the source first on ``PYTHONPATH`` and, in a subprocess, on ``--baseline SRC`` (a ``src``
directory of another checkout, e.g. ``git -C /work/main archive HEAD src | tar -x -C /tmp/base``),
and counts the numbers that differ in any bit (floats compared by ``repr``, which is unique per
bit pattern: -0.0 and 0.0 differ too) and the other values (strings, nulls, flags) that differ:

* ``bench``: the record of ``bench/bench_analyze_hdf5.py`` (its generator, 1 h: 60 random
  levels of 40 s between vibration-off stretches, clipped at ±2.5 g), ``--method random`` and
  ``auto``; ``--big``: the 2 h record as well (120 levels: the issue's);
* ``synthetic``: records of tests/test_analysis_helpers.make_record written to HDF5: random
  levels under red (AR(1)) noise and a drift, sine levels, short levels (few windows: the
  correlated-mean estimator), a rail, a record of several lengths of level (the
  per-(n, ρ) forms reused across lengths and records in one process), and levels on rails that
  leave the model (over-range protection), under each rail model;
* ``rail``: ``vrelab.fits.fit_rail`` itself on 160 seeded level sets around the clipping model,
  with and without departures, under each rail model (the departure scan's decision);
* ``campaign``: the example campaign (examples/campaign, ``make examples``), every
  ``results.json`` and ``levels.csv`` it writes;
* ``triaxial``: triaxial ``vrelab simulate`` runs (random along a direction, a sine, a triaxial
  profile; their JSON and their records' samples) and each record reduced by ``vrelab analyze
  --triaxial``, plus ``simulate_triaxial`` from Python: the one ``simulate`` / ``analyze``
  against the former ``simulate_triaxial`` / ``analyze_triaxial``.

Every case runs in one process per checkout, so a cache that carried one record's numbers into
another would show here. Prints per group the numbers compared, how many differ and the first
differences; exit status 1 if any differs.

    PYTHONPATH=src python bench/check_analysis_exact.py --baseline /tmp/base-speed/src [--big]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
TESTS = ROOT / "tests"


def _cli_json(argv: list[str]) -> Any:
    """``vrelab ARGV`` run in this process: its JSON with ``--json``, else its printout (or the
    exit status and stderr of a refusal)."""
    from vrelab.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as e:
            code = e.code
    if code != 0:
        return {"exit": code, "stderr": err.getvalue()}
    return json.loads(out.getvalue()) if "--json" in argv else out.getvalue()


def _bench(big: bool) -> list[Any]:
    sys.path.insert(0, str(HERE))
    import bench_analyze_hdf5 as B

    out: list[Any] = []
    for hours in (1.0, 2.0) if big else (1.0,):
        path = B.make_record(hours, 4000.0)
        for method in ("random", "auto"):
            out.append(_cli_json(["analyze", str(path), "--dut", "dut", "--reference", "reference",
                                  "--method", method, "--json"]))
    return out


DEPART_RMS = (0.3, 0.45, 0.6, 0.75, 0.9, 1.05, 1.2, 1.4, 1.6)


def _departing(factor: float) -> tuple[float, ...]:
    """VRE [g] of ±2.2 g rails on a 1 g field at :data:`DEPART_RMS`, times ``factor`` from 1.4 g rms on."""
    from vrelab.models.clipping import censored_mean_shift

    return tuple(float(censored_mean_shift(1.0, r, -2.2, 2.2)) * (factor if r >= 1.4 else 1.0) for r in DEPART_RMS)


# (make_record keywords, analyze options): each a path through the level estimators
SYNTHETIC: list[tuple[dict[str, Any], list[str]]] = [
    (dict(seed=11), ["--method", "random"]),
    (dict(seed=5, drift_g_per_s=1e-3, phi=0.995, t_on_s=40.0, t_off_s=20.0), ["--method", "random"]),
    (dict(seed=8, sine_hz=80.0, levels_g=(0.5, 1.0, 2.0)), ["--method", "sine"]),
    (dict(seed=9, sine_hz=120.0, t_off_s=6.0, t_on_s=10.0), ["--method", "auto"]),
    (dict(seed=3, t_on_s=2.0, t_off_s=2.0, phi=0.9), ["--method", "random"]),
    (dict(seed=4, t_on_s=1.2, t_off_s=3.0, levels_g=(0.5, 1.0, 1.5, 2.0)), ["--method", "random"]),
    (dict(seed=6, levels_g=(0.2, 0.4, 1.0, 2.5), vre_g=(0.0, 1e-3, 2e-3, 4e-3), rail_g=3.0), ["--method", "random"]),
    (dict(seed=12, levels_g=(0.3, 0.6, 0.9, 1.2, 1.5, 1.8), vre_g=(1e-4, 4e-4, 9e-4, 1.6e-3, 2.5e-3, 3.6e-3),
          t_on_s=7.0, noise_g=2e-4), ["--method", "random"]),
    (dict(seed=13, fs_hz=2000.0, band_hz=(60.0, 600.0), t_on_s=25.0, t_off_s=12.0, phi=0.999),
     ["--method", "random", "--band", "50", "800"]),
    # the rail fit's departure scan (issue 29): levels on ±2.2 g rails whose top two read half the
    # clipping shift (over-range protection), under each rail model, and the same levels without
    # it (the records leave the model from 1.05 and 1.6 g rms; the bench records stay on it)
    (dict(seed=21, levels_g=DEPART_RMS, vre_g=_departing(0.5), t_on_s=8.0, t_off_s=4.0, noise_g=2e-4),
     ["--method", "random"]),
    (dict(seed=22, levels_g=DEPART_RMS, vre_g=_departing(1.0), t_on_s=8.0, t_off_s=4.0, noise_g=2e-4),
     ["--method", "random"]),
    (dict(seed=21, levels_g=DEPART_RMS, vre_g=_departing(0.5), t_on_s=8.0, t_off_s=4.0, noise_g=2e-4),
     ["--method", "random", "--rail-vrc"]),
    (dict(seed=21, levels_g=DEPART_RMS, vre_g=_departing(0.5), t_on_s=8.0, t_off_s=4.0, noise_g=2e-4),
     ["--method", "random", "--kind", "truncated"]),
]


def _synthetic() -> list[Any]:
    sys.path.insert(0, str(TESTS))
    from test_analysis_helpers import make_record
    from vrelab.record import write_record_hdf5

    out: list[Any] = []
    with tempfile.TemporaryDirectory() as d:
        for i, (kw, opts) in enumerate(SYNTHETIC):
            tr = make_record(**kw)
            rec = tr.record
            path = Path(d) / f"case{i}.h5"
            write_record_hdf5(path, rec.fs_hz, [dict(rec.data)])
            doc = _cli_json(["analyze", str(path), "--dut", "dut", "--reference", "reference", *opts, "--json"])
            out.append(json.loads(json.dumps(doc).replace(d, "<tmp>")))  # the paths differ from run to run
    return out


def _campaign() -> list[Any]:
    example = ROOT / "examples" / "campaign" / "campaign.toml"
    if not (example.parent / "runs").is_dir():
        raise SystemExit("the example campaign's recordings are missing: run `make examples` first")
    out: list[Any] = []
    with tempfile.TemporaryDirectory() as d:
        camp = Path(d) / "camp"
        out.append(_cli_json(["campaign", str(example), "--out", str(camp)]).replace(d, "<tmp>"))
        for p in sorted(camp.rglob("*")):
            if p.suffix == ".json":
                out.append([p.relative_to(camp).as_posix(), json.loads(p.read_text().replace(d, "<tmp>"))])
            elif p.suffix == ".csv":
                out.append([p.relative_to(camp).as_posix(), p.read_text().replace(d, "<tmp>")])
    return out


def _no_clock(x: Any) -> Any:
    """A document without its creation times (a simulation's provenance says when it ran)."""
    if isinstance(x, dict):
        return {k: _no_clock(v) for k, v in x.items() if k != "created_utc"}
    if isinstance(x, list):
        return [_no_clock(v) for v in x]
    return x


# triaxial tests (issue 31: vrelab simulate / analyze one function for one axis and three):
# `vrelab simulate` options, its record then reduced by `vrelab analyze --triaxial`
TRIAXIAL: list[list[str]] = [
    ["--sensor", "adxl355", "--axes", "x,z", "--profile", "flat:50-800", "--direction", "1,0,1",
     "--static-vector", "0.2,0,0.98", "--levels", "0.5,1.5", "--seconds", "2", "--seed", "3"],
    ["--sensor", "adxl355", "--axis", "z", "--freq", "120", "--direction", "0,0.6,0.8", "--levels", "1,2",
     "--seconds", "2", "--seed", "2"],
    ["--sensor", "ideal", "--axes", "x,y,z", "--range", "2", "--profile", "flat:20-500@dir=1,1,0",
     "--levels", "0.8,1.6", "--seconds", "2", "--seed", "7"],
]


def _triaxial() -> list[Any]:
    """Each triaxial simulation (its JSON and its record's samples, summed per channel) and its
    record reduced by ``vrelab analyze --triaxial``; and the Python call
    ``vrelab.triaxial.simulate.simulate_triaxial`` (an alias of ``vrelab.simulate`` here)."""
    import warnings

    import h5py
    import numpy as np

    from vrelab.profiles import RandomProfile
    from vrelab.sensor import load_sensor
    from vrelab.triaxial.simulate import simulate_triaxial

    out: list[Any] = []
    with tempfile.TemporaryDirectory() as d:
        for i, argv in enumerate(TRIAXIAL):
            folder = Path(d) / f"sim{i}"
            sim = _cli_json(["simulate", *argv, "--out", str(folder), "--record", "--json"])
            sim["triaxial"]["record"] = "<staged record>"  # the output folder's staging path, random
            out.append(_no_clock(sim))
            rec = folder / "record.h5"
            with h5py.File(rec, "r") as f:  # the samples: each channel's sum and sum of squares, bit for bit
                out.append({k: [float(np.sum(v[()])), float(np.sum(np.square(v[()])))]
                            for k, v in sorted(f.items()) if isinstance(v, h5py.Dataset) and k != "schedule"})
            duts = ",".join(f"{a}=dut_{a}" for a in sim["triaxial"]["conditions"]["axes"])
            doc = _cli_json(["analyze", str(rec), "--triaxial", "--reference", "reference_x,reference_y,reference_z",
                             "--dut", duts, "--band", "10:1000", "--json"])
            out.append(json.loads(json.dumps(_no_clock(doc)).replace(d, "<tmp>")))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        api = simulate_triaxial([load_sensor("adxl355", range_g=2, axis=a) for a in "xz"],
                                RandomProfile.flat(50.0, 800.0), [0.5, 1.5], direction=(1, 0, 1),
                                static_g=(0.2, 0, 0.98), seconds=2.0, seed=3)
    out.append(_no_clock(api.to_dict()))
    return out


def _rail() -> list[Any]:
    """``vrelab.fits.fit_rail`` on seeded level sets drawn with numpy around the clipping model
    (rails, fields, uncertainties, a k2 the model lacks, departures of 2.5-4 sigma, a lone top
    level at 4-6.5 sigma, over-range protection), under every model: censored and truncated,
    symmetric and not, with and without the VRC term. The departure scan's decision is in each
    result (``departure_rms_g``, ``levels_used``)."""
    import numpy as np

    from vrelab import Estimate, LevelResult
    from vrelab.fits import fit_rail
    from vrelab.models.clipping import censored_mean_shift

    rng = np.random.default_rng(29)
    out: list[Any] = []
    for case in range(160):
        g0 = float(rng.choice([1.0, -1.0, 0.3, 2.0]))
        rail = abs(g0) + float(rng.uniform(0.5, 3.0))
        n = int(rng.choice([3, 5, 8, 12, 20, 40]))
        rms = np.sort(rng.uniform(0.05, 1.3 * rail, n))
        y = np.asarray(censored_mean_shift(g0, rms, -rail, rail))
        u = np.abs(y) * 10 ** rng.uniform(-4, -1) + 10 ** rng.uniform(-7, -4)
        y = y + float(rng.choice([0.0, 1e-5, 1e-4])) * np.sign(g0) * rms**2 + rng.normal(size=n) * u
        mode, k = case % 4, int(rng.integers(2, n))
        if mode == 1:
            y[k:] += np.sign(rng.normal()) * rng.uniform(2.5, 4.0) * rng.uniform(1.0, 3.0) * u[k:]
        elif mode == 2:
            y[-1] += np.sign(rng.normal()) * rng.uniform(8.0, 13.0) * u[-1]
        elif mode == 3:
            y[k:] *= rng.uniform(0.3, 0.9)
        levels = [LevelResult(rms_g=float(r), vre=Estimate(float(v), float(e))) for r, v, e in zip(rms, y, u)]
        kinds = [dict()] if case % 8 else [dict(), dict(symmetric=False), dict(with_vrc=True), dict(kind="truncated")]
        for kw in kinds:
            try:
                out.append(fit_rail(levels, g0, **kw).to_dict())  # type: ignore[arg-type]
            except ValueError as e:
                out.append(str(e))
    return out


def _own(groups: list[str], big: bool) -> dict[str, Any]:
    run = {"bench": lambda: _bench(big), "synthetic": _synthetic, "campaign": _campaign, "triaxial": _triaxial,
           "rail": _rail}
    return {g: run[g]() for g in groups}


def _flat_fits(x: Any) -> Any:
    """``x`` with every fit in the flat form of earlier versions: a fit's nested ``parameters``
    (issue 31) lifted beside its ``model``, and its ``static_g`` (a clipping fit's, new with the
    nesting) left out, so that both checkouts' fits compare number by number."""
    if isinstance(x, dict):
        if "model" in x and isinstance(x.get("parameters"), dict):
            x = {**{k: v for k, v in x.items() if k not in ("parameters", "static_g")}, **x["parameters"]}
        return {k: _flat_fits(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_flat_fits(v) for v in x]
    return x


def _compare(ours: Any, base: Any) -> tuple[int, list[str]]:
    """(floats compared, every difference: a float in any bit, any other value, the structure)."""
    from check_model_exact import flatten  # bench/ is the script's folder, on sys.path

    a, b = flatten(_flat_fits(ours)), flatten(_flat_fits(base))
    if [k for k, _ in a] != [k for k, _ in b]:
        keys_a, keys_b = {k for k, _ in a}, {k for k, _ in b}
        return 0, [f"the structure differs: only here {sorted(keys_a - keys_b)[:3]}, only there "
                   f"{sorted(keys_b - keys_a)[:3]}"]
    n, diff = 0, []
    for (k, x), (_, y) in zip(a, b):
        if isinstance(x, float) or isinstance(y, float):
            n += 1
            if repr(x) != repr(y):
                diff.append(f"{k}: {x!r} != {y!r}")
        elif x != y:
            diff.append(f"{k}: {x!r} != {y!r}")
    return n, diff


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", help="src directory of the baseline checkout")
    ap.add_argument("--groups", default="bench,synthetic,campaign,triaxial,rail")
    ap.add_argument("--big", action="store_true", help="also the 2 h record of 120 levels (about 10 s more per checkout)")
    ap.add_argument("--own", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    groups = args.groups.split(",")
    ours = json.loads(json.dumps(_own(groups, args.big)))
    if args.own:
        print(json.dumps(ours))
        return 0
    if not args.baseline:
        return 0
    env = {**os.environ, "PYTHONPATH": args.baseline}
    own = [sys.executable, __file__, "--own", "--groups", args.groups] + (["--big"] if args.big else [])
    base = json.loads(subprocess.run(own, env=env, check=True, capture_output=True, text=True).stdout)
    ok = True
    for g in groups:
        n, diff = _compare(ours[g], base[g])
        ok = ok and not diff
        print(f"{g:10s} {len(ours[g]):3d} results, {n:6d} numbers: {len(diff)} differ   {'ok' if not diff else 'DIFFERS'}")
        for line in diff[:5]:
            print("    " + line)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
