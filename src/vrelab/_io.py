"""Output helpers: files are written completely or not at all, and only into folders of ours.

The rules, owned here and nowhere else:

* **Whose folder.** Every output folder vrelab writes holds :data:`MARKER`, a JSON file naming
  what wrote it and every entry (file and sub-folder, relative path) it wrote. A later run may
  replace the folder only when it is empty, or when its marker names every entry it holds:
  a file the user put there (``thesis.docx``), or a ``report.html`` that vrelab did not write,
  makes it someone else's folder and the run is refused with one line, the folder untouched.
  Folders written before the marker listed its entries (no marker, or a marker without
  ``entries``) are accepted only when every file in them, at any depth, has a name vrelab
  writes (:data:`vrelab.folder.KNOWN_NAMES`) and one of them is a results file: a user's
  folder holds something else, and is refused.
* **Never an input.** A folder that holds an input of the same run (a record, the manifest,
  a campaign folder, a sensor or profile file), compared by resolved path, is refused whatever
  else it holds: replacing it would delete what the run reads.
* **Staging.** A run writes into a staging folder beside its output and renames it into place
  at the end. Its owner holds an ``fcntl.flock`` on a lock file of the same name + ``.lock``
  for as long as the staging exists; the kernel drops the lock when the owner dies, however
  (SIGKILL, a container stop). A later run removes a staging folder only when it can take that
  lock: a process id would say nothing about a run in another PID namespace (another
  container sharing the folder), which the pid check removed as "dead" while it was writing.
* **A full disk** (``ENOSPC``/``EDQUOT``, raised by Python or by HDF5) is :class:`DiskFull`:
  one line naming the folder, the staging removed, nothing of the run left behind.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import math
import os
import secrets
import shutil
import time
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Iterator, Mapping, Sequence

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer, WriteableBuffer

    from vrelab.results import LevelResult, VreResult

try:
    import fcntl
except ImportError:  # not POSIX (Windows): no locks, so staging folders are never taken for dead
    fcntl = None  # type: ignore[assignment]

MARKER = ".vrelab-output"
_STAGE_PREFIX = ".vrelab-stage-"
_LOCK_SUFFIX = ".lock"
_OLD_SUFFIX = ".old"
# A staging folder without a lock file was made by a vrelab from before the locks; it is
# removed once nothing has touched it for this long (its run cannot still be writing).
LEGACY_STAGE_AGE_S = 24 * 3600.0
_FULL = (errno.ENOSPC, errno.EDQUOT)


class DiskFull(OSError):
    """No space left on the device (or quota) while writing an output; nothing was left behind."""


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` is a full disk or quota: an ``OSError`` with ``ENOSPC``/``EDQUOT``, or an
    error of a C library (HDF5 raises ``RuntimeError("Can't close dataset ... errno = 28 ...")``)
    whose text carries that errno."""
    if isinstance(exc, OSError) and exc.errno in _FULL:
        return True
    text = str(exc)
    return any(f"errno = {e}," in text for e in _FULL) or "No space left on device" in text or "Disk quota exceeded" in text


def disk_full_error(where: str | Path) -> DiskFull:
    return DiskFull(errno.ENOSPC, f"no space left on device writing {where} (nothing was written; free space and run again)")


def existing_paths(values: Iterable[Any]) -> list[Path]:
    """The values that name an existing file or folder (options such as ``--sensor adxl355`` or
    ``--profile flat:20-2000`` name no path and are skipped): a run's inputs, for
    :func:`check_output`."""
    out = []
    for v in values:
        if isinstance(v, (str, Path)) and str(v):
            try:
                if Path(v).exists():
                    out.append(Path(v))
            except (OSError, ValueError):
                continue
    return out


# --------------------------------------------------------------------------- whose folder


