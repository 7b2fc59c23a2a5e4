"""The reader registry and what every format shares: units, the source base class, array helpers."""

from __future__ import annotations

import importlib.util
import logging
import math
import re
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Iterator, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab.record import Schedule

G0 = 9.80665  # standard gravity, m/s² per g
Units = Literal["g", "lsb", "mv", "v", "m/s2", "mg", "mm/s2"]
UNITS: tuple[str, ...] = ("g", "lsb", "mv", "v", "m/s2", "mg", "mm/s2")
# acceleration units: how many of them make one g (the divisor of Scale.to_g)
_PER_G = {"g": 1.0, "mg": 1000.0, "m/s2": G0, "mm/s2": 1000.0 * G0}
FS_KEYS = ("fs_hz", "fs", "Fs", "sample_rate", "sampling_rate", "sample_rate_hz", "rate")
DT_KEYS = ("wf_increment", "dt", "sample_interval", "sampling_interval")
TIME_NAMES = ("time", "t", "time_s", "times", "timestamp", "time_sec", "seconds")
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
# Channels a reader indexes and `vrelab channels` lists: beyond, they are counted (a file of 10^5
# datasets is listed in a second, not minutes) and one is read when named exactly (Source.find).
MAX_CHANNELS = 1000


@dataclass(frozen=True)
class Scale:
    """How raw channel values become g: ``g = raw / sensitivity`` (``m/s2``: raw / 9.80665).

    ``units`` is what the file holds: ``g`` (no scaling), ``lsb`` (counts; ``sensitivity`` in
    LSB/g, e.g. 256000 for an ADXL355 on ±2 g), ``mv`` or ``v`` (``sensitivity`` in mV/g or V/g,
    e.g. 10 mV/g for an IEPE reference), ``m/s2``, ``mg``, ``mm/s2``.

    Examples
    --------
    A DUT at 256000 LSB/g, a reference at 10 mV/g:

    >>> from vrelab.analysis.readers import Scale
    >>> print(f"{Scale('lsb', 256000).to_g(512000.0):.1f} g, {Scale('mv', 10).to_g(-5.0):.1f} g")
    2.0 g, -0.5 g
    """

    units: Units = "g"
    sensitivity: float = 1.0

    def __post_init__(self) -> None:
        V.one_of("units", self.units, UNITS)
        V.positive_scalar("sensitivity", self.sensitivity)

    @classmethod
    def parse(cls, units: str | None, sensitivity: float | None, name: str = "channel") -> Scale:
        """From CLI options: ``--dut-units lsb --dut-sensitivity 256000`` (units per g)."""
        u = (units or "g").strip().lower().replace("/", "").replace("²", "2").replace("^", "")
        u = {"ms2": "m/s2", "mps2": "m/s2", "mms2": "mm/s2", "counts": "lsb", "count": "lsb"}.get(u, u)
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
        if self.units in _PER_G:
            return _PER_G[self.units]
        return float(self.sensitivity)

    def to_g(self, raw: NDArray[Any]) -> NDArray[np.float64]:
        x = np.asarray(raw, dtype=np.float64)
        d = self.divisor
        return x if d == 1.0 else x / d


