"""Profile files: CSV (two columns ``f_hz, psd_g2_per_hz``) and TOML (``[profile]`` with
breakpoints or start and slopes, optional ``[[tone]]`` tables), read and written
(the formats in :mod:`vrelab.profiles`)."""

from __future__ import annotations

import csv
import io
import os
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from vrelab import _validate as v
from vrelab._load import toml_load
from vrelab.profiles.shapes import Profile, RandomProfile, SineOnRandom, Tone, check_tone_count

# --- files ------------------------------------------------------------------------------------


def _read_csv(path: Path) -> RandomProfile:
    freqs: list[float] = []
    psds: list[float] = []
    name: str | None = None
    source: str | None = None
    with open(path, newline="") as fh:
        text = fh.read()
    seen_data = False
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line.startswith("#"):
            # "# name: ..." / "# source: ..." comments carry the metadata write_profile writes.
            body = line.lstrip("#").strip()
            key, sep, val = body.partition(":")
            if sep and key.strip().lower() == "name" and name is None:
                name = val.strip() or None
            elif sep and key.strip().lower() == "source" and source is None:
                source = val.strip() or None
            continue
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        cells = next(csv.reader([line.replace(";", ",").replace("\t", ",")]))
        cells = [c.strip() for c in cells if c.strip()]
        if len(cells) == 1 and " " in cells[0]:
            cells = cells[0].split()
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not seen_data and not freqs:
                seen_data = True  # the header line: column names, allowed once, before the data
                continue
            raise ValueError(f"{path}: line {lineno}: not a number pair: {raw.strip()!r}") from None
        seen_data = True
        if len(values) != 2:
            raise ValueError(
                f"{path}: line {lineno}: expected 2 columns (f_hz, psd_g2_per_hz), "
                f"got {len(values)}: {raw.strip()!r}"
            )
        freqs.append(values[0])
        psds.append(values[1])
    try:
        return RandomProfile(np.array(freqs), np.array(psds), name=name, source=source or str(path))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _toml_pair(path: Path, field: str, item: object) -> tuple[float, float]:
    if not isinstance(item, (list, tuple)) or len(item) != 2:
        raise ValueError(f"{path}: {field} must be a pair [a, b], got {item!r}")
    try:
        return float(item[0]), float(item[1])
    except (TypeError, ValueError):
        raise ValueError(f"{path}: {field} must hold numbers, got {item!r}") from None


def profile_from_table(path: Path, table: dict[str, Any]) -> RandomProfile:
    """Build a profile from a TOML ``[profile]`` table (physics §3 file format)."""
    name = table.get("name")
    source = table.get("source")
    for key in ("name", "source"):
        if table.get(key) is not None and not isinstance(table[key], str):
            raise ValueError(f"{path}: profile.{key} must be a string, got {table[key]!r}")
    has_bp = "breakpoints" in table
    has_slopes = "start" in table or "slopes" in table
    try:
        if has_bp and has_slopes:
            raise ValueError(f"{path}: give profile.breakpoints or profile.start+slopes, not both")
        if has_bp:
            rows = table["breakpoints"]
            if not isinstance(rows, list):
                raise ValueError(f"{path}: profile.breakpoints must be a list of [f_hz, psd] pairs")
            pairs = [_toml_pair(path, f"profile.breakpoints[{i}]", r) for i, r in enumerate(rows)]
            prof = RandomProfile(
                np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]), name, source
            )
        elif has_slopes:
            if "start" not in table or "slopes" not in table:
                raise ValueError(f"{path}: profile.start and profile.slopes go together")
            f0, p0 = _toml_pair(path, "profile.start", table["start"])
            rows = table["slopes"]
            if not isinstance(rows, list):
                raise ValueError(f"{path}: profile.slopes must be a list of [f_end_hz, db_per_oct]")
            segs = [_toml_pair(path, f"profile.slopes[{i}]", r) for i, r in enumerate(rows)]
            prof = RandomProfile.from_slopes(f0, p0, segs, name=name, source=source)
        else:
            raise ValueError(f"{path}: [profile] needs breakpoints, or start and slopes")
        if "grms" in table:
            prof = prof.scaled_to(v.positive_scalar("profile.grms", table["grms"]))
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
    return prof


_TONE_KEYS = ("freq_hz", "peak_g")


