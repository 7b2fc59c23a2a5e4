"""The reader registry and what every format shares: units, the source base class, array helpers."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Iterator, Literal, Mapping, Sequence

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
            return cls(u, V.sensitivity(f"{name} sensitivity", sensitivity))  # type: ignore[arg-type]
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


class Source:
    """Raw channels of one file: names, lengths, optional rate; random-access reads.

    A format is one subclass, registered with :func:`register` (xarray's ``BackendEntrypoint``
    shape): ``fmt`` names it, ``extensions`` are the file endings it claims, ``can_open(head)``
    says whether the file's first bytes are its magic (checked before the extension, so a file
    is read as what it is, whatever its name), and ``open(path)`` returns an instance (a class
    may dispatch to another, as MAT does to HDF5 for v7.3). A format without magic bytes (text)
    is chosen by extension alone.
    """

    fmt: ClassVar[str] = "?"
    extensions: ClassVar[tuple[str, ...]] = ()
    has_magic: ClassVar[bool] = True
    random_access: ClassVar[bool] = True  # False: a stretch costs reading all before it (text)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        """Whether ``head`` (the file's first 1024 bytes) starts like this format."""
        return False

    @classmethod
    def open(cls, path: Path) -> "Source":
        return cls(path)

    @classmethod
    def channel_names(cls, path: Path) -> tuple[str, ...]:
        """The file's channel names, as cheaply as the format allows (checking a campaign's
        manifest needs them before any run is read); by default the file is opened."""
        src = cls.open(path)
        try:
            return src.channels
        finally:
            src.close()

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

    def select(self, names: Sequence[str]) -> None:
        """Called with the channels a record will read, before its rate is taken: a format whose
        channels may have different rates (MDF groups) sets ``fs_hz`` for these, or refuses."""

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        raise NotImplementedError

    def stream(self, names: Sequence[str], start: int, stop: int, block: int) -> Iterator[dict[str, NDArray[Any]]]:
        for i in range(start, stop, block):
            j = min(i + block, stop)
            yield {n: self.read(n, i, j) for n in names}

    def close(self) -> None:
        pass


def one_rate(path: Path, rates: Mapping[str, float], rtol: float) -> float | None:
    """The one sample rate of the channels ``rates`` (name -> Hz), their mean; channels whose
    rates differ by more than ``rtol`` cannot form one record: a one-line error naming two."""
    if not rates:
        return None
    lo, hi = min(rates, key=rates.__getitem__), max(rates, key=rates.__getitem__)
    if rates[hi] - rates[lo] > rtol * rates[hi]:
        raise ValueError(f"{path.name}: channels {lo!r} ({rates[lo]:.9g} Hz) and {hi!r} ({rates[hi]:.9g} Hz) "
                         "have different sample rates")
    return float(sum(rates.values()) / len(rates))


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


class _ArraySource(Source):
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


# ----------------------------------------------------------------------------- the registry

READERS: list[type[Source]] = []


def register(cls: type[Source]) -> type[Source]:
    """Add a format (a :class:`Source` subclass) to the registry; usable as a class decorator."""
    if cls not in READERS:
        READERS.append(cls)
    return cls


def reader_for(path: Path) -> type[Source]:
    """The registered format of ``path``: its magic bytes first, else its extension."""
    with open(path, "rb") as fh:
        head = fh.read(1024)
    if not head:
        raise ValueError(f"{path.name}: file is empty")
    for cls in READERS:
        if cls.can_open(head):
            return cls
    ext = path.suffix.lower()
    for cls in READERS:
        if ext in cls.extensions:
            if cls.has_magic:
                raise ValueError(f"{path.name}: not a valid {cls.fmt.upper()} file (wrong header bytes)")
            return cls
    names = ", ".join(dict.fromkeys(c.fmt.split("-")[0].upper() for c in READERS))
    raise ValueError(f"{path.name}: unknown file format (extension {path.suffix or 'none'!r}); supported: {names}")