def as_scale(s: Scale | float | None) -> Scale:
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

    Examples
    --------
    The raw channels under a record: the TDMS format's subclass, chosen by :func:`detect_format`:

    >>> from vrelab.analysis.readers import Scale, Source, open_record
    >>> with open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", dut_scale=Scale("lsb", 256000)) as record:
    ...     print(isinstance(record.source, Source), record.source.fmt, record.source.unit_of("shaker/sn1_z"))
    True tdms LSB
    """

    fmt: ClassVar[str] = "?"
    extensions: ClassVar[tuple[str, ...]] = ()
    has_magic: ClassVar[bool] = True
    random_access: ClassVar[bool] = True  # False: a stretch costs reading all before it (text)
    requires: ClassVar[str | None] = None  # the import name of the library the format needs
    install: ClassVar[str | None] = None  # what to pip install for it (default: ``requires``)
    # True: each channel carries its own time stamps (IDE, MDF): a channel named "Time" is one of
    # them (a GNSS receiver's clock), never the time base of the others
    own_stamps: ClassVar[bool] = False

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        """Whether ``head`` (the file's first 1024 bytes) starts like this format."""
        return False

    @classmethod
    def open(cls, path: Path) -> Source:
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
        self.units: dict[str, str] = {}  # channel -> the unit the file states for it
        self.header_units: set[str] = set()  # channels whose unit a text header states (a column name, a comment)
        self.rates: dict[str, float] = {}  # channel -> its own rate, where channels differ
        self.ambiguous: dict[str, list[str]] = {}  # a name several channels answer to -> their full names
        # channel -> where its samples live when not in this file's own bytes (HDF5 external
        # storage, a virtual dataset): ("external" | "virtual", the files named)
        self.elsewhere: dict[str, tuple[str, tuple[str, ...]]] = {}
        # channel -> why it is listed but never read (its samples in another file, a chunk that
        # would inflate beyond the memory budget): "keeps its samples outside this file (...)"
        self.unreadable: dict[str, str] = {}
        self.unlisted = 0  # channels beyond the MAX_CHANNELS indexed, counted but not listed

    def find(self, name: str) -> bool:
        """Index channel ``name`` of a file with more than :data:`MAX_CHANNELS` (``unlisted``),
        named by its exact name; False when it has none by that name (the default: a format
        that indexes every channel)."""
        return False

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.lengths)

    def rate_of(self, name: str) -> float | None:
        """The sample rate of channel ``name`` [Hz]: its own, else the file's (None: neither)."""
        return self.rates.get(name, self.fs_hz)

    def unit_of(self, name: str) -> str | None:
        """The unit the file states for channel ``name`` (None: none)."""
        return self.units.get(name) or None

    def location(self, name: str) -> dict[str, Any]:
        """Where channel ``name``'s samples live: ``{"kind": "file", "files": []}`` in this file's
        own bytes; ``"external"`` (HDF5 external storage: raw bytes of the ``files`` named) or
        ``"virtual"`` (an HDF5 virtual dataset mapping datasets of ``files``; ``"."`` is this file)."""
        kind, files = self.elsewhere.get(name, ("file", ()))
        return {"kind": kind, "files": list(files)}

    def outside(self, name: str) -> tuple[str, ...]:
        """The other files channel ``name``'s samples would be read from (empty: none)."""
        return tuple(f for f in self.elsewhere.get(name, ("file", ()))[1] if f != ".")

    def refusal(self, name: str, role: str) -> str | None:
        """The one-line refusal of channel ``name`` read as ``role`` (``DUT channel``), None when
        it can be read: its samples in other files (vrelab reads the file it is given and
        nothing it points to), or a reason the reader gave (:attr:`unreadable`)."""
        if self.outside(name):
            what = "external storage in" if self.elsewhere[name][0] == "external" else "a virtual dataset mapping"
            files = ", ".join(repr(f) for f in self.outside(name))
            why = (f"keeps its samples outside this file ({what} {files}): vrelab reads only the file it is "
                   "given; copy the data into the file (h5repack, or h5py) if that is meant")
        elif name in self.unreadable:
            why = self.unreadable[name]
        else:
            return None
        return f"{self.path.name}: {role} {name!r} {why}"

    def is_integer(self, name: str) -> bool:
        """Whether channel ``name`` holds integer samples (counts of an ADC)."""
        try:
            return np.asarray(self.read(name, 0, 1)).dtype.kind in "iub"
        except Exception:
            return False

    def select(self, names: Sequence[str], fs_hz: float | None = None) -> None:
        """Called with the channels a record will read, before its rate is taken: a format whose
        channels may have different rates (MDF groups, TDMS, LVM) sets ``fs_hz`` for these, or
        refuses. ``fs_hz`` is the user's rate (``--fs``): a format whose own rate check would
        refuse (time stamps with jitter) may leave the rate to it, with a note."""
        chosen = {n: self.rates[n] for n in names if n in self.rates}
        if chosen:
            self.fs_hz = one_rate(self.path, chosen, 1e-9)

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        raise NotImplementedError

    def stream(self, names: Sequence[str], start: int, stop: int, block: int) -> Iterator[dict[str, NDArray[Any]]]:
        for i in range(start, stop, block):
            j = min(i + block, stop)
            yield {n: self.read(n, i, j) for n in names}

    def close(self) -> None:
        pass


