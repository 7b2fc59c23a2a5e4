"""Triaxial profile files and command-line strings (physics §1.6, §3).

A triaxial random profile file (TOML) holds each moving axis's PSD as a single-axis profile file
holds its ``[profile]`` (``breakpoints``, or ``start`` + ``slopes``; an optional ``grms`` scales
that axis), and per pair of axes the coherence γ² and phase, each a constant or a table::

    [triaxial]
    name = "vehicle-3ax"          # optional
    source = "..."                # optional
    grms = 3.0                    # optional: scales the whole to this total rms [g]

    [x]
    breakpoints = [[20, 0.01], [80, 0.04], [350, 0.04], [2000, 0.007]]
    [z]
    start = [20, 0.02]
    slopes = [[2000, 0.0]]
    # no [y]: the y axis is still

    [pair.xz]
    coherence = 0.5                              # γ², or [[f_hz, γ²], ...]
    phase_deg = [[20, 0.0], [2000, 90.0]]        # or a constant; default 0

Axes with different breakpoints are evaluated log-log on the union of all of them (exact: each
segment is a power law); every moving axis must span the same band. A coherence or phase table
is linear in ln f and must span the band; its breakpoints join the union
(:meth:`TriaxialProfile.from_axes`). ``[pair.zx]`` is the same pair seen from z: its phase is
the negative of ``[pair.xz]``'s.

On the command line (:func:`parse_triaxial`) a triaxial vibration is one of:

* ``FILE.toml`` -- a triaxial profile file as above;
* ``PROFILE@dir=X,Y,Z`` -- any single-axis profile (:func:`vrelab.profiles.parse_profile`:
  a name, a file, ``flat:F1-F2``, ``F:P,...``) along the direction (X, Y, Z), normalised;
* ``PROFILE@AφB`` -- along IEEE 1293's mount angle: axis A at φ degrees toward axis B
  (:func:`vrelab.triaxial.profile.direction`), e.g. ``flat:20-2000@z45x``, ``navmat-p9492@x-30y``;
  ``PROFILE@x`` (or ``@y``, ``@z``) is along one axis;
* ``sine:F@...`` -- a sine at F Hz (1 g rms, a shape the levels scale; ``sine:F:RMS`` for a
  level) along a direction given either way.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w
from numpy.typing import NDArray

from vrelab._load import toml_load
from vrelab.profiles import RandomProfile, atomic_write, parse_profile, profile_from_table
from vrelab.triaxial.profile import AXES, PairCoherence, TriaxialProfile, TriaxialSine, direction

__all__ = ["read_triaxial", "write_triaxial", "parse_triaxial", "parse_direction", "is_triaxial_spec"]

_TOP_KEYS = ("triaxial", "x", "y", "z", "pair")
_HEAD_KEYS = ("name", "source", "grms")
_PAIR_KEYS = ("coherence", "phase_deg")
# IEEE 1293 mount angle on the command line: axis, signed degrees, toward axis (z45x, x-30y)
_MOUNT = re.compile(r"([xyz])([+-]?\d+(?:\.\d*)?(?:[eE][+-]?\d+)?)([xyz])")

TriaxialVibration = TriaxialProfile | TriaxialSine


def _value_or_table(path: Path, field: str, value: object) -> tuple[NDArray[np.float64] | None, NDArray[np.float64]]:
    """(frequencies or None, values) of a constant or a ``[[f_hz, value], ...]`` table."""
    if isinstance(value, bool):
        raise ValueError(f"{path}: {field} must be a number or a [[f_hz, value], ...] table, got {value!r}")
    if isinstance(value, (int, float)):
        return None, np.array([float(value)])
    if not isinstance(value, list) or not value:
        raise ValueError(f"{path}: {field} must be a number or a [[f_hz, value], ...] table, got {value!r}")
    rows = []
    for i, item in enumerate(value):
        if (not isinstance(item, list) or len(item) != 2
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in item)):
            raise ValueError(f"{path}: {field}[{i}] must be a pair [f_hz, value] of numbers, got {item!r}")
        rows.append((float(item[0]), float(item[1])))
    arr = np.array(rows)
    return arr[:, 0], arr[:, 1]


def _pair_coherence(path: Path, key: str, table: object) -> tuple[tuple[str, str], PairCoherence]:
    if len(key) != 2 or key[0] not in AXES or key[1] not in AXES or key[0] == key[1]:
        raise ValueError(f"{path}: pair.{key}: a pair is two different axes of x, y, z, e.g. [pair.xz]")
    if not isinstance(table, dict):
        raise ValueError(f"{path}: pair.{key} must be a table with coherence (and phase_deg)")
    unknown = sorted(set(table) - set(_PAIR_KEYS))
    if unknown:
        raise ValueError(f"{path}: pair.{key}.{unknown[0]}: unknown key (known: {', '.join(_PAIR_KEYS)})")
    if "coherence" not in table:
        raise ValueError(f"{path}: pair.{key}: coherence is missing (γ², 0..1)")
    fc, gc = _value_or_table(path, f"pair.{key}.coherence", table["coherence"])
    fp, gp = _value_or_table(path, f"pair.{key}.phase_deg", table.get("phase_deg", 0.0))
    try:
        if fc is None and fp is None:
            pc = PairCoherence.constant(float(gc[0]), float(gp[0]))
        else:
            # one table: the union of both tables' breakpoints, each linear in ln f (a constant stays one)
            # each table whole, before the two are merged: monotonic, finite, coherence within 0..1
            if fc is not None:
                PairCoherence(gc, np.zeros(fc.size), fc)
            if fp is not None:
                PairCoherence(np.zeros(fp.size), gp, fp)
            grids = [f for f in (fc, fp) if f is not None]
            lo, hi = max(g[0] for g in grids), min(g[-1] for g in grids)
            f = np.unique(np.concatenate(grids))
            f = f[(f >= lo) & (f <= hi)]
            coh = gc[0] * np.ones(f.size) if fc is None else np.interp(np.log(f), np.log(fc), gc)
            ph = gp[0] * np.ones(f.size) if fp is None else np.interp(np.log(f), np.log(fp), gp)
            pc = PairCoherence(coh, ph, f)
    except ValueError as exc:
        raise ValueError(f"{path}: pair.{key}: {exc}") from None
    j, k = key[0], key[1]
    if AXES.index(j) > AXES.index(k):  # [pair.zx]: S_zx = conj(S_xz), the phase negated
        pc = PairCoherence(pc.coherence, -pc.phase_deg, pc.freq_hz)
        j, k = k, j
    return (j, k), pc


def read_triaxial(path: str | os.PathLike[str]) -> TriaxialProfile:
    """Read a triaxial profile file (the module docstring gives its form).

    Raises ValueError naming the file and the field on any malformed or inconsistent content
    (coherence outside 0..1, a negative PSD, non-monotonic breakpoints, NaN, coherences that no
    vibration can have), FileNotFoundError when it does not exist.

    Examples
    --------
    A profile file with x and z moving, half coherent (the form the module docstring gives):

    >>> from vrelab.triaxial.files import read_triaxial
    >>> with open("tri.toml", "w") as f:
    ...     _ = f.write('''[triaxial]
    ... grms = 3.0
    ... [x]
    ... breakpoints = [[20, 0.01], [2000, 0.01]]
    ... [z]
    ... breakpoints = [[20, 0.02], [2000, 0.02]]
    ... [pair.xz]
    ... coherence = 0.5
    ... ''')
    >>> tri = read_triaxial("tri.toml")
    >>> print(f"{tri.grms:.3f} g rms", [f"{g:.3f}" for g in tri.axis_mean_square_g2 ** 0.5])
    3.000 g rms ['1.732', '0.000', '2.449']
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(2, "triaxial profile file not found", str(p))
    try:
        with open(p, "rb") as fh:
            doc = toml_load(fh, str(p))
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{p}: not valid TOML: {exc}") from None
    if "profile" in doc and not any(a in doc for a in AXES):
        raise ValueError(f"{p}: a single-axis profile ([profile]); give a direction, e.g. {p}@dir=1,0,1 or {p}@z45x")
    unknown = sorted(set(doc) - set(_TOP_KEYS))
    if unknown:
        raise ValueError(f"{p}: {unknown[0]}: unknown table (known: [triaxial], [x], [y], [z], [pair.xy] ...)")
    head = doc.get("triaxial", {})
    if not isinstance(head, dict):
        raise ValueError(f"{p}: triaxial must be a table")
    bad = sorted(set(head) - set(_HEAD_KEYS))
    if bad:
        raise ValueError(f"{p}: triaxial.{bad[0]}: unknown key (known: {', '.join(_HEAD_KEYS)})")
    for key in ("name", "source"):
        if key in head and not isinstance(head[key], str):
            raise ValueError(f"{p}: triaxial.{key} must be a string, got {head[key]!r}")
    axes: dict[str, RandomProfile] = {}
    for a in AXES:
        if a in doc:
            if not isinstance(doc[a], dict):
                raise ValueError(f"{p}: {a} must be a table ([{a}] with breakpoints)")
            try:
                axes[a] = profile_from_table(p, doc[a])
            except ValueError as exc:
                rest = str(exc).removeprefix(f"{p}: ").replace("profile.", f"{a}.")
                raise ValueError(f"{p}: axis {a}: {rest}") from None
    if not axes:
        raise ValueError(f"{p}: no axis moves: give at least one of [x], [y], [z] with breakpoints")
    pairs_doc = doc.get("pair", {})
    if not isinstance(pairs_doc, dict):
        raise ValueError(f"{p}: pair must hold tables [pair.xy], [pair.xz], [pair.yz]")
    pairs: dict[tuple[str, str], PairCoherence] = {}
    for key, table in pairs_doc.items():
        pair, pc = _pair_coherence(p, key, table)
        if pair in pairs:
            raise ValueError(f"{p}: pair.{key}: the pair {pair[0]}{pair[1]} is given twice")
        pairs[pair] = pc
    try:
        prof = TriaxialProfile.from_axes(axes, pairs, name=head.get("name"), source=head.get("source") or str(p))
        if "grms" in head:
            g = head["grms"]
            if isinstance(g, bool) or not isinstance(g, (int, float)):
                raise ValueError(f"triaxial.grms must be a number [g rms], got {g!r}")
            prof = prof.scaled_to(float(g))
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(str(p)) else f"{p}: {msg}") from None
    return prof


