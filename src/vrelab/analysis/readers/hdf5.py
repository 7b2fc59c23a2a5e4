"""HDF5 through h5py (datasets read by slices; vrelab's own records carry their schedule and meta)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab._load import json_loads
from vrelab.analysis.readers._base import (
    DT_KEYS,
    FS_KEYS,
    HDF5_MAGIC,
    ArraySource,
    column_channels,
    register,
)
from vrelab.record import Schedule


def _find_rate_h5(obj: Any) -> float | None:
    while obj is not None:
        for k in FS_KEYS:
            if k in obj.attrs:
                return float(np.asarray(obj.attrs[k]).ravel()[0])
        for k in DT_KEYS:
            if k in obj.attrs:
                dt = float(np.asarray(obj.attrs[k]).ravel()[0])
                return 1.0 / dt if dt > 0 else None
        obj = obj.parent if obj.name != "/" else None
    return None


@register
class Hdf5Source(ArraySource):
    fmt = "hdf5"
    extensions = (".h5", ".hdf5", ".hdf", ".he5", ".nc")

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(HDF5_MAGIC)

    def __init__(self, path: Path, matlab: bool = False) -> None:
        import h5py

        super().__init__(path)
        if matlab:
            self.fmt = "mat-v7.3"  # type: ignore[misc]  # this instance's format name: MATLAB v7.3 is HDF5
        try:
            self.f = h5py.File(path, "r")
        except OSError as exc:
            raise ValueError(f"{path.name}: cannot open as HDF5 (truncated or corrupt file?): {exc}") from None
        dsets: list[Any] = []
        try:
            self.f.visititems(lambda name, obj: dsets.append(obj) if isinstance(obj, h5py.Dataset) else None)
        except (OSError, RuntimeError, KeyError) as exc:
            raise ValueError(f"{path.name}: cannot read HDF5 structure (truncated or corrupt file?): {exc}") from None
        for d in dsets:
            name = d.name.lstrip("/")
            if name == "schedule" or name.startswith("#refs#") or d.dtype.kind not in "biuf":
                if name == "schedule" and d.ndim == 2 and d.shape[1] == 4:
                    self.schedule = Schedule.from_array(d[()]) if d.shape[0] else None
                continue
            if d.size <= 1:
                if name.split("/")[-1] in FS_KEYS:
                    self.fs_hz = float(np.asarray(d[()]).ravel()[0])
                continue
            chans = column_channels(name, d)
            self.add(chans)
            unit = next((d.attrs[k] for k in ("unit", "units", "unit_string") if k in d.attrs), None)
            if isinstance(unit, bytes):
                unit = unit.decode(errors="replace")
            if isinstance(unit, str) and unit.strip():
                for c in chans:
                    self.units[c] = unit.strip()
        rates = {r for r in (_find_rate_h5(spec[0]) for spec in self.specs.values()) if r}
        if self.fs_hz is None and rates:
            if len(rates) > 1:
                raise ValueError(f"{path.name}: channels have different sample rates: {sorted(rates)}")
            self.fs_hz = rates.pop()
        if "meta" in self.f.attrs:
            try:
                self.meta = dict(json_loads(self.f.attrs["meta"], "attribute 'meta'"))
            except (TypeError, ValueError):
                self.notes.append("attribute 'meta' is not JSON: ignored")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        try:
            return super().read(name, start, stop)
        except OSError as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at samples {start}-{stop} (truncated file?): {exc}") from None

    def close(self) -> None:
        self.f.close()
