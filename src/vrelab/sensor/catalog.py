"""The parts library: what a preset (or a sensor file) says about itself, for ``vrelab sensor list/show``.

A sensor file's numbers each carry a fact (``[facts]``: "datasheet <document>: ..." or
"assumption: ...") and, where the datasheet leaves the number open, an assumed standard
uncertainty (``[uncertainty]``). A part whose datasheet states a VRE condition also carries that
statement as data (``[vre_statement]``, :class:`VreStatement`), so a test can predict at the
stated condition and compare (tests/test_parts_library.py).

Nothing here changes a number: :func:`part_summary` and :func:`part_details` read the file
(:func:`vrelab.sensor.loader.read_spec`) and the loaded :class:`~vrelab.sensor.loader.Sensor`.
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


def vre_statement(table: Any, where: str) -> VreStatement | None:
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
    return VreStatement(**{k: (float(v) if _STATEMENT_KEYS[k][1] == "number" else v) for k, v in table.items()})


def part_summary(spec: str) -> dict[str, Any]:
    """What ``vrelab sensor list`` prints of one preset or sensor file: name, description,
    source, ranges [g], ODRs [Hz] (empty: an analog part) and the datasheet's VRE statement."""
    from vrelab.sensor.loader import load_sensor, read_spec

    data, origin = read_spec(spec)
    s = load_sensor(spec)
    statement = vre_statement(data.get(VRE_STATEMENT), f"{s.name} ({origin})")
    return {
        "name": s.name,
        "origin": origin,
        "description": s.description,
        "source": s.source,
        "ranges_g": list(s.ranges_g or (s.range_g,)),
        "odrs_hz": list(s.odrs_hz),
        "vre_statement": statement.to_dict() if statement else None,
        "vre_statement_text": statement.text() if statement else None,
    }


def _kind(text: str) -> str:
    head = text.strip().lower()
    for kind in ("datasheet", "assumption", "definition", "set by the user", "identified"):
        if head.startswith(kind):
            return kind
    return "other"


def part_details(spec: str, range_g: float | None = None, axis: str | None = None,
                 odr_hz: float | None = None) -> dict[str, Any]:
    """What ``vrelab sensor show`` prints: the summary, then every number's fact (its value and
    where it comes from), every assumed standard uncertainty with its reason (the fact of the
    parameter it belongs to), and the assumptions that carry no u (predict names them)."""
    from vrelab.sensor.loader import load_sensor, numeric_fields
    from vrelab.sensor.parameters import assumable, parameter

    out = part_summary(spec)
    s = load_sensor(spec, range_g=range_g, axis=axis, odr_hz=odr_hz)
    out.update({"range_g": s.range_g, "axis": s.axis, "odr_hz": s.odr_hz})
    facts = []
    for name in numeric_fields():
        value = getattr(s, name)
        text = s.facts.get(name, "unmarked")
        facts.append({"field": name, "value": list(value) if isinstance(value, tuple) else value,
                      "kind": _kind(text), "fact": text})
    out["facts"] = facts
    params = assumable()
    assumptions = []
    for name, u in s.uncertainty.items():
        p = params[name]
        assumptions.append({"parameter": name, "value": parameter(s, name), "u": u, "unit": p.text_unit,
                            "reason": s.facts.get(p.fact_key, "unmarked")})
    out["assumptions"] = assumptions
    out["unstated"] = [{"parameter": n, "value": parameter(s, n), "fact": s.facts.get(params[n].fact_key, "")}
                       for n in s.unstated]
    return out


def parts_table() -> str:
    """The parts table of docs/presets.md, generated from the presets (a test holds the page to
    it, so no number there goes stale): name, ranges, output rates, output filter, datasheet VRE
    statement, and whether the preset reproduces it."""
    from vrelab.sensor.loader import list_presets, load_sensor

    lines = ["| preset | ranges [g] | ODR [Hz] | output filter | datasheet VRE statement | reproduced |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name in list_presets():
        p = part_summary(name)
        s = load_sensor(name)
        lo, hi = (min(p["odrs_hz"]), max(p["odrs_hz"])) if p["odrs_hz"] else (0.0, 0.0)
        odrs = "none modelled" if not p["odrs_hz"] else f"{hi:g}" if lo == hi else f"{lo:g}–{hi:g}"
        filt = ("none" if s.bandwidth_hz is None else
                f"{s.lowpass_kind} order {s.lowpass_order or (3 if s.lowpass_kind == 'sinc' else 4)}, "
                f"{s.bandwidth_hz:g} Hz at {s.lowpass_corner}" + (f" (ODR {s.odr_hz:g})" if s.odr_hz else ""))
        st = p["vre_statement"]
        said = p["vre_statement_text"].split(";")[0] if st else "none found"
        done = "—" if not st else "yes (tests/test_parts_library.py)" if st["reproducible"] else "no: `vrelab sensor show` says why"
        ranges = ", ".join(f"±{r:g}" for r in p["ranges_g"])
        lines.append(f"| `{name}` | {ranges} | {odrs} | {filt} | {said} | {done} |")
    return "\n".join(lines) + "\n"
