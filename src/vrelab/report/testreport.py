"""The frame of a test report around the results: what a metrologist signs.

The order and the content follow the habits of a test report under ISO/IEC 17025:2017 clause
7.8.2 (identification of the laboratory, the customer, the report and the item; the method and
any deviation; the equipment; the environmental conditions; the results with their measurement
uncertainty; statements of conformity with the decision rule applied, clause 7.8.6; who
authorised the report, with the date of issue) and of IEEE Std 1293 (the reference
accelerometer and its calibration):

identification block; 1 Test item; 2 Equipment; 3 Conditions; 4 Procedure; 5 Results (the
report's sections); 6 Decisions; 7 Approval.

What the results know fills itself in (sensor, range, axis, ODR, static field, profile, method,
the input files' SHA-256, vrelab's version); what only the laboratory knows comes from the
metadata file (:mod:`vrelab.report.metadata`), and where it is absent the report says
"not given". This module reads results and metadata; it computes no physics.
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterator, Mapping, Sequence

from vrelab._format import format_mg, format_u, u_resolution
from vrelab._version import __version__
from vrelab.report._markup import ReportTable, css_string, esc, kv_table, table_html
from vrelab.report.metadata import NOT_GIVEN, ReportMetadata
from vrelab.results import VreResult

if TYPE_CHECKING:
    from vrelab.report.html import ReportSection

RESULTS_NUMBER = 5
_MAJOR = (("item", "Test item"), ("equipment", "Equipment"), ("conditions", "Conditions"),
          ("procedure", "Procedure"), ("results", "Results"), ("decisions", "Decisions"), ("approval", "Approval"))

# What vrelab does with a record, by method (physics §4): stated in the procedure, as a lab states
# its method. The wording is the reduction's, not the laboratory's procedure (that is metadata).
_METHOD_TEXT = {
    "random": "Random method (physics §4): the grms of a broadband profile is stepped; every level is bracketed by "
              "vibration-off baselines, the settling time trimmed at each edge. VRE = mean DUT output during the "
              "level minus the mean of its bracketing baselines (drift removed by the bracket); the level is the "
              "reference rms in the test band. The clipping model (effective rail) is fitted by weighted least "
              "squares up to the level where the data leave it.",
    "sine": "Sine method (IEEE Std 1293): at each frequency the amplitude is stepped; VRE per level as for the "
            "random method, averaged over whole periods of the drive; the level is the reference's rms at the drive "
            "frequency. VRC is fitted through the origin by weighted least squares (VRE = VRC·rms²).",
}
_UNCERTAINTY_TEXT = ("Uncertainty (GUM, JCGM 100:2008): Type A from the record by batch means (autocorrelation "
                     "honoured); Type B terms as declared below, each through its sensitivity coefficient; expanded "
                     "uncertainty U = k·u with k from the Welch-Satterthwaite effective degrees of freedom (95.45 % "
                     "coverage).")
_TYPE_B_NAMES = {"u_reference_pct": ("reference sensitivity", "%"), "u_dut_pct": ("DUT sensitivity", "%"),
                 "u_static_g": ("static field (alignment)", "g"), "u_thermal_g": ("thermal offset", "g")}


@dataclass(frozen=True)
class Document:
    """What :func:`render` frames: the results' sections (already rendered, with their anchors)."""

    title: str
    intro: str
    sections: Sequence[ReportSection]
    anchors: Sequence[str]
    results_html: str
    metadata: ReportMetadata
    provenance: Mapping[str, Any]


@dataclass(frozen=True)
class _Entry:
    anchor: str
    section: str
    label: str | None
    channel: str | None
    result: VreResult

    @property
    def link(self) -> tuple[str, str]:
        return (self.section + (f" ({self.label})" if self.label else ""), f"#{self.anchor}")


