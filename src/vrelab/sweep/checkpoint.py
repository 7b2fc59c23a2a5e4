"""The checkpoint: an append-only JSON-lines file, one line per finished point, fsync'd.

A line is written only once its point is finished (or has failed for good), so after a crash or
a SIGKILL the file holds every finished point; at most the last line is torn, and reopening cuts
it off. Each start of a sweep appends a header line (``"type": "run"``) carrying the run number
and the fingerprint of the sweep file, so a resume against a changed file is refused, and every
point line names the run that computed it: a point computed twice shows up as two lines.

Every point line carries a checksum (finds damage, not tampering: whoever can edit the file can
recompute it) and its point's identity (:meth:`vrelab.sweep.spec.SweepSpec.point_key`, a digest
of the point's parameters and seed), checked against the grid on resume: a line relabelled to
another index names the wrong point and is quarantined. A checkpoint of an older vrelab (run
headers without ``format``) is refused whole: its lines name no point, and an index alone cannot
show that a line is the point it claims.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Literal

from vrelab._load import json_loads

CHECKPOINT_NAME = "checkpoint.jsonl"
QUARANTINE_NAME = "checkpoint.quarantine.jsonl"
_STATUSES = ("ok", "failed")
FORMAT = 2  # run headers carry it from the version whose point lines carry their point's identity


def _line_sum(obj: dict[str, Any]) -> str:
    """Checksum of a point line: SHA-256 of its canonical JSON without the ``sum`` key (16 hex)."""
    body = {k: v for k, v in obj.items() if k != "sum"}
    return hashlib.sha256(json.dumps(body, sort_keys=True).encode()).hexdigest()[:16]


@dataclass(frozen=True)
class PointRecord:
    """The outcome of one point: its values, or the error that stopped it after its retries."""

    index: int
    status: Literal["ok", "failed"]
    values: dict[str, float] = field(default_factory=dict)
    error: str | None = None
    attempts: int = 1
    elapsed_s: float = math.nan  # wall time in the point function
    run: int = 0
    cpu_s: float = math.nan  # CPU time of the worker process in it: far below elapsed_s = starved

    def to_line(self, point: str) -> str:
        """The line of this record, ``point`` the identity of its point on the grid."""
        # Python's json writes floats with repr, which round-trips exactly; NaN/inf are written
        # as the (non-standard) tokens that json reads back, since this file is ours alone. The
        # line carries its own checksum, so an edit by hand is found on resume.
        obj: dict[str, Any] = {
            "type": "point",
            "i": self.index,
            "point": point,
            "status": self.status,
            "values": self.values,
            "error": self.error,
            "attempts": self.attempts,
            "elapsed_s": self.elapsed_s,
            "cpu_s": self.cpu_s,
            "run": self.run,
        }
        obj["sum"] = _line_sum(obj)
        return json.dumps(obj)

    @classmethod
    def from_obj(cls, d: dict[str, Any]) -> PointRecord:
        return cls(
            index=int(d["i"]),
            status=d["status"],
            values={k: float(v) for k, v in d["values"].items()},
            error=d.get("error"),
            attempts=int(d.get("attempts", 1)),
            elapsed_s=float(d.get("elapsed_s", math.nan)),
            run=int(d.get("run", 0)),
            cpu_s=float(d.get("cpu_s", math.nan)),
        )


class Checkpoint:
    """Open (or create) ``DIR/checkpoint.jsonl`` for a sweep with ``fingerprint`` and ``n_points``.

    ``point_key(i)`` is the identity of point ``i`` on the sweep's grid, written into each point
    line and checked on resume. Holds an exclusive lock on the file while open, so two processes
    cannot append to the same sweep. ``records`` maps point index to its latest record;
    ``append`` writes and fsyncs.
    """

    def __init__(self, out_dir: str | Path, fingerprint: str, n_points: int, point_key: Callable[[int], str], *,
                 fresh: bool = False, inputs: dict[str, str] | None = None) -> None:
        self.point_key = point_key
        self.path = Path(out_dir) / CHECKPOINT_NAME
        self.path.parent.mkdir(parents=True, exist_ok=True)
        created = not self.path.exists()
        self._fh = open(self.path, "a+b")
        if created:  # the new file's name must survive a crash too, not only its lines
            dir_fd = os.open(self.path.parent, os.O_RDONLY)
            try:
                os.fsync(dir_fd)
            finally:
                os.close(dir_fd)
        try:
            fcntl.flock(self._fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._fh.close()
            raise ValueError(f"another sweep is running with the checkpoint {self.path}") from None
        try:
            if fresh:
                self._fh.truncate(0)
            self.records: dict[int, PointRecord] = {}
            self.runs = 0
            self.n_lines = 0  # point lines, duplicates included: counts evaluations
            self.quarantined: list[tuple[int, bytes, str]] = []
            self._load(fingerprint, n_points, inputs)
            self.run = self.runs + 1
            self._write(
                json.dumps(
                    {
                        "type": "run",
                        "format": FORMAT,
                        "run": self.run,
                        "fingerprint": fingerprint,
                        "n_points": n_points,
                        "inputs": dict(inputs or {}),
                        "started_unix_s": time.time(),
                        "pid": os.getpid(),
                    }
                )
            )
        except BaseException:
            self._fh.close()
            raise

    def _load(self, fingerprint: str, n_points: int, inputs: dict[str, str] | None = None) -> None:
        """Read the lines: run headers must match the sweep; a point line that is not one of
        this sweep's (not JSON, not an object, no or a foreign index, an edited value caught by
        its checksum, no checksum, a point identity that is not its index's on this grid) is
        quarantined: moved to ``checkpoint.quarantine.jsonl`` and its point recomputed, while
        every good line is kept. A checkpoint of an older vrelab (a run header without
        ``format``) is refused with one line: its lines carry no point identity, so nothing
        shows that a line is the point its index names (the relabelled line this check exists
        for passes an index check), and quarantining them all would recompute the whole sweep
        anyway, less plainly than starting afresh."""
        self._fh.seek(0)
        data = self._fh.read()
        good = data.rfind(b"\n") + 1
        if good < len(data):  # a torn last line from a kill mid-write: drop it
            self._fh.truncate(good)
        kept: list[bytes] = []
        bad: list[tuple[int, bytes, str]] = []
        for lineno, line in enumerate(data[:good].splitlines(), 1):
            why = None
            try:
                obj = json_loads(line, "checkpoint line")
            except ValueError:  # not JSON (UnicodeDecodeError is one too), or nested beyond the budget
                obj, why = None, "not JSON"
            if why is None and not isinstance(obj, dict):
                why = f"not a JSON object ({type(obj).__name__})"
            if why is None and obj.get("type") == "run":
                if obj.get("fingerprint") != fingerprint or obj.get("n_points") != n_points:
                    raise ValueError(f"checkpoint {self.path} belongs to a different sweep: {_what_changed(obj, inputs)}; "
                                     "rerun with --fresh or another --out")
                if obj.get("format") != FORMAT:
                    raise ValueError(f"checkpoint {self.path} was written by an older vrelab: its lines do not name "
                                     "their points, so a resume cannot check them against the grid; "
                                     "rerun with --fresh or another --out")
                self.runs = max(self.runs, int(obj["run"]))
                kept.append(line)
                continue
            if why is None:
                why = _bad_point(obj, n_points, self.point_key)
            if why is not None:
                bad.append((lineno, line, why))
                continue
            rec = PointRecord.from_obj(obj)
            self.records[rec.index] = rec
            self.n_lines += 1
            kept.append(line)
        self.quarantined = bad
        if bad:
            qpath = self.path.with_name(QUARANTINE_NAME)
            with open(qpath, "ab") as q:
                for lineno, line, why in bad:
                    q.write(json.dumps({"line": lineno, "why": why, "text": line.decode("utf-8", "replace")}).encode() + b"\n")
                q.flush()
                os.fsync(q.fileno())
            self._fh.seek(0)
            self._fh.truncate(0)
            self._fh.write(b"".join(k + b"\n" for k in kept))
            self._fh.flush()
            os.fsync(self._fh.fileno())

    def _write(self, line: str) -> None:
        self._fh.write(line.encode() + b"\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, records: list[PointRecord]) -> None:
        """Write finished points (one fsync for the lot: a chunk lands together)."""
        if not records:
            return
        self._fh.write(b"".join(r.to_line(self.point_key(r.index)).encode() + b"\n" for r in records))
        self._fh.flush()
        os.fsync(self._fh.fileno())
        for r in records:
            self.records[r.index] = r
        self.n_lines += len(records)

    def close(self) -> None:
        if not self._fh.closed:
            fcntl.flock(self._fh.fileno(), fcntl.LOCK_UN)
            self._fh.close()

    def __enter__(self) -> Checkpoint:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _bad_point(obj: dict[str, Any], n_points: int, point_key: Callable[[int], str]) -> str | None:
    """Why a point line is not one of this sweep's, or None."""
    if obj.get("type") != "point":
        return f"unknown line type {obj.get('type')!r}"
    i = obj.get("i")
    if isinstance(i, bool) or not isinstance(i, int):
        return f"no point index (i = {i!r})"
    if not 0 <= i < n_points:
        return f"point index {i} outside the sweep's 0..{n_points - 1}"
    if obj.get("status") not in _STATUSES or not isinstance(obj.get("values"), dict):
        return "no status or values"
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in obj["values"].values()):
        return "a value is not a number"
    if "sum" not in obj:  # a line of this format always has one: removing it is an edit
        return "no checksum (the line was edited)"
    if obj["sum"] != _line_sum(obj):
        return "checksum mismatch (the line was edited)"
    if obj.get("point") != point_key(i):
        return f"not point {i} of this grid (its point identity is another's: relabelled, or from another grid)"
    return None


def _what_changed(header: dict[str, Any], inputs: dict[str, str] | None) -> str:
    """Name the input file whose content changed since the checkpoint's run, if one did."""
    before = header.get("inputs") or {}
    for name, digest in (inputs or {}).items():
        if name in before and before[name] != digest:
            return f"{name} changed since the checkpoint was written"
    return "the sweep file changed"