def snap_rate(increment: float, digits: int | None = None) -> float:
    """The sample rate behind a sampling increment that was written with a few digits.

    ``Delta_X 0.000977`` (LVM, 3 significant digits) is 1/1024 s rounded, ``1.95312E-05`` (UFF58's
    E13.5) is 1/51200 s rounded: their inverses (1023.54 Hz, 51200.1 Hz) are not the rate the
    instrument ran at. The rate with the fewest significant digits whose inverse, written with
    ``digits`` significant digits, is the increment as written, is the one it ran at. ``digits``
    defaults to the shortest form that gives the float back (a double-precision increment has
    16-17: then nothing was rounded away and 1/increment is returned).
    """
    if not (increment > 0 and math.isfinite(increment)):
        raise ValueError(f"sampling increment must be > 0, got {increment!r}")
    if digits is None:
        digits = next((d for d in range(1, 18) if float(f"{increment:.{d - 1}e}") == increment), 17)
    if digits >= 10:
        return 1.0 / increment
    # half a unit of the last digit written (a tie such as 1/51200 = 1.953125e-05 may be written
    # either way, so the bound is inclusive with a hair of slack for the binary representation)
    half_unit = 0.5 * 10.0 ** (math.floor(math.log10(increment)) - digits + 1) * (1 + 1e-6)
    for d in range(1, 10):
        fs = float(f"{1.0 / increment:.{d}g}")
        if abs(1.0 / fs - increment) <= half_unit:
            return fs
    return 1.0 / increment


def significant_digits(text: str) -> int:
    """Significant digits of a number as written (``0.000977`` -> 3, ``1.95312E-05`` -> 6)."""
    mant = text.strip().lower().split("e")[0].lstrip("+-").replace(",", ".")
    digits = mant.replace(".", "").lstrip("0")
    return max(len(digits), 1)


def stamped_rate(what: str, index: NDArray[Any], times_s: NDArray[Any], gap_samples: float,
                 drift_samples: float, spans_s: NDArray[Any] | None = None) -> tuple[float, str | None]:
    """The sample rate behind time stamps that jitter, and a note saying how much they do.

    ``times_s[k]`` is the time of sample ``index[k]`` (every sample's, as MDF masters give, or
    each block's first, as recorders stamp). The rate is the least-squares line through the
    stamps (so a clock that runs a little fast or slow gives its own rate). Refused, with where:
    a stamp not after the one before; a step between consecutive stamps more than
    ``gap_samples`` samples off the fitted rate (a gap, a lost block); stamps drifting more
    than ``drift_samples`` samples off the line (not one rate).

    ``spans_s[k]``, where the recorder also stamps each block's end: the time from stamp ``k``
    to the last sample before stamp ``k + 1``. Samples within a block are contiguous, so a gap
    can only lie between a block's end and the next block's start: the step judged is that one
    (in samples of the blocks' own period), and a block a few samples longer or shorter than
    the rate gives it is the clock's drift, judged with the rest against the line.
    """
    i = np.asarray(index, dtype=np.float64)
    t = np.asarray(times_s, dtype=np.float64)
    if len(t) < 2 or not (i[-1] > i[0]):
        raise ValueError(f"{what}: fewer than two time stamps: no sample rate")
    d = np.diff(t)
    if not (d > 0).all():
        k = int(np.flatnonzero(~(d > 0))[0]) + 1
        raise ValueError(f"{what}: time stamps are not increasing at sample {int(i[k])} ({t[k]:.9g} s)")
    # the line through the stamps, centred for precision (times of hours, steps of microseconds)
    ic, tc = i - i.mean(), t - t.mean()
    step = float(np.dot(ic, tc) / np.dot(ic, ic)) if len(t) > 2 else float((t[-1] - t[0]) / (i[-1] - i[0]))
    if not step > 0:
        raise ValueError(f"{what}: time stamps give no positive sample step")
    # a gap is judged against the median step (the line's slope leans towards a large gap)
    di = np.diff(i)
    inner = di - 1  # sample periods within a block, from its start stamp to its last sample
    if spans_s is not None and (inner > 0).any():
        span = np.asarray(spans_s, dtype=np.float64)
        typical = float(np.median(span[inner > 0] / inner[inner > 0]))
        jump = (d - span) / typical - 1.0  # samples more (or fewer) than the rate puts between blocks
    else:
        typical = float(np.median(d / di))
        jump = (d - di * typical) / typical  # samples more (or fewer) than the rate puts between them
    k = int(np.argmax(np.abs(jump)))
    if abs(jump[k]) > gap_samples:
        raise ValueError(f"{what}: not evenly sampled: {jump[k]:+.3g} samples between {t[k]:.6g} s and "
                         f"{t[k + 1]:.6g} s (sample {int(i[k + 1])}) at {1 / typical:.6g} Hz: a gap in the recording?")
    res = (tc - ic * step) / step
    worst = float(np.max(np.abs(res)))
    if worst > drift_samples:
        k = int(np.argmax(np.abs(res)))
        raise ValueError(f"{what}: time stamps drift {res[k]:+.3g} samples off one rate of {1 / step:.6g} Hz at "
                         f"sample {int(i[k])}: not one sample rate")
    note = None
    if worst > 1e-6:
        note = (f"{what}: time stamps scatter up to {worst:.3g} sample(s) ({worst * step:.3g} s) about a constant "
                f"rate of {1 / step:.9g} Hz, fitted to them")
    return 1.0 / step, note


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