def _entries(folder: Path) -> Iterator[tuple[str, Path]]:
    """Every entry below ``folder`` as (relative path with ``/``, path), without descending
    into symbolic links; staging folders and their locks at the top are vrelab's own."""
    for root, dirs, files in os.walk(folder):
        rel_root = Path(root).relative_to(folder)
        if root == str(folder):
            dirs[:] = [d for d in dirs if not d.startswith(_STAGE_PREFIX)]
            files = [f for f in files if not f.startswith(_STAGE_PREFIX) and f != MARKER]
        for name in sorted(dirs) + sorted(files):
            yield (rel_root / name).as_posix(), Path(root) / name


def _marker(folder: Path) -> dict[str, Any] | None:
    """The marker's document; ``{}`` for a marker of an older vrelab (plain text), None if none."""
    f = folder / MARKER
    if not f.is_file() or f.is_symlink():
        return None
    try:
        doc = json.loads(f.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, OSError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _legacy_stranger(folder: Path) -> str | None:
    """For a folder without a marker listing its entries (written before the lists existed):
    the first entry that vrelab would not have written, or None. A file must carry a name of
    :data:`vrelab.folder.KNOWN_NAMES`; a sub-folder (a channel's, a run's) may be named
    anything but must itself hold only such files; a symbolic link is never ours. And one
    results file must be at the top, so that a folder of the user's holding, say, only a
    ``levels.csv`` of their own is not taken."""
    from vrelab._names import KNOWN_NAMES, OPAQUE_DIRS, RESULT_FILES

    for rel, path in _entries(folder):
        if "/" in rel and rel.split("/", 1)[0] in OPAQUE_DIRS:
            continue
        if path.is_symlink() or (not path.is_dir() and path.name not in KNOWN_NAMES):
            return rel
    if not any((folder / n).is_file() for n in RESULT_FILES):
        return "(no vrelab results file)"
    return None


def stranger(folder: str | Path) -> str | None:
    """The first entry of an existing folder that vrelab did not write (relative path), or
    None when the folder is empty or every entry is vrelab's (see the module's rules)."""
    folder = Path(folder)
    if not any(True for _ in _entries(folder)):
        return None
    doc = _marker(folder)
    listed = doc.get("entries") if doc else None
    if isinstance(listed, list):
        known = {str(e) for e in listed}
        for rel, path in _entries(folder):
            if rel not in known or path.is_symlink():
                return rel
        return None
    return _legacy_stranger(folder)


def check_output(path: str | Path, inputs: Iterable[str | Path] = ()) -> None:
    """Refuse (``ValueError``, one line naming the folder and why) an output folder that holds
    an input of this run, is not a folder, or holds anything vrelab did not write. An empty or
    missing folder is fine. Nothing is changed."""
    dest = Path(path)
    if dest.exists() and not dest.is_dir():
        raise ValueError(f"output path exists and is not a folder: {dest}")
    where = dest.resolve()
    for p in existing_paths(inputs):
        rp = p.resolve()
        if rp == where:
            raise ValueError(f"output folder {dest} is an input of this run: writing there would replace it; "
                             "choose another folder")
        if where in rp.parents:
            raise ValueError(
                f"output folder {dest} holds {p}, an input of this run: writing there would replace it; "
                "choose another folder"
            )
        # an output folder inside an input folder is fine: it adds a sub-folder, replaces nothing
    if dest.is_dir():
        who = stranger(dest)
        if who is not None:
            if (_marker(dest) or {}).get("entries") is not None:
                why = f"holds {who}, which vrelab did not write"
            elif who.startswith("("):
                why = f"is not a vrelab output folder (no {MARKER} listing its files, no results file)"
            else:
                why = f"is not a vrelab output folder (no {MARKER} listing its files; it holds {who})"
            raise ValueError(f"output folder {dest} {why}: choose a new or empty folder, so nothing of yours "
                             "is overwritten (nothing was changed)")


def _write_marker(folder: Path, extra: Iterable[str] = (), keep: Iterable[str] = ()) -> None:
    """``folder/MARKER``: what wrote the folder and every entry in it (plus ``extra``, names a
    writer may add later, and ``keep``, entries an earlier marker listed)."""
    import shlex
    import sys

    from vrelab._version import __version__

    entries = {rel for rel, _ in _entries(folder)} | set(extra) | set(keep)
    doc = {
        "written_by": f"vrelab {__version__}",
        "command": shlex.join(["vrelab", *sys.argv[1:]]) if Path(sys.argv[0]).name in ("vrelab", "__main__.py") else None,
        "pid": os.getpid(),
        "written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "note": "vrelab replaces this folder only while it holds nothing but these entries",
        "entries": sorted(entries),
    }
    write_json(folder / MARKER, doc)


def claim(path: str | Path, inputs: Iterable[str | Path] = (), entries: Sequence[str] = ()) -> Path:
    """Check ``path`` (:func:`check_output`), create it, and mark it vrelab's with ``entries``
    listed beforehand: for a writer that works in the folder itself (a sweep's checkpoint)."""
    dest = Path(path)
    check_output(dest, inputs)
    dest.mkdir(parents=True, exist_ok=True)
    _write_marker(dest, entries)  # everything already there passed the check: it is listed too
    return dest


def claim_file(folder: str | Path, name: str) -> None:
    """Before writing ``folder/name`` into a results folder (``vrelab report`` writes
    ``report.html`` beside the results it reads): refuse when such a file exists and vrelab did
    not write it. Adding a new file replaces nothing and is fine."""
    folder = Path(folder)
    f = folder / name
    if not (f.exists() or f.is_symlink()):
        return
    doc = _marker(folder)
    listed = doc.get("entries") if doc else None
    ours = name in listed if isinstance(listed, list) else _legacy_stranger(folder) is None
    if not ours or f.is_symlink() or f.is_dir():
        raise ValueError(f"{f} exists and vrelab did not write it: move it away first (nothing was changed)")


def note_written(folder: str | Path, names: Iterable[str]) -> None:
    """Add ``names`` to the marker of ``folder`` (when it has a listing one), so that a folder
    vrelab wrote stays replaceable after a later command added files to it."""
    folder = Path(folder)
    doc = _marker(folder)
    if doc and isinstance(doc.get("entries"), list):
        _write_marker(folder, names, doc["entries"])


# --------------------------------------------------------------------------- staging


def _same_file(fd: int, path: Path) -> bool:
    try:
        a, b = os.fstat(fd), os.stat(path, follow_symlinks=False)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _new_stage(where: Path) -> tuple[Path, int]:
    """A staging folder in ``where`` and the descriptor of its lock file, locked."""
    while True:
        name = f"{_STAGE_PREFIX}{os.getpid()}-{secrets.token_hex(6)}"
        lock = where / (name + _LOCK_SUFFIX)
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            continue
        try:
            if fcntl is not None:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:  # a cleaner caught the file between create and lock: it removes it
            os.close(fd)
            continue
        if not _same_file(fd, lock):  # ... and removed it already: this lock guards nothing
            os.close(fd)
            continue
        stage = where / name
        try:
            os.write(fd, f"vrelab pid {os.getpid()} on {os.uname().nodename}; locked while it writes {name}\n".encode())
            stage.mkdir()
        except BaseException:  # a full disk (a file takes an inode, its line or a folder a block): nothing left
            _release(fd, stage)
            raise
        return stage, fd


def _release(fd: int, stage: Path) -> None:
    (stage.parent / (stage.name + _LOCK_SUFFIX)).unlink(missing_ok=True)
    os.close(fd)


def _rmtree(p: Path) -> None:
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)


