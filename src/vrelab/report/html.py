"""The self-contained HTML report: one file, figures embedded as base64 PNG with an interactive
plotly twin (plotly.js embedded once), no network.

A report is a title, an introduction and a sequence of :class:`ReportSection`; each section is a
result (a :class:`~vrelab.results.VreResult`), its figures and one sentence of what it shows,
rendered as conditions, a table of levels (VRE ± u in mg, saturation counts), the fits with
standard errors, the mechanisms' shares from a prediction, warnings and provenance.
:func:`report_result_dir` builds the one-section report of a results folder (``vrelab report DIR``);
the demo builds a multi-section report with :func:`write_report`.
"""

from __future__ import annotations

import base64
import datetime as _dt
import hashlib
import io
import math
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from matplotlib.figure import Figure

from vrelab import folder as F
from vrelab._format import (
    PREDICTION_RESOLUTION_MG,
    TILT_RESOLUTION_DEG,
    field_label,
    field_text,
    format_mg,
    format_u,
    format_value,
    format_value_u,
)
from vrelab._io import sha256_file
from vrelab._version import __version__
from vrelab.folder import ResultsFolder
from vrelab.report import testreport as T
from vrelab.report._markup import ReportTable, esc, kv_table, script_json, table_html
from vrelab.report.metadata import ReportMetadata
from vrelab.report.page import BOOT_JS, CSS, JS_CLASS
from vrelab.results import FitResult, VreResult

__all__ = ["ReportFigure", "ReportSection", "ReportTable", "render_report", "write_report", "report_result_dir",
           "report_channels_dir", "result_section", "section_results"]


def content_security_policy(scripts: Sequence[str]) -> str:
    """The report's Content-Security-Policy: no network request of any kind (``default-src
    'none'``: no fetch, image, font, frame or form target outside the file), only the report's own
    inline scripts (each by its SHA-256, so a script that got into the page some other way does
    not run), inline styles (plotly sets them), images from ``data:``/``blob:`` (the figures'
    PNGs, plotly's PNG download). CSP Level 3, https://www.w3.org/TR/CSP3/."""
    hashes = " ".join(f"'sha256-{base64.b64encode(hashlib.sha256(js.encode()).digest()).decode()}'" for js in scripts)
    return ("default-src 'none'; " + (f"script-src {hashes}; " if hashes else "")
            + "style-src 'unsafe-inline'; img-src data: blob:; base-uri 'none'; form-action 'none'")


@dataclass(frozen=True)
class ReportFigure:
    """A figure ready to embed: PNG bytes (what prints), its interactive plotly twin as JSON
    (None: static only) and a caption."""

    png: bytes
    caption: str = ""
    plotly_json: str | None = None

    @classmethod
    def from_figure(cls, fig: Figure, caption: str = "", dpi: int = 110, interactive: bool = True) -> ReportFigure:
        from vrelab.report.interactive import to_plotly_json

        buf = io.BytesIO()
        # The layout once, then one draw: savefig under a layout engine draws the figure twice
        # (a draw without output that runs the engine, then the drawing), the first pass as
        # dear as the second; run at the saving dpi, so the PNG is the one savefig makes alone.
        engine = fig.get_layout_engine()
        if engine is not None and dpi == fig.dpi:
            engine.execute(fig)
            fig.set_layout_engine("none")
        fig.savefig(buf, format="png", dpi=dpi)
        # Translated after savefig: the layout engine has placed the axes the twin copies.
        twin = to_plotly_json(fig) if interactive else None
        fig.clear()  # the PNG and the twin are all the report needs; free the artists now
        return cls(buf.getvalue(), caption, twin)


@dataclass(frozen=True)
class ReportSection:
    """One study: a result, its figures, and a sentence of what it shows.

    ``facts`` are (label, value) rows shown first, e.g. ("VRE at 1 g rms", "-83 mg (article
    ≈ -100 mg)"); ``prediction`` is a ``Prediction.to_dict()``; ``notes`` are extra sentences;
    ``tables`` are shown after the figures (a sweep's statistics and failed points).
    ``results`` are further results of the same study, each tabulated under its label (the two
    configurations a figure compares); ``channel`` is the DUT channel the section is about, the
    key of its ``[items.<channel>]`` metadata.
    """

    title: str
    what: str
    result: VreResult | None = None
    figures: Sequence[ReportFigure] = ()
    facts: Sequence[tuple[str, str]] = ()
    prediction: Mapping[str, Any] | None = None
    notes: Sequence[str] = ()
    extra_warnings: Sequence[str] = ()
    provenance: Mapping[str, Any] = field(default_factory=dict)
    tables: Sequence[ReportTable] = ()
    results: Sequence[tuple[str, VreResult]] = ()
    channel: str | None = None

    def tabulated(self) -> list[tuple[str | None, VreResult]]:
        """The results the section tabulates: its ``result`` (no label), then its labelled
        ``results``."""
        return ([(None, self.result)] if self.result is not None else []) + [(label, r) for label, r in self.results]


