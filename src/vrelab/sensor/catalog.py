"""The parts library: what a preset (or a sensor file) says about itself, for ``vrelab sensor list/show``.

A sensor file's numbers each carry a fact (``[facts]``: "datasheet <document>: ..." or
"assumption: ...") and, where the datasheet leaves the number open, an assumed standard
uncertainty (``[uncertainty]``). A part whose datasheet states a VRE condition also carries that
statement as data (``[vre_statement]``, :class:`vrelab.sensor.statement.VreStatement`), so a
test can predict at the stated condition and compare (tests/test_parts_library.py).

Nothing here changes a number: :func:`part_summary` and :func:`part_details` read the file
(:func:`vrelab.sensor.loader.read_spec`) and the loaded :class:`~vrelab.sensor.loader.Sensor`.
"""

from __future__ import annotations

from typing import Any

from vrelab.sensor.statement import VRE_STATEMENT, vre_statement


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
    it, so no number there goes stale): name, ranges, output rates, output filter, the default
    axis's resonance, the over-range trip, datasheet VRE statement, and whether the preset
    reproduces it."""
    from vrelab.sensor.loader import list_presets, load_sensor

    lines = ["| preset | ranges [g] | ODR [Hz] | output filter | resonance (axis) | over-range trip "
             "| datasheet VRE statement | reproduced |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
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
        fn = "none" if s.fn_hz is None else f"{s.fn_hz:g} Hz, Q {s.q:g} ({s.axis})"
        trip = "none modelled" if s.overrange_threshold_g is None else f"{s.overrange_threshold_g:g} g (default range)"
        lines.append(f"| `{name}` | {ranges} | {odrs} | {filt} | {fn} | {trip} | {said} | {done} |")
    return "\n".join(lines) + "\n"
