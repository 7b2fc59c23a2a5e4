"""ASAM MDF (version 4, and 3) through asammdf, as data loggers write it.

Channels: every numeric channel that is not a group's master (time), by its name, or
``<group>/<name>`` when the name occurs in several groups. Values are physical, in the channel's
unit: the raw values read (``raw=True``) and the channel's conversion applied only when it is
arithmetic with no text from the file (identity, linear, rational, polynomial, exponential,
logarithmic, tables): asammdf evaluates an algebraic (formula) conversion's text through numexpr,
else sympy (an ``eval``), so a file with one, on any channel or time channel, is refused naming
the channel and the formula (:func:`conversion_refusal`); value-to-text conversions make no
numbers (the channel is not listed). The sample rate is fitted to the master channel (time
stamps) of each used channel's group: jitter below half a sample is said in the notes, a gap
refused (:func:`~vrelab.analysis.readers._base.stamped_rate`); the channels read must share one
rate; ``--fs`` overrides the stamps.

Memory: reads are record ranges (``get(record_offset=, record_count=)``), so a stretch costs
the records it spans, not the file; opening reads the file's metadata (asammdf's ``MDF``).
"""

from __future__ import annotations

import contextlib
import gc
import sys
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import Source, one_rate, register, stamped_rate

# a logger stamps each record: a step more than half a sample off the fitted rate is a gap, and
# stamps more than a sample off one straight line are not one rate
_GAP_SAMPLES = 0.5
_DRIFT_SAMPLES = 1.0

# Conversion types (ASAM MDF 4.1 cc_type; MDF 3.3 conversion_type) whose arithmetic asammdf does
# with its own constant expressions and the block's numbers, never a text of the file.
_ARITHMETIC_V4 = {0: "identity", 1: "linear", 2: "rational", 4: "table with interpolation", 5: "table",
                  6: "value range table"}
_TEXT_V4 = {7, 8, 9, 10, 11}  # value/range to text, text to value/text, bitfield text
_ARITHMETIC_V3 = {65535: "identity", 0: "linear", 1: "table with interpolation", 2: "table", 6: "polynomial",
                  7: "exponential", 8: "logarithmic", 9: "rational"}
_TEXT_V3 = {11, 12}  # value and range to text
_FORMULA = {True: 3, False: 10}  # algebraic (v4), formula (v3)


def _is_v4(conv: Any) -> bool:
    from asammdf.blocks import v4_blocks

    return isinstance(conv, v4_blocks.ChannelConversion)


def conversion_refusal(conv: Any, depth: int = 0) -> str | None:
    """What is wrong with applying conversion ``conv`` (an asammdf ``ChannelConversion`` or None),
    or None: it is arithmetic on the block's numbers, or makes text from tables whose referenced
    conversions (a value-to-text table's entries and default may be conversions) are themselves
    free of formulas. An algebraic/formula conversion is text from the file that asammdf would
    evaluate; a type this reader does not know is refused as well rather than handed to asammdf."""
    if conv is None:
        return None
    v4 = _is_v4(conv)
    kind = int(conv.conversion_type)
    if kind == _FORMULA[v4]:
        text = str(getattr(conv, "formula", ""))
        shown = text if len(text) <= 80 else text[:80] + "..."
        return f"an algebraic conversion (formula {shown!r})"
    if kind in (_ARITHMETIC_V4 if v4 else _ARITHMETIC_V3):
        return None
    if kind not in (_TEXT_V4 if v4 else _TEXT_V3):
        return f"a conversion of unknown type {kind}"
    refs = [b for b in (getattr(conv, "referenced_blocks", None) or {}).values() if hasattr(b, "conversion_type")]
    if refs and depth >= 4:
        return "value-to-text conversions nested more than 4 deep"
    return next((why for why in (conversion_refusal(b, depth + 1) for b in refs) if why), None)


def _makes_text(conv: Any) -> bool:
    return conv is not None and int(conv.conversion_type) in (_TEXT_V4 if _is_v4(conv) else _TEXT_V3)


def _physical(conv: Any, raw: NDArray[Any]) -> NDArray[Any]:
    """``raw`` through ``conv`` when it is arithmetic (checked again here: this is the one place
    values are converted)."""
    if conv is None:
        return raw
    why = conversion_refusal(conv)
    if why is not None or _makes_text(conv):
        raise ValueError(f"not a numeric conversion: {why or 'value to text'}")
    return np.asarray(conv.convert(raw))


@contextlib.contextmanager
def _half_built_mdf_quiet() -> Iterator[None]:
    """Swallow what asammdf's ``MDF4.__del__``/``MDF3.__del__`` raise on an object whose
    ``__init__`` failed half-way (it closes attributes never set: "Exception ignored in ...
    AttributeError" and a traceback on stderr, after vrelab's one line). Only that: any other
    unraisable exception goes to the hook as before. asammdf gives no way to open a file
    without building that object, hence this filter."""
    previous = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        owner = getattr(unraisable.object, "__qualname__", "")
        if isinstance(unraisable.exc_value, AttributeError) and owner in ("MDF4.__del__", "MDF3.__del__"):
            return
        previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = previous