def _tones_from_tables(path: Path, rows: object) -> tuple[Tone, ...]:
    """The ``[[tone]]`` tables of a profile file (each ``freq_hz`` [Hz], ``peak_g`` [g peak])."""
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise ValueError(f"{path}: tone must be [[tone]] tables with freq_hz and peak_g")
    try:
        check_tone_count(len(rows))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    tones = []
    for i, row in enumerate(rows):
        unknown = sorted(set(row) - set(_TONE_KEYS))
        if unknown:
            raise ValueError(f"{path}: tone[{i}]: unknown key {unknown[0]!r} (known: freq_hz, peak_g)")
        missing = [k for k in _TONE_KEYS if k not in row]
        if missing:
            raise ValueError(f"{path}: tone[{i}]: {missing[0]} is missing (a tone needs freq_hz and peak_g)")
        try:
            tones.append(Tone(row["freq_hz"], row["peak_g"]))
        except ValueError as exc:
            raise ValueError(f"{path}: tone[{i}]: {exc}") from None
    return tuple(tones)


def _read_toml(path: Path) -> Profile:
    try:
        with open(path, "rb") as fh:
            doc = toml_load(fh, str(path))
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    table = doc.get("profile")
    if not isinstance(table, dict):
        raise ValueError(f"{path}: no [profile] table")
    prof = profile_from_table(path, table)
    if "tone" not in doc:
        return prof
    try:
        return SineOnRandom(prof, _tones_from_tables(path, doc["tone"]))
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


def read_profile(path: str | os.PathLike[str]) -> Profile:
    """Read a profile from a CSV (``f_hz, psd_g2_per_hz``) or TOML file.

    A TOML file with ``[[tone]]`` tables (``freq_hz``, ``peak_g``) beside its ``[profile]``
    gives a :class:`SineOnRandom`; ``profile.grms`` there sets the random part's level, the
    tones being given in g peak as they are.

    Raises
    ------
    ValueError
        Unknown extension, or a malformed file; the message names the file and the line
        (CSV) or field (TOML).
    FileNotFoundError
        The file does not exist.

    Examples
    --------
    A profile written as CSV and read back:

    >>> from vrelab.profiles import load_named_profile, read_profile, write_profile
    >>> path = write_profile(load_named_profile("navmat-p9492"), "navmat.csv")
    >>> print(f"{read_profile(path).grms:.2f} g rms")
    6.06 g rms
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".toml", ".txt"):
        raise ValueError(f"profile file must be .csv or .toml, got {str(path)!r}")
    if not p.is_file():
        raise FileNotFoundError(2, "profile file not found", str(p))
    return _read_toml(p) if suffix == ".toml" else _read_csv(p)


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` completely or not at all (temporary file + rename)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_profile(profile: Profile, path: str | os.PathLike[str]) -> Path:
    """Write ``profile`` to ``path`` (.csv or .toml), atomically (temporary file + rename).

    Values are written with ``repr`` precision so that ``read_profile`` gives back the same
    breakpoints exactly. A sine-on-random profile needs .toml (its tones as ``[[tone]]``).

    Examples
    --------
    >>> from vrelab import RandomProfile
    >>> from vrelab.profiles import write_profile
    >>> path = write_profile(RandomProfile.flat(50.0, 2000.0).scaled_to(2.0), "flat.toml")
    >>> print(path.name)
    flat.toml
    >>> print(path.read_text().splitlines()[0])
    [profile]
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if isinstance(profile, SineOnRandom) and suffix == ".csv":
        raise ValueError(f"a profile with sine tones is written as .toml ([[tone]] tables), not .csv: {str(path)!r}")
    if suffix == ".toml":
        table: dict[str, Any] = {}
        if profile.name:
            table["name"] = profile.name
        if profile.source:
            table["source"] = profile.source
        table["breakpoints"] = profile.breakpoints
        doc: dict[str, Any] = {"profile": table}
        if isinstance(profile, SineOnRandom):
            doc["tone"] = [{"freq_hz": t.freq_hz, "peak_g": t.peak_g} for t in profile.tones]
        data = tomli_w.dumps(doc).encode()
    elif suffix == ".csv":
        buf = io.StringIO()
        if profile.name:
            buf.write(f"# name: {profile.name}\n")
        if profile.source:
            buf.write(f"# source: {profile.source}\n")
        buf.write(f"# {profile.describe()}\n")
        buf.write("f_hz,psd_g2_per_hz\n")
        for f, psd in profile.breakpoints:
            buf.write(f"{f!r},{psd!r}\n")
        data = buf.getvalue().encode()
    else:
        raise ValueError(f"profile file must be .csv or .toml, got {str(path)!r}")
    atomic_write(p, data)
    return p
