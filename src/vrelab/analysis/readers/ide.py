"""enDAQ IDE recordings through idelib (the EBML files enDAQ / Slam Stick recorders write).

Channels: every sub-channel holding samples, named by its name (``X (100g)``) and by
``<channel>.<sub-channel>`` (``8.0``). Values are what idelib gives (its calibration applied:
g for accelerometers). A recorder timestamps each data block, not each sample: the sample rate
is the count over the time span of a channel, checked even (every sample within half a step of
a constant rate: no gap, no drop); channels of different rates cannot form one record (IDE files hold several, e.g.
a 20 kHz accelerometer and a 100 Hz one), so a record's channels must share one.

No code from the file: idelib reads a channel's ``SampleRate`` and ``TimeCodeScale`` (strings)
with Python's ``eval``; vrelab hands idelib its own channel parser, which lets through only what
the schema says these fields are (an integer, decimal or ratio, ``16262/32768``) and refuses the
file otherwise, naming the channel and the field (:func:`_parser_types`).

Memory: idelib indexes the file's data blocks on opening (a few numbers per block); a stretch
is read by ``arraySlice(start, stop)``, so memory follows the block read, not the file.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import Source, one_rate, register

_EVEN_RTOL = 0.01


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

    class Channel(parsers.ChannelParser):
        def parse(self, element: Any, **kwargs: Any) -> Any:
            why = evaluated_field_refusal(element.dump())
            if why:
                raise _Refused(why)
            return super().parse(element, **kwargs)

    class ChannelList(parsers.ChannelListParser):
        children = (Channel,)

    class RecordingProperties(parsers.RecordingPropertiesParser):
        children = tuple(ChannelList if c is parsers.ChannelListParser else c
                         for c in parsers.RecordingPropertiesParser.children)

    return [RecordingProperties if t is parsers.RecordingPropertiesParser else t
            for t in importer.ELEMENT_PARSER_TYPES]


@register
class IdeSource(Source):
    fmt = "ide"
    extensions = (".ide",)

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(b"\x1a\x45\xdf\xa3") and b"mide" in head[:64]

    def __init__(self, path: Path) -> None:
        import idelib

        super().__init__(path)
        try:
            self.doc = idelib.importFile(str(path), quiet=True, parserTypes=_parser_types())
        except _Refused as exc:
            raise ValueError(f"{path.name}: {exc}") from None
        except Exception as exc:
            raise ValueError(f"{path.name}: cannot read as IDE: {type(exc).__name__}: {exc}") from None
        self.events: dict[str, Any] = {}
        self.alias: dict[str, str] = {}
        self._rates: dict[str, float] = {}
        for cid, ch in sorted(self.doc.channels.items()):
            for sc in ch.subchannels:
                try:
                    ev = sc.getSession()
                    n = len(ev)
                except Exception:
                    continue
                if n < 2:
                    continue
                name = str(sc.name).strip() or f"{cid}.{sc.id}"
                if name in self.events:
                    name = f"{cid}.{sc.id}"
                self.events[name] = ev
                self.lengths[name] = n
                self.alias[f"{cid}.{sc.id}"] = name
        if not self.events:
            raise ValueError(f"{path.name}: no IDE channel holds samples")
        for key, name in self.alias.items():
            if key not in self.lengths:
                self.lengths[key] = self.lengths[name]

    def rate(self, name: str) -> float:
        """Samples per second of ``name``: count over time span, block starts checked even."""
        name = self.alias.get(name, name)
        if name not in self._rates:
            ev = self.events[name]
            n = len(ev)
            k = min(n, 20000)
            t = np.asarray(ev.arraySlice(0, k)[0], dtype=np.float64) * 1e-6  # idelib times are µs
            t_end = float(ev.arraySlice(n - 1, n)[0][0]) * 1e-6
            step = (t_end - t[0]) / (n - 1)
            # block stamps jitter by a clock tick (1/32768 s: a large part of a sample at 20 kHz),
            # so the test is a gap or a drop: every sample within half a step of the straight line
            idx = np.arange(len(t))
            line = np.polyval(np.polyfit(idx, t, 1), idx) if len(t) > 2 else t
            off = t - line if step > 0 else np.array([np.inf])
            if not (step > 0) or np.max(np.abs(off)) > 0.5 * step:
                i = int(np.argmax(np.abs(off))) if step > 0 else 0
                raise ValueError(f"{self.path.name}: IDE channel {name!r} is not evenly sampled (sample {i} lies "
                                 f"{off[i] / step:+.2f} steps off a constant rate of {1 / step if step > 0 else 0:.6g} Hz: "
                                 "a gap in the recording?)")
            self._rates[name] = 1.0 / step
        return self._rates[name]

    def select(self, names: Sequence[str]) -> None:
        fs = one_rate(self.path, {n: self.rate(n) for n in names}, _EVEN_RTOL)
        if fs is None:
            return
        self.fs_hz = fs
        self.notes.append(f"IDE: sample rate {self.fs_hz:.6g} Hz from the samples' time span (recorders stamp blocks)")

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