def _constant_or_table(f: NDArray[np.float64], values: NDArray[np.float64]) -> float | list[list[float]]:
    # 15 significant digits: |C|² and arg C of a coherency built from γ² = 0.5 are 0.5 within
    # 1e-16, written back as 0.5 (the coherency round-trips to that precision anyway)
    v = [float(f"{x:.15g}") for x in values]
    if all(x == v[0] for x in v):
        return v[0]
    return [[float(a), b] for a, b in zip(f, v)]


def write_triaxial(profile: TriaxialProfile, path: str | os.PathLike[str]) -> Path:
    """Write ``profile`` as a triaxial TOML file, atomically (temporary file + rename).

    Every moving axis is written on the profile's breakpoints and every pair of moving axes as
    its coherence and phase there (constants when they do not vary), with ``repr`` precision:
    :func:`read_triaxial` gives back the breakpoints and PSDs exactly and the coherency to the
    last bits of a square root and a cosine.

    Examples
    --------
    >>> from vrelab.triaxial.files import parse_triaxial, read_triaxial, write_triaxial
    >>> path = write_triaxial(parse_triaxial("flat:50-2000@z45x").scaled_to(2.0), "tri.toml")
    >>> print(path.name, f"{read_triaxial(path).grms:.3f} g rms")
    tri.toml 2.000 g rms
    """
    p = Path(path)
    if p.suffix.lower() != ".toml":
        raise ValueError(f"a triaxial profile is written as .toml, got {str(path)!r}")
    if not isinstance(profile, TriaxialProfile):
        raise ValueError(f"write_triaxial needs a TriaxialProfile, got {type(profile).__name__}")
    doc: dict[str, Any] = {}
    head = {k: v for k, v in (("name", profile.name), ("source", profile.source)) if v}
    if head:
        doc["triaxial"] = head
    f = profile.freq_hz
    moving = [j for j in range(3) if not profile.still[j]]
    for j in moving:
        doc[AXES[j]] = {"breakpoints": [[float(a), float(b)] for a, b in zip(f, profile.axis_psd_g2_per_hz[:, j])]}
    pairs: dict[str, Any] = {}
    for j in moving:
        for k in moving:
            if k <= j:
                continue
            c = profile.coherency[:, j, k]
            if not np.any(c):
                continue
            pairs[AXES[j] + AXES[k]] = {
                "coherence": _constant_or_table(f, np.minimum(np.abs(c) ** 2, 1.0)),
                "phase_deg": _constant_or_table(f, np.degrees(np.angle(c))),
            }
    if pairs:
        doc["pair"] = pairs
    atomic_write(p, tomli_w.dumps(doc).encode())
    return p