def column_channels(prefix: str, arr: Any) -> dict[str, tuple[Any, Any]]:
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


def spec_slice(spec: tuple[Any, Any], start: int, stop: int) -> NDArray[Any]:
    arr, how = spec
    if how is None:
        return np.asarray(arr[start:stop])
    if isinstance(how, str) and how == "squeeze":
        return np.asarray(arr[:, start:stop] if arr.shape[0] == 1 else arr[start:stop, 0]).ravel()
    if isinstance(how, tuple):
        kind, i = how
        return np.asarray(arr[i, start:stop] if kind == "row" else arr[start:stop, i])
    return np.asarray(arr[start:stop][how])


def spec_length(spec: tuple[Any, Any]) -> int:
    arr, how = spec
    if isinstance(how, str) and how == "squeeze":
        return int(max(arr.shape))
    if isinstance(how, tuple):
        return int(arr.shape[1] if how[0] == "row" else arr.shape[0])
    return int(arr.shape[0])


class ArraySource(Source):
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
            self.lengths[name] = spec_length(spec)

    def is_integer(self, name: str) -> bool:
        arr, how = self.specs[name]  # from the dtype: reading a sample to learn it costs a read per channel
        is_field = isinstance(how, str) and how != "squeeze"
        return bool((arr.dtype[how] if is_field else arr.dtype).kind in "iub")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        return spec_slice(self.specs[name], start, stop)


# ----------------------------------------------------------------------------- the registry

READERS: list[type[Source]] = []
# Entry points of this group name Source subclasses of other packages (a lab's recorder format):
# ``[project.entry-points."vrelab.readers"] myrec = "mypkg.reader:MyRecSource"``.
PLUGIN_GROUP = "vrelab.readers"
PLUGINS: dict[type[Source], str] = {}  # a plugin's class -> where it came from (distribution, entry point)
PLUGIN_NOTES: list[str] = []  # one line per plugin that was skipped, and why
_plugins_started = _plugins_loaded = False
_plugins_lock = threading.RLock()
_log = logging.getLogger("vrelab.readers")


def register(cls: type[Source]) -> type[Source]:
    """Add a format (a :class:`Source` subclass) to the registry; usable as a class decorator.

    Examples
    --------
    A format is a :class:`Source` subclass decorated with ``@register`` (a plugin's entry point
    does it on import). Registering one already there keeps one entry:

    >>> from vrelab.analysis.readers import Scale, formats, open_record, register
    >>> with open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", dut_scale=Scale("lsb", 256000)) as record:
    ...     tdms = type(record.source)
    >>> n = len(formats())
    >>> register(tdms) is tdms, len(formats()) == n
    (True, True)
    """
    if cls not in READERS:
        READERS.append(cls)
    return cls


def _skip(note: str) -> None:
    """A plugin that cannot be used: said once, on one line (logging's last-resort handler
    prints a warning on stderr when the application configured none), and kept in PLUGIN_NOTES."""
    if note not in PLUGIN_NOTES:
        PLUGIN_NOTES.append(note)
        _log.warning("vrelab: %s", note)


