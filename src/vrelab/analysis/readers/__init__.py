"""Readers for recorded shaker tests: lab files as a streaming :class:`~vrelab.record.Record`.

:func:`open_record` opens CSV, NPY, NPZ, HDF5, NI TDMS, WAV (through soundfile: every chunk
layout, 8/16/24/32-bit PCM, float, RIFX, RF64), MATLAB (v7.3 through h5py, v5 through scipy),
UFF58, ASAM MDF, enDAQ IDE and LabVIEW LVM files read-only, picks the DUT and reference channels
by name (a name several channels answer to is refused as ambiguous, with each one's full name),
scales them to g, and returns a record whose ``blocks`` read lazily: memory is bounded by the
block size whatever the length of the file. Exceptions, said in ``meta["reader_notes"]``:
compressed NPZ members and MAT v5 files cannot be memory-mapped and are read whole (one member /
the file). :func:`list_channels` lists a file's channels (``vrelab channels``).

Sample rate, in this order: the file's own (HDF5/MAT attributes or variables ``fs_hz``, ``fs``,
``sample_rate``, ``sampling_rate``, ``wf_increment`` (its inverse), TDMS ``wf_increment``, the
WAV header, LVM ``Delta_X``, UFF58's increment, MDF/IDE time stamps fitted), else a time column
(``time``, ``t``, ``Time (s)``, ``t [ms]``...: checked increasing and evenly spaced), else
``fs_hz``. An increment written rounded (``0.000977``) gives the rate it rounds (1024 Hz), with a
note. Channels of one file may have different rates; the ones a record reads must share one. A
given ``fs_hz`` that disagrees with the file's is an error (MDF: it overrides the stamps).

Units (:mod:`vrelab.analysis.readers.units`): the unit the file states for a channel converts it
to g; a voltage or counts need a sensitivity; a non-acceleration is refused; a given unit that
contradicts the file's is refused unless ``accept_file_units``; integer samples with no unit are
counts, refused without a sensitivity.

Every problem is a one-line ``ValueError``: unknown format, a reader library not installed (its
install hint), empty or truncated file, missing channel (the message lists the channels that
exist), mismatched channel lengths, a bad time column (the first bad index), non-finite values
(channel and first index, found while streaming).

Formats are a registry (:mod:`vrelab.analysis.readers._base`): each is one
:class:`~vrelab.analysis.readers._base.Source` subclass in its own module that declares its
extensions and magic bytes and how it opens and streams; :func:`register` adds another, and
:func:`formats` lists them (the CLI's help texts are made from it). A format whose library is not
installed is refused with its install hint (``requires``, ``install``).

**Reader plugins.** Another package adds its recorder's format with an entry point in the group ``vrelab.readers``
naming a :class:`Source` subclass, in its ``pyproject.toml``::

    [project.entry-points."vrelab.readers"]
    myrec = "myrec_vrelab.reader:MyRecSource"

The class is written like the built-in readers (``text.py`` is a short one)::

    from vrelab.analysis.readers import Source

    class MyRecSource(Source):
        fmt = "myrec"                   # its name: letters, digits, _ . + -
        extensions = (".rec",)          # lower-case endings it claims
        requires = None                 # or the import name of a library it needs

        @classmethod
        def can_open(cls, head):        # the file's first 1024 bytes: its magic?
            return head.startswith(b"MYREC")

        def __init__(self, path):
            super().__init__(path)
            ...                         # set self.lengths {channel: samples}, self.fs_hz,
                                        # self.units {channel: unit}, self.notes
        def read(self, name, start, stop):
            ...                         # samples [start, stop) of channel name, 1-D array

        def close(self):
            ...

Plugins are loaded (:func:`load_plugins`) only for a file no built-in format claims, and asked
after the built-in formats, so a plugin cannot change how a built-in format is read nor make one
wait. A plugin's import runs isolated: one that fails, calls ``sys.exit``, or takes more than
``PLUGIN_IMPORT_TIMEOUT_S``, is not a :class:`Source` subclass, reuses a registered format's
name, or raises in ``can_open`` is skipped with a one-line note (:data:`PLUGIN_NOTES`, and a
warning on the ``vrelab.readers`` logger, which the CLI prints on stderr); what it prints at
import is kept off stdout; vrelab keeps working. A plugin's samples are checked as they are read
(real numbers, 1-D, as many as asked). A record read by a plugin says so in its ``reader_notes``.

**Untrusted files.** vrelab reads the file it is given and nothing a file points to: an HDF5
dataset whose samples live in another file (external storage, a virtual dataset mapping another
file) is listed, with where its data live, and refused when named. A compressed HDF5 chunk is
inflated whole by any read: one above 1/64 of the memory budget is refused. At most
``MAX_CHANNELS`` (1000) channels are indexed and listed; the rest are counted, and one of them
is read when named exactly.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab.analysis.readers import (  # noqa: F401  (they register)
    hdf5,
    ide,
    lvm,
    matlab,
    mdf,
    numpy_,
    tdms,
    text,
    uff,
    wav,
)
from vrelab.analysis.readers._base import (
    G0,
    MAX_CHANNELS,
    PLUGIN_GROUP,
    PLUGIN_NOTES,
    PLUGINS,
    READERS,
    TIME_NAMES,
    UNITS,
    Scale,
    Source,
    as_scale,
    formats,
    formats_text,
    load_plugins,
    reader_for,
    register,
)
from vrelab.analysis.readers.units import ASSUMED_NOTE, channel_scale
from vrelab.record import Schedule

# physics §4.2: a sample rate above this is refused before any memory is sized from it. Shaker-test
# DAQs sample at up to a few hundred kHz (IEPE front ends at 51.2-204.8 kHz); 10 MHz leaves a
# wide margin, while a corrupt header (a WAV claiming 4.29 GHz) is far beyond it.
MAX_PLAUSIBLE_FS_HZ = 1e7


def detect_format(path: Path) -> str:
    """The format name of ``path`` from the registry: its magic bytes, else its extension.

    Examples
    --------
    >>> from pathlib import Path
    >>> from vrelab.analysis.readers import detect_format
    >>> detect_format(Path("examples/campaign/runs/01_z_up_80hz.tdms")), detect_format(Path("examples/campaign/runs/02_z_down_80hz.csv"))
    ('tdms', 'csv')
    """
    return reader_for(Path(path)).fmt


def _open_source(path: Path) -> Source:
    cls = reader_for(path)  # a format whose library is missing: refused here with its install hint
    fmt = cls.fmt
    try:
        src = cls.open(path)
        if cls in PLUGINS:
            _check_plugin_source(src, PLUGINS[cls])
            src.notes.append(f"read by reader plugin {PLUGINS[cls]}")
        return src
    except ValueError as exc:
        if str(exc).startswith(path.name):
            raise
        raise ValueError(f"{path.name}: cannot read as {fmt.upper()} (truncated or corrupt?): {exc}") from None
    except MemoryError:
        raise
    except Exception as exc:  # each format's library raises its own types on a corrupt file
        raise ValueError(f"{path.name}: cannot read as {fmt.upper()} (truncated or corrupt?): "
                         f"{type(exc).__name__}: {exc}") from None


def _check_plugin_source(src: Any, where: str) -> None:
    """A plugin's source is held to what the built-in readers give: a :class:`Source`, channel
    names as text, lengths as counts, a rate that is a positive finite number or none, units as
    text. What it gets wrong is one line naming the plugin."""
    def bad(what: str) -> ValueError:
        return ValueError(f"reader plugin {where} gave {what}")

    if not isinstance(src, Source):
        raise bad(f"a {type(src).__name__} from open(), not a Source")
    if not isinstance(src.lengths, dict) or not all(
            isinstance(k, str) and isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 0
            for k, v in src.lengths.items()):
        raise bad("channel lengths that are not {name: samples}")
    fs = src.fs_hz
    if fs is not None and not (isinstance(fs, (int, float, np.floating)) and math.isfinite(fs) and fs > 0):
        raise bad(f"sample rate {fs!r}")
    if not isinstance(src.units, dict) or not all(isinstance(v, str) for v in src.units.values()):
        raise bad("units that are not text")


def plugin_samples(src: Source, name: str, x: Any, n: int) -> NDArray[Any]:
    """A plugin's block of channel ``name``, checked as a built-in reader's would be: a 1-D real
    numeric array of the ``n`` samples asked for (complex samples, None, objects, 2-D arrays or a
    short read are one line naming the plugin and the channel, never a number)."""
    where = PLUGINS.get(type(src), type(src).__name__)
    a = np.asarray(x) if isinstance(x, np.ndarray) or np.isscalar(x) or isinstance(x, (list, tuple)) else None
    if a is None or a.dtype.kind not in "biuf":
        what = "None" if x is None else (f"{a.dtype} samples" if a is not None else f"a {type(x).__name__}")
        raise ValueError(f"reader plugin {where} gave {what} for channel {name!r}: not real numbers")
    if a.ndim != 1 or len(a) != n:
        raise ValueError(f"reader plugin {where} gave an array of shape {a.shape} for channel {name!r}, "
                         f"asked for {n} samples")
    return a


def resolve_channel(name: str, src: Source, role: str) -> str:
    """The file's channel that ``name`` means: exactly, else case-insensitively, else as a column
    index (``ch0``), else as the last part of a ``group/name``. A name that several channels
    answer to is refused with each one's full name (never the first match, silently)."""
    chans = src.channels
    many = getattr(src, "ambiguous", {}) or {}
    if name in many or name.strip() in many:
        cands = many.get(name, many.get(name.strip(), []))
        raise ValueError(f"{role} channel {name!r} is ambiguous in {src.path.name}: it names "
                         f"{', '.join(repr(c) for c in cands)}; give one of these")
    if name in chans:
        return name
    key = name.lower().lstrip("/")
    low = [c for c in chans if c.lower() == key]
    if len(low) == 1:
        return low[0]
    m = re.fullmatch(r"(?:ch|col|channel|c)?_?(\d+)", key)
    if not low and m and m.group(1) in chans:
        return m.group(1)
    tails = low or [c for c in chans if c.lower().split("/")[-1] == key]
    if len(tails) == 1:
        return tails[0]
    if len(tails) > 1:
        raise ValueError(f"{role} channel {name!r} is ambiguous in {src.path.name}: it names "
                         f"{', '.join(repr(c) for c in tails)}; give one of these")
    if src.unlisted and src.find(name):
        return name.lstrip("/") if name.lstrip("/") in src.channels else name
    listing = ", ".join(chans) if chans else "none"
    if src.unlisted:
        listing += f" and {src.unlisted} more not listed"
    raise ValueError(f"{role} channel {name!r} not found in {src.path.name}; channels: {listing} "
                     f"(vrelab channels {src.path.name} lists each with its rate and unit)")