def remove_orphan_stages(folder: str | Path) -> list[Path]:
    """Remove the staging folders in ``folder`` whose owner is gone (a run killed by SIGKILL, a
    batch scheduler's timeout, a container stop): those whose lock file this process can lock.
    A live run holds its lock wherever it runs (another PID namespace, another container on the
    same kernel), so its staging is never touched. Staging folders of an older vrelab (no lock
    file) are removed after :data:`LEGACY_STAGE_AGE_S` untouched. Returns what it removed."""
    folder = Path(folder)
    removed: list[Path] = []
    if not folder.is_dir() or fcntl is None:
        return removed
    for lock in sorted(folder.glob(_STAGE_PREFIX + "*" + _LOCK_SUFFIX)):
        try:
            fd = os.open(lock, os.O_RDWR)  # read-write: NFS emulates flock with POSIX locks
        except OSError:
            continue
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                continue  # its run is alive
            if not _same_file(fd, lock):
                continue
            stage = folder / lock.name[: -len(_LOCK_SUFFIX)]
            for d in (stage, stage.with_name(stage.name + _OLD_SUFFIX)):
                if d.exists():
                    _rmtree(d)
                    removed.append(d)
            lock.unlink(missing_ok=True)
        finally:
            os.close(fd)
    now = time.time()
    for stage in sorted(folder.glob(_STAGE_PREFIX + "*")):
        base = stage.name.removesuffix(_OLD_SUFFIX)
        if stage.name.endswith(_LOCK_SUFFIX) or (folder / (base + _LOCK_SUFFIX)).exists():
            continue
        try:
            age = now - stage.lstat().st_mtime
        except OSError:
            continue
        if stage.is_dir() and not stage.is_symlink() and age > LEGACY_STAGE_AGE_S:
            _rmtree(stage)
            removed.append(stage)
    return removed