def _plugin_problem(cls: Any) -> str | None:
    """Why a plugin's object cannot be a format (None: it can)."""
    if not (isinstance(cls, type) and issubclass(cls, Source)):
        what = f"class {cls.__qualname__}" if isinstance(cls, type) else f"a {type(cls).__name__}"
        return f"it is {what}, not a subclass of vrelab.analysis.readers.Source"
    if not isinstance(cls.fmt, str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.+-]*", cls.fmt) or cls.fmt == "?":
        return f"its fmt {cls.fmt!r} is not a format name (letters, digits, _ . + -)"
    taken = {c.fmt.lower() for c in READERS if c is not cls}
    if cls.fmt.lower() in taken:
        return f"format {cls.fmt!r} is already registered"
    ext = cls.extensions
    if not isinstance(ext, tuple) or not all(isinstance(e, str) and re.fullmatch(r"\.[a-z0-9_.+-]+", e) for e in ext):
        return f"its extensions {ext!r} are not a tuple of lower-case endings such as ('.rec',)"
    return None


def load_plugins() -> list[str]:
    """Register the formats of every installed ``vrelab.readers`` entry point, once per process.

    A plugin that fails to import, is not a :class:`Source` subclass, or clashes with a
    registered format name is skipped with a one-line note (:data:`PLUGIN_NOTES`, and a warning
    on the ``vrelab.readers`` logger); vrelab itself keeps working. Returns the notes.

    Examples
    --------
    No reader plugin is installed here (an entry point in the ``vrelab.readers`` group adds one):

    >>> from vrelab.analysis.readers import load_plugins
    >>> load_plugins()
    []
    """
    global _plugins_started, _plugins_loaded
    if _plugins_loaded or threading.current_thread().name.startswith("vrelab plugin "):
        return PLUGIN_NOTES  # (a plugin whose own import reads a file: the loading has started)
    # two threads reading their first files: one loads, the other waits; a plugin whose own
    # import reads a file (the same thread, back here) finds the loading started and goes on
    with _plugins_lock:
        if not _plugins_started:
            _plugins_started = True
            try:
                _load_plugins()
            finally:
                _plugins_loaded = True
    return PLUGIN_NOTES


def _load_plugins() -> None:
    from importlib.metadata import entry_points

    try:
        eps = list(entry_points(group=PLUGIN_GROUP))
    except Exception as exc:  # a broken distribution's metadata
        _skip(f"reader plugins not loaded: {type(exc).__name__}: {exc}")
        return
    for ep in eps:
        dist = getattr(getattr(ep, "dist", None), "name", None)
        where = f"{ep.name} = {ep.value}" + (f" (package {dist})" if dist else "")
        cls, failed = _isolated_load(ep, where)
        if failed:
            _skip(f"reader plugin {where} skipped: {failed}")
            continue
        why = _plugin_problem(cls)
        if why:
            _skip(f"reader plugin {where} skipped: {why}")
            continue
        PLUGINS[cls] = where
        register(cls)


# a plugin's import may take this long [s] (a vendor SDK loading its DLLs takes a second or two);
# one that takes longer (a hang, a network wait) is skipped and vrelab goes on without it
PLUGIN_IMPORT_TIMEOUT_S = 10.0


def _isolated_load(ep: Any, where: str) -> tuple[Any, str | None]:
    """Import a plugin's entry point so that nothing it does at import reaches vrelab: what it
    prints is kept off stdout (``--json`` prints one JSON object and nothing else) and said as
    a note; ``sys.exit``, any exception, or an import that takes longer than
    :data:`PLUGIN_IMPORT_TIMEOUT_S` (run in a daemon thread, left behind) make it skipped.
    Returns (the object, None) or (None, why it is skipped)."""
    import contextlib
    import io

    out: dict[str, Any] = {}
    printed = io.StringIO()

    def load() -> None:
        try:
            out["obj"] = ep.load()
        except BaseException as exc:  # SystemExit and KeyboardInterrupt raised by a plugin included
            out["exc"] = exc

    with contextlib.redirect_stdout(printed):
        t = threading.Thread(target=load, name=f"vrelab plugin {ep.name}", daemon=True)
        t.start()
        t.join(PLUGIN_IMPORT_TIMEOUT_S)
    if printed.getvalue().strip():
        _skip(f"reader plugin {where} printed at import (kept off stdout): {printed.getvalue().strip()[:80]!r}")
    if t.is_alive():
        return None, f"its import did not finish in {PLUGIN_IMPORT_TIMEOUT_S:g} s"
    if "exc" in out:
        exc = out["exc"]
        if isinstance(exc, SystemExit):
            return None, f"it called sys.exit({exc.code!r}) at import"
        return None, f"{type(exc).__name__}: {exc}"
    return out.get("obj"), None


