"""``vrelab analyze``: SPEC 5 JSON keys, output folder, provenance, and bad files (exit 2, one
stderr line, input file unchanged, no output written)."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from test_analysis_helpers import make_record
from vrelab._io import sha256_file
from vrelab.cli import main
from vrelab.record import write_record_hdf5

FS = 500.0


@pytest.fixture(scope="module")
def truth():
    k2 = 400e-6
    lv = (0.5, 1.0, 1.5)
    return make_record(31, levels_g=lv, vre_g=tuple(k2 * r * r for r in lv), t_off_s=6.0, t_on_s=10.0, noise_g=2e-4)


@pytest.fixture()
def csv_file(tmp_path, truth):
    d = truth.record.data
    t = np.arange(len(d["dut"])) / FS
    p = tmp_path / "rec.csv"
    np.savetxt(p, np.column_stack([t, d["reference"], d["dut"]]), delimiter=",", header="time,ref,adxl", comments="", fmt="%.12g")
    return p


def test_json_has_spec_keys_and_provenance(csv_file, capsys):
    rc = main(["analyze", str(csv_file), "--dut", "adxl", "--reference", "ref", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    d = json.loads(out)
    assert len(d["levels"]) == 3
    for lv in d["levels"]:
        assert {"rms_g", "vre_g", "u_vre_g"} <= set(lv)
    assert set(d["fit"]["vrc_ug_per_g2"]) >= {"value", "u"}
    assert set(d["fit"]["rail_g"]) >= {"value", "u"}
    vrc = d["fit"]["vrc_ug_per_g2"]
    assert abs(vrc["value"] - 400.0) < 3 * vrc["u"] + 10.0
    prov = d["provenance"]
    assert prov["input_file"] == "rec.csv"
    assert prov["input_sha256"] == sha256_file(csv_file)
    assert "analyze" in prov["command"] and prov["vrelab_version"]


def test_file_hashed_once_per_command_in_a_thread(csv_file, tmp_path, capsys, monkeypatch):
    """The provenance SHA-256 is taken once per command (not again for the written results),
    off the main thread (it runs beside the reduction), and is the file's (hashlib's own,
    computed here independently)."""
    import hashlib
    import threading

    import vrelab._digests
    import vrelab._io

    calls: list[str] = []
    real = vrelab._io.sha256_file

    def counting(path):
        calls.append(threading.current_thread().name)
        return real(path)

    # the CLI hashes through vrelab._digests (its cache is off for the suite: tests/conftest.py), which
    # holds its own reference to the hashing function; both names count
    monkeypatch.setattr(vrelab._io, "sha256_file", counting)
    monkeypatch.setattr(vrelab._digests, "sha256_file", counting)
    out_dir = tmp_path / "res"
    rc = main(["analyze", str(csv_file), "--dut", "adxl", "--reference", "ref", "--json", "--out", str(out_dir)])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert len(calls) == 1 and calls[0] != threading.main_thread().name
    want = hashlib.sha256(csv_file.read_bytes()).hexdigest()
    assert json.loads(out)["provenance"]["input_sha256"] == want
    assert json.loads((out_dir / "results.json").read_text())["provenance"]["input_sha256"] == want


def test_human_summary_and_out_dir(csv_file, tmp_path, capsys):
    out_dir = tmp_path / "res"
    rc = main(["analyze", str(csv_file), "--dut", "adxl", "--reference", "ref", "--out", str(out_dir)])
    out, _ = capsys.readouterr()
    assert rc == 0
    assert "VRE ± u (mg)" in out and "vrc_ug_per_g2" in out
    names = {p.name for p in out_dir.iterdir()}
    assert {"results.json", "levels.csv", "envelope.csv", "psd_levels.csv"} <= names
    env = np.genfromtxt(out_dir / "envelope.csv", delimiter=",", names=True, dtype=None, encoding=None)
    assert "reference_rms_g" in env.dtype.names and "segment" in env.dtype.names
    assert {"off", "level 1", "level 3"} <= set(env["segment"])
    res = json.loads((out_dir / "results.json").read_text())
    lv = np.genfromtxt(out_dir / "levels.csv", delimiter=",", names=True)
    assert np.allclose(lv["vre_g"], [x["vre_g"] for x in res["levels"]])


def test_profile_writes_psd_csv(csv_file, tmp_path, capsys):
    out_dir = tmp_path / "res"
    rc = main(["analyze", str(csv_file), "--dut", "adxl", "--reference", "ref", "--profile", "flat:80-200",
               "--out", str(out_dir), "--json"])  # fmt: skip
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert (out_dir / "psd.csv").is_file()
    d = json.loads(out)
    assert d["conditions"]["extra"]["band_hz"] == [80.0, 200.0]


def test_lsb_units_option(tmp_path, truth, capsys):
    d = truth.record.data
    p = tmp_path / "raw.npz"
    np.savez(p, dut=np.round(d["dut"] * 256000).astype(np.int32), ref=d["reference"] * 10.0, fs=np.float64(FS))
    rc = main(["analyze", str(p), "--dut", "dut", "--reference", "ref", "--dut-units", "lsb",
               "--dut-sensitivity", "256000", "--reference-units", "mv", "--reference-sensitivity", "10", "--json"])  # fmt: skip
    out, err = capsys.readouterr()
    assert rc == 0, err
    lv = json.loads(out)["levels"]
    assert [round(x["rms_g"], 1) for x in lv] == [0.5, 1.0, 1.5]


def test_sine_method_cli(tmp_path, capsys):
    tr = make_record(32, sine_hz=120.0, t_off_s=6.0, t_on_s=10.0)
    p = tmp_path / "sine.h5"
    write_record_hdf5(p, FS, [tr.record.data])
    rc = main(["analyze", str(p), "--dut", "dut", "--reference", "reference", "--method", "sine", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    d = json.loads(out)
    assert all(abs(x["freq_hz"] - 120.0) < 0.01 for x in d["levels"])
    assert "vrc_ug_per_g2" in d["fit"]


def _bad(tmp_path: Path, name: str, content: bytes | None = None) -> Path:
    p = tmp_path / name
    if content is not None:
        p.write_bytes(content)
    return p


def _csv(rows: list[str]) -> bytes:
    return ("\n".join(rows) + "\n").encode()


def _good_rows(n: int = 400) -> list[str]:
    return ["time,ref,adxl"] + [f"{i / FS},{np.sin(i):.6f},{1 + 0.001 * np.cos(i):.6f}" for i in range(n)]


def make_bad_files(tmp_path: Path) -> dict[str, tuple[Path, list[str], str]]:
    """name -> (file, extra args, regex the one stderr line must match)."""
    cases: dict[str, tuple[Path, list[str], str]] = {}
    rows = _good_rows()
    cases["missing channel"] = (_bad(tmp_path, "ok.csv", _csv(rows)), ["--dut", "nope"], r"not found.*channels: time, ref, adxl")
    r = rows[:301] + [f"{300 / FS},0.1,nan"] + rows[302:]
    cases["nan"] = (_bad(tmp_path, "nan.csv", _csv(r)), ["--dut", "adxl", "--time", "time"], r"'adxl' \(dut\).*index 300")
    r = list(rows)
    r[101], r[102] = r[102], r[101]
    cases["non-monotonic time"] = (_bad(tmp_path, "nonmono.csv", _csv(r)), ["--dut", "adxl"], r"not increasing at index 101")
    r = rows[:201] + rows[202:]
    cases["gapped time"] = (_bad(tmp_path, "gap.csv", _csv(r)), ["--dut", "adxl"], r"gap or uneven step at index 200")
    cases["empty"] = (_bad(tmp_path, "empty.csv", b""), ["--dut", "adxl"], r"empty")
    hp = tmp_path / "full.h5"
    write_record_hdf5(hp, FS, [{"reference": np.zeros(200_000), "dut": np.ones(200_000)}])
    raw = hp.read_bytes()
    cases["truncated hdf5"] = (_bad(tmp_path, "trunc.h5", raw[: len(raw) // 2]), ["--dut", "dut"], r"trunc")
    np.save(tmp_path / "full.npy", np.zeros((10_000, 2)))
    raw = (tmp_path / "full.npy").read_bytes()
    cases["truncated npy"] = (_bad(tmp_path, "trunc.npy", raw[: len(raw) // 3]), ["--dut", "0", "--fs", "10"], r"trunc")
    r = rows[:-20] + [row.rsplit(",", 1)[0] + "," for row in rows[-20:]]
    cases["mismatched lengths csv"] = (_bad(tmp_path, "short.csv", _csv(r)), ["--dut", "adxl", "--reference", "ref"], r"mismatched lengths")
    mp = tmp_path / "mism.h5"
    with h5py.File(mp, "w") as f:
        f.attrs["fs_hz"] = FS
        f["dut"] = np.zeros(1000)
        f["reference"] = np.zeros(999)
    cases["mismatched lengths hdf5"] = (mp, ["--dut", "dut", "--reference", "reference"], r"mismatched lengths")
    cases["unknown format"] = (_bad(tmp_path, "data.xyz", b"\x00\x01garbage" * 10), ["--dut", "a"], r"unknown file format")
    cases["missing file"] = (tmp_path / "nope.csv", ["--dut", "a"], r"not found")
    return cases


def test_bad_files_exit_2_with_one_line_and_leave_input_and_output_untouched(tmp_path, capsys):
    import re

    for name, (path, extra, pattern) in make_bad_files(tmp_path).items():
        before = path.read_bytes() if path.exists() else None
        out_dir = tmp_path / f"out_{name.replace(' ', '_')}"
        rc = main(["analyze", str(path), *extra, "--out", str(out_dir)])
        out, err = capsys.readouterr()
        assert rc == 2, (name, err)
        assert out == "", name
        lines = err.strip().splitlines()
        assert len(lines) == 1, (name, err)
        assert re.search(pattern, lines[0]), (name, lines[0])
        assert "Traceback" not in err
        if before is not None:
            assert path.read_bytes() == before, name
        assert not out_dir.exists(), name


def test_progress_bar_goes_to_stderr_and_json_stays_clean(csv_file, capsys):
    rc = main(["analyze", str(csv_file), "--dut", "adxl", "--reference", "ref", "--progress", "--json",
               "--kind", "truncated", "--k4", "--band", "50:250"])  # fmt: skip
    out, err = capsys.readouterr()
    assert rc == 0, err
    d = json.loads(out)  # stdout holds exactly one JSON object
    assert "reading" in err
    # the bar redraws with carriage returns, which reach the terminal as such: the escaping of
    # every printed line (control characters in a file's channel names) is not the bar's
    assert "\r" in err and "\\r" not in err
    assert [f["model"] for f in d["fits"]] == ["clip-truncated", "vrc+k4"]  # the one fit policy's order
    assert "c4_ug_per_g4" in d["fit"]
    assert "--k4" in d["provenance"]["command"] and "--band 50:250" in d["provenance"]["command"]


def test_schedule_file_option(tmp_path, truth, capsys):
    d = truth.record.data
    p = tmp_path / "rec.h5"
    write_record_hdf5(p, FS, [d])
    sched = tmp_path / "schedule.csv"
    truth.schedule.write_csv(sched)
    rc = main(["analyze", str(p), "--dut", "dut", "--reference", "reference", "--schedule", str(sched), "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    lv = json.loads(out)["levels"]
    assert len(lv) == 3
    for x, v in zip(lv, truth.vre_g):
        assert abs(x["vre_g"] - v) < 4 * x["u_vre_g"]


def test_rail_vrc_option_adds_the_vrc_term_to_the_rail_fit(csv_file, capsys):
    rc = main(["analyze", str(csv_file), "--dut", "adxl", "--reference", "ref", "--rail-vrc", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    (rail,) = [f for f in json.loads(out)["fits"] if f["model"] == "clip-censored"]
    assert {"rail_g", "vrc_ug_per_g2"} <= set(rail["parameters"])
