"""Sweeps that must not reuse stale or corrupt work (issue 9): referenced files in the
fingerprint, a checkpoint's bad lines quarantined, a scheduler address that is not one, and a
resume with nothing left to compute."""

from __future__ import annotations

import json
import socket
import threading
from pathlib import Path

import pytest

from vrelab.cli import main
from vrelab.sweep import load_spec, run_sweep
from vrelab.sweep.checkpoint import CHECKPOINT_NAME, QUARANTINE_NAME, _line_sum

pytestmark = pytest.mark.timeout(120)

MODEL = """kind = "model"
seed = 1
[fixed]
static_g = 1.0
[grid]
rms_g = [0.5, 1.0, 1.5, 2.0]
"""


def test_an_edited_sensor_file_is_named_on_resume(tmp_path, capsys):
    """Issue 9: a sweep resumed after editing the sensor file it references reused old values."""
    sensor = tmp_path / "part.toml"
    sensor.write_text('schema = 1\nname = "part"\nk2_ug_per_g2 = 100.0\n')
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'kind = "predict"\n[fixed]\nsensor = "{sensor}"\nfreq_hz = 100.0\nstatic_g = 0.0\n'
                     '[grid]\nrms_g = [0.1, 0.2]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(sweep), "--out", str(out), "--no-progress"]) == 0
    sensor.write_text('schema = 1\nname = "part"\nk2_ug_per_g2 = 900.0\n')
    capsys.readouterr()
    assert main(["sweep", str(sweep), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"{sensor} changed since the checkpoint was written" in err and "--fresh" in err
    assert main(["sweep", str(sweep), "--out", str(out), "--no-progress", "--fresh", "--json"]) == 0
    vre = [p["vre_g"] for p in json.loads(capsys.readouterr().out)["points"]]
    assert vre == pytest.approx([900e-6 * 0.01, 900e-6 * 0.04], rel=1e-9)  # k2·rms² (SPEC 1.2), the new k2


def test_bad_checkpoint_lines_are_quarantined_and_only_their_points_recomputed(tmp_path):
    """Issue 9: a line `[1,2,3]`, `null`, no "i", "i": -1, "i" beyond the grid or an edited value
    gave tracebacks, "41/40 points ok" or silently used edits; one bad line forced --fresh."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    spec = load_spec(spec_path)
    out = tmp_path / "out"
    first = run_sweep(spec, out)
    truth = first.dataset["vre_g"].values.copy()
    ck = out / CHECKPOINT_NAME
    lines = ck.read_text().splitlines()
    points = [ln for ln in lines if json.loads(ln)["type"] == "point"]
    edited = json.loads(points[2])
    edited["values"]["vre_g"] = 123.0  # a hand edit, its checksum now wrong
    junk = ["[1, 2, 3]", "null", json.dumps({"type": "point", "status": "ok", "values": {}}),
            json.dumps({**json.loads(points[0]), "i": -1}), json.dumps({**json.loads(points[0]), "i": 99})]
    ck.write_text("\n".join([ln for ln in lines if ln != points[2]] + [json.dumps(edited)] + junk) + "\n")
    again = run_sweep(spec, out)
    s = again.summary
    assert (s["n_ok"], s["n_points"], s["n_computed"], s["n_quarantined"]) == (4, 4, 1, 6)
    assert again.dataset["vre_g"].values.tolist() == truth.tolist()  # the edit was not used
    q = [json.loads(ln) for ln in (out / QUARANTINE_NAME).read_text().splitlines()]
    assert {w["why"].split(" (")[0] for w in q} >= {"checksum mismatch", "not a JSON object", "no point index"}
    assert run_sweep(spec, out).summary["n_quarantined"] == 0  # the checkpoint is clean again


def test_a_checkpoint_of_an_older_vrelab_is_refused_in_one_line(tmp_path, capsys):
    """Issue 30 (integrity): lines of a checkpoint written before lines named their points cannot
    be checked against the grid; the resume says to start afresh instead of trusting indices."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    out = tmp_path / "out"
    assert main(["sweep", str(spec_path), "--out", str(out), "--no-progress"]) == 0
    ck = out / CHECKPOINT_NAME
    rows = [json.loads(ln) for ln in ck.read_text().splitlines()]
    # the previous format: no "format" in the run header, no "point" in the point lines
    old = [{k: v for k, v in r.items() if k not in ("format", "point", "sum")} for r in rows]
    for r in old:
        if r["type"] == "point":
            r["sum"] = _line_sum(r)
    ck.write_text("".join(json.dumps(r) + "\n" for r in old))
    capsys.readouterr()
    assert main(["sweep", str(spec_path), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "older vrelab" in err and "--fresh" in err
    assert main(["sweep", str(spec_path), "--out", str(out), "--no-progress", "--fresh"]) == 0


def _rewrite(ck, edit):
    """Apply ``edit`` to each point line (a dict) of checkpoint ``ck`` and recompute its checksum,
    as a tool that knows the format would."""
    rows = [json.loads(ln) for ln in ck.read_text().splitlines()]
    for r in rows:
        if r["type"] == "point":
            edit(r)
            r["sum"] = _line_sum(r)
    ck.write_text("".join(json.dumps(r) + "\n" for r in rows))


def test_a_line_relabelled_to_another_point_is_quarantined(tmp_path):
    """Issue 30 (integrity): a point line whose index was changed to another point's, its checksum
    recomputed, went into result.csv as that other point. Its identity (a digest of the point's
    parameters and seed, derived from the sweep file) now names the wrong point."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    spec = load_spec(spec_path)
    out = tmp_path / "out"
    truth = run_sweep(spec, out).dataset["vre_g"].values.tolist()
    ck = out / CHECKPOINT_NAME
    _rewrite(ck, lambda r: r.update(i=(r["i"] + 1) % 4))  # every line now claims its neighbour's point
    again = run_sweep(spec, out)
    s = again.summary
    assert (s["n_quarantined"], s["n_computed"], s["n_ok"]) == (4, 4, 4)
    assert {q["why"].split(" (")[0] for q in s["quarantined"]} == {f"not point {i} of this grid" for i in range(4)}
    # each VRE is its own point's (k2·rms², distinct per rms), as computed the first time
    assert again.dataset["vre_g"].values.tolist() == truth


def test_a_line_without_its_checksum_or_identity_is_quarantined(tmp_path):
    """Removing the checksum (or the identity) is an edit: a checkpoint of this format always has
    both, so neither key's absence lets an edited line past the checks."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    spec = load_spec(spec_path)
    out = tmp_path / "out"
    run_sweep(spec, out)
    ck = out / CHECKPOINT_NAME
    rows = [json.loads(ln) for ln in ck.read_text().splitlines()]
    points = [r for r in rows if r["type"] == "point"]
    points[0]["values"]["vre_g"] = 123.0
    del points[0]["sum"]
    del points[1]["point"]
    points[1]["sum"] = _line_sum(points[1])
    ck.write_text("".join(json.dumps(r) + "\n" for r in rows))
    s = run_sweep(spec, out).summary
    assert (s["n_quarantined"], s["n_computed"]) == (2, 2)
    whys = sorted(q["why"].split(" (")[0] for q in s["quarantined"])
    assert whys == ["no checksum", "not point 1 of this grid"]


def test_an_edit_with_its_checksum_recomputed_is_tampering_the_readme_names(tmp_path):
    """The checksum finds damage, not tampering: a value edited by someone who recomputes the
    checksum and keeps the identity is taken (nothing in the file can tell), and the tour's
    sweep paragraph (docs/tour.md) says so."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    spec = load_spec(spec_path)
    out = tmp_path / "out"
    run_sweep(spec, out)
    _rewrite(out / CHECKPOINT_NAME, lambda r: r["values"].update(vre_g=123.0))
    assert set(run_sweep(spec, out).dataset["vre_g"].values.tolist()) == {123.0}
    readme = " ".join((Path(__file__).parents[1] / "docs" / "tour.md").read_text().split())
    assert "The checksum finds damage, not tampering" in readme


class _Impostor:
    """A loopback TCP server that speaks something else than Dask (an SSH banner), bounded."""

    def __init__(self, banner: bytes) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(4)
        self.sock.settimeout(0.2)
        self.banner = banner
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"

    def _serve(self) -> None:
        conns = []
        for _ in range(600):  # at most 2 minutes
            if self.stop.is_set():
                break
            try:
                c, _ = self.sock.accept()
                c.sendall(self.banner)
                conns.append(c)
            except OSError:
                continue
        for c in conns:
            c.close()
        self.sock.close()


@pytest.mark.parametrize("banner", [b"SSH-2.0-OpenSSH_9.6\r\n", b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello"])
def test_a_scheduler_address_that_is_not_dask_is_one_line_exit_2(tmp_path, capsys, banner):
    """Issue 9: an SSH port gave "Unable to allocate 2.82 EiB" as a traceback; an HTTP port hung."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    server = _Impostor(banner)
    try:
        rc = main(["sweep", str(spec_path), "--out", str(tmp_path / "out"), "--scheduler", server.address, "--no-progress"])
    finally:
        server.stop.set()
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "no Dask scheduler answered" in err and "Traceback" not in err


def test_a_resume_with_nothing_left_says_so_and_connects_nowhere(tmp_path, capsys):
    """Issue 9: resuming a finished sweep with --scheduler reported "on serial"."""
    spec_path = tmp_path / "s.toml"
    spec_path.write_text(MODEL)
    out = tmp_path / "out"
    assert main(["sweep", str(spec_path), "--out", str(out), "--no-progress"]) == 0
    capsys.readouterr()
    # an address nobody listens on: connecting would fail, so success proves no connection
    assert main(["sweep", str(spec_path), "--out", str(out), "--scheduler", "tcp://127.0.0.1:9", "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "nothing computed: every point came from the checkpoint" in text and "serial" not in text
