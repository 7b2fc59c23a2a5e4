"""Readers for recorded shaker tests: lab files as a streaming :class:`~vrelab.record.Record`.

:func:`open_record` opens CSV, NPY, NPZ, HDF5, NI TDMS, WAV (PCM, float, RF64) and MATLAB
(v7.3 through h5py, v5 through scipy) files read-only, picks the DUT and reference channels by
name, scales them to g, and returns a record whose ``blocks`` read lazily: memory is bounded by
the block size whatever the length of the file. Exceptions, said in ``meta["reader_notes"]``:
compressed NPZ members and MAT v5 files cannot be memory-mapped and are read whole (one member /
the file), 24-bit WAV is read whole (scipy cannot memory-map it).

Sample rate, in this order: the file's own (HDF5/MAT attributes or variables ``fs_hz``, ``fs``,
``sample_rate``, ``sampling_rate``, ``wf_increment`` (its inverse), TDMS ``wf_increment``, the
WAV header), else a time column (checked increasing and evenly spaced), else ``fs_hz``. A given
``fs_hz`` that disagrees with the file's is an error.

Every problem is a one-line ``ValueError``: unknown format, empty or truncated file, missing
channel (the message lists the channels that exist), mismatched channel lengths, a bad time
column (the first bad index), non-finite values (channel and first index, found while
streaming).
"""

from __future__ import annotations

import json
import math
import re
import struct
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab.record import Schedule

G0 = 9.80665  # standard gravity, m/s² per g
Units = Literal["g", "lsb", "mv", "v", "m/s2"]
UNITS: tuple[str, ...] = ("g", "lsb", "mv", "v", "m/s2")
_FS_KEYS = ("fs_hz", "fs", "Fs", "sample_rate", "sampling_rate", "sample_rate_hz", "rate")
_DT_KEYS = ("wf_increment", "dt", "sample_interval", "sampling_interval")
_TIME_NAMES = ("time", "t", "time_s", "times", "timestamp", "time_sec", "seconds")
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


@dataclass(frozen=True)
class Scale:
    """How raw channel values become g: ``g = raw / sensitivity`` (``m/s2``: raw / 9.80665).

    ``units`` is what the file holds: ``g`` (no scaling), ``lsb`` (counts; ``sensitivity`` in
    LSB/g, e.g. 256000 for an ADXL355 on ±2 g), ``mv`` or ``v`` (``sensitivity`` in mV/g or V/g,
    e.g. 10 mV/g for an IEPE reference), ``m/s2``.
    """

    units: Units = "g"
    sensitivity: float = 1.0

    def __post_init__(self) -> None:
        V.one_of("units", self.units, UNITS)
        V.positive_scalar("sensitivity", self.sensitivity)

    @classmethod
    def parse(cls, units: str | None, sensitivity: float | None, name: str = "channel") -> "Scale":
        """From CLI options: ``--dut-units lsb --dut-sensitivity 256000`` (units per g)."""
        u = (units or "g").strip().lower().replace("/", "").replace("²", "2")
        u = {"ms2": "m/s2", "mps2": "m/s2", "counts": "lsb", "count": "lsb"}.get(u, u)
        if u not in UNITS:
            raise ValueError(f"{name} units must be one of {', '.join(UNITS)}; got {units!r}")
        if u in ("lsb", "mv", "v"):
            if sensitivity is None:
                raise ValueError(f"{name} units {u!r} need a sensitivity ({u} per g)")
            return cls(u, V.positive_scalar(f"{name} sensitivity", sensitivity))  # type: ignore[arg-type]
        if sensitivity is not None:
            raise ValueError(f"{name} sensitivity given, but units are {u!r} (use lsb, mv or v)")
        return cls(u)  # type: ignore[arg-type]

    @property
    def divisor(self) -> float:
        if self.units == "g":
            return 1.0
        if self.units == "m/s2":
            return G0
        return float(self.sensitivity)

    def to_g(self, raw: NDArray[Any]) -> NDArray[np.float64]:
        x = np.asarray(raw, dtype=np.float64)
        d = self.divisor
        return x if d == 1.0 else x / d