def _entries(doc: Document) -> Iterator[_Entry]:
    for sec, anchor in zip(doc.sections, doc.anchors):
        for label, r in sec.tabulated():
            yield _Entry(anchor, sec.title, label, sec.channel or _dut_channel(r), r)


def _dut_channel(r: VreResult) -> str | None:
    ch = r.provenance.get("channels")
    return str(ch["dut"]) if isinstance(ch, Mapping) and ch.get("dut") else None


def _distinct(values: Iterator[Any]) -> list[Any]:
    return list(dict.fromkeys(v for v in values if v not in (None, "")))


def _join(values: Iterator[Any]) -> str:
    got = _distinct(values)
    return ", ".join(str(v) for v in got) if got else NOT_GIVEN


def _g(x: float | None, spec: str = "g", unit: str = "g", sign: bool = False) -> str | None:
    if x is None:
        return None
    return f"{x:+{spec}} {unit}" if sign else f"{x:{spec}} {unit}"


def channels(doc: Document) -> list[str]:
    """The DUT channels of the report, in order of appearance."""
    return _distinct(sec.channel for sec in doc.sections) + [
        c for c in _distinct(e.channel for e in _entries(doc)) if c not in {s.channel for s in doc.sections}]


# --------------------------------------------------------------------------- dates
_ISO_DATE = re.compile(r"\d{4}-\d{2}-\d{2}")
_DUE = re.compile(r"\bdue\b\D{0,12}(\d{4}-\d{2}-\d{2})", re.I)


def _day(text: str | None) -> _dt.date | None:
    """The first ISO date (YYYY-MM-DD) in ``text``, None without one."""
    m = _ISO_DATE.search(text or "")
    if m is None:
        return None
    try:
        return _dt.date.fromisoformat(m.group())
    except ValueError:
        return None


def _test_day(doc: Document) -> tuple[_dt.date | None, str]:
    """The (last) day of the test and where it comes from: the metadata's ``[procedure]
    test_date``, else the latest date a simulated result was made (its provenance)."""
    given = _day(doc.metadata.get("procedure", "test_date"))
    if given is not None:
        return given, "[procedure] test_date"
    made = [d for d in (_day(str(e.result.provenance.get("created_utc") or "")) for e in _entries(doc)) if d]
    return (max(made), "the simulation's date") if made else (None, "")


def _shown_day(day: _dt.date | None, source: str) -> str:
    return NOT_GIVEN if day is None else f"{day} ({source})"


def date_warnings(doc: Document) -> list[str]:
    """What the dates contradict (ISO/IEC 17025:2017 7.8.2.1: the dates of the test and of
    issue; 6.4.7: equipment used within its calibration): a date of issue before the report was
    generated or before the test, a signature dated after the issue, and the reference's
    calibration past due at the test (its "due YYYY-MM-DD" in ``[equipment]
    reference_calibration``). Day resolution; nothing said when a date is not given."""
    m = doc.metadata
    out = []
    issued = _day(m.get("approval", "date"))
    generated = _day(str(doc.provenance.get("date_utc") or ""))
    tested, tested_from = _test_day(doc)
    if issued and generated and issued < generated:
        out.append(f"date of issue {issued} is {(generated - issued).days} days before this report was generated "
                   f"({generated}): a report is issued after it is made (set [approval] date)")
    if issued and tested and issued < tested:
        out.append(f"date of issue {issued} is before the test ({tested}, {tested_from})")
    for role in ("prepared", "reviewed", "approved"):
        signed = _day(m.get("approval", f"{role}_date"))
        if issued and signed and signed > issued:
            out.append(f"{role} on {signed}, after the date of issue {issued}")
    cal = m.get("equipment", "reference_calibration")
    due = _DUE.search(cal or "")
    due_day = _day(due.group(1)) if due else None
    if due_day and tested and due_day < tested:
        out.append(f"the reference's calibration was past due at the test: due {due_day}, tested {tested} ({tested_from})")
    elif due_day and tested is None and generated and due_day < generated:
        out.append(f"the reference's calibration is due {due_day}, before this report was generated ({generated}), and "
                   "the test date is not given ([procedure] test_date): its validity at the test is not shown")
    return out


