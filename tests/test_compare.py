"""``vrelab compare`` / ``vrelab.compare`` (issue 32): candidates ranked against a budget with a
guard of their expanded uncertainty.

The cases have answers known without vrelab's ranking: the ideal sensor (rails at exactly ±range,
nothing else; no u: its numbers are a definition) at ±2 g in a 1 g field at 1 g rms clips to a
VRE of −83 mg (SPEC 1.1, censored Gaussian; tests/test_cli_predict.py) while ±8 g sits 7σ from
its rail; a part whose rails follow a low-pass at ODR/4 keeps a mount resonance at 800 Hz out of
its rails at ODR 500 Hz (125 Hz) and not at 4000 Hz (1 kHz). Small candidate lists, one level.
"""

from __future__ import annotations

import json
import math

import pytest

import vrelab
from vrelab.cli import main
from vrelab.comparison.candidates import Budget, parse_budget, parse_candidates

# A part with only output rails after a 4th-order digital low-pass at ODR/4 (k2 = 0: the rails
# are evaluated exactly, no u stated)
ODR_PART = """schema = 1
name = "odrpart"
description = "test part: rails after a digital low-pass at ODR/4, nothing else"
default_range_g = 4
default_axis = "x"
odrs_hz = [4000.0, 500.0]
default_odr_hz = 4000.0
bandwidth_per_odr = 0.25
lowpass_order = 4
clip_position = "output"
[facts]
bandwidth_hz = "test: ODR/4"
lowpass_order = "test: 4th order"
[uncertainty]
bandwidth_per_odr = 0.0025  # the corner known to 1 %: a u stated, so the part can pass or fail
"""
# The ideal part's numbers (rails at exactly ±range, nothing else) in a user's sensor file with no
# [uncertainty]: the same VRE as the ideal preset, but a part's numbers, not a definition
BARE = """schema = 1
name = "bare"
description = "test part: rails at ±range, no u stated"
default_range_g = 8
default_axis = "x"
clip_position = "output"
"""
# A part whose over-range protection (2 g, 0.5 ms) trips so often at 1 g rms that its holds
# overlap: the analytic model says it is not valid there
TRIPPER = """schema = 1
name = "tripper"
description = "test part whose over-range protection trips often"
default_range_g = 8
default_axis = "x"
clip_position = "output"
overrange_threshold_g = 2.0
overrange_hold_s = 0.0005
[facts]
overrange_threshold_g = "test: 2 g"
overrange_hold_s = "test: 0.5 ms"
"""


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_the_wider_range_wins_where_the_narrow_one_clips():
    cmp = vrelab.compare("flat:50-2000", 1.0, "1mg", candidates="ideal:2g,ideal:8g")
    by = {r.candidate.range_g: r for r in cmp.rows}
    # SPEC 1.1: the censored ±2 g rails in a 1 g field at 1 g rms: −83 mg (±0.5 mg: the SPEC's
    # three digits)
    assert by[2.0].worst.vre_g == pytest.approx(-0.0833, abs=5e-4) and by[2.0].verdict == "fail"
    assert by[2.0].mechanism == "clip"
    assert by[8.0].verdict == "pass" and abs(by[8.0].worst.vre_g) < 1e-9  # 7σ to the rail: Φ(−7) ≈ 1e-12
    assert cmp.best is by[8.0] and cmp.rows[0] is by[8.0]
    assert by[8.0].worst.u_vre_g == 0.0 and by[8.0].dominant_u is None  # the ideal is exact by definition: U = 0


def test_a_bandwidth_above_the_mount_resonance_loses(tmp_path):
    part = tmp_path / "odrpart.toml"
    part.write_text(ODR_PART, encoding="utf-8")
    cmp = vrelab.compare("flat:20-2000", [1.0], "1mg", candidates=f"{part}:4:4000,{part}:4:500", mount=(800.0, 10.0))
    by = {r.candidate.odr_hz: r for r in cmp.rows}
    # the mount multiplies the PSD by up to Q² + 1 = 101 at 800 Hz: through a 1 kHz low-pass the
    # rails at ±4 g see it and clip; through 125 Hz they see the band below, ~0.3 g rms
    assert by[4000.0].verdict == "fail" and abs(by[4000.0].worst.vre_g) > 0.01
    assert by[500.0].verdict == "pass" and cmp.best is by[500.0]
    assert all("mount resonance 800 Hz (Q 10) is inside" in r.notes[0] for r in cmp.rows)