def _as_scale(s: Scale | float | None) -> Scale:
    if s is None:
        return Scale()
    if isinstance(s, Scale):
        return s
    return Scale("lsb", V.positive_scalar("scale", s))


# ----------------------------------------------------------------------------- sources


class _Source:
    """Raw channels of one file: names, lengths, optional rate; random-access reads."""

    fmt = "?"

    def __init__(self, path: Path) -> None:
        self.path = path
        self.lengths: dict[str, int] = {}
        self.fs_hz: float | None = None
        self.notes: list[str] = []
        self.meta: dict[str, Any] = {}
        self.schedule: Schedule | None = None

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.lengths)

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        raise NotImplementedError

    def stream(self, names: Sequence[str], start: int, stop: int, block: int) -> Iterator[dict[str, NDArray[Any]]]:
        for i in range(start, stop, block):
            j = min(i + block, stop)
            yield {n: self.read(n, i, j) for n in names}

    def close(self) -> None:
        pass


def _column_channels(prefix: str, arr: Any) -> dict[str, tuple[Any, Any]]:
    """Channels of an array-like: 1-D -> itself; (N, C) -> columns; structured -> fields."""
    out: dict[str, tuple[Any, Any]] = {}
    dt = arr.dtype
    sep = "/" if prefix else ""
    if dt.names:
        for f in dt.names:
            out[f"{prefix}{sep}{f}"] = (arr, f)
        return out
    if arr.ndim == 1:
        out[prefix or "0"] = (arr, None)
    elif arr.ndim == 2:
        if 1 in arr.shape:
            out[prefix or "0"] = (arr, "squeeze")
        else:
            # (channels, samples) when the first axis is short and the second long
            by_row = arr.shape[0] <= 64 < arr.shape[1]
            for i in range(arr.shape[0] if by_row else arr.shape[1]):
                out[f"{prefix}{sep}{i}"] = (arr, ("row" if by_row else "col", i))
    return out


def _slice(spec: tuple[Any, Any], start: int, stop: int) -> NDArray[Any]:
    arr, how = spec
    if how is None:
        return np.asarray(arr[start:stop])
    if isinstance(how, str) and how == "squeeze":
        return np.asarray(arr[:, start:stop] if arr.shape[0] == 1 else arr[start:stop, 0]).ravel()
    if isinstance(how, tuple):
        kind, i = how
        return np.asarray(arr[i, start:stop] if kind == "row" else arr[start:stop, i])
    return np.asarray(arr[start:stop][how])


def _length(spec: tuple[Any, Any]) -> int:
    arr, how = spec
    if isinstance(how, str) and how == "squeeze":
        return int(max(arr.shape))
    if isinstance(how, tuple):
        return int(arr.shape[1] if how[0] == "row" else arr.shape[0])
    return int(arr.shape[0])