# --------------------------------------------------------------------------- a simulation study
NO_LABORATORY = "none: a simulation study (no laboratory, equipment or environment)"


def simulated(doc: Document) -> bool:
    """Every result of the report is a simulation (the demo): no laboratory took part."""
    kinds = {e.result.kind for e in _entries(doc)}
    return kinds == {"simulation"}


def _applicable(doc: Document, rows: Sequence[tuple[str, Any]]) -> list[tuple[str, Any]]:
    """The rows, without the laboratory's fields left "not given" in a simulation study (a
    simulation has no laboratory: rows of "not given" would say it has one not named)."""
    return [r for r in rows if not (r[1] == NOT_GIVEN and simulated(doc))]


# --------------------------------------------------------------------------- identification
def _identification(doc: Document) -> str:
    m = doc.metadata
    lab = m.get("laboratory", "name")
    addr = m.get("laboratory", "address")
    cust = m.get("customer", "name")
    rows = [
        ("laboratory", f"{lab}, {addr}" if lab and addr else (lab or addr or
                                                              (NO_LABORATORY if simulated(doc) else NOT_GIVEN))),
        ("accreditation", m.shown("laboratory", "accreditation")),
        ("customer", ", ".join(v for v in (cust, m.get("customer", "address")) if v) or NOT_GIVEN),
        ("report number", m.shown("", "report_number")),
        ("date of issue", m.shown("approval", "date")),
        ("date of test", _shown_day(*_test_day(doc))),
        ("generated", f"{doc.provenance.get('date_utc', NOT_GIVEN)} by vrelab {doc.provenance.get('vrelab_version', __version__)}"),
        ("metadata file", m.source or "none (vrelab report DIR --metadata FILE.toml fills the fields that say "
                                     f"'{NOT_GIVEN}')"),
    ]
    body = "".join(f"<tr><th>{esc(k)}</th><td>{esc(v)}</td></tr>" for k, v in _applicable(doc, rows))
    warn = date_warnings(doc)
    listed = ('<ul class="warn dates">' + "".join(f"<li>Dates: {esc(w)}</li>" for w in warn) + "</ul>") if warn else ""
    return f'<table class="kv ident">{body}</table>{listed}'


def _toc(doc: Document) -> str:
    items = []
    for n, (key, name) in enumerate(_MAJOR, 1):
        sub = ""
        if key == "results" and doc.sections:
            sub = "<ol>" + "".join(f'<li><a href="#{esc(a)}">{n}.{i} {esc(s.title)}</a></li>'
                                   for i, (s, a) in enumerate(zip(doc.sections, doc.anchors), 1)) + "</ol>"
        items.append(f'<li><a href="#{key}">{n} {esc(name)}</a>{sub}</li>')
    return '<nav><ol class="toc">' + "".join(items) + "</ol></nav>"


