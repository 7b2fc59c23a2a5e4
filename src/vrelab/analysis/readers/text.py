"""Delimited text (CSV, TSV, semicolon or whitespace separated) through ``pyarrow.csv``, in blocks."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, ClassVar, Iterator, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    Source,
    register,
)
from vrelab.analysis.readers.units import header_unit


@register
class CsvSource(Source):
    """CSV (or TSV / semicolon / whitespace separated), with or without a header line.

    Parsed by ``pyarrow.csv.open_csv`` in streaming batches (no Python loop per row). Opening
    makes one pass to count rows and find empty cells; ``stream`` makes one pass per call.
    """

    fmt = "csv"
    extensions: ClassVar[tuple[str, ...]] = (".csv", ".tsv", ".txt", ".dat")
    has_magic = False  # text: chosen by extension
    random_access = False  # parsed from the start: read in passes, not by position

    @classmethod
    def channel_names(cls, path: Path) -> tuple[str, ...]:
        """The header's column names (no pass over the rows)."""
        return tuple(cls._sniff(path)[1])

    def _comment_header(self) -> None:
        """What a logger states in its comment lines before the column names (PicoQuake:
        ``# Config: data_rate = 2000.0 Hz, filter = 488 Hz, acc_range = 4 g, gyro_range = 250.0 dps``):
        the sample rate (used, and said), the accelerometer's unit from its range (``a_x`` in g)
        and the gyro's (``g_x`` in dps: not an acceleration, whatever its name suggests)."""
        with open(self.path, "rb") as fh:
            head = fh.read(65536).decode("utf-8-sig", errors="replace")
        comments = [ln.lstrip()[1:].strip() for ln in head.splitlines()[: self.skip_comments]
                    if ln.lstrip().startswith("#")]
        text = " ".join(comments)
        m = _RATE.search(text)
        if m:
            fs = float(m.group(2)) * (1000.0 if m.group(3).lower() == "khz" else 1.0)
            if fs > 0 and math.isfinite(fs):
                self.fs_hz = fs
                self.notes.append(f"sample rate {fs:g} Hz from the file's comment header ({m.group(0).strip()!r})")
        for what, pattern in (("acc", _ACC_COLUMN), ("gyro", _GYRO_COLUMN)):
            r = re.search(rf"\b{what}\w*_range\s*[=:]\s*[0-9.eE+-]+\s*([A-Za-z/°²^0-9]+)", text, re.IGNORECASE)
            if not r:
                continue
            for name in self.names:
                if name not in self.units and pattern.fullmatch(name.strip()):
                    self.units[name] = r.group(1)
                    self.header_units.add(name)

    @staticmethod
    def _sniff(path: Path) -> tuple[str, list[str], bool, int]:
        """(delimiter, names, has_header, lines to skip before the header) from the file's head."""
        with open(path, "rb") as fh:
            head = fh.read(65536).decode("utf-8-sig", errors="replace")
        lines = [ln for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
        if not lines:
            raise ValueError(f"{path.name}: CSV file has no data lines")
        first = lines[0]
        delim = next((d for d in (",", "\t", ";") if d in first), " ")
        cells = [c.strip().strip('"') for c in (first.split() if delim == " " else first.split(delim))]
        has_header = any(not _is_number(c) for c in cells)
        names = cells if has_header else [str(i) for i in range(len(cells))]
        return delim, names, has_header, head.splitlines().index(first)

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.delim, self.names, self.has_header, self.skip_comments = self._sniff(path)
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"{path.name}: duplicate column names in the header: {self.names}")
        self.columns = list(self.names)  # every column of a row, channels or not
        self.decimal_point = "."
        for name in self.names:  # a header's unit: "Acceleration x (m/s^2)"
            unit = header_unit(name)
            if unit:
                self.units[name] = unit
                self.header_units.add(name)
        if self.skip_comments:
            self._comment_header()
        self._scan()

    def _scan(self) -> None:
        """One pass: the row count, and each column's length (empty cells only at its end)."""
        path = self.path
        n = 0
        first_null: dict[str, int] = {}
        last_valid: dict[str, int] = {}
        for batch in self._batches(self.names):
            for i, name in enumerate(self.names):
                col = batch.column(i)
                if col.null_count:
                    valid = np.asarray(col.is_valid())
                    if name not in first_null and not valid.all():
                        first_null[name] = n + int(np.argmin(valid))
                    if valid.any():
                        last_valid[name] = n + int(np.flatnonzero(valid)[-1])
                else:
                    last_valid[name] = n + len(col) - 1
            n += batch.num_rows
        if n == 0:
            raise ValueError(f"{path.name}: CSV file has a header but no samples")
        for name in self.names:
            ln = last_valid.get(name, -1) + 1
            fn = first_null.get(name)
            if fn is not None and fn < ln:
                raise ValueError(f"{path.name}: column {name!r} has an empty value at row {fn}")
            self.lengths[name] = ln
        self.n_rows = n

    def _batches(self, names: Sequence[str]) -> Iterator[Any]:
        import pyarrow as pa
        from pyarrow import csv as pacsv

        ro = pacsv.ReadOptions(
            column_names=self.columns,
            skip_rows=self.skip_comments + (1 if self.has_header else 0),
            block_size=1 << 20,  # larger blocks make the reader hold ~40x the block size
            use_threads=False,
        )
        po = pacsv.ParseOptions(delimiter=self.delim if self.delim != " " else " ", ignore_empty_lines=True)
        co = pacsv.ConvertOptions(
            column_types={c: pa.float64() for c in names},
            include_columns=list(names),
            null_values=[""],
            strings_can_be_null=True,
            decimal_point=self.decimal_point,
        )
        try:
            reader = pacsv.open_csv(self.path, read_options=ro, parse_options=po, convert_options=co)
            yield from reader
        except pa.ArrowInvalid as exc:
            msg = str(exc).splitlines()[0]
            raise ValueError(f"{self.path.name}: cannot parse {self.fmt.upper()} (truncated or malformed row?): {msg}") from None

    def stream(self, names: Sequence[str], start: int, stop: int, block: int) -> Iterator[dict[str, NDArray[Any]]]:
        pos = 0
        for batch in self._batches(names):
            m = batch.num_rows
            a, b = max(start - pos, 0), min(stop - pos, m)
            if b > a:
                cols = {n: batch.column(i).to_numpy(zero_copy_only=False) for i, n in enumerate(names)}
                for j in range(a, b, block):  # a parsed batch may hold more rows than a block
                    yield {n: c[j : min(j + block, b)] for n, c in cols.items()}
            pos += m
            if pos >= stop:
                break

    def is_integer(self, name: str) -> bool:
        return False  # parsed as float64: a text file's numbers carry no ADC type

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        return np.concatenate([b[name] for b in self.stream([name], start, stop, stop - start)] or [np.empty(0)])


# a rate stated in a comment line: "data_rate = 2000.0 Hz", "sample rate: 1 kHz", "fs = 512 Hz"
_RATE = re.compile(r"\b(data[ _]?rate|sample[ _]?rate|sampling[ _]?rate|sampling[ _]?frequency|fs)\s*[=:]\s*"
                   r"([0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?)\s*(k?hz)\b", re.IGNORECASE)
# the columns a stated range is the unit of: accelerometer a_x / acc_x / accel_x, gyro g_x / gyro_x / gyr_x
_ACC_COLUMN = re.compile(r"(?:a|acc|accel)[ _]?[xyz]", re.IGNORECASE)
_GYRO_COLUMN = re.compile(r"(?:g|gyr|gyro)[ _]?[xyz]", re.IGNORECASE)


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False
