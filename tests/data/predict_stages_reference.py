"""Records predict's results over a grid of sensors, profiles, levels and static fields into
predict_stages_reference.json, the reference tests/test_predict_stages.py holds the stage-owned
predict against.

The JSON was written by this script run on commit b3d26ac (predict walking the stages by their
string tags, before each stage owned its mean shift):

    mkdir /tmp/b3d26ac && git archive b3d26ac src | tar -x -C /tmp/b3d26ac
    PYTHONPATH=/tmp/b3d26ac/src python tests/data/predict_stages_reference.py

A regression reference, not a truth: the refactor must not change the physics; the truths
predict is held against are in tests/test_predict_exact.py.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

OUT = Path(__file__).with_name("predict_stages_reference.json")

# (label, preset, load_sensor keywords, dataclasses.replace fields, keep the preset's uncertainty)
SENSORS: list[tuple[str, str, dict[str, Any], dict[str, Any], bool]] = [
    ("ideal", "ideal", {}, {}, False),
    ("ideal-poly-offset", "ideal", {}, {"k2_per_g": 2e-3, "k3_per_g2": -1e-3, "k4_per_g3": 4e-4, "offset_g": 0.03},
     False),
    ("ideal-proof-mass", "ideal", {}, {"k2_per_g": 1e-3, "clip_position": "proof-mass"}, False),
    ("adxl355-z2", "adxl355", {"range_g": 2, "axis": "z"}, {}, False),
    ("adxl355-z2-u", "adxl355", {"range_g": 2, "axis": "z"}, {}, True),
    ("adxl355-x8", "adxl355", {"range_g": 8, "axis": "x"}, {}, False),
    ("adxl355-proof-mass", "adxl355", {"range_g": 2}, {"clip_position": "proof-mass", "offset_g": -0.02}, False),
    ("adxl354", "adxl354", {}, {}, False),
    ("adxl357", "adxl357", {}, {"k3_per_g2": 5e-5}, False),
]
# (label, excitation: a profile string, or a list of sine frequencies [Hz])
EXCITATIONS: list[tuple[str, Any]] = [
    ("flat", "flat:50-2000"),
    ("navmat", "navmat-p9492"),
    ("sor", "navmat-p9492+sine:120:0.5"),
    ("sine", [80.0, 1500.0]),
]
LEVELS = [0.3, 1.2, 2.5, 5.0]
STATIC = [-1.0, 0.0, 1.9, 2.5]


def cases() -> list[dict[str, Any]]:
    """The grid, thinned: each sensor and excitation at 1 g censored and truncated, and at one
    more static field (censored) in turn; the propagated u (many predictions each) at 1 g only."""
    out = []
    for i, s in enumerate(SENSORS):
        for j, e in enumerate(EXCITATIONS):
            grid = [("censored", 1.0), ("truncated", 1.0), ("censored", STATIC[(i + j) % len(STATIC)])]
            for kind, g0 in grid[:1] if s[4] else grid:
                out.append({"sensor": s[0], "excitation": e[0], "kind": kind, "static_g": g0})
    return out


def sensor(label: str) -> Any:
    from vrelab.sensor import load_sensor

    _, preset, kw, repl, keep_u = next(s for s in SENSORS if s[0] == label)
    s = load_sensor(preset, **kw)
    if not keep_u:
        repl = {**repl, "uncertainty": {}}
    else:  # the u the preset carried at b3d26ac: its over-range threshold's (the others came with issue 28)
        repl = {**repl, "uncertainty": {k: v for k, v in s.uncertainty.items() if k == "overrange_threshold_g"}}
    return dataclasses.replace(s, **repl) if repl else s


def excitation(label: str) -> Any:
    from vrelab.profiles import parse_profile

    e = next(x for x in EXCITATIONS if x[0] == label)[1]
    return parse_profile(e) if isinstance(e, str) else e


def run(case: dict[str, Any], notes: dict[str, int]) -> dict[str, Any]:
    """predict's result for one case as plain data (NaN as the string "nan")."""
    from vrelab.prediction import predict

    def num(x: float | None) -> Any:
        # 15 significant digits: the comparison is at 1e-12 relative
        return None if x is None else ("nan" if math.isnan(x) else float(f"{x:.15g}"))

    p = predict(sensor(case["sensor"]), excitation(case["excitation"]), LEVELS, case["static_g"], case["kind"])
    return {
        "vibration_off_g": num(p.vibration_off_g),
        "notes": [notes.setdefault(n, len(notes)) for n in p.notes],
        "levels": [
            {
                "rms_g": lv.rms_g, "freq_hz": lv.freq_hz, "vre_g": num(lv.vre_g),
                "tilt_error_deg": num(lv.tilt_error_deg),
                "shares": {k: num(v) for k, v in lv.shares.items()},
                "sigma_proof_mass_g": num(lv.sigma_proof_mass_g), "sigma_output_g": num(lv.sigma_output_g),
                "sigma_at_clip_g": num(lv.sigma_at_clip_g), "overrange_rate_hz": num(lv.overrange_rate_hz),
                "model_error_g": num(lv.model_error_g), "u_vre_g": num(lv.u_vre_g),
                "u_sources_g": None if lv.u_sources_g is None else {k: num(v) for k, v in lv.u_sources_g.items()},
                "valid": lv.valid, "valid_otherwise": lv.valid_otherwise,
                "notes": [notes.setdefault(n, len(notes)) for n in lv.notes],
            }
            for lv in p.levels
        ],
    }


def main() -> None:
    records = []
    notes: dict[str, int] = {}  # each note once: the results give its index
    for case in cases():
        try:
            records.append({**case, "result": run(case, notes)})
        except ValueError as err:
            records.append({**case, "error": str(err)})
    table = sorted(notes, key=notes.__getitem__)
    OUT.write_text(json.dumps({"commit": "b3d26ac", "levels": LEVELS, "notes": table, "cases": records},
                              separators=(",", ":")) + "\n")


if __name__ == "__main__":
    main()