# a time column by its header: time, t, timestamp, seconds, with a unit in brackets or after _
_TIME_HEADER = re.compile(r"(?:time|t|timestamp|times|seconds|elapsed(?: time)?)\s*(?:[\(\[]\s*(s|sec|ms|us|µs|ns)\s*[\)\]]|_(s|sec|ms|us))?")
_TIME_FACTOR = {None: 1.0, "s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9}


def time_unit(name: str) -> float | None:
    """Seconds per unit of a column whose header names time (``Time (s)``, ``t [ms]``, ``time_s``),
    else None."""
    m = _TIME_HEADER.fullmatch(name.lower().split("/")[-1].strip())
    if not m:
        return None
    return _TIME_FACTOR[m.group(1) or m.group(2)]


def _time_rate(src: Source, name: str, block: int = 1 << 20) -> float:
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
    """A lab file as a :class:`~vrelab.record.Record` with channels ``dut`` (and ``reference``) in g.

    Examples
    --------
    What :func:`open_record` returns:

    >>> from vrelab.analysis import open_record
    >>> from vrelab.analysis.readers import Scale
    >>> record = open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", reference="shaker/ref",
    ...                      dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10))
    >>> with record:
    ...     print(type(record).__name__, record.n_samples)
    FileRecord 84000
    """

    source: Source
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
        blocks = self.source.stream(raw, int(start), stop, block_size)
        plugin = type(self.source) in PLUGINS
        pos = int(start)
        while True:
            try:
                blk = next(blocks)
            except StopIteration:
                if plugin and pos < stop:
                    raise ValueError(f"reader plugin {PLUGINS[type(self.source)]} gave {pos - int(start)} samples of "
                                     f"{', '.join(map(repr, raw))}, asked for {stop - int(start)}") from None
                return
            except ValueError:
                raise
            except MemoryError:
                raise
            except Exception as exc:  # a decoder's own error on a corrupt file (zlib, struct, h5py, ...)
                name = self.path.name
                raise ValueError(f"{name}: cannot read its samples (truncated or corrupt?): {type(exc).__name__}: {exc}") from None
            if plugin:  # each channel's block as long as asked (Source.stream's contract)
                n = min(block_size, stop - pos)
                blk = {r: plugin_samples(self.source, r, blk.get(r) if isinstance(blk, dict) else None, n) for r in raw}
                pos += n
            yield {c: self.scales[c].to_g(blk[r]) for c, r in zip(channels, raw)}

    @property
    def random_access(self) -> bool:
        """Whether a stretch can be read without reading what comes before it (not so for CSV)."""
        return bool(getattr(self.source, "random_access", True))

    def close(self) -> None:
        self.source.close()

    def __enter__(self) -> FileRecord:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def dut_channels(dut: str | Sequence[str] | Mapping[str, str]) -> dict[str, str]:
    """Record channel -> file channel for ``open_record``'s ``dut``: one name gives ``dut``;
    a list (the file's names are the campaign's) or a mapping name -> file channel gives
    ``dut:<name>`` for each.

    Examples
    --------
    >>> from vrelab.analysis.readers import dut_channels
    >>> dut_channels("shaker/sn1_z")
    {'dut': 'shaker/sn1_z'}
    >>> dut_channels({"sn1": "shaker/sn1_z", "sn2": "shaker/sn2_z"})
    {'dut:sn1': 'shaker/sn1_z', 'dut:sn2': 'shaker/sn2_z'}
    """
    if isinstance(dut, str):
        return {"dut": dut}
    pairs = list(dut.items()) if isinstance(dut, Mapping) else [(str(d), str(d)) for d in dut]
    if not pairs:
        raise ValueError("no DUT channel given")
    out: dict[str, str] = {}
    for name, ch in pairs:
        if not isinstance(ch, str) or not str(name).strip() or not ch.strip():
            raise ValueError(f"DUT channel {name!r} = {ch!r}: give a channel name")
        key = f"dut:{str(name).strip()}"
        if key in out:
            raise ValueError(f"DUT channel {name!r} given twice")
        out[key] = ch.strip()
    return out


def open_record(
    path: str | Path,
    dut: str | Sequence[str] | Mapping[str, str],
    reference: str | None = None,
    fs_hz: float | None = None,
    dut_scale: Scale | float | None | Mapping[str, Scale | float | None] = None,
    reference_scale: Scale | float | None = None,
    time_channel: str | None = None,
    accept_file_units: bool = False,
) -> FileRecord:
    """Open a recorded test read-only as a streaming record with channels ``dut``/``reference`` in g.

    Parameters
    ----------
    path : str or Path
        CSV/TSV, NPY, NPZ, HDF5, NI TDMS, WAV (PCM, float, RF64), MAT (v5 or v7.3).
    dut, reference : str
        Channel names in the file: a CSV column (or its index ``0``/``ch0``), an HDF5/MAT dataset
        path, a TDMS ``group/channel`` (or a unique channel name), a WAV/NPY column index, a
        UFF58 ``id1`` or ``NODE:DIR``. Several DUTs: a list of the file's names, or a mapping
        campaign name -> file channel; the record's channels are then ``dut:<name>`` (read one
        with :class:`vrelab.record.ChannelView`) and ``dut_scale`` may map names to scales.
    fs_hz : float, optional
        Sample rate [Hz] when neither the file nor a time column gives it.
    dut_scale, reference_scale : Scale or float, optional
        Raw units to g (a float is a sensitivity in LSB/g). Default (None): the unit the file
        states for the channel (:mod:`vrelab.analysis.readers.units`), else g; integer samples
        with no unit are counts and are refused without a sensitivity.
    time_channel : str, optional
        Time column [s]; by default a column named ``time``/``t``/``time_s``/``timestamp`` is
        used when the file has no sample rate of its own.
    accept_file_units : bool
        Use the given units even where they contradict the unit the file states.

    Returns
    -------
    FileRecord
        ``blocks()`` reads lazily; ``meta`` holds ``source``, ``format``, ``channels`` and
        ``reader_notes`` (plus the HDF5 ``meta`` attribute of vrelab's own records).

    Examples
    --------
    The example campaign's 80 Hz run (a TDMS file): its DUT in LSB at 256000 LSB/g and its
    reference in mV at 10 mV/g, read in g:

    >>> from vrelab.analysis import open_record
    >>> from vrelab.analysis.readers import Scale
    >>> record = open_record("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z", reference="shaker/ref",
    ...                      dut_scale=Scale("lsb", 256000), reference_scale=Scale("mv", 10))
    >>> with record:
    ...     print(record.channels, f"{record.fs_hz:.0f} Hz")
    ('dut', 'reference') 6000 Hz
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
        mapping = {key: resolve_channel(ch, src, "DUT") for key, ch in dut_channels(dut).items()}
        seen: dict[str, str] = {}
        for key, ch in mapping.items():
            if ch in seen:
                raise ValueError(f"DUTs {seen[ch][4:]!r} and {key[4:]!r} are the same file channel {ch!r}")
            seen[ch] = key
        if reference is not None:
            mapping["reference"] = resolve_channel(reference, src, "reference")
            if mapping["reference"] in seen:
                raise ValueError(f"reference and DUT are the same channel {mapping['reference']!r}")
        src.select(list(mapping.values()), fs_hz)
        lens = {f"{role} {ch!r}": src.lengths[ch] for role, ch in mapping.items()}
        tcol = None
        if time_channel is not None:
            tcol = resolve_channel(time_channel, src, "time")
        elif src.fs_hz is None:
            cands = [c for c in src.channels if (c.lower().split("/")[-1] in TIME_NAMES or time_unit(c) is not None)
                     and c not in mapping.values()]
            tcol = cands[0] if len(cands) == 1 else None
        if tcol is not None:
            lens[f"time {tcol!r}"] = src.lengths[tcol]
        for role, ch in list(mapping.items()) + ([("time", tcol)] if tcol is not None else []):
            why = src.refusal(ch, "DUT channel" if role.startswith("dut") else f"{role} channel")
            if why:
                raise ValueError(why)
        if len(set(lens.values())) > 1:
            raise ValueError(
                f"{path.name}: channels have mismatched lengths: "
                + ", ".join(f"{k} has {v} samples" for k, v in lens.items())
            )
        n = next(iter(lens.values()))
        if n == 0:
            raise ValueError(f"{path.name}: channels hold no samples")
        fs, how = _sample_rate(path, src, fs_hz, tcol, n)
        scales: dict[str, Scale] = {}
        assumed: list[str] = []
        for key, ch in mapping.items():
            ref = key == "reference"
            given = _given_scale(reference_scale if ref else dut_scale, key)
            role = "reference" if ref else ("DUT" if key == "dut" else f"DUT {key[4:]!r}")
            try:
                scales[key], note = channel_scale(role, ch, given, src.unit_of(ch), src.is_integer(ch),
                                                  accept_file_units, "--reference-units" if ref else "--dut-units")
            except ValueError as exc:
                raise ValueError(f"{path.name}: {exc}") from None
            if note:
                src.notes.append(note)
                if ASSUMED_NOTE in note:
                    assumed.append(ch)
        meta = dict(src.meta)
        meta.update(
            source=path.name,
            format=src.fmt,
            channels=dict(mapping),
            fs_from=how,
            reader_notes=list(src.notes),
            units_assumed=assumed,  # file channels read as g for want of any stated unit
        )
        if not isinstance(dut, str):
            meta["duts"] = {key[4:]: ch for key, ch in mapping.items() if key.startswith("dut:")}
        return FileRecord(src, mapping, scales, float(fs), int(n), src.schedule, meta)
    except BaseException:
        src.close()
        raise


def _sample_rate(path: Path, src: Source, fs_hz: float | None, tcol: str | None, n: int) -> tuple[float, str]:
    """(rate [Hz], where it came from): the file's, else its time column's, else ``fs_hz``; a
    given rate that disagrees is refused, one that replaces an implausible header is noted."""
    fs = src.fs_hz
    how = "file"
    if fs is None and tcol is not None:
        fs, how = _time_rate(src, tcol) / (time_unit(tcol) or 1.0), f"time column {tcol!r}"
    if fs is None:
        if fs_hz is None:
            raise ValueError(f"{path.name}: no sample rate in the file and no time column: give --fs HZ")
        fs, how = fs_hz, "given"
    elif fs_hz is not None and fs > MAX_PLAUSIBLE_FS_HZ and fs_hz <= MAX_PLAUSIBLE_FS_HZ:
        # a corrupt header: the user's rate wins, and the record says so
        src.notes.append(f"the file's sample rate {fs:.6g} Hz is implausible: --fs {fs_hz:g} Hz used instead")
        fs, how = fs_hz, "given (the file's is implausible)"
    elif fs_hz is not None and abs(fs - fs_hz) > 1e-6 * fs:
        raise ValueError(f"--fs {fs_hz:g} Hz disagrees with the sample rate from the {how}: {fs:.9g} Hz")
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"{path.name}: bad sample rate {fs!r} from the {how}")
    if fs > MAX_PLAUSIBLE_FS_HZ:
        raise ValueError(
            f"{path.name}: sample rate {fs:.6g} Hz from the {how} is implausible for a vibration record "
            f"(above {MAX_PLAUSIBLE_FS_HZ:g} Hz; {n} samples would last {n / fs:.3g} s): a corrupt header? "
            "give the true rate with --fs"
        )
    return float(fs), how


def list_channels(path: str | Path) -> dict[str, Any]:
    """Every channel of a file as a plain dict (``vrelab channels``): ``{"file", "format",
    "notes", "unlisted", "channels": [{"name", "rate_hz", "n_samples", "duration_s", "unit",
    "unit_source", "notes", "data"}]}``.

    ``name`` is what ``--dut``/``--reference`` take; ``rate_hz`` the channel's own rate (null
    with the reason in ``notes`` when the file gives none or its stamps are refused); ``unit``
    what the file states (null: none), ``unit_source`` where that comes from
    (:func:`unit_source`: ``file``, ``header``, ``assumed`` g, or ``none`` for counts); ``notes``
    what a reader said of the channel (another name it answers to, integer counts, the time
    column used, a rate snapped or fitted, why it is not read); ``data`` where its samples live
    (:meth:`Source.location`: ``{"kind": "file" | "external" | "virtual", "files": [...]}``).
    At most :data:`MAX_CHANNELS` are listed; ``unlisted`` counts the rest.

    Examples
    --------
    >>> from vrelab.analysis.readers import list_channels
    >>> listing = list_channels("examples/campaign/runs/01_z_up_80hz.tdms")
    >>> listing["format"], [channel["name"] for channel in listing["channels"]]
    ('tdms', ['shaker/ref', 'shaker/sn1_z', 'shaker/sn2_z'])
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"input file not found: {path}")
    if path.stat().st_size == 0:
        raise ValueError(f"{path.name}: file is empty")
    src = _open_source(path)
    try:
        if not src.channels:
            raise ValueError(f"{path.name}: no numeric channels found")
        aliases: dict[str, list[str]] = {}
        for key, name in (getattr(src, "alias", {}) or {}).items():
            if key != name:
                aliases.setdefault(name, []).append(key)
        names = [c for c in src.channels if c not in (getattr(src, "alias", {}) or {}) or c in aliases]
        unlisted = src.unlisted + max(len(names) - MAX_CHANNELS, 0)
        names = names[:MAX_CHANNELS]
        # a file-level time column times the others; where each channel has its own stamps, none does
        tcols = [] if src.own_stamps else [c for c in names
                                           if c.lower().split("/")[-1] in TIME_NAMES or time_unit(c) is not None]
        time_fs: float | None = None
        time_note = None
        if src.fs_hz is None and not src.rates and len(tcols) == 1:
            try:
                time_fs = _time_rate(src, tcols[0]) / (time_unit(tcols[0]) or 1.0)
                time_note = f"rate from the time column {tcols[0]!r}"
            except ValueError as exc:
                time_note = str(exc)
        file_notes_before = list(src.notes)
        out = []
        for name in names:
            notes: list[str] = []
            if name in aliases:
                notes.append("also named " + ", ".join(repr(a) for a in aliases[name]))
            before = len(src.notes)
            refused = False  # the file's stamps give no rate: their reason, not "give --fs", is the note
            try:
                fs = src.rate_of(name)
            except ValueError as exc:
                fs, notes, refused = None, notes + [str(exc)], True
            notes += [n for n in src.notes[before:] if n not in file_notes_before]
            if name in tcols:
                notes.append("a time column")
            elif fs is None and time_fs is not None:
                fs = time_fs
                notes.append(time_note or "")
            elif fs is None and not refused:
                notes.append(time_note or "no sample rate in the file: give --fs HZ")
            n = int(src.lengths[name])
            if src.is_integer(name) and not src.unit_of(name):
                notes.append("integer samples (ADC counts): give --dut-units lsb --dut-sensitivity S")
            why = src.refusal(name, "channel")
            if why:
                notes.append("not read: " + why.split(f"{name!r} ", 1)[1])
            out.append({
                "name": name, "rate_hz": fs, "n_samples": n,
                "duration_s": (n / fs) if fs else None,
                "unit": src.unit_of(name), "unit_source": unit_source(src, name), "notes": notes,
                "data": src.location(name),
            })
        for name, cands in src.ambiguous.items():
            out.append({"name": name, "rate_hz": None, "n_samples": None, "duration_s": None, "unit": None,
                        "unit_source": None, "data": None,
                        "notes": [f"ambiguous: names {', '.join(repr(c) for c in cands)}; give one of these"]})
        notes = list(src.notes)
        if unlisted and not src.unlisted:
            notes.append(f"{len(names) + unlisted} channels: the first {len(names)} listed, {unlisted} more not listed")
        return {"file": str(path), "format": src.fmt, "notes": notes, "channels": out, "unlisted": unlisted}
    finally:
        src.close()


