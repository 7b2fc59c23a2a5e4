"""``vrelab simulate`` with a triaxial excitation (issue 22): --direction, --axes, --static-vector.

Truths: the single-axis ``vrelab simulate`` (a drive along the input axis gives its levels
exactly) and IEEE 1293's vibropendulous error of a sine at 45°, ``Kip·r²/2`` (SPEC 1.6).
"""

from __future__ import annotations

import json
import math

import h5py
import pytest

from vrelab.cli import main
from vrelab.folder import read_folder


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


COMMON = ("simulate", "--sensor", "ideal", "--range", "2", "--k2", "1000", "--profile", "flat:20-500",
          "--levels", "0.5,1", "--seconds", "2", "--seed", "3", "--json")


def test_direction_along_the_axis_is_the_single_axis_simulate(capsys):
    rc, out, err = _run(capsys, *COMMON, "--axis", "z")
    assert rc == 0, err
    single = json.loads(out)
    rc, out, err = _run(capsys, *COMMON, "--axis", "z", "--direction", "0,0,2")
    assert rc == 0, err
    tri = json.loads(out)
    assert [c["channel"] for c in tri["channels"]] == ["z"]
    got = tri["channels"][0]["levels"]
    for a, b in zip(single["levels"], got):
        assert (a["vre_g"], a["u_vre_g"], a["rms_g"]) == (b["vre_g"], b["u_vre_g"], b["rms_g"])
    assert tri["triaxial"]["static_vector_g"] == [0.0, 0.0, 1.0]  # --static (1) along the DUT axis
    assert got[1]["vre_g"] < -0.05  # clipped in the 1 g field: a real signal, not zeros


def _sensor_file(tmp_path, kip_ug: float) -> str:
    from importlib import resources

    text = (resources.files("vrelab.sensor") / "presets" / "ideal.toml").read_text(encoding="utf-8")
    head, facts = text.split("[facts]", 1)
    path = tmp_path / "kip.toml"
    path.write_text(head.replace('name = "ideal"', 'name = "kip-part"') + f"kip_ug_per_g2 = {kip_ug}\n\n[facts]"
                    + facts, encoding="utf-8")
    return str(path)


def test_a_sine_at_45_degrees_shows_the_vibropendulous_error_and_writes_a_triaxial_record(tmp_path, capsys):
    sensor = _sensor_file(tmp_path, 20000.0)  # Kip = 0.02 /g on every axis (x's pendulous axis is y)
    out_dir = tmp_path / "out"
    rc, out, err = _run(capsys, "simulate", "--sensor", sensor, "--range", "20", "--freq", "80",
                        "--direction", "1,1,0", "--axes", "x,y,z", "--static-vector", "0,0,1", "--levels", "2",
                        "--seconds", "2", "--out", str(out_dir), "--record")
    assert rc == 0, err
    assert "axis x:" in out and "axis z:" in out
    doc = json.loads((out_dir / "results.json").read_text())
    vre = {c["channel"]: c["levels"][0]["vre_g"] for c in doc["channels"]}
    # x: i = x, p = y, a_x = a_y = a/√2: Kip·r²·sin45·cos45 = 0.02·4/2; y: i = y, p = z (still): 0;
    # z: i = z, p = x, the input axis still: 0
    assert vre["x"] == pytest.approx(0.02 * 4 * 0.5, rel=1e-6)
    assert abs(vre["y"]) < 1e-9 and abs(vre["z"]) < 1e-9
    folder = read_folder(out_dir)
    assert folder.kind == "channels"
    with h5py.File(out_dir / "record.h5", "r") as f:
        assert {"reference_x", "reference_y", "reference_z", "dut_x", "dut_y", "dut_z"} <= set(f)
        assert f["reference_x"][:] == pytest.approx(f["reference_y"][:], abs=1e-15)
        assert float(abs(f["reference_z"][:]).max()) == 0.0
        peak = float(abs(f["reference_x"][:]).max())
        # 2 g rms along (1,1,0)/√2: a peak of √2·2/√2 = 2 g on x, sampled at the record rate
        assert 1.99 < peak <= 2 * math.sqrt(2) / math.sqrt(2) + 1e-12


@pytest.mark.parametrize("extra, words", [
    (("--direction", "1,2"), "--direction must be three finite numbers"),
    (("--direction", "0,0,0"), "zero vector"),
    (("--direction", "1,0,0", "--axes", "x,x"), "--axes must name distinct axes"),
    (("--direction", "1,0,0", "--axes", "x,w"), "axis must be one of"),
    (("--direction", "1,0,0", "--clip-sigma", "3"), "--clip-sigma does not apply to a triaxial test"),
    (("--direction", "1,0,0", "--static-vector", "0,nan,1"), "--static-vector must be three finite numbers"),
    (("--axes", "x"), "needs --direction"),
])
def test_bad_triaxial_input_is_one_line_and_exit_2(capsys, extra, words):
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--profile", "flat:20-500", "--levels", "1",
                        "--seconds", "2", *extra)
    assert rc == 2
    assert words in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_two_sine_frequencies_along_a_direction_are_refused(capsys):
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--freq", "80,160", "--levels", "1",
                        "--direction", "1,0,0")
    assert rc == 2 and "one --freq F along a --direction" in err


