"""NI TDMS through npTDMS (``TdmsFile.open``: channels read by slices, never whole)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    Source,
    register,
)


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
            self.f = TdmsFile.open(path)
        except Exception as exc:  # npTDMS raises ValueError/EOFError/struct.error on bad files
            raise ValueError(f"{path.name}: cannot read as TDMS (truncated or corrupt file?): {exc}") from None
        self.chans: dict[str, Any] = {}
        rates = set()
        for g in self.f.groups():
            for ch in g.channels():
                if ch.dtype is None or np.dtype(ch.dtype).kind not in "biuf":
                    continue
                name = f"{g.name}/{ch.name}"
                self.chans[name] = ch
                self.lengths[name] = len(ch)
                inc = ch.properties.get("wf_increment")
                if inc:
                    rates.add(round(1.0 / float(inc), 9))
        if len(rates) > 1:
            raise ValueError(f"{path.name}: channels have different wf_increment rates: {sorted(rates)}")
        if rates:
            self.fs_hz = rates.pop()

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        try:
            return np.asarray(self.chans[name][start:stop])
        except Exception as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at samples {start}-{stop}: {exc}") from None

    def close(self) -> None:
        self.f.close()