# --------------------------------------------------------------------------- 1 test item
def _item(doc: Document) -> str:
    m = doc.metadata
    chans = channels(doc)
    unknown = [c for c in m.items if c not in chans]
    if unknown:
        where = f"report metadata {m.source}" if m.source else "report metadata"
        raise ValueError(f"{where}: [items.{unknown[0]}]: no channel {unknown[0]!r} in this report "
                         f"(channels: {', '.join(chans) or 'none named'})")
    keys = ("name", "manufacturer", "model", "serial", "description", "condition", "received")
    head = ["channel", "item", "manufacturer", "model", "serial", "description", "condition on receipt", "received"]
    each: list[str | None] = [*chans] if chans else [None]  # None: the report's one DUT
    rows = [[c or "DUT"] + [m.item(c, k) or NOT_GIVEN for k in keys] for c in each]
    if simulated(doc) and all(v == NOT_GIVEN for row in rows for v in row[1:]):
        parts = ['<p class="mute">A simulation study: no physical item (the simulated sensor is described below).</p>']
    else:
        parts = [table_html(ReportTable("Identification (metadata)", head, rows), 3)]
    entries = list(_entries(doc))
    known = []
    for c in each:
        mine_e = [e for e in entries if e.channel == c or not chans]
        mine = [e.result for e in mine_e]
        known.append([
            c or "DUT",
            _or_else(_sensors_where(mine_e), _item_model(m, c)),
            _or_else(_join(f"±{r.conditions.range_g:g} g" if r.conditions.range_g is not None else None for r in mine),
                     _from_item(m, c, "range")),
            _or_else(_join(str(r.conditions.axis).upper() if r.conditions.axis else None for r in mine),
                     _from_item(m, c, "axis")),
            _or_else(_join(_g(r.conditions.odr_hz, "g", "Hz") for r in mine), _from_item(m, c, "odr"),
                     _record_rate(mine)),
            _or_else(_join(_g(r.conditions.bandwidth_hz, "g", "Hz") for r in mine), _from_item(m, c, "bandwidth")),
        ])
    parts.append(table_html(ReportTable("Recorded in the results (else as noted)", ["channel", "sensor", "range", "axis",
                                                                                    "output data rate", "bandwidth"],
                                        known), 3))
    return "".join(parts)


def _or_else(*values: str | None) -> str:
    """The first value given (the results' own, then what the note in it names), else "not given"."""
    return next((v for v in values if v and v != NOT_GIVEN), NOT_GIVEN)


def _from_item(m: ReportMetadata, channel: str | None, key: str) -> str | None:
    v = m.item(channel, key)
    return None if v is None else f"{v} (metadata [item] {key})"


def _item_model(m: ReportMetadata, channel: str | None) -> str | None:
    got = " ".join(v for v in (m.item(channel, "manufacturer"), m.item(channel, "model")) if v)
    return f"{got} (metadata [item])" if got else None


def _record_rate(results: Sequence[VreResult]) -> str | None:
    """A recording's sample rate: the rate its DUT channel was read at (not the sensor's own
    output data rate when a data acquisition resampled it: said as such)."""
    rates = _distinct(f"{r.provenance['fs_hz']:.6g}" for r in results
                      if r.kind != "simulation" and isinstance(r.provenance.get("fs_hz"), (int, float)))
    return f"{', '.join(rates)} Hz (the record's sample rate)" if rates else None


def _sensors_where(entries: Sequence[_Entry]) -> str:
    """Each distinct sensor with the result sections that used it ("... [adxl355] (5.3–5.7)"): a
    report of several sensors (the demo's ideal reference and its ADXL355) says which is which."""
    where: dict[str, list[str]] = {}
    for e in entries:
        text = _sensor_text(e.result)
        if text:
            num = f"{RESULTS_NUMBER}.{e.anchor[1:]}" if e.anchor[1:].isdigit() else e.anchor
            if num not in where.setdefault(text, []):
                where[text].append(num)
    if len(where) <= 1:
        return next(iter(where), NOT_GIVEN)
    return "; ".join(f"{text} (section{'s' if len(n) > 1 else ''} {', '.join(n)})" for text, n in where.items())


def _sensor_text(r: VreResult) -> str | None:
    desc = r.provenance.get("sensor")
    name = r.conditions.sensor
    if isinstance(desc, Mapping):
        bits = [str(desc.get("description") or name or "")]
        if desc.get("source"):
            bits.append(f"({desc['source']})")
        text = " ".join(b for b in bits if b)
        return f"simulated: {text} [{name}]" if r.kind == "simulation" else text
    if name:
        return f"simulated: {name}" if r.kind == "simulation" else str(name)
    return None