class _ArraySource(_Source):
    """Channels backed by array-likes that slice lazily (memmaps, h5py datasets)."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.specs: dict[str, tuple[Any, Any]] = {}

    def add(self, chans: Mapping[str, tuple[Any, Any]]) -> None:
        for name, spec in chans.items():
            arr, how = spec
            is_field = isinstance(how, str) and how != "squeeze"
            if (arr.dtype[how] if is_field else arr.dtype).kind not in "biuf":
                continue
            self.specs[name] = spec
            self.lengths[name] = _length(spec)

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        return _slice(self.specs[name], start, stop)


class NpySource(_ArraySource):
    fmt = "npy"

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
        self.add(_column_channels("", arr))


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


class NpzSource(_ArraySource):
    fmt = "npz"

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
                    if name in _FS_KEYS:
                        self.fs_hz = float(np.asarray(arr[...]).ravel()[0])
                    continue
                chans = _column_channels(name if len(infos) > 1 or arr.ndim == 1 else "", arr)
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

    def __getitem__(self, key: Any) -> NDArray[Any]:
        if self._arr is None:
            with zipfile.ZipFile(self.path) as zf, zf.open(self.member) as fh:
                self._arr = np.lib.format.read_array(fh, allow_pickle=False)
        return self._arr[key]


def _find_rate_h5(obj: Any) -> float | None:
    while obj is not None:
        for k in _FS_KEYS:
            if k in obj.attrs:
                return float(np.asarray(obj.attrs[k]).ravel()[0])
        for k in _DT_KEYS:
            if k in obj.attrs:
                dt = float(np.asarray(obj.attrs[k]).ravel()[0])
                return 1.0 / dt if dt > 0 else None
        obj = obj.parent if obj.name != "/" else None
    return None


class Hdf5Source(_ArraySource):
    fmt = "hdf5"

    def __init__(self, path: Path, matlab: bool = False) -> None:
        import h5py

        super().__init__(path)
        if matlab:
            self.fmt = "mat-v7.3"
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
                if name.split("/")[-1] in _FS_KEYS:
                    self.fs_hz = float(np.asarray(d[()]).ravel()[0])
                continue
            self.add(_column_channels(name, d))
        rates = {r for r in (_find_rate_h5(spec[0]) for spec in self.specs.values()) if r}
        if self.fs_hz is None and rates:
            if len(rates) > 1:
                raise ValueError(f"{path.name}: channels have different sample rates: {sorted(rates)}")
            self.fs_hz = rates.pop()
        if "meta" in self.f.attrs:
            try:
                self.meta = dict(json.loads(self.f.attrs["meta"]))
            except (TypeError, ValueError):
                self.notes.append("attribute 'meta' is not JSON: ignored")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        try:
            return super().read(name, start, stop)
        except OSError as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at samples {start}-{stop} (truncated file?): {exc}") from None

    def close(self) -> None:
        self.f.close()


class MatV5Source(_Source):
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


class TdmsSource(_Source):
    fmt = "tdms"

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


class WavSource(_Source):
    fmt = "wav"

    def __init__(self, path: Path) -> None:
        import warnings

        from scipy.io import wavfile

        super().__init__(path)
        with warnings.catch_warnings():
            warnings.simplefilter("error", wavfile.WavFileWarning)
            try:
                rate, data = wavfile.read(path, mmap=True)
            except ValueError as exc:
                if "mmap" not in str(exc):
                    raise ValueError(f"{path.name}: cannot read WAV (truncated or corrupt?): {exc}") from None
                rate, data = wavfile.read(path, mmap=False)
                self.notes.append(f"WAV read whole into memory (scipy cannot memory-map it: {exc})")
            except wavfile.WavFileWarning as exc:
                raise ValueError(f"{path.name}: cannot read WAV (truncated or corrupt?): {exc}") from None
        self.fs_hz = float(rate)
        self.data = data
        cols = data.shape[1] if data.ndim == 2 else 1
        for i in range(cols):
            self.lengths[str(i)] = int(data.shape[0])
        if data.dtype.kind in "iu":
            self.notes.append(f"WAV holds {data.dtype} PCM counts: give the sensitivity in LSB/g to scale to g")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        i = int(name)
        return np.array(self.data[start:stop, i] if self.data.ndim == 2 else self.data[start:stop])


class CsvSource(_Source):
    """CSV (or TSV / semicolon / whitespace separated), with or without a header line.

    Parsed by ``pyarrow.csv.open_csv`` in streaming batches (no Python loop per row). Opening
    makes one pass to count rows and find empty cells; ``stream`` makes one pass per call.
    """

    fmt = "csv"

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        with open(path, "rb") as fh:
            head = fh.read(65536).decode("utf-8-sig", errors="replace")
        lines = [ln for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
        if not lines:
            raise ValueError(f"{path.name}: CSV file has no data lines")
        first = lines[0]
        self.delim = next((d for d in (",", "\t", ";") if d in first), " ")
        cells = [c.strip().strip('"') for c in (first.split() if self.delim == " " else first.split(self.delim))]
        self.has_header = any(not _is_number(c) for c in cells)
        self.names = cells if self.has_header else [str(i) for i in range(len(cells))]
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"{path.name}: duplicate column names in the header: {self.names}")
        self.skip_comments = head.splitlines().index(first)
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
            column_names=self.names,
            skip_rows=self.skip_comments + (1 if self.has_header else 0),
            block_size=1 << 20,  # larger blocks make the reader hold ~40x the block size
            use_threads=False,
        )
        po = pacsv.ParseOptions(delimiter=self.delim if self.delim != " " else " ", ignore_empty_lines=True)
        co = pacsv.ConvertOptions(
            column_types={c: pa.float64() for c in self.names},
            include_columns=list(names),
            null_values=[""],
            strings_can_be_null=True,
        )
        try:
            reader = pacsv.open_csv(self.path, read_options=ro, parse_options=po, convert_options=co)
            for batch in reader:
                yield batch
        except pa.ArrowInvalid as exc:
            msg = str(exc).splitlines()[0]
            raise ValueError(f"{self.path.name}: cannot parse CSV (truncated or malformed row?): {msg}") from None

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

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        return np.concatenate([b[name] for b in self.stream([name], start, stop, stop - start)] or [np.empty(0)])


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


# ----------------------------------------------------------------------------- format detection

_EXT = {
    ".csv": "csv", ".tsv": "csv", ".txt": "csv", ".dat": "csv",
    ".npy": "npy", ".npz": "npz",
    ".h5": "hdf5", ".hdf5": "hdf5", ".hdf": "hdf5", ".he5": "hdf5", ".nc": "hdf5",
    ".tdms": "tdms", ".wav": "wav", ".wave": "wav", ".mat": "mat",
}  # fmt: skip


def detect_format(path: Path) -> str:
    """Format from the file's magic bytes, else its extension."""
    with open(path, "rb") as fh:
        head = fh.read(1024)
    if not head:
        raise ValueError(f"{path.name}: file is empty")
    if head.startswith(HDF5_MAGIC):
        return "hdf5"
    if head.startswith(b"\x93NUMPY"):
        return "npy"
    if head.startswith(b"PK\x03\x04") or head.startswith(b"PK\x05\x06"):
        return "npz"
    if head[:4] in (b"RIFF", b"RF64", b"RIFX") and head[8:12] == b"WAVE":
        return "wav"
    if head.startswith(b"TDSm"):
        return "tdms"
    if head.startswith(b"MATLAB"):
        return "mat"
    fmt = _EXT.get(path.suffix.lower())
    if fmt in ("csv", "mat", "hdf5", "npy", "npz", "wav", "tdms"):
        if fmt != "csv":
            raise ValueError(f"{path.name}: not a valid {fmt.upper()} file (wrong header bytes)")
        return fmt
    raise ValueError(
        f"{path.name}: unknown file format (extension {path.suffix or 'none'!r}); "
        "supported: CSV, NPY, NPZ, HDF5, TDMS, WAV, MAT"
    )


