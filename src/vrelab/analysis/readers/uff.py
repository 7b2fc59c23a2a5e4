"""UFF dataset 58 time records (ASCII 58 and binary 58b) through pyuff, as vibration controllers
export them.

A channel is one record of function type 1 (time response) with even abscissa spacing, named by
its ``id1`` (trailing spaces stripped) and by ``NODE:DIR`` (response node and direction, e.g.
``101:+Z``: UFF directions 1/2/3 = X/Y/Z, 4/5/6 = RX/RY/RZ, signed). The sample rate is
``1/abscissa_inc`` (snapped when written rounded); records at several rates may share a file,
the ones a record reads must share one. Records of other kinds (spectra, FRFs) are left
out with a note.

Memory: pyuff reads a record whole, and lists the file by reading it whole. Opening reads the
headers only (``read_sets(header_only=True)``); a channel's samples are parsed on its first read
and kept, so the peak is about the file's size (pyuff's index pass) plus 8 bytes per sample of
each channel read (float64). Reading the headers costs one pass over the file's bytes.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import Source, register, snap_rate

_DIRS = {1: "X", 2: "Y", 3: "Z", 4: "RX", 5: "RY", 6: "RZ"}
# a UFF file starts with the delimiter line "    -1" (I6: four spaces), then the dataset number
# right-aligned in 6 columns (58, or 58b): a text column of numbers does not look like that
_HEAD = re.compile(rb"\A {4}-1 *\r?\n {2,5}(\d{2,4})(b?)(?: |\r?\n)")


def node_dir(node: Any, direction: Any) -> str:
    """``NODE:DIR`` of a record: ``101:+Z``; scalar (direction 0): ``101``."""
    d = int(direction)
    if d == 0 or abs(d) not in _DIRS:
        return f"{int(node)}"
    return f"{int(node)}:{'+' if d > 0 else '-'}{_DIRS[abs(d)]}"


def rate_from_increment(inc: float) -> float:
    """The sample rate behind an abscissa increment that an exporter printed with a few digits.

    UFF58 writes the increment as E13.5 (6 significant digits): 6 kHz becomes 1.66667E-04 s, whose
    inverse is 5999.988 Hz. The rate with the fewest significant digits whose inverse prints as
    the same increment (to 6 digits) is the one the controller ran at; when none does, or the
    increment has more digits than that (a double-precision export), 1/inc.
    """
    if float(f"{inc:.5E}") != inc:
        return 1.0 / inc
    return snap_rate(inc, 6)


def _ordinate_unit(h: dict[str, Any]) -> str | None:
    """The unit a record states for its values: its ordinate axis units label (record 8). The
    data-type code and unit exponents are not used: what they mean depends on the file's unit
    system (dataset 164), which a record does not carry."""
    label = str(h.get("ordinate_axis_units_lab", "") or "").strip()
    if label and label.upper() not in ("NONE", "-"):
        return label
    return None


@functools.lru_cache(maxsize=16)
def _indexed(path: str, mtime_ns: int, size: int) -> Any:
    """pyuff's index of a file (its records' byte ranges and types: small), kept for the file's
    next opening in this process (a campaign checks the channels, then reduces the run); a
    changed file (another mtime or size) is indexed again."""
    import pyuff

    return pyuff.UFF(path)


@register
class UffSource(Source):
    fmt = "uff"
    extensions = (".uff", ".unv")
    has_magic = False  # text: chosen by its first lines or its extension

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        m = _HEAD.match(head)
        return bool(m and m.group(1) in (b"58", b"151", b"164", b"15", b"55", b"82", b"2411", b"2412"))

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        try:
            st = path.stat()
            self.uff = _indexed(str(path.resolve()), st.st_mtime_ns, st.st_size)
            types = np.asarray(self.uff.get_set_types()).astype(int)
        except Exception as exc:
            raise ValueError(f"{path.name}: cannot read as UFF: {type(exc).__name__}: {exc}") from None
        if not len(types):
            raise ValueError(f"{path.name}: no UFF dataset found (no '    -1' delimiters)")
        self.sets: dict[str, int] = {}
        self.alias: dict[str, str] = {}
        self.cache: dict[str, NDArray[np.float64]] = {}
        rates: dict[str, float] = {}
        by_nd: dict[str, list[str]] = {}  # NODE:DIR -> the records there
        skipped = 0
        for i in np.flatnonzero(types == 58):
            h = self._header(int(i))
            if int(h.get("func_type", 0)) != 1 or int(h.get("abscissa_spacing", 1)) != 1:
                skipped += 1
                continue
            name = str(h.get("id1", "")).strip() or f"record {i}"
            nd = node_dir(h.get("rsp_node", 0), h.get("rsp_dir", 0))
            if name in self.sets:
                name = nd if nd not in self.sets else f"{name} #{i}"
            self.sets[name] = int(i)
            self.lengths[name] = int(h.get("num_pts", 0))
            by_nd.setdefault(nd, []).append(name)
            unit = _ordinate_unit(h)
            if unit:
                self.units[name] = unit
            inc = float(h.get("abscissa_inc", 0.0))
            if not inc > 0:
                raise ValueError(f"{path.name}: record {name!r} has abscissa increment {inc!r}: no sample rate")
            rates[name] = 1.0 / inc
        if skipped:
            self.notes.append(f"{skipped} UFF58 record(s) that are not evenly sampled time responses were left out")
        if not self.sets:
            raise ValueError(f"{path.name}: no UFF58 time record (function type 1) in the file")
        # NODE:DIR names are channels too (the campaign's and the CLI's lookups see them); one
        # that several records share (two records on node 1 +Z) names none of them: ambiguous
        for nd, names in by_nd.items():
            if nd in self.sets:
                continue
            if len(names) > 1:
                self.ambiguous[nd] = names
                continue
            self.alias[nd] = names[0]
            self.lengths[nd] = self.lengths[names[0]]
            if names[0] in self.units:
                self.units[nd] = self.units[names[0]]
        snapped: dict[str, float] = {}
        for name, fs in rates.items():
            snapped[name] = rate_from_increment(1.0 / fs)
            if snapped[name] != fs:
                note = (f"UFF58 abscissa increment {1.0 / fs:.6g} s is the rounded inverse of {snapped[name]:g} Hz: "
                        f"that rate used (1/increment = {fs:.9g} Hz)")
                if note not in self.notes:
                    self.notes.append(note)
        for nd, name in self.alias.items():
            snapped[nd] = snapped[name]
        if len(set(snapped.values())) == 1:  # one rate for the file; else a record's channels share one
            self.fs_hz = next(iter(snapped.values()))
        else:
            self.rates = snapped

    def _header(self, i: int) -> dict[str, Any]:
        # pyuff's read_sets(header_only=True) splits the whole record into lines to keep 13 of
        # them (a second pass over the data); its header parser is given the record's first
        # 2 KB instead (13 lines of at most 80 characters and their line ends)
        try:
            from pyuff.datasets.dataset_58 import _extract58

            start = int(self.uff._block_ind[i][0])
            with open(self.path, "rb") as fh:
                fh.seek(start)
                head = fh.read(2048)
            return dict(_extract58(head, header_only=True))
        except Exception:
            pass
        try:
            return dict(self.uff.read_sets(i, header_only=True))
        except Exception as exc:
            raise ValueError(f"{self.path.name}: UFF record {i} has a malformed header: {type(exc).__name__}: {exc}") from None

    def is_integer(self, name: str) -> bool:
        return False  # pyuff gives float64 (and asking would parse the record)

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        name = self.alias.get(name, name)
        if name not in self.cache:
            try:
                d = self.uff.read_sets(self.sets[name])
                data = np.asarray(d["data"])
            except Exception as exc:
                raise ValueError(f"{self.path.name}: cannot read UFF record {name!r}: {type(exc).__name__}: {exc}") from None
            if np.iscomplexobj(data):
                raise ValueError(f"{self.path.name}: UFF record {name!r} holds complex values, not a time record")
            if len(data) != self.lengths[name]:
                raise ValueError(f"{self.path.name}: UFF record {name!r} holds {len(data)} values, its header says "
                                 f"{self.lengths[name]} (truncated file?)")
            self.cache[name] = data.astype(np.float64, copy=False)
        return self.cache[name][start:stop]

    def close(self) -> None:
        self.cache.clear()