# --------------------------------------------------------------------------- 2 equipment
def _equipment(doc: Document) -> str:
    m = doc.metadata
    rows: list[tuple[str, Any]] = [
        ("reference accelerometer", m.shown("equipment", "reference")),
        ("reference serial number", m.shown("equipment", "reference_serial")),
        ("reference calibration", m.shown("equipment", "reference_calibration")),
        ("shaker", m.shown("equipment", "shaker")),
        ("vibration controller", m.shown("equipment", "controller")),
        ("data acquisition", m.shown("equipment", "daq")),
        ("fixture", m.shown("equipment", "fixture")),
        ("other", m.shown("equipment", "other")),
    ]
    entries = list(_entries(doc))
    refs = _distinct(str(e.result.provenance["channels"].get("reference"))
                     for e in entries if isinstance(e.result.provenance.get("channels"), Mapping)
                     and e.result.provenance["channels"].get("reference"))
    if refs:
        rows.append(("reference channel in the record", ", ".join(refs)))
    sim = [e for e in entries if e.result.kind == "simulation"]
    if sim:
        which = "all results" if len(sim) == len(entries) else f"{len(sim)} of {len(entries)} results"
        rows.append(("simulation", f"{which}: vrelab's simulated shaker test (vrelab.shaker); the reference is the "
                                   "simulated drive; no physical shaker, reference or data acquisition"))
    rows.append(("software", f"vrelab {doc.provenance.get('vrelab_version', __version__)} (reduction, fits, "
                             "uncertainty, this report)"))
    return kv_table(_applicable(doc, rows))


# --------------------------------------------------------------------------- 3 conditions
def _levels_text(r: VreResult) -> str:
    from vrelab.report.plots import levels_reached

    reached = levels_reached(r)
    n = sum(1 for lv in r.levels if lv.rms_g == lv.rms_g)
    return "none" if reached is None else f"{n}: {reached}"


def _conditions(doc: Document) -> str:
    m = doc.metadata
    ambient = kv_table(_applicable(doc, [("ambient temperature", m.shown("conditions", "temperature")),
                                         ("relative humidity", m.shown("conditions", "humidity")),
                                         ("other conditions", m.shown("conditions", "notes"))]))
    ambient = ambient or '<p class="mute">A simulation study: no laboratory environment.</p>'
    rows = []
    for e in _entries(doc):
        c = e.result.conditions
        band = dict(c.extra).get("band_hz")
        freqs = _distinct(round(lv.freq_hz, 6) for lv in e.result.levels if lv.freq_hz is not None)
        rows.append([e.link, e.result.method, c.profile or NOT_GIVEN,
                     _g(c.static_g, ".4g", "g", sign=True) or NOT_GIVEN,
                     f"{band[0]:g}–{band[1]:g} Hz" if isinstance(band, (list, tuple)) and len(band) == 2 else NOT_GIVEN,
                     _levels_text(e.result), ", ".join(f"{f:g}" for f in freqs) or "–"])
    table = table_html(ReportTable("Test conditions (from the results)", ["section", "method", "profile", "static field g0",
                                                                          "measurement band", "levels", "sine frequencies (Hz)"],
                                   rows), 3) if rows else ('<p class="mute">No test levels in this report: the '
                                                            "conditions of its results are in their sections (5).</p>")
    return "<h3>Environment (metadata)</h3>" + ambient + table


# --------------------------------------------------------------------------- 4 procedure
def _input_files(doc: Document) -> list[list[Any]]:
    """(file, SHA-256, where) for every checksummed file the results name."""
    seen: dict[tuple[str, str], list[Any]] = {}
    for sec, anchor in zip(doc.sections, doc.anchors):
        provs = [dict(r.provenance) for _, r in sec.tabulated()] + [dict(sec.provenance)]
        for prov in provs:
            for key, digest in prov.items():
                if not key.endswith("_sha256") or not isinstance(digest, str):
                    continue
                base = key[: -len("_sha256")]
                name = prov.get(f"{base}_file") or prov.get(base) or base
                row = seen.setdefault((str(name), digest), [str(name), digest, []])
                if (sec.title, f"#{anchor}") not in row[2]:
                    row[2].append((sec.title, f"#{anchor}"))
    out = []
    for name, digest, where in seen.values():
        out.append([name, digest, where[0] if len(where) == 1 else f"{len(where)} sections"])
    return out


