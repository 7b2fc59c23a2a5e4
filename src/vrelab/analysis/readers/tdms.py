"""NI TDMS through npTDMS (``TdmsFile.open``: channels read by slices, never whole).

Each channel's rate is ``1/wf_increment`` (snapped when stored rounded), its unit
``unit_string``; channels at several rates may share a file, a record's channels share one."""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path
from typing import Any, Iterator

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    MAX_CHANNELS,
    Source,
    register,
    snap_rate,
)


@contextlib.contextmanager
def _library_says(notes: list[str]) -> Iterator[None]:
    """What npTDMS logs while it reads (a truncated file's "Last segment of file has less data
    than expected"), as the source's notes rather than lines of its own on stderr: npTDMS puts
    its own console handler on each of its loggers (nptdms.log.LogManager)."""
    from nptdms.log import log_manager

    said: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            said.append(record.getMessage())

    h = Collect(logging.WARNING)
    loggers = list(log_manager.loggers.values())
    for lg in loggers:
        lg.removeHandler(log_manager.console_handler)
        lg.addHandler(h)
    try:
        yield
    finally:
        for lg in loggers:
            lg.removeHandler(h)
            lg.addHandler(log_manager.console_handler)
        for m in said:
            note = f"npTDMS: {m}"
            if note not in notes:
                notes.append(note)


def _rate(inc: float, notes: list[str]) -> float:
    """The rate of a ``wf_increment`` (snapped when it was stored rounded, with a note)."""
    fs = snap_rate(inc)
    if fs != 1.0 / inc:
        note = f"TDMS wf_increment {inc!r} s is the rounded inverse of {fs:g} Hz: that rate used"
        if note not in notes:
            notes.append(note)
    return fs


@register
class TdmsSource(Source):
    fmt = "tdms"
    extensions = (".tdms",)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"TDSm")

    def __init__(self, path: Path) -> None:
        from nptdms import TdmsFile

        super().__init__(path)
        try:
            with _library_says(self.notes):
                self.f = TdmsFile.open(path)
        except Exception as exc:  # npTDMS raises ValueError/EOFError/struct.error on bad files
            raise ValueError(f"{path.name}: cannot read as TDMS (truncated or corrupt file?): {exc}") from None
        self.chans: dict[str, Any] = {}
        self._rest: dict[str, Any] = {}  # channels beyond MAX_CHANNELS: named, not yet indexed
        for g in self.f.groups():
            for ch in g.channels():
                if len(self.chans) < MAX_CHANNELS:
                    self._index(f"{g.name}/{ch.name}", ch)
                else:
                    self._rest[f"{g.name}/{ch.name}"] = ch
        self.unlisted = len(self._rest)
        if self.unlisted:
            self.notes.append(f"{len(self.chans) + self.unlisted} channels or more: the first {len(self.chans)} "
                              f"indexed, {self.unlisted} more not listed (name one as group/channel to read it)")
        if len(set(self.rates.values())) == 1:  # one rate for the file; else each record's channels share one
            self.fs_hz = next(iter(self.rates.values()))
            self.rates = {}

    def _index(self, name: str, ch: Any) -> None:
        if ch.dtype is None or np.dtype(ch.dtype).kind not in "biuf":
            return
        self.chans[name] = ch
        self.lengths[name] = len(ch)
        inc = ch.properties.get("wf_increment")
        if inc:
            self.rates[name] = _rate(float(inc), self.notes)
        unit = str(ch.properties.get("unit_string", "") or "").strip()
        if unit:
            self.units[name] = unit

    def find(self, name: str) -> bool:
        ch = self._rest.pop(name, None)
        if ch is None:
            return False
        self._index(name, ch)
        if name in self.rates and self.fs_hz is not None:
            if self.rates[name] == self.fs_hz:
                del self.rates[name]  # the file's one rate
            else:  # no longer one rate for the file: each channel's own, as when opened so
                self.rates = {n: self.fs_hz for n in self.chans if n != name} | {name: self.rates[name]}
                self.fs_hz = None
        return name in self.chans

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        try:
            with _library_says(self.notes):
                return np.asarray(self.chans[name][start:stop])
        except Exception as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at samples {start}-{stop}: {exc}") from None

    def close(self) -> None:
        self.f.close()