def unit_source(src: Source, name: str) -> str:
    """Where channel ``name``'s unit comes from: ``"file"`` (the format's metadata: TDMS
    ``unit_string``, an HDF5 attribute, LVM ``Y_Unit_Label``...), ``"header"`` (a text header:
    a column name's brackets, a logger's comment lines), ``"assumed"`` (none stated, floating
    samples: read as g unless told, and said), ``"none"`` (none stated, integer samples: counts,
    refused without a sensitivity)."""
    if src.unit_of(name):
        return "header" if name in src.header_units else "file"
    return "none" if src.is_integer(name) else "assumed"


def _given_scale(scale: Any, key: str) -> Scale | None:
    """The scale the caller gives for record channel ``key`` (``dut``, ``dut:<name>`` or
    ``reference``): one for all, or a mapping name -> scale; None where none is given."""
    if isinstance(scale, Mapping):
        name = key[4:]
        if name not in scale:
            raise ValueError(f"no DUT sensitivity for channel {name!r} (the table names {', '.join(map(str, scale))})")
        scale = scale[name]
    return None if scale is None else as_scale(scale)


__all__ = ["open_record", "list_channels", "dut_channels", "FileRecord", "Scale", "Source", "detect_format", "register",
           "READERS", "UNITS", "G0", "formats", "formats_text", "load_plugins", "PLUGIN_GROUP", "PLUGIN_NOTES"]
