"""A datasheet's own VRE statement as data: a sensor file's ``[vre_statement]`` table.

A part whose datasheet states a VRE condition carries that statement (the value, max or
typical, and the condition: range, level, profile, static field, axis, source), so a test can
predict at the stated condition and compare (tests/test_parts_library.py); ``vrelab sensor
list/show`` print it (:mod:`vrelab.sensor.catalog`). The loader checks the table
(:func:`vre_statement`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal, Mapping

from vrelab.sensor.configs import is_number

VRE_STATEMENT = "vre_statement"
# The keys of a [vre_statement] table: (required, kind). A statement gives the VRE [g] or the VRC
# [µg/g²] (value_g or vrc_ug_per_g2), as a maximum or a typical value, at one condition.
_STATEMENT_KEYS: dict[str, tuple[bool, str]] = {
    "value_g": (False, "number"),          # the stated VRE [g] (the mean output shift, sign as stated or |.|)
    "vrc_ug_per_g2": (False, "number"),    # or the stated VRC [µg/g²]
    "bound": (True, "text"),               # "max" (the VRE stays below) or "typ" (a typical value)
    "spread_g": (False, "number"),         # the datasheet's own spread of a typical VRE [g], if stated
    "level_grms": (False, "number"),       # the vibration's overall level [g rms] (random)
    "freq_hz": (False, "number"),          # or a sine's frequency [Hz] (with amplitude_g)
    "amplitude_g": (False, "number"),      # the sine's amplitude [g]
    "profile": (False, "text"),            # the vrelab profile the prediction uses (a random statement)
    "profile_stated": (True, "text"),      # what the datasheet says of the profile, or "unstated: assumed ..."
    "range_g": (True, "number"),           # the range the statement is for [g]
    "static_g": (True, "number"),          # the static field along the axis [g] (the "1 g orientation")
    "axis": (False, "text"),               # the axis (default: the file's default axis)
    "odr_hz": (False, "number"),           # the output rate (default: the file's default ODR)
    "source": (True, "text"),              # datasheet, revision, table/page
    "reproducible": (False, "bool"),       # false: the preset cannot reproduce it (why_not says why)
    "why_not": (False, "text"),
}


@dataclass(frozen=True)
class VreStatement:
    """A datasheet's own VRE (or VRC) statement: the value and the condition it holds at.

    ``bound = "max"``: the datasheet guarantees ``|VRE| < value_g``; ``"typ"``: a typical value
    (``spread_g`` its own spread where stated). A random statement names ``level_grms`` and the
    profile vrelab predicts it with (``profile``; ``profile_stated`` quotes the datasheet or says
    which profile is assumed); a sine statement ``freq_hz`` and ``amplitude_g``.
    """

    bound: Literal["max", "typ"]
    profile_stated: str
    range_g: float
    static_g: float
    source: str
    value_g: float | None = None
    vrc_ug_per_g2: float | None = None
    spread_g: float | None = None
    level_grms: float | None = None
    freq_hz: float | None = None
    amplitude_g: float | None = None
    profile: str | None = None
    axis: str | None = None
    odr_hz: float | None = None
    reproducible: bool = True
    why_not: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def text(self) -> str:
        """One line: the statement as the datasheet gives it."""
        what = (f"VRE {'<' if self.bound == 'max' else '≈'} {self.value_g * 1e3:g} mg" if self.value_g is not None
                else f"VRC {'≤' if self.bound == 'max' else '≈'} {self.vrc_ug_per_g2:g} µg/g²")
        level = (f"{self.level_grms:g} g rms" if self.level_grms is not None
                 else f"sine {self.amplitude_g:g} g at {self.freq_hz:g} Hz" if self.freq_hz is not None else "")
        typ = " typical" if self.bound == "typ" else ""
        return (f"{what}{typ} at ±{self.range_g:g} g, {level}, {self.static_g:g} g static ({self.profile_stated}); "
                f"{self.source}")


def vre_statement(table: object, where: str) -> VreStatement | None:
    """A file's ``[vre_statement]`` table, checked (None when the file has none)."""
    if table is None:
        return None
    bad = f"sensor {where}: {VRE_STATEMENT}"
    if not isinstance(table, Mapping):
        raise ValueError(f"{bad} must be a table, got {table!r}")
    unknown = sorted(set(table) - set(_STATEMENT_KEYS))
    if unknown:
        raise ValueError(f"{bad}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(_STATEMENT_KEYS)}")
    for key, (required, kind) in _STATEMENT_KEYS.items():
        if key not in table:
            if required:
                raise ValueError(f"{bad}: {key} is required")
            continue
        v = table[key]
        ok = (is_number(v) and math.isfinite(v) if kind == "number" else isinstance(v, bool) if kind == "bool"
              else isinstance(v, str) and bool(v))
        if not ok:
            raise ValueError(f"{bad}.{key} must be a {'finite number' if kind == 'number' else kind}, got {v!r}")
    if table["bound"] not in ("max", "typ"):
        raise ValueError(f"{bad}.bound must be max or typ, got {table['bound']!r}")
    if ("value_g" in table) == ("vrc_ug_per_g2" in table):
        raise ValueError(f"{bad}: give exactly one of value_g (a VRE) and vrc_ug_per_g2 (a VRC)")
    if ("level_grms" in table) == ("freq_hz" in table):
        raise ValueError(f"{bad}: give exactly one of level_grms (random) and freq_hz (sine)")
    if "freq_hz" in table and "amplitude_g" not in table:
        raise ValueError(f"{bad}: a sine statement (freq_hz) needs amplitude_g")
    if table.get("reproducible") is False and not table.get("why_not"):
        raise ValueError(f"{bad}: reproducible = false needs why_not (the reason)")
    values: dict[str, Any] = {k: (float(v) if _STATEMENT_KEYS[k][1] == "number" else v) for k, v in table.items()}
    return VreStatement(**values)