def parse_direction(text: str) -> NDArray[np.float64]:
    """A unit direction from ``dir=X,Y,Z``, a mount angle ``AφB`` (``z45x``) or an axis ``x``.

    Examples
    --------
    The same direction three ways: components, a mount angle (45° from z toward x) and an axis:

    >>> from vrelab.triaxial.files import parse_direction
    >>> print(parse_direction("dir=1,0,1").round(4), parse_direction("z45x").round(4), parse_direction("x"))
    [0.7071 0.     0.7071] [0.7071 0.     0.7071] [1. 0. 0.]
    """
    t = text.strip().lower()
    if t in AXES:
        d = np.zeros(3)
        d[AXES.index(t)] = 1.0
        return d
    if t.startswith("dir="):
        parts = t[4:].split(",")
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            vals = []
        if len(vals) != 3 or not all(math.isfinite(x) for x in vals):
            raise ValueError(f"direction {text!r}: give dir=X,Y,Z with three finite numbers, e.g. dir=1,0,1")
        d = np.array(vals)
        if not np.any(d):
            raise ValueError(f"direction {text!r}: a direction must not be the zero vector")
        return d / float(np.linalg.norm(d))
    m = _MOUNT.fullmatch(t)
    if m:
        return direction(m.group(1), m.group(3), float(m.group(2)))
    raise ValueError(f"direction {text!r}: give dir=X,Y,Z, a mount angle AφB (axis A at φ degrees toward "
                     "axis B, e.g. z45x) or an axis x, y, z")


