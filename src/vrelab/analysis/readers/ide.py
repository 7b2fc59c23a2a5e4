"""enDAQ IDE recordings through idelib (the EBML files enDAQ / Slam Stick recorders write).

Channels: every sub-channel holding samples, named by its name (``X (100g)``) and by
``<channel>.<sub-channel>`` (``8.0``); a name two sub-channels share is neither's (each is then
``<channel name>/<name>``) and asking for it is refused as ambiguous. Values are what idelib
gives (its calibration applied: g for accelerometers), in the sub-channel's units. A recorder
timestamps each data block, not each sample: the sample rate is fitted to the block stamps
(jitter of a clock tick and a slow drift accepted and said in the notes, a jump of several
samples refused as a gap); channels of different rates cannot form one record (IDE files hold
several, e.g. a 20 kHz accelerometer and a 100 Hz one), so a record's channels must share one.
idelib's own ``getSampleRate()`` (the first block's stamps alone) is stated beside it in the
notes and in the record's ``meta["fs_library_hz"]``; the analysis judges their difference level
by level (:func:`vrelab.analysis.pipeline.library_rate_notice`).

No code from the file: idelib reads a channel's ``SampleRate`` and ``TimeCodeScale`` (strings)
with Python's ``eval``; vrelab hands idelib its own channel parser, which lets through only what
the schema says these fields are (an integer, decimal or ratio, ``16262/32768``) and refuses the
file otherwise, naming the channel and the field (:func:`_parser_types`).

Memory: idelib indexes the file's data blocks on opening (a few numbers per block); a stretch
is read by ``arraySlice(start, stop)``, so memory follows the block read, not the file.
"""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import Source, one_rate, register, stamped_rate

_EVEN_RTOL = 0.01
# block stamps: a jump of more than this many samples between blocks is a gap (stamp jitter is a
# clock tick, about a sample at 20 kHz); stamps further than this off one line are not one rate
_GAP_SAMPLES = 5.0
_DRIFT_SAMPLES = 25.0


def _block_stamps(ev: Any) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """(first sample index, start time [s]) of each data block, and the time [s] from each
    block's start stamp to its end stamp (its last sample) where the recorder wrote end stamps
    (None otherwise: old files have none, idelib then repeats the start).

    idelib keeps each block's index range and stamps (``EventArray._data``, not public API):
    reading them costs nothing, where every sample's time costs a pass over the file. Without
    them, the first 20000 samples' times."""
    try:
        blocks = list(ev._data)
        idx = [int(b.indexRange[0]) for b in blocks]
        last = [int(b.indexRange[1]) - 1 for b in blocks]
        t = [float(b.startTime) for b in blocks]
        end = [float(b.endTime) for b in blocks]
    except (AttributeError, TypeError):
        idx = []
    if len(idx) < 3:  # no block index, or too few blocks to fit: the samples' own times
        k = min(len(ev), 20000)
        times = np.asarray(ev.arraySlice(0, k)[0], dtype=np.float64)
        return np.arange(k, dtype=np.float64), times * 1e-6, None  # idelib times are µs
    span = (np.asarray(end) - np.asarray(t))[:-1] * 1e-6
    inner = (np.asarray(last) - np.asarray(idx))[:-1]
    # end stamps are the recorder's only where every block of several samples has one after its start
    spans = span if ((span > 0) | (inner == 0)).all() else None
    return np.asarray(idx, dtype=np.float64), np.asarray(t, dtype=np.float64) * 1e-6, spans