def _open_source(path: Path) -> _Source:
    fmt = detect_format(path)
    try:
        if fmt == "csv":
            return CsvSource(path)
        if fmt == "npy":
            return NpySource(path)
        if fmt == "npz":
            return NpzSource(path)
        if fmt == "hdf5":
            return Hdf5Source(path)
        if fmt == "tdms":
            return TdmsSource(path)
        if fmt == "wav":
            return WavSource(path)
        # MAT: v7.3 is HDF5 behind a 512-byte header; v4/v5 need scipy.io.loadmat
        with open(path, "rb") as fh:
            fh.seek(512)
            is_h5 = fh.read(8) == HDF5_MAGIC
        return Hdf5Source(path, matlab=True) if is_h5 else MatV5Source(path)
    except ValueError as exc:
        if str(exc).startswith(path.name):
            raise
        raise ValueError(f"{path.name}: cannot read as {fmt.upper()} (truncated or corrupt?): {exc}") from None
    except (OSError, EOFError, struct.error, zipfile.BadZipFile, KeyError) as exc:
        raise ValueError(f"{path.name}: cannot read as {fmt.upper()} (truncated or corrupt?): {exc}") from None


def _resolve(name: str, src: _Source, role: str) -> str:
    chans = src.channels
    if name in chans:
        return name
    low = {c.lower(): c for c in chans}
    key = name.lower().lstrip("/")
    if key in low:
        return low[key]
    m = re.fullmatch(r"(?:ch|col|channel|c)?_?(\d+)", key)
    if m and m.group(1) in chans:
        return m.group(1)
    tails = [c for c in chans if c.lower().split("/")[-1] == key]
    if len(tails) == 1:
        return tails[0]
    listing = ", ".join(chans) if chans else "none"
    if len(tails) > 1:
        raise ValueError(f"{role} channel {name!r} is ambiguous in {src.path.name}: matches {', '.join(tails)}")
    raise ValueError(f"{role} channel {name!r} not found in {src.path.name}; channels: {listing}")