@register
class MdfSource(Source):
    fmt = "mdf"
    extensions = (".mf4", ".mdf")
    requires = "asammdf"
    install = "vrelab[formats]"
    own_stamps = True

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        # "UnFinMF " is a file a logger has not finalised (CANedge, ...): asammdf finalises it in memory
        return head.startswith((b"MDF     ", b"UnFinMF "))

    def __init__(self, path: Path) -> None:
        from asammdf import MDF

        super().__init__(path)
        failure = None
        with _half_built_mdf_quiet():
            try:
                self.mdf = MDF(str(path))
            except Exception as exc:
                failure = f"{path.name}: cannot read as MDF: {type(exc).__name__}: {exc}"
            if failure is not None:  # the half-built object, if a cycle holds it, goes now, under the filter
                gc.collect()
        if failure is not None:
            raise ValueError(failure)
        self.where: dict[str, tuple[int, int]] = {}
        self._rates: dict[int, float | None] = {}
        try:
            for grp in self.mdf.groups:  # every channel, time channels too, before any value is read
                for ch in grp.channels:
                    self._refuse_formula(str(ch.name), ch.conversion)
        except ValueError:
            self.mdf.close()
            raise
        # asammdf types groups as list[v3 Group] | list[v4 Group]: enumerate() joins them to object
        groups: list[Any] = self.mdf.groups
        masters = {i: g.channel_group for i, g in enumerate(groups)}
        for name, places in self.mdf.channels_db.items():
            for gi, ci in places:
                grp = self.mdf.groups[gi]
                ch = grp.channels[ci]
                if ci == self._master_index(gi) or getattr(ch, "channel_type", 0) in (2, 3):
                    continue
                if _makes_text(ch.conversion) or not self._numeric(gi, ci):
                    continue
                key = name if len(places) == 1 else f"{gi}/{name}"
                self.where[key] = (gi, ci)
                self.lengths[key] = int(masters[gi].cycles_nr)
        if not self.where:
            self.mdf.close()
            raise ValueError(f"{path.name}: no numeric MDF channel")

    def _refuse_formula(self, name: str, conv: Any) -> None:
        why = conversion_refusal(conv)
        if why is not None:
            raise ValueError(f"{self.path.name}: channel {name!r} has {why}; vrelab does not evaluate a file's "
                             "formulas (asammdf would run them as code): refused")

    def _master_index(self, gi: int) -> int | None:
        try:
            return self.mdf.masters_db.get(gi)
        except AttributeError:
            return None

    def _numeric(self, gi: int, ci: int) -> bool:
        try:
            s = self.mdf.get(group=gi, index=ci, record_offset=0, record_count=1, raw=True)
        except Exception:
            return False
        return np.asarray(s.samples).dtype.kind in "biuf"

    def rate(self, name: str) -> float:
        """The sample rate of ``name``'s group, fitted to its master channel's time stamps:
        jitter well below a sample (a logger's ns on 1 ms steps) is accepted and said in the
        notes; a step half a sample off, or stamps drifting a sample off one rate, is refused."""
        gi, _ = self.where[name]
        if gi not in self._rates:
            t = np.asarray(self.mdf.get_master(gi), dtype=np.float64)
            fs, note = stamped_rate(f"{self.path.name}: group {gi}", np.arange(len(t)), t,
                                    gap_samples=_GAP_SAMPLES, drift_samples=_DRIFT_SAMPLES)
            if note and note not in self.notes:
                self.notes.append(note)
            self._rates[gi] = fs
        return float(self._rates[gi])  # type: ignore[arg-type]

    def select(self, names: Sequence[str], fs_hz: float | None = None) -> None:
        names = [n for n in names if n in self.where]
        if fs_hz is not None:
            # the user's rate (--fs) overrides the stamps: they are checked only to say so
            for n in names:
                try:
                    fs = self.rate(n)
                    self.notes.append(f"--fs {fs_hz:g} Hz used; {n!r}'s time stamps give {fs:.9g} Hz")
                except ValueError as exc:
                    self.notes.append(f"--fs {fs_hz:g} Hz used; {exc}")
            self.fs_hz = None
            return
        common = one_rate(self.path, {n: self.rate(n) for n in names}, 1e-6)
        if common is not None:
            self.fs_hz = common

    def rate_of(self, name: str) -> float | None:
        return self.rate(name)

    def unit_of(self, name: str) -> str | None:
        """The channel's physical unit (its conversion's, else its own), None when blank."""
        gi, ci = self.where[name]
        try:
            unit = str(self.mdf.get(group=gi, index=ci, record_offset=0, record_count=1).unit or "").strip()
        except Exception:
            return None
        return unit or None

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        gi, ci = self.where[name]
        try:
            s = self.mdf.get(group=gi, index=ci, record_offset=int(start), record_count=int(stop - start), raw=True)
            return _physical(self.mdf.groups[gi].channels[ci].conversion, np.asarray(s.samples))
        except Exception as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at records {start}-{stop}: {exc}") from None

    def close(self) -> None:
        self.mdf.close()
