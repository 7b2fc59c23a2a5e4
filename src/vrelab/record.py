"""The record: the boundary between the test (simulated or real) and the analysis.

A record is a set of equally sampled channels in g (``reference``, ``dut``, ...) read in blocks,
so that memory never grows with its length, plus an optional schedule of segments
(vibration off / on at a level). The simulated shaker writes records with
:func:`write_record_hdf5`; :mod:`vrelab.analysis.readers` reads them back with any lab file.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Protocol, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V

# The timing of a schedule's reduction, shared by the reducer (vrelab.analysis) and the simulated
# test that must give it long enough segments (vrelab.simulation): the settling time trimmed at
# each segment edge by default [s] and the averaging window [s].
DEFAULT_SETTLE_S = 0.5
WINDOW_S = 0.1


def window_seconds(band_hz: tuple[float, float], window_s: float = WINDOW_S) -> float:
    """The reduction's averaging window [s] for a test band: ``window_s``, longer when needed to
    put 2 FFT bins below the band's lower edge (2/f1: 0.4 s for a band from 5 Hz, so that the
    band's power is resolved). A simulated test's baselines and levels must hold several such
    windows after the settling trims (vrelab.simulation.plan.min_segment_seconds)."""
    return max(window_s, 2.0 / band_hz[0])


def window_length(fs_hz: float, band_hz: tuple[float, float], window_s: float = WINDOW_S) -> int:
    """Samples per window of the reduction's first pass: :func:`window_seconds` at ``fs_hz``.

    The band is resolved to one FFT bin (1/window, 10 Hz for 0.1 s): its edges fall on the
    nearest bins inside it.
    """
    return max(1, int(round(window_seconds(band_hz, window_s) * fs_hz)))


@dataclass(frozen=True)
class Segment:
    """One stretch of a test: ``nominal_rms_g == 0`` is a vibration-off baseline."""

    start_s: float
    end_s: float
    nominal_rms_g: float
    freq_hz: float | None = None

    def __post_init__(self) -> None:
        if not (self.end_s > self.start_s >= 0):
            raise ValueError(
                f"schedule segment must have 0 <= start_s < end_s, got start_s={self.start_s}, end_s={self.end_s}"
            )
        if not np.isfinite(self.nominal_rms_g) or self.nominal_rms_g < 0:
            raise ValueError(f"schedule nominal_rms_g must be >= 0, got {self.nominal_rms_g}")

    @property
    def is_baseline(self) -> bool:
        return self.nominal_rms_g == 0


@dataclass(frozen=True)
class Schedule:
    """Segments in time order, not overlapping."""

    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        for a, b in zip(self.segments, self.segments[1:]):
            if b.start_s < a.end_s:
                raise ValueError(
                    f"schedule segments overlap or are out of order: {a.start_s}-{a.end_s} s then {b.start_s}-{b.end_s} s"
                )

    def to_array(self) -> NDArray[np.float64]:
        return np.array(
            [[s.start_s, s.end_s, s.nominal_rms_g, np.nan if s.freq_hz is None else s.freq_hz] for s in self.segments],
            dtype=np.float64,
        ).reshape(-1, 4)

    @classmethod
    def from_array(cls, arr: NDArray[np.float64]) -> Schedule:
        return cls(
            tuple(
                Segment(float(a), float(b), float(c), None if not np.isfinite(d) else float(d))
                for a, b, c, d in np.asarray(arr, dtype=np.float64).reshape(-1, 4)
            )
        )

    def write_csv(self, path: str | Path) -> None:
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["start_s", "end_s", "nominal_rms_g", "freq_hz"])
            for s in self.segments:
                w.writerow([s.start_s, s.end_s, s.nominal_rms_g, "" if s.freq_hz is None else s.freq_hz])

    @classmethod
    def read_csv(cls, path: str | Path) -> Schedule:
        """Read ``start_s,end_s,nominal_rms_g[,freq_hz]`` rows (a header line is optional)."""
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"schedule file not found: {path}")
        segs: list[Segment] = []
        with open(path, newline="") as fh:
            for lineno, row in enumerate(csv.reader(fh), start=1):
                row = [c.strip() for c in row]
                if not row or not any(row) or row[0].startswith("#"):
                    continue
                try:
                    vals = [float(c) if c else np.nan for c in row[:4]]
                except ValueError:
                    if lineno == 1:
                        continue  # header
                    raise ValueError(f"schedule {path} line {lineno}: not a number in {row!r}") from None
                if len(vals) < 3:
                    raise ValueError(f"schedule {path} line {lineno}: need start_s,end_s,nominal_rms_g, got {row!r}")
                freq = vals[3] if len(vals) > 3 and np.isfinite(vals[3]) else None
                segs.append(Segment(vals[0], vals[1], vals[2], freq))
        if not segs:
            raise ValueError(f"schedule {path} has no segments")
        return cls(tuple(segs))


class Record(Protocol):
    """What the analysis reads: channels in g, sampled at ``fs_hz``, delivered in blocks."""

    # read-only: a record may hold them as fields or give them as properties
    @property
    def fs_hz(self) -> float: ...

    @property
    def n_samples(self) -> int: ...

    @property
    def channels(self) -> tuple[str, ...]: ...

    @property
    def schedule(self) -> Schedule | None: ...

    @property
    def meta(self) -> Mapping[str, Any]: ...

    def blocks(
        self, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
    ) -> Iterator[dict[str, NDArray[np.float64]]]:
        """Yield dicts channel -> float64 array of at most ``block_size`` samples, in order."""
        ...


@dataclass
class ArrayRecord:
    """A record held in memory (tests, small simulations)."""

    data: Mapping[str, NDArray[np.float64]]
    fs_hz: float
    schedule: Schedule | None = None
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        V.positive_scalar("fs_hz", self.fs_hz)
        lengths = {k: len(v) for k, v in self.data.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"channels have mismatched lengths: {lengths}")
        if self.meta is None:  # given as None: no metadata
            self.meta = {}

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.data)

    @property
    def n_samples(self) -> int:
        return len(next(iter(self.data.values()))) if self.data else 0

    def blocks(
        self, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
    ) -> Iterator[dict[str, NDArray[np.float64]]]:
        stop = self.n_samples if stop is None else min(stop, self.n_samples)
        for i in range(start, stop, block_size):
            j = min(i + block_size, stop)
            yield {c: np.asarray(self.data[c][i:j], dtype=np.float64) for c in channels}


def write_record_hdf5(
    path: str | Path,
    fs_hz: float,
    blocks: Iterable[Mapping[str, NDArray[np.float64]]],
    schedule: Schedule | None = None,
    meta: Mapping[str, Any] | None = None,
) -> int:
    """Stream channel blocks into an HDF5 file, completely or not at all.

    Layout: one float64 dataset per channel (units g, attribute ``units``), file attributes
    ``fs_hz`` and ``meta`` (JSON), and a ``schedule`` dataset (start_s, end_s, nominal_rms_g,
    freq_hz) when given. Written to a temporary name and renamed at the end, so a crash never
    leaves a half file under the final name. Returns the number of samples written.

    A full disk is :class:`vrelab._io.DiskFull` with nothing left behind: HDF5 writes through
    :class:`vrelab._io.GuardedFile` (HDF5 itself crashes the process after a failed write).
    """
    import h5py

    from vrelab._io import GuardedFile, disk_full_error

    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    n = 0
    try:
        raw = GuardedFile(tmp)
        with raw, h5py.File(raw, "w") as f:
            f.attrs["fs_hz"] = float(fs_hz)
            f.attrs["meta"] = json.dumps(dict(meta or {}))
            dsets: dict[str, Any] = {}
            for blk in blocks:
                m = None
                for name, arr in blk.items():
                    arr = np.asarray(arr, dtype=np.float64)
                    if name not in dsets:
                        dsets[name] = f.create_dataset(name, shape=(0,), maxshape=(None,), dtype="f8", chunks=(1 << 16,))
                        dsets[name].attrs["units"] = "g"
                    d = dsets[name]
                    d.resize((n + arr.size,))
                    d[n:] = arr
                    m = arr.size
                n += m or 0
            if schedule is not None:
                f.create_dataset("schedule", data=schedule.to_array())
                f["schedule"].attrs["columns"] = "start_s,end_s,nominal_rms_g,freq_hz"
        if raw.failed is not None:
            raise disk_full_error(path)
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return n


class ChannelView:
    """One DUT of a several-DUT record, seen as a record with channels ``dut`` and ``reference``
    (by default the record's ``reference``; ``reference=`` names another channel).

    A lab file with several DUT channels opens as one record whose DUTs are ``dut:<name>``
    (:func:`vrelab.analysis.readers.open_record`); the reduction reads one of them through this
    view, so it never needs to know that the file holds others.
    """

    def __init__(self, record: Record, dut: str, reference: str | None = None) -> None:
        for name in (dut, reference):
            if name is not None and name not in record.channels:
                raise ValueError(f"record has no channel {name!r}; channels: {', '.join(record.channels)}")
        self.base = record
        self.dut = dut
        self.names = {"dut": dut}
        if reference is not None:  # another channel than "reference" (a triaxial reference's axis)
            self.names["reference"] = reference
        elif "reference" in record.channels:
            self.names["reference"] = "reference"
        self.fs_hz = record.fs_hz
        self.n_samples = record.n_samples
        self.schedule = record.schedule
        meta = dict(record.meta or {})
        files = dict(meta.get("channels") or {})
        meta["channels"] = {k: files.get(v, v) for k, v in self.names.items()}
        self.meta = meta
        base_map = getattr(record, "mapping", None) or {}
        self.mapping = {k: base_map.get(v, v) for k, v in self.names.items()}

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.names)

    @property
    def random_access(self) -> bool:
        return bool(getattr(self.base, "random_access", True))

    def blocks(
        self, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
    ) -> Iterator[dict[str, NDArray[np.float64]]]:
        for c in channels:
            if c not in self.names:
                raise ValueError(f"record has no channel {c!r}; channels: {', '.join(self.names)}")
        raw = [self.names[c] for c in channels]
        for blk in self.base.blocks(block_size, list(dict.fromkeys(raw)), start, stop):
            yield {c: blk[r] for c, r in zip(channels, raw)}
