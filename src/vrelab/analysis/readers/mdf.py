"""ASAM MDF (version 4, and 3) through asammdf, as data loggers write it.

Channels: every numeric channel that is not a group's master (time), by its name, or
``<group>/<name>`` when the name occurs in several groups. Values are physical (the channel's
conversion applied, ``raw=False``). The sample rate comes from the master channel of each used
channel's group: checked evenly spaced (1e-6 relative), and one rate for every channel read.

Memory: reads are record ranges (``get(record_offset=, record_count=)``), so a stretch costs
the records it spans, not the file; opening reads the file's metadata (asammdf's ``MDF``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import Source, one_rate, register

_EVEN_RTOL = 1e-6


@register
class MdfSource(Source):
    fmt = "mdf"
    extensions = (".mf4", ".mdf")

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"MDF     ")

    def __init__(self, path: Path) -> None:
        from asammdf import MDF

        super().__init__(path)
        try:
            self.mdf = MDF(str(path))
        except Exception as exc:
            raise ValueError(f"{path.name}: cannot read as MDF: {type(exc).__name__}: {exc}") from None
        self.where: dict[str, tuple[int, int]] = {}
        self._rates: dict[int, float | None] = {}
        masters = {i: g.channel_group for i, g in enumerate(self.mdf.groups)}
        for name, places in self.mdf.channels_db.items():
            for gi, ci in places:
                grp = self.mdf.groups[gi]
                ch = grp.channels[ci]
                if ci == self._master_index(gi) or getattr(ch, "channel_type", 0) in (2, 3):
                    continue
                if not self._numeric(gi, ci):
                    continue
                key = name if len(places) == 1 else f"{gi}/{name}"
                self.where[key] = (gi, ci)
                self.lengths[key] = int(masters[gi].cycles_nr)
        if not self.where:
            raise ValueError(f"{path.name}: no numeric MDF channel")

    def _master_index(self, gi: int) -> int | None:
        try:
            return self.mdf.masters_db.get(gi)
        except AttributeError:
            return None

    def _numeric(self, gi: int, ci: int) -> bool:
        try:
            s = self.mdf.get(group=gi, index=ci, record_offset=0, record_count=1)
        except Exception:
            return False
        return np.asarray(s.samples).dtype.kind in "biuf"

    def rate(self, name: str) -> float:
        """The sample rate of ``name``'s group, from its master channel (checked evenly spaced)."""
        gi, _ = self.where[name]
        if gi not in self._rates:
            t = np.asarray(self.mdf.get_master(gi), dtype=np.float64)
            d = np.diff(t)
            if len(d) == 0 or not (d > 0).all():
                raise ValueError(f"{self.path.name}: group {gi}'s time channel is not increasing")
            dt = float(np.median(d))
            bad = np.flatnonzero(np.abs(d - dt) > _EVEN_RTOL * dt + 1e-12)
            if len(bad):
                raise ValueError(f"{self.path.name}: group {gi} is not evenly sampled (step {d[bad[0]]:.9g} s "
                                 f"at record {bad[0] + 1}, expected {dt:.9g} s)")
            self._rates[gi] = (len(t) - 1) / (t[-1] - t[0])
        return float(self._rates[gi])  # type: ignore[arg-type]

    def select(self, names: Sequence[str]) -> None:
        fs = one_rate(self.path, {n: self.rate(n) for n in names if n in self.where}, 1e-9)
        if fs is not None:
            self.fs_hz = fs

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        gi, ci = self.where[name]
        try:
            s = self.mdf.get(group=gi, index=ci, record_offset=int(start), record_count=int(stop - start))
        except Exception as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at records {start}-{stop}: {exc}") from None
        return np.asarray(s.samples)

    def close(self) -> None:
        self.mdf.close()
