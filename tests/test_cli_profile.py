"""`vrelab profile` (SPEC section 5): JSON keys, scaling, listing, writing, exit 2 on bad input."""

from __future__ import annotations

import json

import pytest

from vrelab.cli import main
from vrelab.profiles import read_profile


def run_json(capsys, *argv):
    assert main(["profile", *argv, "--json"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1  # exactly one JSON object
    return json.loads(out)


def test_json_keys_navmat_6_06_grms(capsys):
    """SPEC 3 check value: NAVMAT P-9492 = 6.06 grms, through the CLI contract keys."""
    d = run_json(capsys, "navmat-p9492")
    assert {"grms", "breakpoints", "band_hz", "slopes_db_per_oct", "name", "source"} <= set(d)
    assert d["grms"] == pytest.approx(6.06, abs=0.005)
    assert d["breakpoints"][0] == [20.0, 0.01] and d["band_hz"] == [20.0, 2000.0]
    assert d["slopes_db_per_oct"] == pytest.approx([3.0103, 0.0, -3.0103], abs=1e-4)


def test_inline_profile_6_92_grms_and_scaling(capsys):
    """SPEC 3 check value 6.92 grms; --grms multiplies every PSD value by the ratio squared."""
    d = run_json(capsys, "20:0.01,80:0.05,350:0.05,2000:0.01")
    assert d["grms"] == pytest.approx(6.92, abs=0.005)
    s = run_json(capsys, "20:0.01,80:0.05,350:0.05,2000:0.01", "--grms", "3.46")
    assert s["grms"] == pytest.approx(3.46, rel=1e-12)
    ratio2 = (3.46 / d["grms"]) ** 2
    assert [p for _, p in s["breakpoints"]] == pytest.approx([p * ratio2 for _, p in d["breakpoints"]], rel=1e-12)


def test_flat_scaled(capsys):
    d = run_json(capsys, "flat:50-2000", "--grms", "2.5")
    assert d["breakpoints"][0][1] == pytest.approx(2.5**2 / 1950, rel=1e-12)


def test_text_output_has_grms_and_slopes(capsys):
    assert main(["profile", "navmat-p9492"]) == 0
    out = capsys.readouterr().out
    assert "6.06" in out and "-3.01 dB/oct" in out and "0.007" in out


@pytest.mark.parametrize("argv", [["--list"], ["list"]])
def test_list(capsys, argv):
    d = run_json(capsys, *argv)
    names = {p["name"] for p in d["profiles"]}
    assert {"navmat-p9492", "adi-flat-50-2000", "gevs-workmanship"} <= names


@pytest.mark.parametrize("ext", ["csv", "toml"])
def test_write(capsys, tmp_path, ext):
    path = tmp_path / f"out.{ext}"
    d = run_json(capsys, "navmat-p9492", "--grms", "2", "--write", str(path))
    assert read_profile(path).grms == pytest.approx(2.0, rel=1e-12)
    assert read_profile(path).breakpoints == d["breakpoints"]


@pytest.mark.parametrize(
    "argv",
    [
        ["nonsense"],
        ["20:0.01"],
        ["20:0.01,10:0.02"],
        ["20:0.01,80:-1"],
        ["20:0.01,80:nan"],
        ["flat:2000-50"],
        ["navmat-p9492", "--grms", "-1"],
        ["navmat-p9492", "--grms", "abc"],
        ["/nonexistent/profile.csv"],
        ["navmat-p9492", "--write", "x.xyz"],
        [],
    ],
)
def test_bad_input_exit_2_one_line(capsys, argv):
    assert main(["profile", *argv, "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err.count("\n") == 1 and "Traceback" not in cap.err