# --------------------------------------------------------------------------- helpers
def _fmt(x: object, digits: int = 4) -> str:
    """A table cell without an uncertainty: numbers by :func:`vrelab._format.format_value`."""
    if x is None:
        return "–"
    if isinstance(x, (int, float)) and not isinstance(x, bool):
        return format_value(x, digits=digits)
    return str(x)


# A PSD table with more lines than this is a fine-resolution estimate of a short record:
# average it in fractional-octave bands before reading it against a ±3 dB tolerance.
PSD_LINES_BEFORE_AVERAGING = 600


def describe_fit_param(name: str) -> tuple[str, str]:
    """Display name and unit of a fit parameter from its unit-bearing name."""
    table = {
        "vrc_ug_per_g2": ("VRC", "µg/g²"),
        "rail_g": ("effective rail", "g"),
        "rail_low_g": ("lower rail", "g"),
        "rail_high_g": ("upper rail", "g"),
        "k2_ug_per_g2": ("k2", "µg/g²"),
        "k3_ug_per_g3": ("k3", "µg/g³"),
        "k4_ug_per_g4": ("k4", "µg/g⁴"),
    }
    return table.get(name, (name, ""))


def collect_warnings(
    result: VreResult | None,
    psd_check: Mapping[str, Any] | None = None,
    prediction: Mapping[str, Any] | None = None,
) -> list[str]:
    """Everything a reader must not miss: the result's own warnings plus what the numbers show.

    Saturated samples, over-range flags, a fit's departure from its model, a reference PSD
    outside tolerance, and the prediction's validity notes. Duplicates are dropped.
    """
    out: list[str] = []
    if result is not None:
        out += [str(w) for w in result.warnings]
        sat = [lv for lv in result.levels if lv.n_saturated]
        if sat:
            worst = max(sat, key=lambda lv: lv.n_saturated)
            frac = f" ({100 * worst.n_saturated / worst.n_samples:.2g} % of samples)" if worst.n_samples else ""
            out.append(
                f"Saturation: {len(sat)} of {len(result.levels)} levels have clipped sensor samples; "
                f"most at {worst.rms_g:.3g} g rms: {worst.n_saturated} samples{frac}."
            )
        psd_bad = [lv for lv in result.levels if any("psd" in f.lower() for f in lv.flags)]
        if psd_bad:
            out.append("PSD out of tolerance (analysis flag) at " + ", ".join(f"{lv.rms_g:.3g}" for lv in psd_bad) + " g rms.")
        over = [lv for lv in result.levels if any("over" in f.lower() for f in lv.flags)]
        if over:
            out.append(
                "Over-range: flagged at " + ", ".join(f"{lv.rms_g:.3g}" for lv in over) + " g rms "
                "(the sensor's over-range protection acted; VRE there is not clipping alone)."
            )
        for f in result.fits:
            if f.departure_rms_g is not None:
                out.append(f"Fit departure: the data leave the {f.model} model above {f.departure_rms_g:.3g} g rms.")
    if psd_check is not None and not psd_check.get("passed", True):
        out.append(
            f"PSD out of tolerance: reference PSD deviates {psd_check.get('max_dev_db', float('nan')):+.1f} / "
            f"{psd_check.get('min_dev_db', float('nan')):+.1f} dB from the profile "
            f"(±{psd_check.get('tol_db', 3):g} dB allowed, checked {psd_check.get('how', 'line by line')})."
        )
    if prediction is not None:
        out += [f"Prediction: {n}" for n in prediction.get("notes") or ()]
        invalid = [lv for lv in prediction.get("levels") or () if lv.get("valid") is False]
        if invalid:
            out.append(
                "Prediction: the analytic model is outside its validity at "
                + ", ".join(f"{lv.get('rms_g', float('nan')):.3g}" for lv in invalid)
                + " g rms (see the notes of the prediction table); the simulation is the reference there."
            )
    return list(dict.fromkeys(out))  # each once, in order


_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def collapse_warnings(warnings: Sequence[str]) -> list[str]:
    """Each warning once (with a count "×3" when it came more than once), and a family of warnings that differ only in their numbers (one per
    segment of a record) as its first with a count and the others' numbers: "segment 0-2 s is
    short ... (×7; the others: 2-4, 4-6, ...)". In order of first appearance."""
    times: dict[str, int] = {}
    for w in warnings:
        times[w] = times.get(w, 0) + 1
    groups: dict[str, list[str]] = {}
    for w in times:
        groups.setdefault(_NUMBER.sub("#", w), []).append(w)
    out = []
    for family in groups.values():
        first, rest = family[0], family[1:]
        if not rest:
            out.append(first if times[first] == 1 else f"{first} (×{times[first]})")
            continue
        head = [m.group() for m in _NUMBER.finditer(first)]
        spans = []
        for w in rest:
            ms = list(_NUMBER.finditer(w))
            differ = [i for i, m in enumerate(ms) if m.group() != head[i]]
            spans.append(w[ms[differ[0]].start():ms[differ[-1]].end()])
        out.append(f"{first} (×{sum(times[w] for w in family)}; the others: {', '.join(spans)})")
    return out