def is_triaxial_spec(spec: str) -> bool:
    """Whether a command-line profile string means a triaxial vibration (an ``@direction``, or
    a TOML file with [x]/[y]/[z] or [triaxial] tables).

    Examples
    --------
    >>> from vrelab.triaxial.files import is_triaxial_spec
    >>> is_triaxial_spec("flat:50-2000@dir=1,0,1"), is_triaxial_spec("flat:50-2000")
    (True, False)
    """
    text = spec.strip()
    if "@" in text and not Path(text).is_file():
        return True
    p = Path(text)
    if p.suffix.lower() == ".toml" and p.is_file():
        try:
            with open(p, "rb") as fh:
                doc = toml_load(fh, str(p))
        except (OSError, ValueError):  # not TOML, or too deep: the single-axis reader says why
            return False
        return any(k in doc for k in ("triaxial", *AXES))
    return False


def parse_triaxial(spec: str) -> TriaxialVibration:
    """A triaxial vibration from a command-line string (the module docstring lists the forms).

    Raises ValueError with one line naming the problem (an unknown form, a zero direction, a bad
    profile or file).

    Examples
    --------
    A flat profile along a direction at 45° between z and x, scaled to 1 g rms:

    >>> from vrelab.triaxial.files import parse_triaxial
    >>> tri = parse_triaxial("flat:50-2000@dir=1,0,1").scaled_to(1.0)
    >>> print(type(tri).__name__, f"{tri.grms:.3f} g rms", [f"{g:.3f}" for g in tri.axis_mean_square_g2 ** 0.5])
    TriaxialProfile 1.000 g rms ['0.707', '0.000', '0.707']
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError("triaxial profile: give FILE.toml, PROFILE@dir=X,Y,Z, PROFILE@z45x or sine:F@dir=X,Y,Z")
    text = spec.strip()
    if "@" not in text or Path(text).is_file():
        if not is_triaxial_spec(text):
            raise ValueError(f"triaxial profile {spec!r}: a single-axis profile needs a direction: "
                             f"{text}@dir=X,Y,Z, {text}@z45x or {text}@x")
        return read_triaxial(text)
    base, _, where = text.rpartition("@")
    try:
        d = parse_direction(where)
    except ValueError as exc:
        raise ValueError(f"triaxial profile {spec!r}: {exc}") from None
    if not base.strip():
        raise ValueError(f"triaxial profile {spec!r}: give a profile before '@', e.g. flat:20-2000@{where}")
    if base.lower().startswith("sine:"):
        parts = base.split(":")[1:]
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            vals = []
        if len(vals) not in (1, 2):
            raise ValueError(f"triaxial profile {spec!r}: a sine is sine:F (Hz) or sine:F:RMS (Hz, g rms)")
        try:
            return TriaxialSine(vals[0], (float(d[0]), float(d[1]), float(d[2])), vals[1] if len(vals) == 2 else 1.0)
        except ValueError as exc:
            raise ValueError(f"triaxial profile {spec!r}: {exc}") from None
    prof = parse_profile(base)
    if not isinstance(prof, RandomProfile):
        raise ValueError(f"triaxial profile {spec!r}: a sine-on-random profile along a direction is not supported "
                         "yet (its tones would need a direction of their own)")
    return TriaxialProfile.along(prof, d)