def test_a_part_with_no_stated_u_is_undecided_and_only_the_ideal_is_exact(tmp_path, capsys):
    part = tmp_path / "bare.toml"
    part.write_text(BARE, encoding="utf-8")
    cmp = vrelab.compare("flat:50-2000", 1.0, "1mg", candidates=f"{part}:8,ideal:8")
    by = {r.candidate.part: r for r in cmp.rows}
    ideal, bare = by["ideal"], by[str(part)]
    # the same VRE, within the budget by far (±8 g rails 7σ from a 1 g field at 1 g rms: Φ(−7) ≈ 1e-12)
    assert abs(ideal.worst.vre_g) < 1e-9 and bare.worst.vre_g == ideal.worst.vre_g
    assert ideal.verdict == "pass" and ideal.to_dict()["U_vre_g"] == 0.0 and cmp.best is ideal
    # a number with no u is no claim: neither a pass nor a fail, said why; its U is unknown, not 0
    assert bare.verdict == "undecided" and "states no u" in bare.reason
    assert bare.to_dict()["U_vre_g"] is None and bare.to_dict()["points"][0]["U_vre_g"] is None
    rc, out, _ = _run(capsys, "compare", "--environment", "flat:50-2000", "--levels", "1", "--budget-vre", "1mg",
                      "--candidates", f"{part}:8,ideal:8")
    assert rc == 0 and f"undecided: {part} ±8 g no ODR: its prediction states no u" in out and "± ?" in out
    assert "best: ideal:8g" in out


def test_an_invalid_prediction_is_never_a_pass(tmp_path, capsys):
    part = tmp_path / "tripper.toml"
    part.write_text(TRIPPER, encoding="utf-8")
    # a budget no VRE could exceed: only the validity can keep the part from passing
    cmp = vrelab.compare("flat:50-2000", 1.0, "1g", candidates=f"{part},ideal:8")
    tripper = next(r for r in cmp.rows if r.candidate.part == str(part))
    assert tripper.verdict == "invalid" and not tripper.valid and "holds overlap" in tripper.reason
    assert cmp.rows[-1] is tripper and cmp.best.candidate.part == "ideal"
    d = tripper.to_dict()
    assert d["vre_g"] is None and d["margin"] is None and d["verdict"] == "invalid"
    rc, out, _ = _run(capsys, "compare", "--environment", "flat:50-2000", "--levels", "1", "--budget-vre", "1g",
                      "--candidates", f"{part},ideal:8")
    assert rc == 0 and f"invalid: {part} ±8 g no ODR: prediction not valid" in out and "holds overlap" in out


@pytest.mark.parametrize(("argv", "says"), [
    (["--candidates", "nosuchpart:2g"], "nosuchpart"),
    (["--candidates", ""], "--candidates"),
    (["--candidates", "ideal:-2g"], "range"),
    (["--levels", "0"], "--levels: values must be > 0"),
    (["--budget-vre", "1"], "--budget-vre must be a number with its unit"),
    (["--budget-vre", "0mg"], "--budget-vre must be > 0"),
    (["--budget-tilt", "0.05deg", "--static", "1"], "a tilt error needs a static field away from ±1 g"),
    (["--tilt-range", "10:-10"], "--tilt-range"),
    (["--mount-fn", "800"], "--mount-fn and --mount-q go together"),
])
def test_bad_input_exits_2_with_one_line(capsys, argv, says):
    base = {"--environment": "flat:50-2000", "--levels": "1", "--budget-vre": "1mg", "--candidates": "ideal:8"}
    opts = dict(base)
    given = dict(zip(argv[::2], argv[1::2]))
    if "--budget-tilt" in given:
        opts.pop("--budget-vre")
    opts.update(given)
    rc, out, err = _run(capsys, "compare", *[x for kv in opts.items() for x in kv])
    assert rc == 2 and out == "" and err.strip().count("\n") == 0 and says in err, err


def test_the_api_refuses_what_the_cli_refuses():
    with pytest.raises(ValueError, match="no candidates"):
        vrelab.compare("flat:50-2000", 1.0, "1mg", candidates=[])
    with pytest.raises(ValueError, match="levels must be numbers > 0"):
        vrelab.compare("flat:50-2000", [0.0], "1mg", candidates="ideal:8")
    with pytest.raises(ValueError, match="give one budget"):
        parse_budget(None, None)
    assert parse_candidates("adxl355:2g:4000Hz:z,my.toml::500") == [
        vrelab.comparison.Candidate("adxl355", 2.0, 4000.0, "z"), vrelab.comparison.Candidate("my.toml", None, 500.0)]