# --------------------------------------------------------------------------- rendering
def _conditions_rows(result: VreResult) -> list[tuple[str, object]]:
    from vrelab.report.plots import levels_reached

    c = result.conditions
    rows: list[tuple[str, object]] = [
        ("kind", result.kind),
        ("method", result.method),
        ("sensor", c.sensor),
        ("range", None if c.range_g is None else f"±{c.range_g:g} g"),
        ("axis", None if c.axis is None else str(c.axis).upper()),
        ("bandwidth", None if c.bandwidth_hz is None else f"{c.bandwidth_hz:g} Hz"),
        ("output data rate", None if c.odr_hz is None else f"{c.odr_hz:g} Hz"),
        ("static field g0", None if c.static_g is None else f"{c.static_g:+g} g"),
        ("profile", c.profile),
        ("levels reached", levels_reached(result)),
        ("model", c.model),
    ]
    for k, v in dict(c.extra).items():
        rows.append(field_text(k, v))
    return rows


def _levels_table(result: VreResult) -> str:
    lv = result.levels
    if not lv:
        return '<p class="mute">No levels.</p>'
    has_f = any(x.freq_hz is not None for x in lv)
    has_dur = any(x.duration_s is not None for x in lv)
    has_b = any(x.budget for x in lv)
    has_d = any(x.decision is not None for x in lv)
    head = ["#"] + (["freq (Hz)"] if has_f else []) + ["level (g rms)", "VRE ± u (mg)", "VRC ± u (µg/g²)"]
    head += (["U (mg)", "k"] if has_b else []) + (["decision"] if has_d else [])
    head += (["duration (s)"] if has_dur else []) + ["samples", "saturated", "flags"]
    num = {"#", "freq (Hz)", "level (g rms)", "VRE ± u (mg)", "VRC ± u (µg/g²)", "U (mg)", "k", "duration (s)",
           "samples", "saturated"}
    rows = []
    for i, x in enumerate(lv, 1):
        # A simulated sine's level is exact: a u of 1e-16 g is rounding, not information.
        shown_u = x.u_rms_g is not None and math.isfinite(x.u_rms_g) and x.u_rms_g > 1e-6 * abs(x.rms_g)
        rms = format_value_u(x.rms_g, x.u_rms_g) if shown_u else _fmt(x.rms_g)
        vrc = x.vrc  # VRE / rms² with its u (physics §1.2), beside the VRE
        cells = [str(i)] + ([_fmt(x.freq_hz, 6)] if has_f else []) + [rms, format_mg(x.vre.value, x.vre.u),
                                                                      format_value_u(vrc.value, vrc.u)]
        if has_b:
            cells += [format_u(x.U_vre_g, scale=1e3), format_value(x.k, resolution=0.01)]
        if has_d:
            cells += [x.decision or "undefined (no VRE)"]
        cells += ([_fmt(x.duration_s, 3)] if has_dur else []) + [_fmt(x.n_samples), str(x.n_saturated), ", ".join(x.flags)]
        rows.append("<tr>" + "".join(f'<td class="{"num" if h in num else ""}">{esc(c)}</td>' for h, c in zip(head, cells)) + "</tr>")
    th = "".join(f'<th class="{"num" if h in num else ""}">{esc(h)}</th>' for h in head)
    return f'<div class="scroll"><table><thead><tr>{th}</tr></thead><tbody>{"".join(rows)}</tbody></table></div>'


def _budget_table(result: VreResult, title: str = "Uncertainty budget (GUM)") -> str:
    """Each level's uncertainty budget (physics §4.3): the terms, their type and size, U and k."""
    rows = []
    for i, x in enumerate(result.levels, 1):
        for t in x.budget:
            u = t.get("u_g")
            rows.append((str(i), _fmt(x.rms_g), str(t.get("source", "")), str(t.get("type", "")),
                         "not evaluated" if u is None else format_u(u, scale=1e3), str(t.get("note", ""))))
        if x.budget:
            rows.append((str(i), _fmt(x.rms_g), "combined u; U = k·u", "",
                         f"{format_u(x.vre.u, scale=1e3)}; U = {format_u(x.U_vre_g, scale=1e3)}",
                         f"k = {format_value(x.k, resolution=0.01)} (Welch-Satterthwaite)"))
    if not rows:
        return ""
    return table_html(ReportTable(title, ["level", "g rms", "source", "type", "u (mg)", "note"],
                                   rows, numeric=(0, 1, 4)))


