"""Output helpers: files are written completely or not at all."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

# Every output folder vrelab writes holds this file, so a later run may replace the folder
# (and never a folder of the user's that merely has the same name).
MARKER = ".vrelab-output"
_STAGE_PREFIX = ".vrelab-stage-"


# Files only vrelab writes: a folder holding one came from an earlier version (before MARKER).
_OUR_FILES = ("results.json", "report.html", "summary.json", "result.nc")


def _ours(folder: Path) -> bool:
    """An empty folder, or one vrelab wrote (its marker, or a file only vrelab writes)."""
    entries = [p for p in folder.iterdir() if not p.name.startswith(_STAGE_PREFIX)]
    return not entries or (folder / MARKER).exists() or any((folder / n).is_file() for n in _OUR_FILES)


def _owner_alive(stage: Path) -> bool:
    """Whether the process that made a staging folder (``.vrelab-stage-<pid>-...``) still runs."""
    try:
        pid = int(stage.name[len(_STAGE_PREFIX):].split("-", 1)[0])
    except ValueError:
        return True  # not ours to judge
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return pid != 0


def remove_orphan_stages(folder: Path) -> list[Path]:
    """Remove staging folders left in ``folder`` by runs that were killed (SIGKILL, a batch
    scheduler's timeout, a container stop): those whose process is gone. Returns what it removed."""
    removed = []
    if not folder.is_dir():
        return removed
    for stage in folder.glob(_STAGE_PREFIX + "*"):
        if stage.is_dir() and not stage.is_symlink() and not _owner_alive(stage):
            shutil.rmtree(stage, ignore_errors=True)
            removed.append(stage)
    return removed


@contextmanager
def output_dir(path: str | Path, replace: bool = True) -> Iterator[Path]:
    """Yield a staging folder; on success it becomes ``path``, on failure nothing changes.

    ``replace=True`` (a run's results): the folder afterwards holds exactly this run's files.
    An existing ``path`` is replaced only when it is empty or a vrelab output folder (it holds
    :data:`MARKER`); any other folder is refused, never emptied. ``replace=False`` (a sweep,
    whose checkpoint lives beside its results): new files are moved in, same-named ones
    replaced, others left alone.

    Staging happens beside ``path`` (same file system: the final step is a rename), or inside
    it when its parent is read-only. Staging folders whose process is gone (a run killed by
    SIGKILL) are removed first, in both places.
    """
    dest = Path(path)
    if dest.exists() and not dest.is_dir():
        raise ValueError(f"output path exists and is not a folder: {dest}")
    if replace and dest.is_dir() and not _ours(dest):
        raise ValueError(
            f"output folder {dest} exists and is not a vrelab output folder (no {MARKER}): "
            "choose a new or empty folder, so nothing of yours is overwritten"
        )
    parent = dest.parent
    parent.mkdir(parents=True, exist_ok=True)
    remove_orphan_stages(parent)
    remove_orphan_stages(dest)
    beside = os.access(parent, os.W_OK | os.X_OK)
    if not beside:
        dest.mkdir(exist_ok=True)
    where = parent if beside else dest
    stage = Path(tempfile.mkdtemp(prefix=f"{_STAGE_PREFIX}{os.getpid()}-", dir=where))
    try:
        yield stage
        (stage / MARKER).write_text("written by vrelab; a later run may replace this folder\n")
        if replace and beside:
            old = None
            if dest.exists():
                old = Path(tempfile.mkdtemp(prefix=f"{_STAGE_PREFIX}{os.getpid()}-old-", dir=parent))
                os.replace(dest, old / "x")
            os.replace(stage, dest)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
            return
        dest.mkdir(exist_ok=True)
        new = {item.name for item in stage.iterdir()}
        if replace:  # staging inside dest (read-only parent): drop what the new run does not have
            for item in dest.iterdir():
                if item != stage and item.name not in new:
                    shutil.rmtree(item) if item.is_dir() and not item.is_symlink() else item.unlink()
        for item in stage.iterdir():
            target = dest / item.name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(item, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def sha256_file(path: str | Path) -> str:
    """SHA-256 of a file, streamed (read in chunks, never whole: records can exceed memory)."""
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def write_json(path: str | Path, obj: Any) -> None:
    """Write JSON atomically (temporary file + rename)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    with open(tmp, "w") as fh:
        json.dump(obj, fh, indent=2, allow_nan=False)
        fh.write("\n")
    os.replace(tmp, path)


LEVELS_CSV_COLUMNS = (
    "freq_hz", "rms_g", "u_rms_g", "vre_g", "u_vre_g", "duration_s", "n_samples", "n_saturated", "flags",
)


def write_levels_csv(path: str | Path, result: Any) -> None:
    """``levels.csv``: one row per level of a ``VreResult``, the numbers of ``results.json``.

    The one layout shared by ``simulate --out``, ``analyze --out`` and the demo. Floats are
    written with ``repr`` so they read back bit for bit; unknown values are empty cells.
    """
    write_levels_table(path, [({}, result)])


def write_levels_table(path: str | Path, groups: Sequence[tuple[Mapping[str, Any], Any]]) -> None:
    """Levels of several results in one CSV: each group's leading columns (``channel``,
    ``run``, ...: the keys of the first group, in order) then :data:`LEVELS_CSV_COLUMNS`."""
    import csv

    def cell(x: Any) -> str:
        return "" if x is None else repr(float(x))

    lead = list(groups[0][0]) if groups else []
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(lead + list(LEVELS_CSV_COLUMNS))
        for keys, result in groups:
            first = ["" if keys.get(k) is None else str(keys.get(k)) for k in lead]
            for lv in result.levels:
                w.writerow(first + [
                    cell(lv.freq_hz), cell(lv.rms_g), cell(lv.u_rms_g), cell(lv.vre.value), cell(lv.vre.u),
                    cell(lv.duration_s), "" if lv.n_samples is None else lv.n_samples, lv.n_saturated,
                    ";".join(lv.flags),
                ])  # fmt: skip
    os.replace(tmp, path)
