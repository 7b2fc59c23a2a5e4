"""``vrelab simulate``: the SPEC 5 contract (options, JSON keys, --out files, errors)."""

from __future__ import annotations

import csv
import json

import pytest

from vrelab.cli import main


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_random_json_has_the_contract_keys(capsys):
    rc, out, err = _run(capsys, "simulate", "--sensor", "adxl355", "--axis", "z", "--range", "2", "--odr", "4000",
                        "--static", "1", "--profile", "flat:50-2000", "--levels", "0.5,1:2:1", "--seconds", "2",
                        "--seed", "3", "--json")
    assert rc == 0, err
    d = json.loads(out)  # exactly one JSON object on stdout
    assert [round(lv["rms_g"], 1) for lv in d["levels"]] == [0.5, 1.0, 2.0]
    for lv in d["levels"]:
        assert {"rms_g", "vre_g", "u_vre_g"} <= set(lv)
        assert lv["u_vre_g"] > 0
    assert "fit" in d and "rail_g" in d["fit"]
    assert d["conditions"]["sensor"] == "adxl355" and d["conditions"]["axis"] == "z"
    assert d["conditions"]["extra"]["seed"] == 3
    # SPEC 1.1 / article Fig. 2: clipping in a 1 g field pulls the mean down
    assert d["levels"][-1]["vre_g"] < -0.05


def test_sine_json_has_freq_and_vrc_per_frequency(capsys):
    """Ideal sensor with --k2 (SPEC 5): VRE = k2·rms² (SPEC 1.2) at each frequency."""
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--k2", "1000", "--static", "0",
                        "--freq", "100,1000", "--levels", "0.5,1", "--seconds", "2", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert [lv["freq_hz"] for lv in d["levels"]] == pytest.approx([100, 100, 1000, 1000])
    for lv in d["levels"]:
        assert lv["vre_g"] == pytest.approx(1000e-6 * lv["rms_g"] ** 2, rel=2e-3)
    assert d["fit"]["vrc_ug_per_g2"]["value"] == pytest.approx(1000, rel=2e-3)
    assert len(d["fits"]) == 2


def test_out_writes_every_file(tmp_path, capsys):
    out_dir = tmp_path / "run"
    rc, out, err = _run(capsys, "simulate", "--sensor", "adxl355", "--axis", "z", "--profile", "flat:50-2000",
                        "--levels", "1,2", "--seconds", "2", "--out", str(out_dir), "--record", "--json")
    assert rc == 0, err
    assert sorted(p.name for p in out_dir.iterdir()) == [".vrelab-output", "levels.csv", "prediction.json", "record.h5", "results.json"]
    results = json.loads((out_dir / "results.json").read_text())
    assert results == json.loads(out)
    rows = list(csv.DictReader(open(out_dir / "levels.csv")))
    assert len(rows) == 2 and float(rows[1]["vre_g"]) == pytest.approx(results["levels"][1]["vre_g"])
    pred = json.loads((out_dir / "prediction.json").read_text())
    assert len(pred["levels"]) == 2 and {"rms_g", "vre_g", "tilt_error_deg"} <= set(pred["levels"][0])
    import h5py

    with h5py.File(out_dir / "record.h5") as f:
        assert {"dut", "reference", "schedule"} <= set(f)
        assert f.attrs["fs_hz"] == results["conditions"]["extra"]["fs_record_hz"]


def test_human_output_is_a_table(capsys):
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1,2",
                        "--seconds", "2")
    assert rc == 0, err
    assert "VRE ± u (mg)" in out and "rail_g" in out
    assert not out.lstrip().startswith("{")


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1,-1"], "--levels"),
        (["--sensor", "nosuch", "--profile", "flat:50-2000", "--levels", "1"], "nosuch"),
        (["--sensor", "ideal", "--profile", "flat:2000-50", "--levels", "1"], "f_hi"),
        (["--sensor", "ideal", "--profile", "flat:50-2000", "--freq", "100", "--levels", "1"], "not allowed"),
        (["--sensor", "ideal", "--levels", "1"], "one of the arguments"),
        (["--sensor", "ideal", "--freq", "100,abc", "--levels", "1"], "--freq"),
        (["--sensor", "ideal", "--freq", "100", "--levels", "1", "--seconds", "-2"], "--seconds"),
        (["--sensor", "adxl355", "--range", "3", "--freq", "100", "--levels", "1"], "range"),
        (["--sensor", "ideal", "--freq", "100", "--levels", "1", "--record"], "--out"),
        (["--sensor", "ideal", "--freq", "100", "--levels", "1", "--kurtosis", "5"], "--kurtosis"),
        (["--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1", "--kurtosis", "2"], "kurtosis"),
        (["--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1", "--seconds", "1"], "seconds"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, argv, word):
    rc, out, err = _run(capsys, "simulate", *argv)
    assert rc == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and word in err, err


def test_record_closes_the_loop_through_vrelab_analyze(tmp_path, capsys):
    """simulate --record writes record.h5; `vrelab analyze record.h5 --dut dut --reference
    reference` with the simulation's settling time and measurement band gives the same levels
    and VRE as the simulation's own reduction (the same reduction code reads the file)."""
    out_dir = tmp_path / "sim"
    rc, out, err = _run(capsys, "simulate", "--sensor", "adxl355", "--axis", "z", "--profile", "flat:50-2000",
                        "--levels", "1,2,3", "--seconds", "2", "--seed", "4", "--out", str(out_dir), "--record",
                        "--json")
    assert rc == 0, err
    sim = json.loads(out)
    rc, out, err = _run(capsys, "analyze", str(out_dir / "record.h5"), "--dut", "dut", "--reference", "reference",
                        "--settle", "0.5", "--band", "25:4000", "--json")
    assert rc == 0, err
    ana = json.loads(out)
    assert len(ana["levels"]) == 3
    for a, s in zip(ana["levels"], sim["levels"]):
        assert a["rms_g"] == pytest.approx(s["rms_g"], rel=1e-9)
        assert a["vre_g"] == pytest.approx(s["vre_g"], rel=1e-9, abs=1e-12)
        assert a["u_vre_g"] == pytest.approx(s["u_vre_g"], rel=1e-9)
    assert ana["fit"]["rail_g"]["value"] == pytest.approx(sim["fit"]["rail_g"]["value"], rel=0.02)


def test_out_is_complete_or_absent(tmp_path, capsys, monkeypatch):
    """A failure during the run leaves no output folder (vrelab._io.output_dir)."""
    from vrelab import shaker

    def boom(*args, **kwargs):
        raise ValueError("simulated failure")

    monkeypatch.setattr(shaker, "run_random_test", boom)
    out_dir = tmp_path / "never"
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1",
                        "--out", str(out_dir))
    assert rc == 2 and "simulated failure" in err
    assert not out_dir.exists()
    assert list(tmp_path.iterdir()) == []  # no staging folder left behind either


def test_a_test_beyond_the_budget_is_refused_up_front_with_its_cost(capsys):
    """`--seconds 1e9` once tried to allocate 74.5 GiB; the plan now states the time it would take
    (1e9 s at 16 kHz: 1.6e13 samples at 0.5 µs, about 93 days per level) and refuses at once."""
    rc = main(["simulate", "--sensor", "adxl355", "--profile", "flat:50-2000", "--levels", "1", "--seconds", "1e9"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "would take about" in err and "days" in err and "VRELAB_TIME_BUDGET_H" in err