def _fits_table(fits: Sequence[FitResult]) -> str:
    from vrelab.report import plots

    if not fits:
        return '<p class="mute">No fits.</p>'
    rows = []
    for f in fits:
        if f.no_fit_reason is not None:
            params = f"no fit: {f.no_fit_reason}"
        else:
            params = "; ".join(
                f"{describe_fit_param(k)[0]} = {plots.fit_param_text(k, v.value, v.u, describe_fit_param(k)[1] or v.unit)}"
                for k, v in f.params.items()
            )
        used = f"{len(f.levels_used)} levels ≤ {max(f.levels_used):.3g} g rms" if f.levels_used else str(f.n_points)
        cells = [
            f.model.name,
            _fmt(f.freq_hz, 6) if f.freq_hz is not None else "",
            params,
            used,
            _fmt(f.chi2_reduced, 3),
            "" if f.departure_rms_g is None else f"{f.departure_rms_g:.3g} g rms",
            "; ".join(f.notes),
        ]
        rows.append("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in cells) + "</tr>")
    head = ["model", "freq (Hz)", "parameters (± standard uncertainty)", "points", "χ²/dof", "departs above", "notes"]
    return ('<div class="scroll"><table><thead><tr>' + "".join(f"<th>{h}</th>" for h in head)
            + f"</tr></thead><tbody>{''.join(rows)}</tbody></table></div>")


def _vrc_cell(lv: Mapping[str, Any], res_mg: float) -> str:
    """A prediction level's VRC (VRE / rms², µg/g²) with its u where it has one, shown to the VRE's
    resolution carried over (``res_mg`` mg = 1e3·res µg, per rms²); a prediction written before
    the VRC was a key gets it from its VRE (:func:`vrelab.results.level_vrc`)."""
    from vrelab.results import level_vrc

    rms, vre = lv.get("rms_g"), lv.get("vre_g")
    if not isinstance(rms, (int, float)) or not isinstance(vre, (int, float)) or not rms > 0:
        return format_value(None)
    value, u = level_vrc(float(vre), float(rms), lv.get("u_vre_g"))
    return format_value_u(value, u, resolution=1e3 * res_mg / float(rms) ** 2)


def _prediction_html(pred: Mapping[str, Any]) -> str:
    """Prediction levels with each mechanism's share (keys found, not assumed)."""
    levels = pred.get("levels") or []
    if not levels:
        return ""
    share_keys: list[str] = []
    for lv in levels:
        for k in (lv.get("shares") or lv.get("mechanisms") or {}):
            if k not in share_keys:
                share_keys.append(k)
    def share_name(k: str) -> str:
        return (k[:-2] if k.endswith("_g") else k).replace("_", " ")

    has_f = any(lv.get("freq_hz") is not None for lv in levels)
    has_valid = any("valid" in lv for lv in levels)
    # Shown to PREDICTION_RESOLUTION_MG: a clipping share of -8.9e-112 mg is 0, not a number.
    res = PREDICTION_RESOLUTION_MG
    head = (["freq (Hz)"] if has_f else []) + ["level (g rms)", "VRE (mg)", "VRC (µg/g²)", "tilt error (°)"]
    head += [f"{share_name(k)} (mg)" for k in share_keys] + (["model valid"] if has_valid else [])
    # Per-level notes are sentences: listed under the table, each once with its levels.
    by_note: dict[str, list[str]] = {}
    for lv in levels:
        for n in lv.get("notes") or ():
            by_note.setdefault(str(n), []).append(_fmt(lv.get("rms_g"), 3))
    rows = []
    for lv in levels:
        sh = lv.get("shares") or lv.get("mechanisms") or {}
        cells = ([_fmt(lv.get("freq_hz"), 6)] if has_f else []) + [
            _fmt(lv.get("rms_g")),
            format_mg(lv.get("vre_g"), resolution_mg=res),
            _vrc_cell(lv, res),
            format_value(lv.get("tilt_error_deg"), resolution=TILT_RESOLUTION_DEG),
        ]
        for k in share_keys:
            v = sh.get(k)
            if isinstance(v, Mapping):
                v = v.get("vre_g", v.get("value"))
            cells.append(format_mg(v, resolution_mg=res) if isinstance(v, (int, float)) else _fmt(v))
        if has_valid:
            # The reasons are the numbered notes under the table: written out in every row they
            # made the table three page-widths wide and hid this column off the screen.
            why = ", ".join(str(list(by_note).index(str(n)) + 1) for n in dict.fromkeys(lv.get("notes") or ()))
            cells.append("yes" if lv.get("valid") else (f"no (note {why})" if why else "no (reason not given)"))
        rows.append("<tr>" + "".join(f'<td class="num">{esc(c)}</td>' for c in cells) + "</tr>")
    th = "".join(f'<th class="num">{esc(h)}</th>' for h in head)
    extra = []
    for k, v in pred.items():
        if k in ("levels", "notes") or isinstance(v, (list, dict)):
            continue
        extra.append(field_text(k, v))
    notes = f'<p class="mute">Predicted values to {res:g} mg; a smaller share is shown as 0.</p>'
    if by_note:
        notes += '<ol class="notes">' + "".join(f"<li>{esc(n)} (at {', '.join(lv)} g rms)</li>" for n, lv in by_note.items()) + "</ol>"
    return (kv_table(extra) + f'<div class="scroll"><table class="pred"><thead><tr>{th}</tr></thead>'
            f'<tbody>{"".join(rows)}</tbody></table></div>' + notes)


# Provenance keys that name a file beside the report: shown as a link to it.
_ATTACHED = ("results_file", "record_file")


def _provenance_html(prov: Mapping[str, Any]) -> str:
    """Provenance as a table a person reads (field names, units, nested descriptions as nested
    tables folded on screen and open in print); the raw JSON is the results file it names."""
    body = []
    for k, v in prov.items():
        if v in (None, "", {}) and k not in ("covariance",):
            continue
        if isinstance(v, Mapping) and v:
            name = field_label(str(k))[0]
            val = f"<details><summary>{esc(len(v))} fields</summary>{_provenance_html(v)}</details>"
        elif k in _ATTACHED and isinstance(v, str) and not Path(v).is_absolute():
            # The raw JSON (and the record) are attachments: linked, relative to the report.
            name, val = field_label(str(k))[0], f'<a href="{esc(v)}">{esc(v)}</a>'
        else:
            name, text = field_text(str(k), v)
            val = esc(text)
        body.append(f"<tr><th>{esc(name)}</th><td>{val}</td></tr>")
    return f'<table class="kv">{"".join(body)}</table>' if body else ""


def _figure_html(fig: ReportFigure, fid: str, alt: str) -> str:
    """A figure: its interactive twin (drawn by the page's script, hidden in print) above the
    PNG (shown in print, and on screen wherever the twin is missing or did not draw)."""
    b64 = base64.b64encode(fig.png).decode("ascii")
    live = ""
    if fig.plotly_json is not None:
        # type="application/json": data, never run (and not allowed to run by the page's CSP)
        live = (f'<div class="iplot" data-spec="{esc(fid)}-data" role="img" aria-label="{esc(alt)}"></div>'
                f'<script type="application/json" id="{esc(fid)}-data">{script_json(fig.plotly_json)}</script>')
    return (f'<figure id="{esc(fid)}">{live}<img class="static" src="data:image/png;base64,{b64}" alt="{esc(alt)}">'
            + (f"<figcaption>{esc(fig.caption)}</figcaption>" if fig.caption else "") + "</figure>")


def section_results(sec: ReportSection) -> list[tuple[str | None, VreResult]]:
    """The results a section tabulates (:meth:`ReportSection.tabulated`)."""
    return sec.tabulated()


def _result_tables(r: VreResult, label: str | None) -> list[str]:
    pre = f"{label}: " if label else ""
    parts = [f"<h4>{esc(pre)}Conditions</h4>" + kv_table(_conditions_rows(r)),
             f"<h4>{esc(pre)}Levels</h4>" + _levels_table(r)]
    rule = dict(r.conditions.extra).get("decision_rule")
    if rule:
        parts.append(f'<p class="what">Decision rule: {esc(rule)}; limit {esc(dict(r.conditions.extra).get("limit_g"))} g.</p>')
    drive = _drive_table(r)
    if drive:
        parts.append(f"<h4>{esc(pre)}Drive waveform (reference)</h4>" + drive)
    budget = _budget_table(r, f"{pre}Uncertainty budget (GUM)")
    if budget:
        parts.append(budget)
    parts.append(f"<h4>{esc(pre)}Fits</h4>" + _fits_table(r.fits))
    return parts


# Harmonics of the drive a report's table shows (the results hold up to DRIVE_HARMONICS of them).
REPORT_HARMONICS = 3
# the resolution [%] of the drive table's harmonics and THD
PCT_RESOLUTION = 1e-3


def _drive_table(result: VreResult) -> str:
    """Each sine level's reference waveform (physics §4.4): the harmonics' rms as % of the
    fundamental, the THD, E[x²] against the fundamental's rms² and E[x³]: what the VRC was fitted
    against (the levels' ``drive``)."""
    lv = [(i, x) for i, x in enumerate(result.levels, 1) if x.drive is not None]
    if not lv:
        return ""
    n_h = min(REPORT_HARMONICS, max(len(x.drive.harmonics_rms_g) for _, x in lv if x.drive is not None))
    # h2 and h3 (the THD holds the rest; every harmonic and what they leave are in the results):
    # the table keeps within the page's width on screen and on A4
    head = ["#", "freq (Hz)", "h1 (g rms)"] + [f"h{h} (% of h1)" for h in range(2, n_h + 1)]
    head += ["THD ± u (%)", "E[x²]/rms²", "E[x³] ± u (g³)"]
    rows = []
    for i, x in lv:
        d = x.drive
        assert d is not None
        a1 = d.harmonics_rms_g[0].value
        # percentages at 0.001 % (a pure drive's harmonics are its reference's noise, 1e-5 of the
        # fundamental in the tests' records; shown 0, not as powers of ten that widen the table)
        pct = [format_value(100 * e.value / a1, resolution=PCT_RESOLUTION) if a1 > 0 else "" for e in d.harmonics_rms_g[1:n_h]]
        ratio = d.mean_square_g2.value / x.rms_g**2 if x.rms_g > 0 else math.nan
        rows.append("<tr>" + "".join(f'<td class="num">{esc(c)}</td>' for c in (
            [str(i), _fmt(x.freq_hz, 6), _fmt(a1)] + pct + [""] * (n_h - 1 - len(pct))
            + [format_value_u(100 * d.thd.value, 100 * d.thd.u) if 100 * d.thd.value >= PCT_RESOLUTION
               else format_value(100 * d.thd.value, resolution=PCT_RESOLUTION), format_value(ratio, digits=6),
               format_value_u(d.mean_cube_g3.value, d.mean_cube_g3.u)])) + "</tr>")
    th = "".join(f'<th class="num">{esc(h)}</th>' for h in head)
    note = ('<p class="mute">A shaker\'s drive is not a pure sine: a sine level\'s VRE is k2·E[x²] + k3·(3·g0·E[x²] + E[x³]) '
            "of the waveform measured on the reference (physics §4.4). The VRC is fitted against E[x²]; E[x³] makes the "
            "cubic term rectify as at a shifted static field (the VRC fit's note), which the campaign's k2/k3 fit "
            "uses. The DUT is taken to see the reference's waveform: its response is assumed equal at the "
            "harmonics as at the fundamental.</p>")
    return f'<div class="scroll"><table><thead><tr>{th}</tr></thead><tbody>{"".join(rows)}</tbody></table></div>' + note


def render_section(sec: ReportSection, anchor: str, number: str = "") -> str:
    """One section of the results: ``<h3>`` with its number, then what it shows, facts, warnings,
    figures, notes, tables, and for each of its results the conditions, levels, budget, fits;
    the prediction; the provenance."""
    head = f"{number} {sec.title}" if number else sec.title
    parts = [f'<section class="result" id="{esc(anchor)}"><h3>{esc(head)}</h3>', f'<p class="what">{esc(sec.what)}</p>']
    if sec.facts:
        parts.append(kv_table(sec.facts))
    results = section_results(sec)
    warnings = list(sec.extra_warnings)
    for k, (label, r) in enumerate(results):
        pre = f"{label}: " if label else ""
        warnings += [pre + w for w in collect_warnings(r, None, sec.prediction if k == 0 else None)]
    if not results:
        warnings += collect_warnings(None, None, sec.prediction)
    if warnings:
        parts.append("<h4>Warnings</h4><ul class=\"warn\">" + "".join(f"<li>{esc(w)}</li>" for w in collapse_warnings(warnings)) + "</ul>")
    for i, fig in enumerate(sec.figures, 1):
        parts.append(_figure_html(fig, f"{anchor}-f{i}", fig.caption or f"{sec.title}, figure {i}"))
    if sec.notes:
        parts.append('<ul class="notes">' + "".join(f"<li>{esc(n)}</li>" for n in sec.notes) + "</ul>")
    parts += [table_html(t) for t in sec.tables]
    for label, r in results:
        parts += _result_tables(r, label)
    if sec.prediction:
        parts.append("<h4>Prediction: mechanisms' shares</h4>" + _prediction_html(sec.prediction))
    for k, (label, r) in enumerate(results):
        prov = dict(r.provenance)
        if k == 0:
            prov.update(sec.provenance)
        if prov:
            parts.append(f"<h4>{esc(label + ': ' if label else '')}Provenance</h4>" + _provenance_html(prov))
    if not results and sec.provenance:
        parts.append("<h4>Provenance</h4>" + _provenance_html(sec.provenance))
    parts.append("</section>")
    return "\n".join(parts)


def render_report(
    sections: Sequence[ReportSection],
    title: str,
    intro: str = "",
    provenance: Mapping[str, Any] | None = None,
    metadata: ReportMetadata | None = None,
) -> str:
    """The whole report as one HTML string (UTF-8, self-contained), structured as a test report
    (:mod:`vrelab.report.testreport`): identification, 1 test item, 2 equipment, 3 conditions,
    4 procedure, 5 results (``sections``), 6 decisions, 7 approval. The plotly.js bundle is
    embedded once when any figure has an interactive twin."""
    meta = metadata or ReportMetadata()
    prov = default_provenance() | dict(provenance or {})
    anchors = [f"s{i}" for i in range(1, len(sections) + 1)]
    body = "\n".join(render_section(s, a, f"{T.RESULTS_NUMBER}.{i}") for i, (s, a) in enumerate(zip(sections, anchors), 1))
    doc = T.Document(title=title, intro=intro, sections=sections, anchors=anchors, results_html=body,
                     metadata=meta, provenance=prov)
    foot = "; ".join(f"{esc(k.replace('_', ' '))}: {esc(v)}" for k, v in prov.items())
    live = any(f.plotly_json is not None for s in sections for f in s.figures)
    run: list[str] = []
    if live:
        from vrelab.report.interactive import plotly_js

        # plotly.js once for the whole file, then one small script draws every figure.
        run = [JS_CLASS, plotly_js(), BOOT_JS]
    scripts = "".join(f"<script>{js}</script>" for js in run[1:])
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        f'<meta http-equiv="Content-Security-Policy" content="{content_security_policy(run)}">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{esc(title)}</title><style>{CSS}{T.page_css(meta, title)}</style>"
        + "".join(f"<script>{js}</script>" for js in run[:1])
        + "</head><body>"
        + T.render(doc)
        + f"<footer>Report provenance — {foot}</footer>{scripts}</body></html>\n"
    )


