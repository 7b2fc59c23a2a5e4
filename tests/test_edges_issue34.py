"""Issue 34's edge rows beyond the unit slip (that one: tests/test_campaign_slip.py): each case is
refused in one line, or kept compactly, in bounded memory, before anything long starts."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from vrelab.campaigns import read_manifest
from vrelab.cli import main


def _tiny_csv(path: Path) -> None:
    """0.2 s at 1 kHz of noise: too short to hold a level and its baselines, so every run fails."""
    rng = np.random.default_rng(34)
    t = np.arange(200) / 1000
    np.savetxt(path, np.c_[t, rng.standard_normal(200), rng.standard_normal(200)], delimiter=",",
               header="time,ref,dut", comments="")


def _many_runs(tmp: Path, n: int, schedules: bool) -> Path:
    _tiny_csv(tmp / "tiny.csv")
    runs = []
    for i in range(n):
        sched = ""
        if schedules:  # each run its own part of the one record: a legitimate campaign
            (tmp / f"s{i}.csv").write_text(f"start_s,end_s,rms_g,freq_hz\n0,0.05,0,\n0.05,0.1,{0.1 + i * 1e-4},80\n")
            sched = f'schedule = "s{i}.csv"\n'
        runs.append(f'[[run]]\nfile = "tiny.csv"\ndut = ["dut"]\nreference = "ref"\nstatic_g = 0\n{sched}')
    m = tmp / "many.toml"
    m.write_text('name = "many runs on one file"\n' + "\n".join(runs))
    return m


@pytest.mark.parametrize("schedules", [True, False])
def test_many_runs_on_one_file_are_checked_in_linear_memory(tmp_path: Path, schedules: bool) -> None:
    """Row 'OOM': 10 000 runs on one file were `internal error: MemoryError` after 50 s: the
    check that no recording serves a DUT twice listed every pair of runs on the file first (n²/2
    tuples: 50 million). 1000 runs here made 500 000 pairs: peaks of 117 MB (kept) and 73 MB
    (refused) of Python objects measured with the quadratic check (some 25 MB of it modules then
    imported); the linear one's are 2.8 MB and 2.3 MB. 20 MB parts them with room either way."""
    (tmp_path / "warm").mkdir()
    read_manifest(_many_runs(tmp_path / "warm", 2, schedules=True))  # the modules it imports, loaded before the count
    m = _many_runs(tmp_path, 1000, schedules)
    tracemalloc.start()
    try:
        if schedules:
            assert len(read_manifest(m).runs) == 1000
        else:  # one recording twice for DUT 'dut': refused, naming the first two runs
            with pytest.raises(ValueError, match=r"run 1 \('tiny.csv'\) and run 2 \('tiny.csv'\) are the same file"):
                read_manifest(m)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, peak


def test_a_campaign_whose_runs_all_fail_keeps_one_line_each(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    m = _many_runs(tmp_path, 60, schedules=True)
    assert main(["campaign", str(m), "--json"]) == 1
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert doc["n_failed"] == 60 and all(r["status"] == "failed" and "\n" not in r["error"] for r in doc["runs"])
    lines = cap.err.strip().splitlines()
    assert len(lines) == 60 and all(ln.startswith(f"vrelab: run {i} (tiny.csv) failed: ") for i, ln in enumerate(lines, 1))


@pytest.mark.parametrize("value, kind", [("{a = 1}", "table"), ("[1, 2]", "array"), ("3", "integer")])
def test_a_description_that_is_not_a_string_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        value: str, kind: str) -> None:
    """Row 'silent accept': a table was stringified ("{'a': 1}") into the campaign document."""
    _tiny_csv(tmp_path / "tiny.csv")
    m = tmp_path / "m.toml"
    m.write_text(f'name = "x"\ndescription = {value}\n[[run]]\nfile = "tiny.csv"\ndut = ["dut"]\nreference = "ref"\n'
                 "static_g = 0\n")
    assert main(["campaign", str(m), "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == f"vrelab: error: m.toml: description must be a string, got a {kind}\n"


@pytest.mark.parametrize("field", ["rms_g", "static_g", "vre_2f.value"])
def test_identify_refuses_a_number_beyond_physics_by_its_field(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                field: str) -> None:
    """Row 'internal error': a campaign document with an rms of 1e308 gave numpy's overflow
    warning on rms², then `internal error: ZeroDivisionError`; now one line naming the field."""
    level = {"rms_g": 0.5, "vre_g": 1e-3, "u_vre_g": 1e-5, "freq_hz": 80.0, "vre_2f": {"value": 1e-3, "u": 1e-5}}
    ch: dict = {"channel": "a", "static_g": 1.0, "levels": [level, {**level, "rms_g": 0.2}]}
    where = {"rms_g": "levels[0].rms_g", "static_g": "static_g", "vre_2f.value": "levels[0].vre_2f.value"}[field]
    if field == "static_g":
        ch["static_g"] = 1e308
    elif field == "rms_g":
        level["rms_g"] = 1e308
    else:
        level["vre_2f"]["value"] = 1e308
    camp = tmp_path / "camp"
    camp.mkdir()
    (camp / "results.json").write_text(json.dumps({"kind": "campaign", "name": "x", "channels": [], "runs": [
        {"index": 1, "status": "ok", "method": "sine", "label": "a", "channels": [ch]}]}))
    assert main(["identify", str(camp), "--out", str(tmp_path / "id"), "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.count("\n") == 1, cap.err
    assert cap.err.startswith(f"vrelab: error: identify: campaign document runs[0].channels[0].{where} must be "), cap.err
    assert "1e+308" in cap.err


def test_a_simulate_sweep_beyond_the_time_budget_is_refused_before_it_starts(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Row 'hang': a sweep of many `simulate` points with long records started, each point within
    `simulate`'s own budget; the sweep is now refused by the same owner for the sum of its points."""
    import vrelab.sweep as S
    from vrelab._budget import SIMULATION_SECONDS_PER_SAMPLE as per_sample
    from vrelab.rates import simulation_rate_hz
    from vrelab.sensor import load_sensor

    monkeypatch.setenv("VRELAB_TIME_BUDGET_H", "0.002")  # 7.2 s of estimated compute
    monkeypatch.setattr(S, "run_points", lambda *a, **k: pytest.fail("the sweep started"))
    f = tmp_path / "sweep.toml"
    f.write_text('kind = "simulate"\nseed = 1\nseconds = 20\n[fixed]\nsensor = "ideal"\nprofile = "flat:50-2000"\n'
                 '[grid]\nrms_g = "0.1:10:0.1"\n')
    # a point's record: a 2 s baseline each side of its 20 s level (the shaker's default
    # baseline_s), at the internal rate the simulator picks for the ideal sensor and a 2 kHz band
    one = (2 + 20 + 2) * simulation_rate_hz(load_sensor("ideal"), 2000.0)
    assert one * per_sample < 7.2 < 100 * one * per_sample  # each point alone passes, the 100 do not
    out = tmp_path / "out"
    assert main(["sweep", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vrelab: error: sweep: 100 simulate point(s) would take about "), err
    assert f"({100 * one:.3g} samples at the internal rate), beyond the 7.2 s budget" in err, err
    assert not out.exists()