def _procedure(doc: Document) -> str:
    m = doc.metadata
    parts = [kv_table(_applicable(doc, [("standard or method", m.shown("procedure", "standard")),
                                        ("procedure", m.shown("procedure", "text")),
                                        ("deviations", m.shown("procedure", "deviations"))]))]
    entries = list(_entries(doc))
    methods = _distinct(e.result.method for e in entries)
    items = [_METHOD_TEXT[x] for x in methods if x in _METHOD_TEXT]
    if entries:
        budgets = _distinct(_type_b_text(e.result) for e in entries)
        items.append(_UNCERTAINTY_TEXT + " Declared Type B terms: " + "; ".join(budgets) + ".")
    if any(e.result.kind == "simulation" for e in entries):
        items.append("Simulated records are reduced and fitted by the same code as recorded files.")
    if items:
        parts.append(f"<h3>Reduction and evaluation (vrelab {esc(doc.provenance.get('vrelab_version', __version__))})</h3>"
                     + '<ul class="notes">' + "".join(f"<li>{esc(t)}</li>" for t in items) + "</ul>")
    files = _input_files(doc)
    if files:
        parts.append(table_html(ReportTable("Files (SHA-256)", ["file", "SHA-256", "used in"], files, breakable=(0, 1)), 3))
    return "".join(parts)


def _type_b_text(r: VreResult) -> str:
    tb = dict(r.conditions.extra).get("type_b")
    if not isinstance(tb, Mapping):
        return "none (no budget evaluated: U not given)" if not any(lv.budget for lv in r.levels) else "none"
    declared = [f"{_TYPE_B_NAMES[k][0]} {v:g} {_TYPE_B_NAMES[k][1]}" for k, v in tb.items()
                if k in _TYPE_B_NAMES and isinstance(v, (int, float)) and v > 0]
    return ", ".join(declared) if declared else "none (U from Type A only)"


# --------------------------------------------------------------------------- 6 decisions
def _decisions(doc: Document) -> str:
    entries = [e for e in _entries(doc) if dict(e.result.conditions.extra).get("limit_g") is not None]
    if not entries:
        return ('<p class="rule">No limit was given to any result, so no level was judged (a section that compares '
                "a value with a published limit states a comparison, not a decision). A limit (<code>vrelab analyze ... "
                "--limit G</code>, <code>vrelab campaign ... --limit G</code>) judges every level under the rule "
                "of guarded acceptance: pass only when |VRE| + U &lt;= limit, fail when |VRE| − U &gt; limit, "
                "indeterminate otherwise.</p>")
    rules = _distinct(dict(e.result.conditions.extra).get("decision_rule") for e in entries)
    parts = ['<p class="rule">Decision rule: ' + esc("; ".join(rules) or NOT_GIVEN)
             + ". Guarded acceptance (ILAC-G8:09/2019, ISO 14253-1): a pass is stated only when the whole "
             "interval VRE ± U lies inside the limit, a fail only when it lies wholly outside.</p>"]
    rows = []
    counts: dict[str, int] = {}
    for e in entries:
        limit = float(dict(e.result.conditions.extra)["limit_g"])
        for i, lv in enumerate(e.result.levels, 1):
            d = lv.decision or "undefined (no VRE)"
            counts[d] = counts.get(d, 0) + 1
            v, U = lv.vre.value, lv.U_vre_g
            res = u_resolution(None if U is None else 1e3 * U)  # the numbers of a level at U's last digit
            interval = "–" if U is None or v != v else f"{format_mg(abs(v) - U, signed=False, resolution_mg=res)} … {format_mg(abs(v) + U, signed=False, resolution_mg=res)}"
            rows.append([e.link, str(i), "–" if lv.freq_hz is None else f"{lv.freq_hz:.5g}", f"{lv.rms_g:.4g}",
                         format_mg(v, signed=True, resolution_mg=res) if v == v else "–",
                         format_u(U, scale=1e3) if U is not None else "not evaluated", interval,
                         format_mg(limit, signed=False), d])
    summary = ", ".join(f"{n} {k}" for k, n in counts.items())
    parts.append(f"<p>{esc(summary)} ({sum(counts.values())} levels).</p>")
    parts.append(table_html(ReportTable("", ["section", "level", "freq (Hz)", "g rms", "VRE (mg)", "U (mg)",
                                             "|VRE| − U … |VRE| + U (mg)", "limit (mg)", "decision"], rows,
                                        numeric=(1, 2, 3, 4, 5, 6, 7)), 3))
    return "".join(parts)


