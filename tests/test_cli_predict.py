"""``vrelab predict``: the SPEC 5 contract (options, JSON keys, errors)."""

from __future__ import annotations

import json

import pytest

from vrelab.cli import main


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_profile_json_keys_and_values(capsys):
    """SPEC 5 keys; ideal ±2 g sensor in a 1 g field at 1 g rms: the censored -83 mg (SPEC 1.1)."""
    rc, out, err = _run(capsys, "predict", "--sensor", "ideal", "--range", "2", "--static", "1",
                        "--profile", "flat:50-2000", "--levels", "0.5:1:0.5", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert [lv["rms_g"] for lv in d["levels"]] == [0.5, 1.0]
    for lv in d["levels"]:
        assert {"rms_g", "vre_g", "tilt_error_deg"} <= set(lv)
    assert d["levels"][1]["vre_g"] == pytest.approx(-0.0833, abs=0.0005)


def test_truncated_kind_gives_the_articles_model(capsys):
    """SPEC 1.1: truncated model, ±2 g, 1 g field, 1 g rms: -283 mg."""
    rc, out, err = _run(capsys, "predict", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1",
                        "--kind", "truncated", "--json")
    assert rc == 0, err
    assert json.loads(out)["levels"][0]["vre_g"] == pytest.approx(-0.283, abs=0.0005)


def test_sine_with_sensor_options(capsys):
    """--k2/--k3 set the nonlinearity (SPEC 5): (k2 + 3·k3·g0)·rms² (SPEC 1.2), ideal sensor, no clip."""
    rc, out, err = _run(capsys, "predict", "--sensor", "ideal", "--range", "40", "--static", "1", "--k2", "100",
                        "--k3", "10", "--freq", "200", "--levels", "1,2", "--json")
    assert rc == 0, err
    d = json.loads(out)
    for lv in d["levels"]:
        assert lv["freq_hz"] == 200
        assert lv["vre_g"] == pytest.approx((100 + 3 * 10) * 1e-6 * lv["rms_g"] ** 2, rel=1e-9)


def test_adxl355_options_reach_the_sensor(capsys):
    rc, out, err = _run(capsys, "predict", "--sensor", "adxl355", "--range", "8", "--axis", "x", "--odr", "500",
                        "--profile", "flat:50-2000", "--levels", "1", "--json")
    assert rc == 0, err
    c = json.loads(out)["conditions"]
    assert (c["range_g"], c["axis"], c["odr_hz"], c["bandwidth_hz"]) == (8, "x", 500, 125)


def test_human_output_and_out_dir(tmp_path, capsys):
    rc, out, err = _run(capsys, "predict", "--sensor", "adxl355", "--axis", "z", "--profile", "flat:50-2000",
                        "--levels", "1,4", "--out", str(tmp_path / "p"))
    assert rc == 0, err
    assert "VRE mg" in out and "valid" in out
    d = json.loads((tmp_path / "p" / "prediction.json").read_text())
    assert len(d["levels"]) == 2


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "-1"], "--levels"),
        (["--sensor", "nosuch", "--profile", "flat:50-2000", "--levels", "1"], "nosuch"),
        (["--sensor", "ideal", "--profile", "50:0.1", "--levels", "1"], "profile"),
        (["--sensor", "ideal", "--profile", "flat:50-2000", "--freq", "100", "--levels", "1"], "not allowed"),
        (["--sensor", "ideal", "--levels", "1"], "one of the arguments"),
        (["--sensor", "ideal", "--freq", "-5", "--levels", "1"], "--freq"),
        (["--sensor", "adxl355", "--axis", "w", "--freq", "100", "--levels", "1"], "axis"),
        (["--sensor", "adxl355", "--odr", "3000", "--freq", "100", "--levels", "1"], "odr"),
        (["--sensor", "ideal", "--freq", "100"], "--levels"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, argv, word):
    rc, out, err = _run(capsys, "predict", *argv)
    assert rc == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and word in err, err


def test_table_shows_shares_below_resolution_as_zero_never_as_exponents(capsys):
    """The ADXL355 Z at 0.2 g rms: its over-range share is ~1e-176 mg (the 8 g threshold is 40
    sigma away) and its clipping share ~1e-12 mg. The table shows them as 0 at 0.001 mg; the JSON
    keeps the numbers (scripts read them)."""
    # k2 and k3 set by hand: the preset's assumed u of them (the 0.1 % FS bound, issue 28) would show as 0.1 mg
    argv = ["predict", "--sensor", "adxl355", "--axis", "z", "--range", "2", "--static", "1",
            "--profile", "flat:50-2000", "--levels", "0.2,1", "--k2", "20", "--k3", "0"]
    rc, out, err = _run(capsys, *argv)
    assert rc == 0, err
    rows = [line.split() for line in out.splitlines() if line.split()[:1] in (["0.2"], ["1"])]
    assert len(rows) == 2 and not any("e-" in c or "e+" in c for r in rows for c in r), out
    low = rows[0]
    assert low[-4] == "0" and low[-2] == "0"  # clip mg, overrange mg (counted from the right: VRE may carry "± u")
    # the preset's remaining assumed u (threshold, filters, resonance) is far below the 0.001 mg shown: "< 0.001"
    assert low[2:4] == ["±", "<0.001"], low
    # VRE to 0.001 mg where its u is below that (the 1 g row's is rounded to its u: the filters' assumed shape)
    assert len(low[1].split(".")[1]) == 3
    rc, out, err = _run(capsys, *argv, "--json")
    d = json.loads(out)
    assert 0 < abs(d["levels"][0]["shares"]["overrange_g"]) < 1e-9  # the number itself is kept