def default_provenance(argv: Sequence[str] | None = None) -> dict[str, Any]:
    return {
        "vrelab_version": __version__,
        "command_line": " ".join(["vrelab", *sys.argv[1:]] if argv is None else list(argv)),
        "date_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
    }


def write_report(
    path: str | Path,
    sections: Sequence[ReportSection],
    title: str = "Vibration rectification error report",
    intro: str = "",
    provenance: Mapping[str, Any] | None = None,
    metadata: ReportMetadata | None = None,
) -> Path:
    """Write the report atomically (temporary file, then rename) and return its path.

    ``metadata`` (:func:`vrelab.report.metadata.load_metadata`) fills the test report's
    identification, item, equipment, conditions, procedure and approval; without it those
    fields say "not given"."""
    path = Path(path)
    text = render_report(sections, title, intro, provenance, metadata)
    tmp = path.with_name(path.name + ".partial")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


# --------------------------------------------------------------------------- output folders
def _rails_of(result: VreResult) -> tuple[float, float] | None:
    ex = dict(result.conditions.extra)
    for key in ("rails_g", "rails"):
        r = ex.get(key)
        if isinstance(r, (list, tuple)) and len(r) == 2:
            return (float(r[0]), float(r[1]))
    if result.conditions.range_g is not None:
        return (-float(result.conditions.range_g), float(result.conditions.range_g))
    return None


