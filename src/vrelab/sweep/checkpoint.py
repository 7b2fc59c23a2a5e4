"""The checkpoint: an append-only JSON-lines file, one line per finished point, fsync'd.

A line is written only once its point is finished (or has failed for good), so after a crash or
a SIGKILL the file holds every finished point; at most the last line is torn, and reopening cuts
it off. Each start of a sweep appends a header line (``"type": "run"``) carrying the run number
and the fingerprint of the sweep file, so a resume against a changed file is refused, and every
point line names the run that computed it: a point computed twice shows up as two lines.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

CHECKPOINT_NAME = "checkpoint.jsonl"


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

    def to_line(self) -> str:
        # Python's json writes floats with repr, which round-trips exactly; NaN/inf are written
        # as the (non-standard) tokens that json reads back, since this file is ours alone.
        return json.dumps(
            {
                "type": "point",
                "i": self.index,
                "status": self.status,
                "values": self.values,
                "error": self.error,
                "attempts": self.attempts,
                "elapsed_s": self.elapsed_s,
                "cpu_s": self.cpu_s,
                "run": self.run,
            }
        )

    @classmethod
    def from_obj(cls, d: dict[str, Any]) -> "PointRecord":
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

    Holds an exclusive lock on the file while open, so two processes cannot append to the same
    sweep. ``records`` maps point index to its latest record; ``append`` writes and fsyncs.
    """

    def __init__(self, out_dir: str | Path, fingerprint: str, n_points: int, *, fresh: bool = False) -> None:
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
            self._load(fingerprint, n_points)
            self.run = self.runs + 1
            self._write(
                json.dumps(
                    {
                        "type": "run",
                        "run": self.run,
                        "fingerprint": fingerprint,
                        "n_points": n_points,
                        "started_unix_s": time.time(),
                        "pid": os.getpid(),
                    }
                )
            )
        except BaseException:
            self._fh.close()
            raise

    def _load(self, fingerprint: str, n_points: int) -> None:
        self._fh.seek(0)
        data = self._fh.read()
        good = data.rfind(b"\n") + 1
        if good < len(data):  # a torn last line from a kill mid-write: drop it
            self._fh.truncate(good)
        for lineno, line in enumerate(data[:good].splitlines(), 1):
            try:
                obj = json.loads(line)
            except json.JSONDecodeError:
                raise ValueError(f"checkpoint {self.path} line {lineno} is corrupt; rerun with --fresh") from None
            if obj.get("type") == "run":
                if obj.get("fingerprint") != fingerprint or obj.get("n_points") != n_points:
                    raise ValueError(
                        f"checkpoint {self.path} belongs to a different sweep (the file changed); "
                        "rerun with --fresh or another --out"
                    )
                self.runs = max(self.runs, int(obj["run"]))
            elif obj.get("type") == "point":
                rec = PointRecord.from_obj(obj)
                self.records[rec.index] = rec
                self.n_lines += 1

    def _write(self, line: str) -> None:
        self._fh.write(line.encode() + b"\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, records: list[PointRecord]) -> None:
        """Write finished points (one fsync for the lot: a chunk lands together)."""
        if not records:
            return
        self._fh.write(b"".join(r.to_line().encode() + b"\n" for r in records))
        self._fh.flush()
        os.fsync(self._fh.fileno())
        for r in records:
            self.records[r.index] = r
        self.n_lines += len(records)

    def close(self) -> None:
        if not self._fh.closed:
            fcntl.flock(self._fh.fileno(), fcntl.LOCK_UN)
            self._fh.close()

    def __enter__(self) -> "Checkpoint":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
