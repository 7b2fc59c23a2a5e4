"""Issue 23, the data-loss, process and disk rows: a user's files are never taken for vrelab's,
workers die with their run, a live run's staging is safe from another container's run, and a
full disk is one line with nothing left behind.

Each test reruns one row of the issue's table as the probe did (the command line, a real
subprocess and real signals for the process rows, a real full file system when one can be
mounted) and asserts what the issue asks for.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from vrelab import _io
from vrelab.cli import EXIT_DISK_FULL, main

SIM = ["simulate", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1", "--seconds", "2"]
PY = [sys.executable, "-m", "vrelab"]


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ----------------------------------------------------------------------------- a small campaign


def _records(folder: Path, n: int, seconds: float) -> Path:
    """A sine campaign of ``n`` runs, each its own record (the same simulated test with its
    run number in the file's metadata, so no two files are the same bytes)."""
    rec = folder / "rec"
    assert main(["simulate", "--sensor", "ideal", "--freq", "100", "--levels", "0.3,0.6", "--seconds", str(seconds),
                 "--record", "--out", str(rec)]) == 0
    runs = []
    for i in range(1, n + 1):
        f = folder / f"run{i}.h5"
        f.write_bytes((rec / "record.h5").read_bytes())
        with h5py.File(f, "a") as h:
            h.attrs["run"] = i
        runs.append(f'[[run]]\nfile = "{f.name}"\ndut = ["dut"]\nstatic_g = 1.0\n')  # the record's own baseline reads +1 g
    manifest = folder / "campaign.toml"
    manifest.write_text('name = "hardening"\n[defaults]\nreference = "reference"\n' + "".join(runs))
    return manifest


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _records(tmp_path_factory.mktemp("camp"), 2, 2.0)


@pytest.fixture(scope="module")
def slow_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A campaign the pool is busy with for several seconds (24 runs of 300 s; ~7 s with two
    workers on an idle 2-core machine, ~260 MB): long enough to be signalled mid-run. (8 runs of
    40 s took 1 s once the window pass stopped waking BLAS threads per block, and the signal then
    reached a finished command.)"""
    return _records(tmp_path_factory.mktemp("slowcamp"), 24, 300.0)


# ----------------------------------------------------------------------------- data loss


def test_a_folder_with_a_report_beside_the_users_files_is_refused(tmp_path, capsys):
    """Row 1: any report.html made the folder "vrelab's" and it was emptied (thesis.docx gone)."""
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "report.html").write_text("<html>my own report</html>")
    (mine / "thesis.docx").write_bytes(b"four years")
    before = _tree(mine)
    for cmd in (SIM, ["predict", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1"],
                ["demo", "--quick"]):
        assert main([*cmd, "--out", str(mine)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(mine) in err[0] and "thesis.docx" in err[0], err
    assert _tree(mine) == before and sorted(p.name for p in tmp_path.iterdir()) == ["thesis"]


def test_a_vrelab_folder_the_user_added_a_file_to_is_refused(tmp_path, capsys):
    out = tmp_path / "run"
    assert main([*SIM, "--out", str(out)]) == 0
    assert main(["report", str(out)]) == 0  # report.html is vrelab's: the folder stays replaceable
    assert main([*SIM, "--levels", "0.5", "--out", str(out)]) == 0
    (out / "notes.txt").write_text("mine")
    capsys.readouterr()
    assert main([*SIM, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "notes.txt" in err and "vrelab did not write" in err
    assert (out / "notes.txt").read_text() == "mine"


def test_report_does_not_overwrite_a_report_html_vrelab_did_not_write(tmp_path, capsys):
    out = tmp_path / "run"
    assert main([*SIM, "--out", str(out)]) == 0
    (out / "report.html").write_text("the user's")
    capsys.readouterr()
    assert main(["report", str(out)]) == 2
    assert "report.html exists and vrelab did not write it" in capsys.readouterr().err
    assert (out / "report.html").read_text() == "the user's"


def test_an_older_vrelab_folder_without_the_listing_marker(tmp_path, capsys):
    """Folders written before the marker listed its entries: accepted when every file carries
    a name vrelab writes (a channel's sub-folder included), refused otherwise."""
    old = tmp_path / "old"
    (old / "ch1").mkdir(parents=True)
    for f in ("results.json", "levels.csv", "report.html", "ch1/results.json", "ch1/envelope.csv"):
        (old / f).write_text("{}")
    (old / _io.MARKER).write_text("written by vrelab; a later run may replace this folder\n")  # the old text
    assert _io.stranger(old) is None
    (old / "ch1" / "fit.py").write_text("mine")
    assert _io.stranger(old) == "ch1/fit.py"
    assert main([*SIM, "--out", str(old)]) == 2
    assert "ch1/fit.py" in capsys.readouterr().err and (old / "ch1" / "fit.py").exists()
    (old / "ch1" / "fit.py").unlink()
    assert main([*SIM, "--out", str(old)]) == 0
    assert sorted(p.name for p in old.iterdir()) == [_io.MARKER, "levels.csv", "prediction.json", "results.json"]


def test_campaign_out_the_campaign_folder_is_refused(small_campaign, tmp_path, capsys):
    """Row 2: `campaign camp/campaign.toml --out camp` after a report was written into camp/
    deleted the manifest and every record."""
    camp = tmp_path / "camp"
    camp.mkdir()
    for f in small_campaign.parent.glob("*"):
        if f.is_file():
            (camp / f.name).write_bytes(f.read_bytes())
    (camp / "report.html").write_text("<html></html>")
    before = _tree(camp)
    manifest = camp / "campaign.toml"
    for out in (camp, tmp_path):  # the folder itself and a parent of it
        assert main(["campaign", str(manifest), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "an input of this run" in err[0] and str(out) in err[0], err
    assert _tree(camp) == before


def test_an_input_inside_a_vrelab_folder_is_not_replaced(tmp_path, capsys):
    """`simulate --record --out d; analyze d/record.h5 --out d` replaced d and lost the record."""
    d = tmp_path / "d"
    assert main([*SIM, "--record", "--out", str(d)]) == 0
    before = _tree(d)
    capsys.readouterr()
    assert main(["analyze", str(d / "record.h5"), "--dut", "dut", "--reference", "reference", "--out", str(d)]) == 2
    assert "record.h5, an input of this run" in capsys.readouterr().err
    assert _tree(d) == before


def test_identify_out_the_campaign_folder_is_refused(small_campaign, tmp_path, capsys):
    """Row 3: `identify campdir --out campdir` replaced the campaign's results."""
    campdir = tmp_path / "campdir"
    assert main(["campaign", str(small_campaign), "--out", str(campdir)]) == 0
    before = _tree(campdir)
    capsys.readouterr()
    for out in (campdir, tmp_path):
        assert main(["identify", str(campdir), "--base-sensor", "ideal", "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "an input of this run" in err[0], err
    assert _tree(campdir) == before
    # and a manifest's records count as inputs too
    assert main(["identify", str(small_campaign), "--base-sensor", "ideal", "--out", str(small_campaign.parent)]) == 2
    assert "an input of this run" in capsys.readouterr().err


def test_sweep_out_a_folder_of_the_users_is_refused(tmp_path, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "model"\n[grid]\nrms_g = [0.5, 1.0]\n')
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "result.csv").write_text("my numbers")
    (mine / "thesis.docx").write_text("x")
    rc = main(["sweep", str(spec), "--out", str(mine), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2 and "thesis.docx" in err, err
    assert (mine / "result.csv").read_text() == "my numbers" and not (mine / "checkpoint.jsonl").exists()
    assert main(["sweep", str(spec), "--out", str(tmp_path), "--no-progress"]) == 2  # holds the sweep file
    assert "an input of this run" in capsys.readouterr().err


# ----------------------------------------------------------------------------- processes


def _children(pid: int) -> list[int]:
    """Live descendants of ``pid`` from /proc (no psutil): every process whose parent chain
    reaches it."""
    parents: dict[int, int] = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
            except OSError:
                continue
            fields = stat.rsplit(")", 1)[1].split()
            if fields[0] != "Z":
                parents[int(d)] = int(fields[1])
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parents.items() if pp == p]
        out += kids
        todo += kids
    return out


def _cmdline(pid: int) -> bytes | None:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return None


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _start_campaign(manifest: Path, out: Path, sigint_ignored: bool = False) -> tuple[subprocess.Popen, list[int]]:
    """Start `campaign --workers 2` and return once its two workers are busy."""
    proc = subprocess.Popen([*PY, "campaign", str(manifest), "--workers", "2", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True, text=True,
                            preexec_fn=_ignore_sigint if sigint_ignored else None)
    deadline = time.monotonic() + 20
    kids: list[int] = []
    while time.monotonic() < deadline and proc.poll() is None:
        # the pool's workers are forks of the command (its own command line); a library's helper
        # process at import (ctypes.util.find_library runs ldconfig) is not, and signalling the
        # command then would hit it before it has installed its handlers
        kids = [k for k in _children(proc.pid) if _cmdline(k) == _cmdline(proc.pid)]
        if len(kids) >= 2:
            break
        time.sleep(0.02)
    if len(kids) < 2:
        proc.kill()
        pytest.fail(f"the campaign never had two workers (exit {proc.poll()})")
    time.sleep(0.3)  # the workers are reducing their first runs
    if proc.poll() is not None:
        pytest.fail(f"the campaign finished (exit {proc.returncode}) before it could be signalled: make the fixture longer")
    return proc, kids


def _gone(pids: list[int], within_s: float) -> list[int]:
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        left = [p for p in pids if _alive(p)]
        if not left:
            return []
        time.sleep(0.05)
    return [p for p in pids if _alive(p)]


def _signal(proc: subprocess.Popen, kids: list[int], send) -> tuple[str, list[int]]:
    """``send()`` a signal, wait for ``proc``; its stderr and the workers still alive 5 s later
    (any left are killed here, after being counted)."""
    try:
        send()
        _, err = proc.communicate(timeout=20)
        left = _gone(kids, 5.0)
    finally:
        for p in kids:
            if _alive(p):
                os.kill(p, signal.SIGKILL)
    return err, left


WANT = {signal.SIGTERM: (143, "vrelab: terminated"), signal.SIGINT: (130, "vrelab: interrupted")}


@pytest.mark.slow
@pytest.mark.timeout(60)
def test_sigkill_of_the_campaign_takes_its_workers(slow_campaign, tmp_path):
    """Row 'orphans': SIGKILL to `campaign --workers 2` left the workers running."""
    out = tmp_path / "out"
    proc, kids = _start_campaign(slow_campaign, out)
    _, left = _signal(proc, kids, lambda: os.kill(proc.pid, signal.SIGKILL))
    assert left == [], f"workers {left} outlived their parent"
    assert not out.exists()
    # the staging it left is the next run's to remove: its lock died with it
    stages = [p for p in tmp_path.glob(".vrelab-stage-*") if p.is_dir()]
    assert stages
    deadline = time.monotonic() + 5  # the kernel releases the dead processes' files promptly
    while _io.remove_orphan_stages(tmp_path) != stages and time.monotonic() < deadline:
        time.sleep(0.05)
    assert main([*SIM, "--out", str(tmp_path / "next")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["next"]


@pytest.mark.slow
@pytest.mark.timeout(60)
@pytest.mark.parametrize("how", ["SIGTERM", "SIGINT to the parent", "Ctrl-C (SIGINT to the process group)",
                                 "SIGINT, started with SIGINT ignored (a script's `vrelab ... &`)"])
def test_sigterm_and_ctrl_c_end_the_workers_and_the_staging(slow_campaign, tmp_path, how):
    """Row 'orphans': SIGTERM left the workers running; Ctrl-C exited 0 with the workers busy
    (started in the background of a script, the process inherits SIGINT ignored)."""
    out = tmp_path / "out"
    proc, kids = _start_campaign(slow_campaign, out, sigint_ignored="ignored" in how)
    sig = signal.SIGTERM if how == "SIGTERM" else signal.SIGINT
    send = os.killpg if how.startswith("Ctrl-C") else os.kill
    err, left = _signal(proc, kids, lambda: send(proc.pid, sig))
    assert (proc.returncode, err.strip()) == WANT[sig], err
    assert left == [], f"workers {left} outlived their parent"
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == []  # staging removed


@pytest.mark.slow
@pytest.mark.timeout(60)
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_sweeps_pool_ends_with_it_and_keeps_its_checkpoint(tmp_path, sig):
    """The sweep's process pool (its own backend) on SIGTERM/SIGINT: exit 143/130 at once (not
    after the running points), no worker left, the checkpoint kept for the resume."""
    (tmp_path / "hf_points.py").write_text("import time\ndef slow(params, seed):\n    time.sleep(0.4)\n"
                                           "    return {'a': float(params['x'])}\n")
    spec = tmp_path / "slow.toml"
    spec.write_text('kind = "python"\nfunction = "hf_points:slow"\nseed = 1\n[grid]\nx = "0:199:1"\n')
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([*PY, "sweep", str(spec), "--workers", "2", "--out", str(out), "--no-progress", "--allow-python"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    ck = out / "checkpoint.jsonl"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and not (ck.exists() and ck.read_text().count('"point"') >= 4):
        time.sleep(0.05)
    kids = _children(proc.pid)
    if len(kids) < 2:
        proc.kill()
        pytest.fail("the sweep never had its two workers")
    err, left = _signal(proc, kids, lambda: proc.send_signal(sig))
    assert (proc.returncode, err.strip()) == WANT[sig], err
    assert left == []
    assert ck.read_text().count('"point"') >= 4 and not (out / "result.nc").exists()
    assert _io.stranger(out) is None  # the folder stays the sweep's: the rerun resumes there


# ----------------------------------------------------------------------------- races


_HOLD = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR)
fcntl.flock(fd, fcntl.LOCK_EX)
print("locked", flush=True)
time.sleep(60)
"""


@pytest.mark.timeout(60)
def test_a_live_runs_staging_is_safe_from_a_run_in_another_pid_namespace(tmp_path):
    """Row 'races': a second run from another PID namespace (another container) in the same
    folder removed the live run's staging as "dead" (results.json named 420 run folders, runs/
    held 318). A process id says nothing across namespaces: here the staging's name carries a
    pid that does not exist in ours, as a run in another container's would, while its owner
    holds the lock. The next run must leave it; once the owner is gone, remove it."""
    out = tmp_path / "run"
    foreign = tmp_path / ".vrelab-stage-4194303-a1b2c3"  # pid_max: no such process here
    (foreign / "runs" / "01-a").mkdir(parents=True)
    (foreign / "runs" / "01-a" / "results.json").write_text("{}")
    lock = tmp_path / (foreign.name + ".lock")
    lock.write_text("")
    holder = subprocess.Popen([sys.executable, "-c", _HOLD, str(lock)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        assert main([*SIM, "--out", str(out)]) == 0
        assert (foreign / "runs" / "01-a" / "results.json").exists(), "the live run's staging was removed"
        assert _io.remove_orphan_stages(tmp_path) == []
    finally:
        holder.kill()
        holder.wait()
    assert _io.remove_orphan_stages(tmp_path) == [foreign]  # its owner is gone: its lock is free
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


@pytest.mark.slow
@pytest.mark.timeout(60)
def test_two_runs_into_one_folder_each_land_whole(tmp_path):
    """Two runs at once into the same --out: each stages under its own lock; the folder ends
    holding one of them whole (results.json and levels.csv of the same run)."""
    out = tmp_path / "run"
    procs = [subprocess.Popen([*PY, *SIM, "--levels", lv, "--out", str(out)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE, text=True) for lv in ("0.5", "1.5")]
    for p in procs:
        _, err = p.communicate(timeout=60)
        assert p.returncode == 0, err
    doc = json.loads((out / "results.json").read_text())
    levels = (out / "levels.csv").read_text().splitlines()
    assert len(doc["levels"]) == 1 and len(levels) == 2
    assert float(levels[1].split(",")[1]) == doc["levels"][0]["rms_g"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_staging_lock_is_taken_by_a_cleaner_only_when_free(tmp_path):
    """The lock, not a pid: the cleaner's non-blocking flock fails while the owner holds it
    (flock conflicts between open file descriptions, in one process as across processes)."""
    stage, fd = _io._new_stage(tmp_path)
    try:
        assert _io.remove_orphan_stages(tmp_path) == [] and stage.is_dir()
        other = os.open(tmp_path / (stage.name + ".lock"), os.O_RDWR)
        with pytest.raises(BlockingIOError):
            fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.close(other)
    finally:
        os.close(fd)  # the owner "dies": the kernel drops its lock
    assert _io.remove_orphan_stages(tmp_path) == [stage]
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- a full disk


@pytest.fixture
def tiny_disk(tmp_path):
    """A 1 MB tmpfs (where this process may mount one: root on Linux); else a folder whose
    writes fail with ENOSPC after 1 MB through a patched os.pwrite/os.write, in the
    subprocess only (vrelab._io.GuardedFile writes with os.pwrite)."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mnt)], capture_output=True)
    if r.returncode == 0:
        yield mnt, []
        subprocess.run(["umount", "-l", str(mnt)], check=False)
        return
    boot = tmp_path / "boot"
    boot.mkdir()
    (boot / "sitecustomize.py").write_text(
        "import errno, os\n"
        "_left = [1 << 20]\n"
        "def _wrap(f):\n"
        "    def g(fd, data, *a):\n"
        f"        if os.path.realpath(os.readlink(f'/proc/self/fd/{{fd}}')).startswith({str(mnt)!r}):\n"
        "            _left[0] -= len(data)\n"
        "            if _left[0] < 0:\n"
        "                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))\n"
        "        return f(fd, data, *a)\n"
        "    return g\n"
        "os.pwrite = _wrap(os.pwrite)\n"
    )
    yield mnt, [str(boot)]


@pytest.mark.timeout(60)
def test_a_full_disk_during_simulate_record_is_one_line_and_leaves_nothing(tiny_disk):
    """Row 'internal error': disk full during `simulate --record` was `RuntimeError: Can't close
    dataset`, exit 1 "internal error" (and HDF5 then crashed the interpreter at exit)."""
    mnt, extra_path = tiny_disk
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([*extra_path, os.environ.get("PYTHONPATH", "")]))
    out = mnt / "run"
    r = subprocess.run([*PY, *SIM, "--seconds", "8", "--record", "--out", str(out)], capture_output=True, text=True,
                       env=env, timeout=60)
    assert r.returncode == EXIT_DISK_FULL, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0] == (f"vrelab: error: no space left on device writing {out} "
                                            "(nothing was written; free space and run again)"), r.stderr
    assert list(mnt.iterdir()) == []  # no run folder, no staging, no lock, no partial record


def test_a_full_disk_in_any_writer_is_one_line(tmp_path, monkeypatch, capsys):
    """ENOSPC from a JSON or CSV writer (no HDF5): the same line, the same exit, nothing left."""
    def full(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(_io, "write_levels_table", full)
    out = tmp_path / "run"
    assert main([*SIM, "--out", str(out)]) == EXIT_DISK_FULL
    assert capsys.readouterr().err == (f"vrelab: error: no space left on device writing {out} "
                                       "(nothing was written; free space and run again)\n")
    assert list(tmp_path.iterdir()) == []


EXAMPLE_MANIFEST = Path(__file__).resolve().parent.parent / "examples" / "campaign" / "campaign.toml"


@pytest.mark.parametrize("fails", ["write", "mkdir"])
@pytest.mark.parametrize("command", ["analyze", "campaign"])
def test_no_room_for_the_staging_leaves_no_lock_file(tmp_path, monkeypatch, capsys, fails, command):
    """Issue 34, row 'leftover': on a disk with no room, `analyze --out` and `campaign --out`
    said exit 74 in one line but left the staging's `.vrelab-stage-....lock` in the parent (the
    lock file takes an inode, its pid line or the staging folder a block that is not there)."""
    def full(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    if fails == "mkdir":
        mkdir = Path.mkdir
        monkeypatch.setattr(Path, "mkdir", lambda self, *a, **k: full() if self.name.startswith(".vrelab-stage-")
                            else mkdir(self, *a, **k))
    else:
        write = os.write
        monkeypatch.setattr(_io.os, "write", lambda fd, data: full() if os.readlink(f"/proc/self/fd/{fd}").endswith(
            ".lock") else write(fd, data))
    out = tmp_path / "out"
    runs = EXAMPLE_MANIFEST.parent / "runs"
    args = (["analyze", str(runs / "01_z_up_80hz.tdms"), "--dut", "shaker/sn1_z", "--reference", "shaker/ref",
             "--reference-units", "mv", "--reference-sensitivity", "10", "--dut-units", "lsb",
             "--dut-sensitivity", "256000"] if command == "analyze" else ["campaign", str(EXAMPLE_MANIFEST)])
    assert main([*args, "--out", str(out)]) == EXIT_DISK_FULL
    assert capsys.readouterr().err == (f"vrelab: error: no space left on device writing {out} "
                                       "(nothing was written; free space and run again)\n")
    assert list(tmp_path.iterdir()) == []


def test_guarded_file_keeps_hdf5_whole_when_there_is_space(tmp_path):
    """The HDF5 writer's file reads back bit for bit (the guard only acts on a full disk)."""
    from vrelab.record import write_record_hdf5

    rng = np.random.default_rng(23)
    blocks = [{"dut": rng.standard_normal(70_000), "reference": rng.standard_normal(70_000)} for _ in range(3)]
    n = write_record_hdf5(tmp_path / "r.h5", 1000.0, iter(blocks))
    with h5py.File(tmp_path / "r.h5", "r") as f:
        assert n == 210_000 and f.attrs["fs_hz"] == 1000.0
        np.testing.assert_array_equal(f["dut"][:], np.concatenate([b["dut"] for b in blocks]))