@contextmanager
def output_dir(path: str | Path, replace: bool = True, inputs: Iterable[str | Path] = ()) -> Iterator[Path]:
    """Yield a staging folder; on success it becomes ``path``, on failure nothing changes.

    ``path`` is checked first (:func:`check_output`: not an input of the run, empty or all
    vrelab's). ``replace=True`` (a run's results): the folder afterwards holds exactly this
    run's files. ``replace=False`` (a sweep, whose checkpoint lives beside its results): new
    files are moved in, same-named ones replaced, others left alone. Either way the folder's
    :data:`MARKER` lists every entry vrelab wrote.

    Staging happens beside ``path`` (same file system: the final step is a rename), or inside
    it when its parent is read-only. Staging folders whose owner is gone are removed first, in
    both places. A full disk while writing is :class:`DiskFull`.
    """
    dest = Path(path)
    inputs = list(inputs)
    check_output(dest, inputs)
    parent = dest.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        if is_disk_full(exc):
            raise disk_full_error(dest) from None
        raise
    remove_orphan_stages(parent)
    remove_orphan_stages(dest)
    beside = os.access(parent, os.W_OK | os.X_OK)
    if not beside:
        dest.mkdir(exist_ok=True)
    where = parent if beside else dest
    try:
        stage, fd = _new_stage(where)
    except OSError as exc:
        if is_disk_full(exc):
            raise disk_full_error(dest) from None
        raise
    try:
        yield stage
        check_output(dest, inputs)  # the folder may have changed while the run worked
        # merging (replace=False): what the folder holds stays, and passed the check: listed too
        keep = [rel for rel, _ in _entries(dest)] if not replace and dest.is_dir() else []
        _write_marker(stage, keep=keep)
        if replace and beside:
            old = stage.with_name(stage.name + _OLD_SUFFIX)
            if dest.exists():
                os.rename(dest, old)
            os.rename(stage, dest)
            _rmtree(old)
            return
        dest.mkdir(exist_ok=True)
        new = {item.name for item in stage.iterdir()}
        if replace:  # staging inside dest (read-only parent): drop what the new run does not have
            for item in dest.iterdir():
                if item != stage and item.name not in new and not item.name.startswith(_STAGE_PREFIX):
                    shutil.rmtree(item) if item.is_dir() and not item.is_symlink() else item.unlink()
        for item in stage.iterdir():
            target = dest / item.name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(item, target)
    except BaseException as exc:
        if is_disk_full(exc):  # named by the folder the user asked for, not the staging
            raise disk_full_error(dest) from None
        raise
    finally:
        _rmtree(stage)
        _release(fd, stage)


