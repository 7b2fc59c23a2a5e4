"""MATLAB ``.mat`` files, v7.3 (HDF5) and v4/v5 (scipy)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    _FS_KEYS,
    HDF5_MAGIC,
    Source,
    _column_channels,
    _length,
    _slice,
    register,
)


@register
class MatSource(Source):
    """MATLAB ``.mat``: v7.3 is HDF5 behind a 512-byte text header (read by slices through
    :class:`~vrelab.analysis.readers.hdf5.Hdf5Source`); v4/v5 go through ``scipy.io.loadmat``,
    which reads the whole file."""

    fmt = "mat"
    extensions = (".mat",)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"MATLAB")

    @classmethod
    def open(cls, path: Path) -> Source:
        from vrelab.analysis.readers.hdf5 import Hdf5Source

        with open(path, "rb") as fh:
            fh.seek(512)
            is_h5 = fh.read(8) == HDF5_MAGIC
        return Hdf5Source(path, matlab=True) if is_h5 else MatV5Source(path)


class MatV5Source(Source):
    fmt = "mat-v5"

    def __init__(self, path: Path) -> None:
        from scipy.io import loadmat

        super().__init__(path)
        try:
            data = loadmat(path, squeeze_me=False)
        except Exception as exc:  # scipy raises several types on a bad file
            raise ValueError(f"{path.name}: cannot read as MATLAB v5 file (truncated or corrupt?): {exc}") from None
        self.notes.append("MAT v5 file read whole into memory (scipy.io.loadmat); save with -v7.3 for long records")
        self.arrays: dict[str, tuple[Any, Any]] = {}
        for k, v in data.items():
            if k.startswith("__") or not isinstance(v, np.ndarray) or v.dtype.kind not in "biuf":
                continue
            if v.size == 1:
                if k in _FS_KEYS:
                    self.fs_hz = float(v.ravel()[0])
                continue
            for name, spec in _column_channels(k, v).items():
                self.arrays[name] = spec
                self.lengths[name] = _length(spec)

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        return _slice(self.arrays[name], start, stop)
