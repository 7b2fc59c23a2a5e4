"""Output folders (issue 9): a folder holds exactly one run, a killed run's staging is cleaned
by the next, a read-only parent still works, and a folder of the user's is never emptied."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from vrelab import _io
from vrelab.cli import main

SIM = ["simulate", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1", "--seconds", "2"]


def test_a_reused_out_folder_holds_exactly_the_new_run(tmp_path, capsys):
    """Issue 9: a second, different run into the same --out kept the first run's record.h5, and
    the report mixed the two runs."""
    out = tmp_path / "run"
    assert main([*SIM, "--out", str(out), "--record"]) == 0
    assert (out / "record.h5").is_file()
    assert main([*SIM, "--levels", "0.5", "--out", str(out)]) == 0
    capsys.readouterr()
    assert not (out / "record.h5").exists()
    doc = json.loads((out / "results.json").read_text())
    assert [round(lv["rms_g"], 1) for lv in doc["levels"]] == [0.5]
    assert sorted(p.name for p in out.iterdir()) == [".vrelab-output", "levels.csv", "prediction.json", "results.json"]
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # no staging left beside it


def test_a_folder_of_the_users_is_refused_not_emptied(tmp_path, capsys):
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "chapter1.tex").write_text("precious")
    assert main([*SIM, "--out", str(mine)]) == 2
    assert "is not a vrelab output folder" in capsys.readouterr().err
    assert (mine / "chapter1.tex").read_text() == "precious"


def test_a_read_only_parent_stages_inside_the_folder(tmp_path, monkeypatch):
    """Issue 9: --out an existing writable folder in a read-only parent was refused. (Root ignores
    permission bits, so the parent's refusal is simulated at os.access, where _io asks.)"""
    out = tmp_path / "run"
    with _io.output_dir(out) as stage:  # an earlier run's folder
        (stage / "levels.csv").write_text("from an earlier run")
    real = os.access
    monkeypatch.setattr(_io.os, "access", lambda p, mode: False if Path(p) == tmp_path else real(p, mode))
    with _io.output_dir(out) as stage:
        (stage / "results.json").write_text("{}")
        assert stage.parent == out
    assert sorted(p.name for p in out.iterdir()) == [_io.MARKER, "results.json"]


def test_a_killed_runs_staging_is_removed_by_the_next_run(tmp_path):
    """Issue 9: a run killed by SIGKILL left a hidden .vrelab-*/record.h5.partial (~700 MB)
    forever. The staging folder's lock is held by its process; the next run in that folder
    removes the staging whose lock it can take (the owner is gone), and leaves a live one's alone."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "vrelab", *SIM, "--seconds", "400", "--record", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not list(tmp_path.glob(".vrelab-stage-*/*")) and time.monotonic() < deadline:
            time.sleep(0.1)
        stages = list(tmp_path.glob(".vrelab-stage-*"))
        assert stages, "the run never started staging"
        live = _io.remove_orphan_stages(tmp_path)
        assert live == [] and all(s.exists() for s in stages)  # its owner still runs
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    assert all(s.exists() for s in stages) and not out.exists()  # the kill left it, nothing landed
    assert main([*SIM, "--out", str(out)]) == 0
    assert not any(s.exists() for s in stages)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