# --------------------------------------------------------------------------- 7 approval
def _approval(doc: Document) -> str:
    m = doc.metadata
    rows = []
    for role, key in (("Prepared by", "prepared"), ("Reviewed by", "reviewed"), ("Approved by", "approved")):
        issued = m.get("approval", "date")
        day = m.get("approval", key + "_date") or (f"{issued} (date of issue)" if issued else NOT_GIVEN)
        rows.append(f"<tr><th>{role}</th><td>{esc(m.shown('approval', key + '_by'))}</td>"
                    f"<td>{esc(day)}</td><td class=\"sign\"></td></tr>")
    return ('<p>The results relate only to the item(s) tested, under the conditions stated in this report.</p>'
            '<table class="approval"><thead><tr><th>role</th><th>name</th><th>date</th><th>signature</th></tr></thead>'
            f"<tbody>{''.join(rows)}</tbody></table>"
            f"<p>Date of issue: {esc(m.shown('approval', 'date'))}.</p>")


# --------------------------------------------------------------------------- the whole
def render(doc: Document) -> str:
    """The report's body: header, contents, the seven numbered sections."""
    body = {
        "item": _item(doc),
        "equipment": _equipment(doc),
        "conditions": _conditions(doc),
        "procedure": _procedure(doc),
        "results": (f'<p class="lead">{esc(doc.intro)}</p>' if doc.intro else "") + doc.results_html,
        "decisions": _decisions(doc),
        "approval": _approval(doc),
    }
    out = [f"<header><h1>{esc(doc.title)}</h1>{_identification(doc)}{_toc(doc)}</header><main>"]
    for n, (key, name) in enumerate(_MAJOR, 1):
        cls = "major front" if key in ("item", "equipment", "conditions", "procedure") else "major"
        out.append(f'<section class="{cls}" id="{key}"><h2>{n} {esc(name)}</h2>{body[key]}</section>')
    out.append("</main>")
    return "\n".join(out)


def page_css(meta: ReportMetadata, title: str) -> str:
    """@page rules: the paper (A4 unless the metadata's ``paper`` says letter), margins that fit
    both, the report's number (or title) and "Page x of y" in the bottom margin of every printed
    page (ISO/IEC 17025 7.8.2.1 e)."""
    ident = meta.get("", "report_number")
    left = f"Report {ident}" if ident else title
    return (f"\n@page {{ size: {meta.get('', 'paper') or 'A4'}; margin: 15mm 15mm 16mm 15mm;"
            f" @bottom-left {{ content: {css_string(left[:90])}; font: 7.5pt sans-serif; color: #5b6570; }}"
            ' @bottom-right { content: "Page " counter(page) " of " counter(pages); font: 7.5pt sans-serif; color: #5b6570; } }\n')