def _sensor_number(result: VreResult, key: str) -> float | None:
    """A sensor parameter from the conditions, else from the sensor description in provenance."""
    for src in (dict(result.conditions.extra), result.provenance.get("sensor")):
        if isinstance(src, Mapping) and isinstance(src.get(key), (int, float)) and math.isfinite(src[key]):
            return float(src[key])
    return None


def result_figures(result: VreResult, folder: Path | None = None) -> tuple[list[ReportFigure], list[str]]:
    """The standard figures of one result (and of the optional files next to its results.json).

    Returns (figures, notes).
    """
    from vrelab.report import plots

    figs: list[ReportFigure] = []
    notes: list[str] = []
    finite = [lv for lv in result.levels if math.isfinite(lv.rms_g) and math.isfinite(lv.vre.value)]
    if finite:
        if result.method == "random":
            try:
                curves = plots.model_curves(result)
            except ImportError:
                curves, notes = [], notes + ["Model curves omitted: vrelab.models is not available."]
            fig = plots.plot_vre_vs_rms([plots.Series(plots.describe_conditions(result, short=True) or "VRE", result, tuple(curves))])
            figs.append(ReportFigure.from_figure(fig, "VRE against vibration level, ±1 standard uncertainty; lines: models at the fitted parameters."))
        if any("vrc_ug_per_g2" in f.params for f in result.fits) or result.method == "sine":
            figs.append(ReportFigure.from_figure(plots.plot_vre_vs_rms2(result), "VRE against rms²: the slope of the line through the origin is the VRC."))
        if sum(1 for f in result.fits if f.freq_hz is not None and "vrc_ug_per_g2" in f.params) > 1:
            fn = _sensor_number(result, "fn_hz")
            figs.append(ReportFigure.from_figure(plots.plot_vrc_vs_freq(result, fn_hz=fn), "VRC against sine frequency: resonance amplifies the nonlinearity."))
    if result.noise is not None and result.noise.tau_s:
        figs.append(ReportFigure.from_figure(
            plots.plot_allan(result.noise),
            f"DUT noise with vibration off: Allan deviation (IEEE 1554) over {result.noise.n_stretches} baseline(s); "
            f"{result.noise}.",
        ))
    if folder is not None:
        rec = folder / F.RECORD
        if rec.is_file():
            env = plots.record_envelope(rec)
            figs.append(ReportFigure.from_figure(plots.plot_time_series(env, rails_g=_rails_of(result), static_g=result.conditions.static_g), f"Record {rec.name} (min/max envelope of {env.bin_size}-sample bins), segments shaded."))
        elif (folder / F.ENVELOPE).is_file():
            figs.append(ReportFigure.from_figure(plots.plot_envelope_csv(folder / F.ENVELOPE), "Analysis windows: vibration level and sensor mean against time."))
        if (folder / F.PSD).is_file():
            d = plots.read_psd_csv(folder / F.PSD)
            f, pm, pp = d["freq_hz"], d["psd_measured"], d["psd_profile"]
            label, how = "reference PSD", "line by line"
            if f.size > PSD_LINES_BEFORE_AVERAGING:
                f, pm, pp = plots.fractional_octave_average(f, pm, 24, pp)
                label, how = "reference PSD, 1/24-octave average", "in 1/24-octave bands"
            # Shown, not judged: the tolerance verdict is the analysis's (physics §3 check on the
            # whole level, flagged per level and listed in the warnings); a table of a short
            # record's PSD scatters too much line by line to be read against ±3 dB.
            figs.append(
                ReportFigure.from_figure(
                    plots.plot_psd(f, pm, pp, label=label),
                    f"Reference PSD at the highest level against the profile and its ±3 dB tolerance band ({how}).",
                )
            )
    return figs, notes


