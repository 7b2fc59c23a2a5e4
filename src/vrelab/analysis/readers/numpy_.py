"""NumPy ``.npy`` (memory-mapped) and ``.npz`` (stored members memory-mapped, compressed ones read whole)."""

from __future__ import annotations

import struct
import zipfile
from pathlib import Path
from types import EllipsisType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    FS_KEYS,
    ArraySource,
    column_channels,
    register,
)


@register
class NpySource(ArraySource):
    fmt = "npy"
    extensions = (".npy",)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"\x93NUMPY")

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
        self.add(column_channels("", arr))


def _npy_header(fh: Any, version: tuple[int, int]) -> tuple[tuple[int, ...], bool, np.dtype]:
    fmt = np.lib.format
    if version == (1, 0):
        return fmt.read_array_header_1_0(fh)
    return fmt.read_array_header_2_0(fh)


def _npz_member_memmap(path: Path, zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.memmap:
    """Memory-map an uncompressed (stored) .npy member of a zip archive, in place."""
    with open(path, "rb") as fh:
        fh.seek(info.header_offset)
        hdr = fh.read(30)
        if hdr[:4] != b"PK\x03\x04":
            raise ValueError(f"{path.name}: bad zip member header for {info.filename}")
        n_name, n_extra = struct.unpack("<HH", hdr[26:30])
        data_start = info.header_offset + 30 + n_name + n_extra
        fh.seek(data_start)
        version = np.lib.format.read_magic(fh)
        shape, fortran, dtype = _npy_header(fh, version)
        offset = fh.tell()
    if dtype.hasobject:
        raise ValueError(f"{path.name}: member {info.filename} holds Python objects, not numbers")
    return np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=shape, order="F" if fortran else "C")


@register
class NpzSource(ArraySource):
    fmt = "npz"
    extensions = (".npz",)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"PK\x03\x04") or head.startswith(b"PK\x05\x06")

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self._npz = None
        self._loaded: dict[str, NDArray[Any]] = {}
        with zipfile.ZipFile(path) as zf:
            infos = [i for i in zf.infolist() if i.filename.endswith(".npy")]
            if not infos:
                raise ValueError(f"{path.name}: NPZ archive holds no .npy arrays")
            compressed = []
            for info in infos:
                name = info.filename[:-4]
                if info.compress_type == zipfile.ZIP_STORED:
                    arr: Any = _npz_member_memmap(path, zf, info)
                else:
                    compressed.append(name)
                    arr = _LazyMember(path, info.filename)
                if arr.ndim == 0 or arr.shape == (1,) or arr.shape == (1, 1):
                    if name in FS_KEYS:
                        self.fs_hz = float(np.asarray(arr[...]).ravel()[0])
                    continue
                chans = column_channels(name if len(infos) > 1 or arr.ndim == 1 else "", arr)
                if arr.ndim == 1 and not arr.dtype.names:
                    chans = {name: (arr, None)}
                self.add(chans)
        if compressed:
            self.notes.append(
                f"compressed NPZ members ({', '.join(compressed)}) cannot be memory-mapped: each one read is loaded whole"
            )


class _LazyMember:
    """A compressed NPZ member: loaded whole on first slice (zip deflate has no random access)."""

    def __init__(self, path: Path, member: str) -> None:
        self.path, self.member = path, member
        with zipfile.ZipFile(path) as zf, zf.open(member) as fh:
            version = np.lib.format.read_magic(fh)
            self.shape, _, self.dtype = _npy_header(fh, version)
        self.ndim = len(self.shape)
        self._arr: NDArray[Any] | None = None

    # what spec_slice and the fs lookup ask: a range of rows, a row or column's range, or all
    def __getitem__(self, key: slice | tuple[int | slice, int | slice] | EllipsisType) -> NDArray[Any]:
        if self._arr is None:
            with zipfile.ZipFile(self.path) as zf, zf.open(self.member) as fh:
                self._arr = np.lib.format.read_array(fh, allow_pickle=False)
        return self._arr[key]