def _claims(cls: type[Source], head: bytes) -> bool:
    if cls not in PLUGINS:
        return cls.can_open(head)
    try:  # a plugin's error here must not stop other formats from being read
        return bool(cls.can_open(head))
    except Exception as exc:
        _skip(f"reader plugin {PLUGINS[cls]}: can_open raised {type(exc).__name__}: {exc} (taken as not its file)")
        return False


def missing_library(cls: type[Source]) -> str | None:
    """The install hint of a format whose library is not installed (None: nothing missing)."""
    if cls.requires is None:
        return None
    try:
        found = importlib.util.find_spec(cls.requires) is not None
    except (ImportError, ValueError):
        found = False
    if found:
        return None
    return f"reading {cls.fmt.upper()} needs {cls.requires}: pip install '{cls.install or cls.requires}'"


def reader_for(path: Path) -> type[Source]:
    """The registered format of ``path``: its magic bytes first, else its extension.

    The built-in formats are asked first, then the plugins (:func:`load_plugins`, only when no
    built-in format claims the file: a built-in format's file never waits on a plugin's import).
    A format whose library is not installed is refused with its install hint.
    """
    with open(path, "rb") as fh:
        head = fh.read(1024)
    if not head:
        raise ValueError(f"{path.name}: file is empty")
    # the built-in formats first, by magic bytes and then by extension (CSV has no magic), and
    # only then the plugins: a plugin whose can_open says yes to everything cannot take a
    # built-in format's file
    found = None
    ext = path.suffix.lower()
    for plugins in (False, True):
        if plugins:
            load_plugins()
        group = [c for c in READERS if (c in PLUGINS) == plugins]
        found = next((cls for cls in group if _claims(cls, head)), None)
        if found is None:
            for cls in group:
                if ext in cls.extensions:
                    if cls.has_magic:
                        raise ValueError(f"{path.name}: not a valid {cls.fmt.upper()} file (wrong header bytes)")
                    found = cls
                    break
        if found is not None:
            break
    if found is None:
        names = ", ".join(dict.fromkeys(c.fmt.split("-")[0].upper() for c in READERS))
        raise ValueError(f"{path.name}: unknown file format (extension {path.suffix or 'none'!r}); supported: {names}")
    hint = missing_library(found)
    if hint:
        raise ValueError(f"{path.name}: {hint}")
    return found


def formats() -> list[dict[str, Any]]:
    """Every registered format, plugins included: ``{"format", "extensions", "requires",
    "installed", "install", "plugin"}`` (``plugin``: the entry point, None for a built-in).

    Examples
    --------
    >>> from vrelab.analysis.readers import formats
    >>> sorted(f["format"] for f in formats())[:4]
    ['csv', 'hdf5', 'ide', 'lvm']
    """
    load_plugins()
    return [{"format": cls.fmt, "extensions": list(cls.extensions), "requires": cls.requires,
             "installed": missing_library(cls) is None, "install": cls.install or cls.requires,
             "plugin": PLUGINS.get(cls)} for cls in READERS]


def formats_text() -> str:
    """The registered formats in one line for help texts: ``CSV (.csv .tsv), ..., MDF (.mf4 .mdf;
    needs asammdf, not installed: pip install 'vrelab[formats]'), REC (.rec; plugin ...)``.

    Examples
    --------
    >>> from vrelab.analysis.readers import formats_text
    >>> formats_text().split(", ")[0]
    'HDF5 (.h5 .hdf5 .hdf .he5 .nc)'
    """
    parts = []
    for f in formats():
        extra = []
        if f["requires"]:
            extra.append(f"needs {f['requires']}" + ("" if f["installed"] else f", not installed: pip install '{f['install']}'"))
        if f["plugin"]:
            extra.append(f"plugin {f['plugin']}")
        detail = "; ".join(([" ".join(f["extensions"])] if f["extensions"] else []) + extra)
        parts.append(f"{f['format'].upper()} ({detail})" if detail else f["format"].upper())
    return ", ".join(parts)