def summary_sentence(result: VreResult) -> str:
    """One sentence of what a result shows, for a section without a hand-written one."""
    from vrelab.report import plots

    lv = [x for x in result.levels if math.isfinite(x.rms_g) and math.isfinite(x.vre.value)]
    what = f"{'Simulated' if result.kind == 'simulation' else 'Measured'} VRE"
    if not lv:
        return f"{what}: no valid levels."
    lo, hi = min(x.rms_g for x in lv), max(x.rms_g for x in lv)
    top = max(lv, key=lambda x: x.rms_g)
    s = f"{what} at {len(lv)} levels from {lo:.3g} to {hi:.3g} g rms ({result.method} method): {format_mg(top.vre.value, top.vre.u)} mg at {hi:.3g} g rms"
    bits = []
    for f in result.fits:
        if "rail_g" in f.params:
            rail = plots.fit_param_text("rail_g", f.params["rail_g"].value, f.params["rail_g"].u, "g")
            bits.append(f"the {f.model} model's effective rail: {rail}")
        elif "vrc_ug_per_g2" in f.params and f.freq_hz is None:
            bits.append(f"VRC = {format_value_u(f.params['vrc_ug_per_g2'].value, f.params['vrc_ug_per_g2'].u, unit='µg/g²')}")
    return s + ("; " + "; ".join(bits) if bits else "") + "."