def test_the_tilt_conversion_against_a_direct_computation():
    """δθ ≈ VRE/(g·cos θ) against the exact asin((g0 + δ)/g) − asin(g0/g), and a tilt budget as the
    VRE budget g·cos θ·δθ at each static field of a tilt range."""
    for theta in (0.0, 20.0, -45.0, 60.0):
        g0 = math.sin(math.radians(theta))
        for vre in (1e-4, -5e-4):
            exact = math.degrees(math.asin(g0 + vre) - math.asin(g0))
            # the first-order form leaves tan θ·δθ²/2 (the next Taylor term): a relative
            # |tan θ·δθ|/2, under 1e-3 for these (δθ below 1e-3 rad, |tan θ| at most 1.8)
            assert Budget.tilt_deg(vre, g0) == pytest.approx(exact, rel=1e-3)
            b = parse_budget(None, "0.05deg")
            assert b.limit_g(g0) == pytest.approx(math.radians(0.05) * math.cos(math.radians(theta)), rel=1e-12)
    # a tilt range: judged at its ends, middle and 0; the row's tilt is its worst point's
    cmp = vrelab.compare("flat:50-2000", 1.0, "0.05deg", tilt_range_deg=(-30.0, 30.0), candidates="ideal:2g")
    assert cmp.conditions["static_g"] == pytest.approx([-0.5, 0.0, 0.5], abs=1e-12)
    row = cmp.rows[0]
    w = row.worst
    assert w is not None and w.limit_g == pytest.approx(math.radians(0.05) * math.sqrt(1 - w.static_g**2), rel=1e-12)
    assert row.tilt_error_deg[0] == pytest.approx(math.degrees(w.vre_g / math.sqrt(1 - w.static_g**2)), rel=1e-12)


ROW_KEYS = {"candidate", "label", "part", "range_g", "odr_hz", "axis", "verdict", "valid", "reason", "vre_g",
            "U_vre_g", "k", "vrc_ug_per_g2", "tilt_error_deg", "U_tilt_error_deg", "margin", "worst",
            "dominant_mechanism", "dominant_u", "points", "notes"}


def test_the_json_schema(capsys):
    rc, out, err = _run(capsys, "compare", "--environment", "flat:50-2000", "--levels", "1", "--static", "0.5",
                        "--budget-vre", "1mg", "--candidates", "ideal:2g,ideal:8g", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["kind"] == "comparison" and d["best"] == "ideal:8g"
    assert set(d["conditions"]) == {"environment", "band_hz", "levels_g", "static_g", "tilt_range_deg", "budget",
                                    "budget_kind", "budget_value", "mount", "coverage_k"}
    assert d["counts"] == {"pass": 1, "undecided": 0, "fail": 1, "invalid": 0}
    for row in d["rows"]:
        assert set(row) == ROW_KEYS
        assert set(row["points"][0]) == {"rms_g", "static_g", "vre_g", "u_vre_g", "U_vre_g", "budget_g", "margin"}
        # the VRC is the VRE per rms² at the worst point, in µg/g²
        assert row["vrc_ug_per_g2"] == pytest.approx(row["vre_g"] / row["worst"]["rms_g"] ** 2 * 1e6, rel=1e-12)
    assert [r["verdict"] for r in d["rows"]] == ["pass", "fail"]


@pytest.mark.slow
def test_workers_give_the_serial_numbers():
    """The candidates as points of the sweep's engine on a process pool: the same predictions (same
    machine, same bits) as the serial run."""
    serial = vrelab.compare("flat:50-2000", 1.0, "1mg", candidates="ideal:2g,ideal:4g")
    pooled = vrelab.compare("flat:50-2000", 1.0, "1mg", candidates="ideal:2g,ideal:4g", workers=2)
    assert pooled.to_dict() == serial.to_dict()


def test_the_page_is_written(tmp_path, capsys):
    rc, out, err = _run(capsys, "compare", "--environment", "flat:50-2000", "--levels", "1", "--budget-vre", "1mg",
                        "--candidates", "ideal:2g,ideal:4g", "--html", str(tmp_path / "compare.html"))
    assert rc == 0, err
    text = (tmp_path / "compare.html").read_text(encoding="utf-8")
    assert "Candidates, ranked" in text and "ideal ±4 g no ODR" in text and text.count("data:image/png;base64,") >= 2
    # no remote assets: the figures embedded, the report's Content-Security-Policy in the head
    # (tests/test_report_browser.py holds the report's page to no network request)
    assert "Content-Security-Policy" in text.split("</head>")[0]
    assert "best: ideal:4g" in out
    assert "best ideal ±4 g" in repr(vrelab.compare("flat:50-2000", 1.0, "1mg", candidates="ideal:2g,ideal:4g"))