class GuardedFile(io.RawIOBase):
    """A file for ``h5py.File(GuardedFile(path), "w")`` that survives a full disk.

    HDF5 cannot recover from a failed write: the file's objects stay half open, ``close`` fails
    again and the library crashes the interpreter at exit (a segmentation fault, measured with
    h5py 3 on a 1 MB tmpfs). This file takes HDF5's writes through ``os.pwrite``; the first
    ``ENOSPC``/``EDQUOT`` is kept in :attr:`failed` and every later write is dropped while HDF5
    is told it succeeded, so HDF5 closes cleanly; the caller then checks :attr:`failed`,
    deletes the (useless) file and raises :class:`DiskFull`. Written by hand: no library offers
    this, and the Python file object's buffering would raise the error again on seek.
    """

    def __init__(self, path: str | Path) -> None:
        super().__init__()
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
        self._pos = 0
        self._size = 0
        self.failed: OSError | None = None

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = 0) -> int:
        self._pos = offset if whence == 0 else self._pos + offset if whence == 1 else self._size + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, buf: WriteableBuffer) -> int:
        n = os.preadv(self._fd, [buf], self._pos)
        self._pos += n
        return n

    def write(self, data: ReadableBuffer) -> int:
        view = memoryview(data).cast("B")
        n = len(view)
        if self.failed is None:
            try:
                done = 0
                while done < n:
                    done += os.pwrite(self._fd, view[done:], self._pos + done)
            except OSError as exc:
                if exc.errno not in _FULL:
                    raise
                self.failed = exc
        self._pos += n
        self._size = max(self._size, self._pos)
        return n

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else size
        try:
            os.ftruncate(self._fd, size)
        except OSError as exc:
            if exc.errno not in _FULL:
                raise
            self.failed = self.failed or exc
        self._size = size
        return size

    def close(self) -> None:
        if not self.closed:
            try:
                os.fsync(self._fd)
            except OSError as exc:
                if exc.errno not in _FULL:
                    raise
                self.failed = self.failed or exc
            finally:
                os.close(self._fd)
        super().close()


def sha256_file(path: str | Path) -> str:
    """SHA-256 of a file, streamed (read in chunks, never whole: records can exceed memory)."""
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def write_json(path: str | Path, obj: object) -> None:
    """Write JSON atomically (temporary file + rename)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    with open(tmp, "w") as fh:
        json.dump(obj, fh, indent=2, allow_nan=False)
        fh.write("\n")
    os.replace(tmp, path)


LEVELS_CSV_COLUMNS = (
    "freq_hz", "rms_g", "u_rms_g", "vre_g", "u_vre_g", "duration_s", "n_samples", "n_saturated", "flags",
    "thd", "u_thd",  # a sine level's drive distortion (physics §4.4: DriveWaveform.thd, a ratio); empty otherwise
)


def write_levels_csv(path: str | Path, result: VreResult) -> None:
    """``levels.csv``: one row per level of a ``VreResult``, the numbers of ``results.json``.

    The one layout shared by ``simulate --out``, ``analyze --out`` and the demo. Floats are
    written with ``repr`` so they read back bit for bit; unknown values are empty cells (the THD
    of a random level, or of a sine level whose reference's waveform was not measured).
    """
    write_levels_table(path, [({}, result)])


def write_levels_table(path: str | Path, groups: Sequence[tuple[Mapping[str, Any], VreResult]]) -> None:
    """Levels of several results in one CSV: each group's leading columns (``channel``,
    ``run``, ...: the keys of the first group, in order) then :data:`LEVELS_CSV_COLUMNS`."""
    import csv

    def cell(x: float | None) -> str:
        return "" if x is None else repr(float(x))

    def thd(lv: LevelResult) -> list[str]:  # a THD not measured (nan) is unknown: empty, as a random level's
        e = None if lv.drive is None else lv.drive.thd
        return ["", ""] if e is None or math.isnan(e.value) else [cell(e.value), cell(e.u)]

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
                    *thd(lv),
                ])  # fmt: skip
    os.replace(tmp, path)