class _Said(logging.Handler):
    """idelib's log records, as one-line messages."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(str(record.getMessage()).splitlines()[0] if record.getMessage() else record.levelname)


def _unit(sc: Any) -> str | None:
    """The unit idelib gives a sub-channel (``units`` is (quantity, unit): ('Acceleration', 'g'))."""
    u = getattr(sc, "units", None)
    if isinstance(u, (tuple, list)) and len(u) >= 2:
        return str(u[1]).strip() or None
    return None


# The schema's "integer, decimal or ratio" (mide_ide.xml, SampleRate and TimeCodeScale), with
# at most 30 digits a number: the only text idelib's eval is given.
_NUMBER = r"\s*[0-9]{1,30}(?:\.[0-9]{0,30})?\s*"  # no exponent: valEval reads its e as math.e
_RATIO = re.compile(rf"{_NUMBER}(?:/{_NUMBER})?")
_EVALUATED = {"SampleRate": "sample-rate", "TimeCodeScale": "time-code-scale"}


class _Refused(ValueError):
    """A field idelib would evaluate holds an expression, not a number."""


def evaluated_field_refusal(channel: dict[str, Any]) -> str | None:
    """Why a ``Channel`` element (its dump: element name -> value) cannot be handed to idelib,
    or None: a field idelib evaluates (``SampleRate``, ``TimeCodeScale``) that is not a number
    or a ratio of two. idelib's ``valEval`` is Python's ``eval`` behind a character filter that
    lets ``9**9**9**9`` through (it never returns) and, through the math-function names it
    allows, more; the fields are checked before idelib sees them, not evaluated here."""
    for key, what in _EVALUATED.items():
        text = channel.get(key)
        if text is None:
            continue
        if isinstance(text, (bytes, bytearray)):
            text = bytes(text).decode("utf-8", "replace")
        if not isinstance(text, str) or not _RATIO.fullmatch(text):
            shown = text if isinstance(text, str) and len(text) <= 60 else f"{str(text)[:60]}..."
            name = channel.get("ChannelName")
            label = f"IDE channel {channel.get('ChannelID', '?')}" + (f" ({name})" if name else "")
            return (f"{label}: its {what} field {shown!r} is not an integer, decimal or ratio; "
                    "vrelab does not evaluate a file's expressions: refused")
    return None


def _parser_types() -> list[type]:
    """idelib's element parsers with the channel parser replaced by one that checks the fields
    idelib evaluates first (idelib's own hook: ``importFile(parserTypes=)``)."""
    from idelib import importer, parsers

    # idelib has no type hints (nor stubs on PyPI): its parser classes are Any to mypy, hence the
    # three ignores of subclassing them
    class Channel(parsers.ChannelParser):  # type: ignore[misc]
        def parse(self, element: Any, **kwargs: Any) -> Any:
            why = evaluated_field_refusal(element.dump())
            if why:
                raise _Refused(why)
            return super().parse(element, **kwargs)

    class ChannelList(parsers.ChannelListParser):  # type: ignore[misc]
        children = (Channel,)

    class RecordingProperties(parsers.RecordingPropertiesParser):  # type: ignore[misc]
        children = tuple(ChannelList if c is parsers.ChannelListParser else c
                         for c in parsers.RecordingPropertiesParser.children)

    return [RecordingProperties if t is parsers.RecordingPropertiesParser else t
            for t in importer.ELEMENT_PARSER_TYPES]


@register
class IdeSource(Source):
    fmt = "ide"
    extensions = (".ide",)
    requires = "idelib"
    install = "vrelab[formats]"
    own_stamps = True

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"\x1a\x45\xdf\xa3") and b"mide" in head[:64]

    def __init__(self, path: Path) -> None:
        import idelib

        super().__init__(path)
        # idelib logs what it cannot parse (with a traceback) on the root logger's stderr: kept
        # here as notes, one line each, so a command's stderr stays one line
        log, said = logging.getLogger("idelib"), _Said()
        log.addHandler(said)
        log.propagate = False
        # idelib.importFile's two steps (openFile, readData) on a stream this reader owns, so a
        # file idelib refuses half-way is closed here rather than left to the garbage collector
        stream = open(path, "rb")
        try:
            parsers = _parser_types()
            self.doc = idelib.importer.openFile(stream, parserTypes=parsers, quiet=True)
            idelib.importer.readData(self.doc, parserTypes=parsers)
        except _Refused as exc:
            stream.close()
            raise ValueError(f"{path.name}: {exc}") from None
        except Exception as exc:
            stream.close()
            raise ValueError(f"{path.name}: cannot read as IDE: {type(exc).__name__}: {exc}") from None
        finally:
            log.removeHandler(said)
            log.propagate = True
        self.notes += [f"idelib: {m}" for m in dict.fromkeys(said.messages)]
        try:
            self._index()
        except BaseException:
            self.close()  # refused after idelib opened the file: do not leave its handle to the GC
            raise

    def _index(self) -> None:
        """The channels that hold samples, by name (ambiguous names by channel)."""
        path = self.path
        self.events: dict[str, Any] = {}
        self.alias: dict[str, str] = {}
        self._rates: dict[str, float] = {}
        found: list[tuple[str, str, str, Any, Any]] = []  # (name, channel/name, cid.sid, events, sub-channel)
        for cid, ch in sorted(self.doc.channels.items()):
            for sc in ch.subchannels:
                try:
                    ev = sc.getSession()
                    n = len(ev)
                except Exception:
                    continue
                if n < 2:
                    continue
                key = f"{cid}.{sc.id}"
                name = str(sc.name).strip() or key
                found.append((name, f"{str(ch.name).strip() or cid}/{name}", key, ev, sc))
        if not found:
            raise ValueError(f"{path.name}: no IDE channel holds samples")
        counts: dict[str, int] = {}
        for name, *_ in found:
            counts[name] = counts.get(name, 0) + 1
        full_counts: dict[str, int] = {}
        for _, full, *_ in found:
            full_counts[full] = full_counts.get(full, 0) + 1
        for name, full, key, ev, sc in found:
            # a name two sub-channels share (X of the accelerometer and X of a quaternion) is
            # neither's: each is named by its channel, and the bare name is ambiguous
            if counts[name] > 1:
                self.ambiguous.setdefault(name, []).append(full if full_counts[full] == 1 else key)
                name = full if full_counts[full] == 1 else key
            self.events[name] = ev
            self.lengths[name] = len(ev)
            self.alias[key] = name
            if full != name and full_counts[full] == 1:
                self.alias[full] = name  # 'Acceleration/Y' too, whether or not 'Y' is unique
            unit = _unit(sc)
            if unit:
                self.units[name] = unit
        for key, name in self.alias.items():
            if key not in self.lengths:
                self.lengths[key] = self.lengths[name]
                if name in self.units:
                    self.units[key] = self.units[name]

    def rate(self, name: str) -> float:
        """Samples per second of ``name``, fitted to the recorder's block stamps
        (:func:`~vrelab.analysis.readers._base.stamped_rate`): stamps jitter by a clock tick
        (1/32768 s, more than a sample at 20 kHz) and a recorder's clock drifts a few samples
        over a record; a jump of more than a few samples between blocks is a gap, refused."""
        name = self.alias.get(name, name)
        if name not in self._rates:
            idx, t, spans = _block_stamps(self.events[name])
            fs, note = stamped_rate(f"{self.path.name}: IDE channel {name!r}", idx, t,
                                    gap_samples=_GAP_SAMPLES, drift_samples=_DRIFT_SAMPLES, spans_s=spans)
            if note and note not in self.notes:
                self.notes.append(note)
            self._rates[name] = fs
        return self._rates[name]

    def rate_of(self, name: str) -> float | None:
        return self.rate(name)

    def select(self, names: Sequence[str], fs_hz: float | None = None) -> None:
        fs = one_rate(self.path, {n: self.rate(n) for n in names}, _EVEN_RTOL)
        if fs is None:
            return
        self.fs_hz = fs
        lib = self._library_rate(names)
        if lib is None:
            self.notes.append(f"IDE: sample rate {self.fs_hz:.9g} Hz fitted to the recorder's block time stamps")
            return
        # idelib's own rate: the channel's stated SampleRate, else its first block's stamps alone
        # (one block: a clock tick of jitter over its span is 0.02-0.4 % on enDAQ files); the
        # analysis judges the difference level by level against each level's u
        self.meta["fs_library_hz"] = lib
        self.notes.append(f"IDE: sample rate {self.fs_hz:.9g} Hz fitted to the recorder's block time stamps over "
                          f"the record; idelib's getSampleRate() gives {lib:.9g} Hz ({100 * (lib / fs - 1):+.3g} %: "
                          "the channel's stated rate, else its first block's stamps alone)")

    def _library_rate(self, names: Sequence[str]) -> float | None:
        """idelib's ``EventArray.getSampleRate()`` of the channels ``names`` (their mean), or None
        when idelib gives none."""
        rates = []
        for n in names:
            try:
                r = float(self.events[self.alias.get(n, n)].getSampleRate())
            except Exception:  # idelib's internals on a file it half understands: no second opinion
                return None
            if not (math.isfinite(r) and r > 0):
                return None
            rates.append(r)
        return sum(rates) / len(rates) if rates else None

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        name = self.alias.get(name, name)
        try:
            return np.asarray(self.events[name].arraySlice(int(start), int(stop))[1], dtype=np.float64)
        except Exception as exc:
            raise ValueError(f"{self.path.name}: cannot read IDE channel {name!r} at {start}-{stop}: {exc}") from None

    def close(self) -> None:
        try:
            self.doc.close()
        except Exception:
            pass
