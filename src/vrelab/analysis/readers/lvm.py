"""LabVIEW measurement files (LVM text), as LabVIEW's Write To Measurement File writes them.

Written here: no maintained PyPI library reads LVM while streaming (``lvm_read`` loads the whole
file into Python lists). The layout (NI, "The LabVIEW Measurement (.lvm) file format"): a file
header from ``LabVIEW Measurement`` to ``***End_of_Header***`` (``Separator`` Tab or Comma,
``Decimal_Separator``, ``X_Columns`` No/One/Multi), then a segment header (``Channels``,
``Samples``, ``Delta_X`` and ``Y_Unit_Label`` per channel, ...) ending with ``***End_of_Header***``, the column
names line (``X_Value``, channel names, ``Comment``) and the rows. One segment is read; a file
with several segments is refused (each segment restarts its time base). The sample rate is
``1/Delta_X`` (snapped to the nominal rate when written rounded); channels may differ, the two
a record reads must share one. ``Y_Unit_Label`` is each channel's unit. Rows are parsed in streaming batches by pyarrow,
as CSV is (:class:`~vrelab.analysis.readers.text.CsvSource`), the decimal comma included.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

from vrelab.analysis.readers._base import Source, register, significant_digits, snap_rate
from vrelab.analysis.readers.text import CsvSource

_END = "***End_of_Header***"
_SEPARATORS = {"tab": "\t", "comma": ",", "semicolon": ";", "space": " "}


@register
class LvmSource(CsvSource):
    fmt = "lvm"
    extensions: ClassVar[tuple[str, ...]] = (".lvm",)
    has_magic = True
    random_access = False

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.lstrip(b"\xef\xbb\xbf").startswith(b"LabVIEW Measurement")

    @classmethod
    def channel_names(cls, path: Path) -> tuple[str, ...]:
        return tuple(cls(path, header_only=True).names)

    def __init__(self, path: Path, header_only: bool = False) -> None:  # noqa: D107  (not CsvSource's sniffing)
        Source.__init__(self, path)
        lines: list[str] = []
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            for line in fh:
                lines.append(line.rstrip("\r\n"))
                if sum(1 for x in lines if x.split("\t")[0].split(",")[0].strip() == _END) == 2:
                    lines.append(fh.readline().rstrip("\r\n"))  # the column names
                    lines.append(fh.readline().rstrip("\r\n"))  # the first row
                    break
                if len(lines) > 10_000:
                    break
        ends = [i for i, x in enumerate(lines) if x.split("\t")[0].split(",")[0].strip() == _END]
        if len(ends) < 2:
            raise ValueError(f"{path.name}: LVM header incomplete (no segment header ending in {_END})")
        file_head = self._table(lines[: ends[0]])
        sep_name = file_head.get("Separator", ["Tab"])[0].strip().lower()
        if sep_name not in _SEPARATORS:
            raise ValueError(f"{path.name}: LVM Separator {sep_name!r} not understood (Tab or Comma)")
        self.delim = _SEPARATORS[sep_name]
        self.decimal_point = (file_head.get("Decimal_Separator", ["."])[0] or ".")[0]
        seg = self._table(lines[ends[0] + 1 : ends[1]])
        names_line = lines[ends[1] + 1] if len(lines) > ends[1] + 1 else ""
        cols = [c.strip() for c in names_line.split(self.delim)]
        if not cols or cols[0] == "":
            raise ValueError(f"{path.name}: LVM file has no column names line after the segment header")
        first_row = lines[ends[1] + 2] if len(lines) > ends[1] + 2 else ""
        n_cells = len(first_row.split(self.delim))
        if cols[-1] == "Comment" and n_cells == len(cols) - 1:
            cols = cols[:-1]  # rows without a comment cell (LabVIEW writes none when there is none)
        # unique names (X_Columns = Multi repeats X_Value): later copies numbered
        seen: dict[str, int] = {}
        self.columns = []
        for c in cols:
            seen[c] = seen.get(c, 0) + 1
            self.columns.append(c if seen[c] == 1 else f"{c}_{seen[c]}")
        self.names = [c for c in self.columns if c and not c.startswith("X_Value") and c != "Comment"]
        self.has_header = True
        self.skip_comments = ends[1] + 1
        self._rates(seg)
        if header_only:
            return
        self._scan()
        self.lengths = {n: self.lengths[n] for n in self.names}

    def _rates(self, seg: dict[str, list[str]]) -> None:
        """Each channel's rate from its ``Delta_X`` (snapped where the increment was written
        rounded: ``0.000977`` is 1/1024 s) and its unit from ``Y_Unit_Label``; one rate for the
        file when every channel shares it, else per channel (a record's channels must share one)."""
        path = self.path
        cells = self._per_channel(seg.get("Delta_X", []))
        if not any(cells.values()):
            raise ValueError(f"{path.name}: LVM segment header has no Delta_X: no sample rate")
        for name, text in cells.items():
            if not text:
                continue
            try:
                dx = float(text.replace(self.decimal_point, "."))
            except ValueError:
                raise ValueError(f"{path.name}: LVM Delta_X {text!r} of {name!r} is not a number") from None
            if not dx > 0:
                raise ValueError(f"{path.name}: LVM Delta_X must be > 0, got {dx} for {name!r}")
            fs = snap_rate(dx, significant_digits(text))
            if fs != 1.0 / dx:
                note = (f"LVM Delta_X {text} s is the rounded inverse of {fs:g} Hz: that rate used "
                        f"(1/Delta_X = {1.0 / dx:.9g} Hz)")
                if note not in self.notes:
                    self.notes.append(note)
            self.rates[name] = fs
        for name, unit in self._per_channel(seg.get("Y_Unit_Label", [])).items():
            if unit:
                self.units[name] = unit
        if len(set(self.rates.values())) == 1:
            self.fs_hz = next(iter(self.rates.values()))
            self.rates = {}

    def _per_channel(self, cells: list[str]) -> dict[str, str]:
        """A segment header row's cells by channel. The row's label stands where the first
        column's name stands, so cell k lies over column k + 1 when the columns start with
        ``X_Value`` (``X_Columns`` One or Multi: with Multi, each channel's own ``X_Value``
        column has a blank cell, ``Volts<tab><tab>g``) and over column k when they do not
        (``X_Columns`` No). Matched by position among the channels alone, a Multi file's second
        channel took the blank of the first one's X column (its unit ``g`` dropped)."""
        shift = 1 if self.columns and self.columns[0].startswith("X_Value") else 0
        out: dict[str, str] = {}
        for k, text in enumerate(cells):
            j = k + shift
            if j < len(self.columns) and self.columns[j] in self.names:
                out[self.columns[j]] = text.strip()
        return out

    @staticmethod
    def _table(lines: list[str]) -> dict[str, list[str]]:
        out: dict[str, list[str]] = {}
        for line in lines:
            cells = line.split("\t") if "\t" in line else line.split(",")
            if cells and cells[0].strip():
                out[cells[0].strip()] = cells[1:]
        return out

    def _scan(self) -> None:
        # a second segment header in the rows is a row that does not parse: say what it is
        try:
            super()._scan()
        except ValueError as exc:
            with open(self.path, encoding="utf-8-sig", errors="replace") as fh:
                n_end = sum(1 for line in fh if line.startswith(_END))
            if n_end > 2:
                raise ValueError(f"{self.path.name}: LVM file holds {n_end - 1} segments; one is read (export "
                                 "each segment on its own)") from None
            raise exc
