"""ASAM MDF (version 4, and 3) through asammdf, as data loggers write it.

Channels: every numeric channel that is not a group's master (time), by its name, or
``<group>/<name>`` when the name occurs in several groups. Values are physical (the channel's
conversion applied, ``raw=False``), in the channel's unit. The sample rate is fitted to the
master channel (time stamps) of each used channel's group: jitter below half a sample is said in
the notes, a gap refused (:func:`~vrelab.analysis.readers._base.stamped_rate`); the channels read
must share one rate; ``--fs`` overrides the stamps.

Memory: reads are record ranges (``get(record_offset=, record_count=)``), so a stretch costs
the records it spans, not the file; opening reads the file's metadata (asammdf's ``MDF``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import Source, one_rate, register, stamped_rate

# a logger stamps each record: a step more than half a sample off the fitted rate is a gap, and
# stamps more than a sample off one straight line are not one rate
_GAP_SAMPLES = 0.5
_DRIFT_SAMPLES = 1.0


@register
class MdfSource(Source):
    fmt = "mdf"
    extensions = (".mf4", ".mdf")
    requires = "asammdf"

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
        """The sample rate of ``name``'s group, fitted to its master channel's time stamps:
        jitter well below a sample (a logger's ns on 1 ms steps) is accepted and said in the
        notes; a step half a sample off, or stamps drifting a sample off one rate, is refused."""
        gi, _ = self.where[name]
        if gi not in self._rates:
            t = np.asarray(self.mdf.get_master(gi), dtype=np.float64)
            fs, note = stamped_rate(f"{self.path.name}: group {gi}", np.arange(len(t)), t,
                                    gap_samples=_GAP_SAMPLES, drift_samples=_DRIFT_SAMPLES)
            if note and note not in self.notes:
                self.notes.append(note)
            self._rates[gi] = fs
        return float(self._rates[gi])  # type: ignore[arg-type]

    def select(self, names: Sequence[str], fs_hz: float | None = None) -> None:
        names = [n for n in names if n in self.where]
        if fs_hz is not None:
            # the user's rate (--fs) overrides the stamps: they are checked only to say so
            for n in names:
                try:
                    fs = self.rate(n)
                    self.notes.append(f"--fs {fs_hz:g} Hz used; {n!r}'s time stamps give {fs:.9g} Hz")
                except ValueError as exc:
                    self.notes.append(f"--fs {fs_hz:g} Hz used; {exc}")
            self.fs_hz = None
            return
        fs = one_rate(self.path, {n: self.rate(n) for n in names}, 1e-6)
        if fs is not None:
            self.fs_hz = fs

    def rate_of(self, name: str) -> float | None:
        return self.rate(name)

    def unit_of(self, name: str) -> str | None:
        """The channel's physical unit (its conversion's, else its own), None when blank."""
        gi, ci = self.where[name]
        try:
            unit = str(self.mdf.get(group=gi, index=ci, record_offset=0, record_count=1).unit or "").strip()
        except Exception:
            return None
        return unit or None

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        gi, ci = self.where[name]
        try:
            s = self.mdf.get(group=gi, index=ci, record_offset=int(start), record_count=int(stop - start))
        except Exception as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at records {start}-{stop}: {exc}") from None
        return np.asarray(s.samples)

    def close(self) -> None:
        self.mdf.close()