def _time_rate(src: _Source, name: str, block: int = 1 << 20) -> float:
    """Sample rate from a time column, checked increasing and evenly spaced (first bad index)."""
    n = src.lengths[name]
    if n < 2:
        raise ValueError(f"time column {name!r} has fewer than 2 samples")
    dt0 = None
    prev = None
    first = None
    last = None
    pos = 0
    for blk in src.stream([name], 0, n, block):
        t = np.asarray(blk[name], dtype=np.float64)
        if not np.isfinite(t).all():
            i = int(np.flatnonzero(~np.isfinite(t))[0])
            raise ValueError(f"time column {name!r} has a non-finite value at index {pos + i}")
        if prev is not None:
            t = np.concatenate([[prev], t])
            off = pos - 1
        else:
            first = float(t[0])
            off = pos
        d = np.diff(t)
        if len(d):
            if dt0 is None:
                dt0 = float(np.median(d[: min(len(d), 1000)]))
            bad_mono = np.flatnonzero(d <= 0)
            if len(bad_mono):
                i = off + int(bad_mono[0]) + 1
                raise ValueError(f"time column {name!r} is not increasing at index {i}")
            bad = np.flatnonzero(np.abs(d - dt0) > 0.25 * dt0)
            if len(bad):
                i = off + int(bad[0]) + 1
                raise ValueError(
                    f"time column {name!r} has a gap or uneven step at index {i} "
                    f"(step {d[bad[0]]:.6g} s, expected {dt0:.6g} s)"
                )
        prev = float(t[-1])
        last = prev
        pos += len(blk[name])
    return (n - 1) / (last - first)  # type: ignore[operator]


# ----------------------------------------------------------------------------- the record


