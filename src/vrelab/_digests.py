"""The SHA-256 of an input file, remembered across runs under the file's identity (issue 29).

A result promises the SHA-256 of the file its numbers came from (its provenance). Hashing a 2 h
record (461 MB) costs about 2 s of CPU on a processor without SHA instructions (~230 MB/s),
more than the reduction of its reference's spectra; a second analysis of the same file (other
options, another channel) need not pay it again.

The digest is kept under the file's identity as the kernel states it (``os.stat``): device,
inode, size, and modification and status-change times in nanoseconds. Every write to a file
sets its status-change time (ctime) to the clock's now, and no user call sets it back (``touch``
and ``os.utime`` set mtime, not ctime), so a changed file never matches an old entry. As git's
index does for "racy" files, an entry is stored only when the file's mtime and ctime were older
than :data:`RACY_S` seconds when its hashing started and its identity was the same when it
ended: a write in the clock tick of the stat, or during the hash, is never remembered.

Entries are small files under ``$XDG_CACHE_HOME/vrelab/sha256`` (``~/.cache/vrelab/sha256`` by
default), one per identity, written atomically (several processes may share them);
``VRELAB_NO_DIGEST_CACHE=1`` turns the cache off. A cache that cannot be read or written is no
error: the file is hashed.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
import time
from pathlib import Path

from vrelab._io import sha256_file

# A file changed less than this long before its hashing started is not remembered (git's racy
# rule): timestamps are as coarse as the kernel's clock tick (a few ms), a write in the same
# tick as the stat would keep both times. Two seconds also covers file systems of 1 s or 2 s
# timestamps (FAT: 2 s).
RACY_S = 2.0
_HEX64 = re.compile(r"[0-9a-f]{64}")


def cache_dir() -> Path | None:
    """Where the digests are kept; None when ``VRELAB_NO_DIGEST_CACHE`` is set (not to "0")."""
    if os.environ.get("VRELAB_NO_DIGEST_CACHE", "0") not in ("", "0"):
        return None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "vrelab" / "sha256"


def _identity(st: os.stat_result) -> tuple[int, ...]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def _entry(folder: Path, st: os.stat_result) -> Path:
    return folder / hashlib.sha256(repr(_identity(st)).encode()).hexdigest()


def file_sha256(path: str | Path) -> str:
    """SHA-256 of the file at ``path``, hex: from the cache when the file's identity (see the
    module) is the one it was hashed under, else computed (:func:`vrelab._io.sha256_file`) and
    remembered unless the file changed within :data:`RACY_S` s of its hashing."""
    folder = cache_dir()
    if folder is None:
        return sha256_file(path)
    before = os.stat(path)
    entry = _entry(folder, before)
    try:
        known = entry.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError):
        known = ""
    if _HEX64.fullmatch(known):
        return known
    started_ns = time.time_ns()
    digest = sha256_file(path)
    after = os.stat(path)
    settled = max(before.st_mtime_ns, before.st_ctime_ns) < started_ns - int(RACY_S * 1e9)
    if settled and _identity(after) == _identity(before):
        _store(entry, digest)
    return digest


def _store(entry: Path, digest: str) -> None:
    """Write ``digest`` to ``entry`` atomically (a temporary file renamed); never raises."""
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=entry.parent, prefix=".tmp-")
        try:
            with os.fdopen(fd, "w", encoding="ascii") as fh:
                fh.write(digest)
            os.replace(tmp, entry)
        except OSError:
            os.unlink(tmp)
            raise
    except OSError:
        pass  # a read-only or full cache: the digest was computed, it is only not remembered
