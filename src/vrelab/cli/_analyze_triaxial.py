"""``vrelab analyze FILE --triaxial --reference X,Y,Z --dut ...``: a triaxial recording reduced per axis.

The JSON is the several-DUT document of the CLI reference (``channels``: [{``channel`` (the axis),
``levels``, ``fit``, ...}]) with each level's ``axis_rms_g`` and each channel's ``level_axis``,
plus ``triaxial``: the reference channels, the axis the segments came from and per level the
reference's total and per-axis rms and its measured cross-spectrum (PSDs, coherences, phases with
their uncertainties and numbers of averages; :mod:`vrelab.triaxial.analyze`). ``--out DIR``
writes the several-channel folder and ``reference_csd.csv`` (one row per level, band and axis
pair).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path
from typing import Any, Iterable

from vrelab import _io, folder
from vrelab.cli._common import positive_list, print_json, print_levels, typeb_from_args
from vrelab.triaxial.profile import AXES

CSD_FILE = "reference_csd.csv"


def _axis_channels(text: str, what: str, exactly_three: bool) -> dict[str, str]:
    items = [t.strip() for t in text.split(",")]
    if any(not t for t in items):
        raise ValueError(f"{what} {text!r}: an empty channel name")
    if all("=" in t for t in items):
        out: dict[str, str] = {}
        for t in items:
            axis, _, ch = t.partition("=")
            axis = axis.strip().lower()
            if axis not in AXES or not ch.strip():
                raise ValueError(f"{what} {text!r}: {t!r} is not AXIS=CHANNEL with AXIS x, y or z")
            if axis in out:
                raise ValueError(f"{what} {text!r}: axis {axis} given twice")
            out[axis] = ch.strip()
    elif len(items) == 3:
        out = dict(zip(AXES, items))
    else:
        raise ValueError(f"{what} {text!r}: give the x, y, z channels in order (three), or AXIS=CH items")
    if exactly_three and sorted(out) != list(AXES):
        raise ValueError(f"{what} {text!r}: a triaxial reference needs its three channels x, y, z")
    return out


def run_triaxial(args: argparse.Namespace, inputs: Iterable[str | Path], command: str) -> int:
    from vrelab._api import analyze
    from vrelab._digests import file_sha256
    from vrelab.analysis.options import FitOptions, ReductionOptions
    from vrelab.analysis.readers import Scale, open_record
    from vrelab.record import Schedule

    if not args.reference:
        raise ValueError("--triaxial needs --reference X,Y,Z: the triaxial reference's three channels")
    for opt, given in (("--profile", args.profile), ("--static", args.static is not None),
                       ("--rail-vrc", args.rail_vrc), ("--limit", args.limit is not None),
                       ("--u-* budget options", typeb_from_args(args).declared)):
        if given:
            raise ValueError(f"{opt} is not supported with --triaxial yet (the triaxial reduction fits the VRC "
                             "against the total rms only)")
    ref = _axis_channels(args.reference, "--reference", True)
    duts = _axis_channels(args.dut, "--dut", False)
    sens: list[float | None] = ([*positive_list(args.dut_sensitivity, "--dut-sensitivity")]
                                if args.dut_sensitivity else [None])
    if len(sens) not in (1, len(duts)):
        raise ValueError(f"--dut-sensitivity: give one value or one per DUT axis ({len(duts)}), got {len(sens)}")
    per = sens * len(duts) if len(sens) == 1 else sens
    scales: dict[str, Any] = {}
    for axis, s in zip(duts, per):
        scales[axis] = Scale.parse(args.dut_units, s, "--dut") if args.dut_units or s is not None else None
    ref_scale = (Scale.parse(args.reference_units, args.reference_sensitivity, "--reference")
                 if args.reference_units or args.reference_sensitivity is not None else None)
    for axis in AXES:
        scales[f"reference-{axis}"] = ref_scale
    mapping = {**duts, **{f"reference-{a}": ref[a] for a in AXES}}
    path = Path(args.file)
    record = open_record(path, mapping, None, args.fs, scales, None, args.time,
                         accept_file_units=args.accept_file_units)
    with record:
        schedule = Schedule.read_csv(args.schedule) if args.schedule and args.schedule != "auto" else None
        if args.schedule == "auto":
            record.schedule = None
        provenance = {"input_file": path.name, "input_sha256": file_sha256(path), "command": command}
        accept = [name for name in ("unit-ratio", "channels", "method") if getattr(args, "accept_" + name.replace("-", "_"))]
        options = ReductionOptions(band_hz=args.band, settle_s=args.settle, rail_g=args.rail,
                                   accept=frozenset(accept), progress=bool(args.progress))
        res = analyze(record, {a: f"dut:{a}" for a in duts}, {a: f"dut:reference-{a}" for a in AXES},
                      method=args.method, options=options, fit=FitOptions(k4=args.k4), schedule=schedule,
                      provenance=provenance)
    doc = res.to_dict()  # its provenance the one given (the result's own)
    doc["triaxial"]["reference_channels"] = dict(ref)
    if args.out:
        with _io.output_dir(Path(args.out), inputs=inputs) as stage:
            folder.write_channels(stage, list(res.axes.items()), doc)
            _write_csd(stage / CSD_FILE, doc)
    if args.json:
        print_json(doc)
    else:
        tri = doc["triaxial"]
        for lv in tri["levels"]:
            a = lv["axis_rms_g"]
            print(f"level {lv['start_s']:.4g}-{lv['end_s']:.4g} s: {lv['rms_g']:.4g} g rms total "
                  f"(x {a['x']:.4g}, y {a['y']:.4g}, z {a['z']:.4g})")
        for name, result in res.axes.items():
            print(f"{path.name} DUT axis {name}: {result.method} method, {len(result.levels)} level(s), "
                  "levels as the reference's total rms")
            print_levels(result)
        if args.out:
            print(f"wrote {args.out}/results.json, levels.csv, {CSD_FILE} and a folder per axis", file=sys.stdout)
    return 0


def _write_csd(path: Path, doc: dict[str, Any]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["level", "rms_g", "freq_hz", "n_averages", "pair", "psd_or_coherence", "u", "phase_deg",
                    "u_phase_deg"])
        for i, lv in enumerate(doc["triaxial"]["levels"], start=1):
            c = lv.get("csd")
            if c is None:
                continue
            for m, f in enumerate(c["freq_hz"]):
                for a in AXES:
                    w.writerow([i, f"{lv['rms_g']:.6g}", f"{f:.6g}", f"{c['n_averages'][m]:.4g}", a + a,
                                f"{c['psd_g2_per_hz'][a][m]:.6g}", f"{c['u_psd_g2_per_hz'][a][m]:.3g}", "", ""])
                for pair in ("xy", "xz", "yz"):
                    up = c["u_phase_deg"][pair][m]
                    w.writerow([i, f"{lv['rms_g']:.6g}", f"{f:.6g}", f"{c['n_averages'][m]:.4g}", pair,
                                f"{c['coherence'][pair][m]:.6g}", f"{c['u_coherence'][pair][m]:.3g}",
                                f"{c['phase_deg'][pair][m]:.6g}", "" if up is None else f"{up:.3g}"])