def report_title(title: str | None, metadata: ReportMetadata | None, default: str) -> str:
    """The title: ``--title``, else the metadata's ``title``, else ``default``."""
    return title or (metadata.get("", "title") if metadata else None) or default


def result_section(rf: ResultsFolder, title: str | None = None, channel: str | None = None,
                   base: Path | None = None) -> ReportSection:
    """The report section of one simulate/analyze/demo results folder (one channel's folder);
    ``base``: the report's folder, when it is not this one (its files are linked from there)."""
    folder = rf.path
    result, prediction = rf.result, rf.prediction
    assert result is not None
    figs, notes = result_figures(result, folder)
    res_file = folder / F.RESULTS
    rel = Path(os.path.relpath(folder, base)) if base is not None else Path()
    prov: dict[str, Any] = {"results_file": (rel / res_file.name).as_posix(), "results_sha256": sha256_file(res_file)}
    src = next((result.provenance.get(k) for k in ("input", "input_file", "file", "path") if result.provenance.get(k)), None)
    if src and not any(k.endswith("sha256") for k in result.provenance):
        p = Path(str(src))
        if not p.is_absolute():
            p = folder / p if (folder / p).is_file() else p
        if p.is_file():
            prov["input_sha256"] = sha256_file(p)
    rec = folder / F.RECORD
    if rec.is_file():
        prov["record_file"] = (rel / rec.name).as_posix()
        prov["record_sha256"] = sha256_file(rec)
    return ReportSection(
        title=title or f"{describe(result)}",
        what=summary_sentence(result),
        result=result,
        figures=figs,
        prediction=prediction,
        notes=notes,
        provenance=prov,
        channel=channel,
    )


def report_result_dir(rf: ResultsFolder, argv: Sequence[str] | None = None, title: str | None = None,
                      metadata: ReportMetadata | None = None) -> Path:
    """Write ``report.html`` into a simulate/analyze/demo results folder (``vrelab report DIR``
    goes through :func:`vrelab.report.report_dir`, which reads the folder and picks this or the
    sweep report)."""
    folder = rf.path
    return write_report(
        folder / F.REPORT,
        [result_section(rf, title)],
        title=report_title(title, metadata, "Vibration rectification error report"),
        intro=f"Report of {folder.name or folder.resolve().name}/{F.RESULTS}.",
        provenance=default_provenance(argv),
        metadata=metadata,
    )


def report_channels_dir(rf: ResultsFolder, argv: Sequence[str] | None = None, title: str | None = None,
                        metadata: ReportMetadata | None = None) -> Path:
    """``report.html`` of several DUT channels of one file (``analyze --dut a,b --out DIR``):
    one section per channel, each from its sub-folder."""
    folder = rf.path
    doc = rf.doc or {}
    subs = F.channel_folder_names([str(c.get("channel")) for c in doc.get("channels", [])])
    sections = []
    for name, sub in subs.items():
        sf = F.read_folder(folder / sub)
        sections.append(result_section(sf, f"Channel {name}: {describe(sf.result)}" if sf.result else name, channel=name,
                                       base=folder))
    src = (doc.get("provenance") or {}).get("input_file", "")
    return write_report(
        folder / F.REPORT,
        sections,
        title=report_title(title, metadata, f"Vibration rectification error report: {len(sections)} channels"
                           + (f" of {src}" if src else "")),
        intro=f"Report of {folder.name or folder.resolve().name}/{F.RESULTS}: each DUT channel reduced against "
        "the one reference, with the same segments.",
        provenance=default_provenance(argv),
        metadata=metadata,
    )


def describe(result: VreResult) -> str:
    from vrelab.report.plots import describe_conditions

    return describe_conditions(result) or f"{result.method} test"
