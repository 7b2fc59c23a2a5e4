"""MATLAB ``.mat`` files, v7.3 (HDF5) and v4/v5 (scipy)."""

from __future__ import annotations

import re
import struct
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    FS_KEYS,
    HDF5_MAGIC,
    Source,
    column_channels,
    register,
    spec_length,
    spec_slice,
)


@register
class MatSource(Source):
    """MATLAB ``.mat``: v7.3 is HDF5 behind a 512-byte text header (read by slices through
    :class:`~vrelab.analysis.readers.hdf5.Hdf5Source`); v5 (the ``MATLAB`` text header) and v4
    (no text header: a matrix header first) go through ``scipy.io.loadmat``, which reads the
    whole file."""

    fmt = "mat"
    extensions = (".mat",)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"MATLAB") or _is_mat4(head)

    @classmethod
    def open(cls, path: Path) -> Source:
        from vrelab.analysis.readers.hdf5 import Hdf5Source

        with open(path, "rb") as fh:
            head = fh.read(8)
            fh.seek(512)
            is_h5 = head.startswith(b"MATLAB") and fh.read(8) == HDF5_MAGIC
        if is_h5:
            return Hdf5Source(path, matlab=True)
        return MatV5Source(path) if head.startswith(b"MATLAB") else MatV4Source(path)


_MAT4_NAME = re.compile(rb"[A-Za-z_][A-Za-z0-9_]*\0")


def _is_mat4(head: bytes) -> bool:
    """Whether ``head`` starts as a MAT v4 file: its first matrix header, five int32 (type MOPT,
    rows, columns, imaginary flag, name length) in the byte order MOPT's M digit states (0 little,
    1 big endian), then the matrix's NUL-terminated name (MATLAB's "MAT-File Format", v4 section).
    scipy's own test (a zero among the first four bytes) would claim far too many files."""
    if len(head) < 22:
        return False
    for order, m in (("<", 0), (">", 1)):
        mopt, rows, cols, imagf, namlen = struct.unpack(order + "5i", head[:20])
        if not (0 <= mopt < 5000 and mopt // 1000 == m):
            continue
        o, p, t = mopt // 100 % 10, mopt // 10 % 10, mopt % 10
        if o == 0 and p <= 5 and t <= 2 and rows >= 0 and cols >= 0 and imagf in (0, 1) and 2 <= namlen <= 64:
            return _MAT4_NAME.fullmatch(head[20 : 20 + namlen]) is not None
    return False


# the numeric classes MATLAB states for a variable (scipy.io.whosmat), as numpy dtypes
_MAT_CLASS = {"double": np.float64, "single": np.float32}


class MatV5Source(Source):
    """MAT v4 and v5 through ``scipy.io.loadmat``, each variable of the class MATLAB states:
    MATLAB stores a double matrix of whole numbers compactly (as uint8, ...), which is still a
    double, not counts; an int16 variable stays int16. The class comes from ``scipy.io.whosmat``
    rather than loadmat's ``mat_dtype=True``, which casts a complex double to its real part."""

    fmt = "mat-v5"

    def __init__(self, path: Path) -> None:
        from scipy.io import loadmat, whosmat

        super().__init__(path)
        version = self.fmt.removeprefix("mat-")
        try:
            data = loadmat(path, squeeze_me=False)
            classes = {name: cls for name, _, cls in whosmat(path)}
        except Exception as exc:  # scipy raises several types on a bad file
            raise ValueError(f"{path.name}: cannot read as MATLAB {version} file (truncated or corrupt?): {exc}") from None
        self.notes.append(f"MAT {version} file read whole into memory (scipy.io.loadmat); save with -v7.3 for long records")
        self.arrays: dict[str, tuple[Any, Any]] = {}
        for k, v in list(data.items()):
            if not k.startswith("__") and isinstance(v, np.ndarray) and v.dtype.names:
                data.update(_struct_fields(k, v))
        for k, v in data.items():
            if k.startswith("__") or not isinstance(v, np.ndarray) or v.dtype.kind not in "biuf":
                continue
            stated = _MAT_CLASS.get(classes.get(k, ""))
            if stated is not None and v.dtype.kind in "biu":
                v = v.astype(stated)  # whole numbers stored compactly: exact in the stated class
            if v.size == 1:
                if k in FS_KEYS:
                    self.fs_hz = float(v.ravel()[0])
                continue
            for name, spec in column_channels(k, v).items():
                self.arrays[name] = spec
                self.lengths[name] = spec_length(spec)

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        return spec_slice(self.arrays[name], start, stop)


def _struct_fields(name: str, v: NDArray[Any], depth: int = 0) -> dict[str, Any]:
    """The arrays inside a MATLAB struct (DAQ exports keep their signals there:
    ``data.accel``), named ``struct.field`` (``struct(2).field`` for an element of a struct
    array, 1-based as MATLAB writes it), nested structs walked up to 8 deep."""
    out: dict[str, Any] = {}
    if depth > 8 or not v.dtype.names:
        return out
    flat = v.ravel(order="F")  # MATLAB's column-major element order
    for i, elem in enumerate(flat):
        base = name if flat.size == 1 else f"{name}({i + 1})"
        for f in v.dtype.names:
            x = elem[f]
            if isinstance(x, np.ndarray) and x.dtype.names:
                out.update(_struct_fields(f"{base}.{f}", x, depth + 1))
            elif isinstance(x, np.ndarray):
                out[f"{base}.{f}"] = x
    return out


class MatV4Source(MatV5Source):
    """MAT v4 (MATLAB 4 and ``save -v4``): read as v5 is, by ``scipy.io.loadmat``."""

    fmt = "mat-v4"