@dataclass
class FileRecord:
    """A lab file as a :class:`~vrelab.record.Record` with channels ``dut`` (and ``reference``) in g."""

    source: _Source
    mapping: dict[str, str]  # record channel -> file channel
    scales: dict[str, Scale]
    fs_hz: float
    n_samples: int
    schedule: Schedule | None = None
    meta: Mapping[str, Any] = field(default_factory=dict)

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.mapping)

    @property
    def path(self) -> Path:
        return self.source.path

    def blocks(
        self, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
    ) -> Iterator[dict[str, NDArray[np.float64]]]:
        for c in channels:
            if c not in self.mapping:
                raise ValueError(f"record has no channel {c!r}; channels: {', '.join(self.mapping)}")
        stop = self.n_samples if stop is None else min(int(stop), self.n_samples)
        block_size = int(block_size)
        raw = [self.mapping[c] for c in channels]
        for blk in self.source.stream(raw, int(start), stop, block_size):
            yield {c: self.scales[c].to_g(blk[r]) for c, r in zip(channels, raw)}

    def close(self) -> None:
        self.source.close()

    def __enter__(self) -> "FileRecord":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def open_record(
    path: str | Path,
    dut: str,
    reference: str | None = None,
    fs_hz: float | None = None,
    dut_scale: Scale | float | None = None,
    reference_scale: Scale | float | None = None,
    time_channel: str | None = None,
) -> FileRecord:
    """Open a recorded test read-only as a streaming record with channels ``dut``/``reference`` in g.

    Parameters
    ----------
    path : str or Path
        CSV/TSV, NPY, NPZ, HDF5, NI TDMS, WAV (PCM, float, RF64), MAT (v5 or v7.3).
    dut, reference : str
        Channel names in the file: a CSV column (or its index ``0``/``ch0``), an HDF5/MAT dataset
        path, a TDMS ``group/channel`` (or a unique channel name), a WAV/NPY column index.
    fs_hz : float, optional
        Sample rate [Hz] when neither the file nor a time column gives it.
    dut_scale, reference_scale : Scale or float, optional
        Raw units to g (a float is a sensitivity in LSB/g). Default: the file holds g.
    time_channel : str, optional
        Time column [s]; by default a column named ``time``/``t``/``time_s``/``timestamp`` is
        used when the file has no sample rate of its own.

    Returns
    -------
    FileRecord
        ``blocks()`` reads lazily; ``meta`` holds ``source``, ``format``, ``channels`` and
        ``reader_notes`` (plus the HDF5 ``meta`` attribute of vrelab's own records).
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"input file not found: {path}")
    if not path.is_file():
        raise ValueError(f"input path is not a file: {path}")
    if path.stat().st_size == 0:
        raise ValueError(f"{path.name}: file is empty")
    if fs_hz is not None:
        fs_hz = V.positive_scalar("fs_hz", fs_hz)
    src = _open_source(path)
    try:
        if not src.channels:
            raise ValueError(f"{path.name}: no numeric channels found")
        mapping = {"dut": _resolve(dut, src, "DUT")}
        if reference is not None:
            mapping["reference"] = _resolve(reference, src, "reference")
            if mapping["reference"] == mapping["dut"]:
                raise ValueError(f"reference and DUT are the same channel {mapping['dut']!r}")
        lens = {f"{role} {ch!r}": src.lengths[ch] for role, ch in mapping.items()}
        tcol = None
        if time_channel is not None:
            tcol = _resolve(time_channel, src, "time")
        elif src.fs_hz is None:
            cands = [c for c in src.channels if c.lower().split("/")[-1] in _TIME_NAMES and c not in mapping.values()]
            tcol = cands[0] if len(cands) == 1 else None
        if tcol is not None:
            lens[f"time {tcol!r}"] = src.lengths[tcol]
        if len(set(lens.values())) > 1:
            raise ValueError(
                f"{path.name}: channels have mismatched lengths: "
                + ", ".join(f"{k} has {v} samples" for k, v in lens.items())
            )
        n = next(iter(lens.values()))
        if n == 0:
            raise ValueError(f"{path.name}: channels hold no samples")
        fs = src.fs_hz
        how = "file"
        if fs is None and tcol is not None:
            fs, how = _time_rate(src, tcol), f"time column {tcol!r}"
        if fs is None:
            if fs_hz is None:
                raise ValueError(f"{path.name}: no sample rate in the file and no time column: give --fs HZ")
            fs, how = fs_hz, "given"
        elif fs_hz is not None and abs(fs - fs_hz) > 1e-6 * fs:
            raise ValueError(f"--fs {fs_hz:g} Hz disagrees with the sample rate from the {how}: {fs:.9g} Hz")
        if not (math.isfinite(fs) and fs > 0):
            raise ValueError(f"{path.name}: bad sample rate {fs!r} from the {how}")
        scales = {"dut": _as_scale(dut_scale)}
        if reference is not None:
            scales["reference"] = _as_scale(reference_scale)
        meta = dict(src.meta)
        meta.update(
            source=path.name,
            format=src.fmt,
            channels=dict(mapping),
            fs_from=how,
            reader_notes=list(src.notes),
        )
        return FileRecord(src, mapping, scales, float(fs), int(n), src.schedule, meta)
    except BaseException:
        src.close()
        raise


__all__ = ["open_record", "FileRecord", "Scale", "detect_format", "UNITS"]
