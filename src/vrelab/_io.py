"""Output helpers: files are written completely or not at all."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator


@contextmanager
def output_dir(path: str | Path) -> Iterator[Path]:
    """Yield a staging folder; on success its files move into ``path``, on failure nothing does.

    Existing files in ``path`` with other names are left alone; files of the same name are
    replaced only once every new file is complete.
    """
    dest = Path(path)
    if dest.exists() and not dest.is_dir():
        raise ValueError(f"output path exists and is not a folder: {dest}")
    dest.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".vrelab-", dir=dest.parent))
    try:
        yield stage
        dest.mkdir(exist_ok=True)
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
    import csv

    def cell(x: Any) -> str:
        return "" if x is None else repr(float(x))

    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(LEVELS_CSV_COLUMNS)
        for lv in result.levels:
            w.writerow([
                cell(lv.freq_hz), cell(lv.rms_g), cell(lv.u_rms_g), cell(lv.vre.value), cell(lv.vre.u),
                cell(lv.duration_s), "" if lv.n_samples is None else lv.n_samples, lv.n_saturated,
                ";".join(lv.flags),
            ])  # fmt: skip
    os.replace(tmp, path)