def test_simulate_and_analyze_give_the_same_numbers_for_the_same_record(tmp_path, capsys):
    # one owner: `vrelab simulate --direction ... --record` reduces its record through
    # analyze_triaxial, so `vrelab analyze RECORD --triaxial` with the simulation's band and
    # settling time gives the same VRE, u and level, bit for bit
    out_dir = tmp_path / "out"
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--range", "20", "--k2", "1000",
                        "--profile", "flat:20-500", "--direction", "1,0,1", "--axes", "x,z", "--levels", "1,2",
                        "--seconds", "2", "--seed", "3", "--out", str(out_dir), "--record", "--json")
    assert rc == 0, err
    sim = json.loads(out)
    cond = sim["channels"][0]["conditions"]
    band = cond["extra"]["band_hz"] if "extra" in cond else cond["band_hz"]
    settle = cond["extra"]["settle_s"] if "extra" in cond else cond["settle_s"]
    assert band == [10.0, 1000.0]  # the profile's band widened an octave (vrelab.shaker)
    rc, out, err = _run(capsys, "analyze", str(out_dir / "record.h5"), "--triaxial", "--reference",
                        "reference_x,reference_y,reference_z", "--dut", "x=dut_x,z=dut_z",
                        "--band", f"{band[0]}:{band[1]}", "--settle", str(settle), "--json")
    assert rc == 0, err
    ana = json.loads(out)
    assert [c["channel"] for c in ana["channels"]] == [c["channel"] for c in sim["channels"]] == ["x", "z"]
    keys = ("vre_g", "u_vre_g", "rms_g", "u_rms_g", "dof")
    for a, b in zip(sim["channels"], ana["channels"]):
        assert len(a["levels"]) == len(b["levels"]) == 2
        for la, lb in zip(a["levels"], b["levels"]):
            assert {k: la.get(k) for k in keys} == {k: lb.get(k) for k in keys}
        assert a["fit"] == b["fit"]
    # one level per segment for every axis, and the triaxial summary holds the same number
    assert [lv["rms_g"] for lv in ana["triaxial"]["levels"]] == [lv["rms_g"] for lv in ana["channels"][0]["levels"]]


@pytest.mark.parametrize("command", [
    ("predict", "--sensor", "ideal", "--profile", "flat:20-500", "--levels", "1"),
    ("simulate", "--sensor", "ideal", "--profile", "flat:20-500", "--levels", "1", "--seconds", "2",
     "--direction", "1,0,1"),
])
def test_static_and_static_vector_together_are_refused_by_predict_and_simulate_alike(capsys, command):
    # one rule for the static field (vrelab.cli._triaxial): --static along the axis or
    # --static-vector in the part's frame; both at once is ambiguous and refused, the same line
    rc, out, err = _run(capsys, *command, "--static", "1", "--static-vector", "0,0,1")
    assert rc == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "give the static field once: --static (along the axis) or --static-vector" in err
    rc, out, err = _run(capsys, *command, "--static-vector", "0,0,-1", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    vector = (doc["conditions"]["extra"]["static_vector_g"] if command[0] == "predict"
              else doc["triaxial"]["static_vector_g"])
    assert vector == [0.0, 0.0, -1.0]


def test_simulate_takes_the_mount_angle_as_predict_does(capsys):
    # --mount-deg 45 on axis z (ideal part: pendulous x) is the direction (sin 45°, 0, cos 45°):
    # the same drive, the same seed, the same numbers as --direction 1,0,1
    common = ("simulate", "--sensor", "ideal", "--axis", "z", "--k2", "1000", "--profile", "flat:20-500",
              "--levels", "0.5", "--seconds", "2", "--seed", "3", "--json")
    rc, out, err = _run(capsys, *common, "--mount-deg", "45")
    assert rc == 0, err
    rc, out2, err = _run(capsys, *common, "--direction", "1,0,1")
    assert rc == 0, err
    a, b = json.loads(out)["channels"][0]["levels"][0], json.loads(out2)["channels"][0]["levels"][0]
    assert a["vre_g"] == pytest.approx(b["vre_g"], rel=1e-9, abs=1e-12) and a["rms_g"] == pytest.approx(b["rms_g"], rel=1e-9)
    rc, _, err = _run(capsys, "simulate", "--sensor", "ideal", "--profile", "flat:20-500@z45x", "--levels", "1",
                      "--mount-deg", "45")
    assert rc == 2 and "apply to a single-axis --profile" in err


def test_the_text_output_shows_the_profile_shape_not_its_unscaled_rms(capsys):
    """The profile is scaled to each level: the vibration line gives each axis's share of the
    total and the band, not the rms of the profile as written (21.9 g for flat:20-500 at its
    default density, which no run of 0.5 and 1 g rms ever saw)."""
    rc, out, err = _run(capsys, *COMMON[:-1], "--axis", "z", "--direction", "1,0,1")
    assert rc == 0, err
    line = next(ln for ln in out.splitlines() if ln.startswith("vibration:"))
    assert "rms x 0.707, y 0, z 0.707 of the total, 20-500 Hz" in line
    assert "g rms total" not in line
