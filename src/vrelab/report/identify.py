"""The identification report (``vrelab report DIR`` on a ``vrelab identify --out DIR`` folder).

First what was identified from what (campaign, base sensor, clip model, the sensor file); then
per channel: the parameters (value ± u, or null with the reason and where the value used comes
from; IEEE 1293's cross-coupling Kip, Kpp, Kio, Koo beside k2 and k3), the apparent VRC of every sine run against frequency with the identified
``(k2 + 3·k3·g0)·|H(f)|²`` per orientation, the mount-angle runs' VRE/σ² against their angle
with the identified cross-coupling model, each level's pull (measured − model)/u by run, the
2f cross-check and the notes. It reads ``identification.json`` only: nothing is refitted.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from vrelab import folder as F
from vrelab._format import format_value_u
from vrelab.folder import ResultsFolder
from vrelab.report.html import (
    ReportFigure,
    ReportSection,
    ReportTable,
    default_provenance,
    report_title,
    write_report,
)
from vrelab.report.metadata import ReportMetadata
from vrelab.sensor.parameters import TABLE


def vrc_model_figure(ch: Mapping[str, Any]) -> ReportFigure | None:
    """Apparent VRC of each sine run (markers, 1 u: :func:`vrelab.identification.apparent_vrc`, read
    from the document) and the identified model per orientation."""
    from vrelab.models.dynamics import vrc_at_frequency
    from vrelab.report.plots import new_figure

    pts = [(r["freq_hz"], r["static_g"], r["vrc_ug_per_g2"]["value"], r["vrc_ug_per_g2"]["u"])
           for r in ch.get("runs") or [] if r.get("vrc_ug_per_g2")]
    if not pts:
        return None
    used = ch.get("values_used") or {}
    k2, k3 = used.get("k2_ug_per_g2") or 0.0, used.get("k3_ug_per_g3") or 0.0
    fn, q = used.get("fn_hz"), used.get("q")
    f = np.array([p[0] for p in pts])
    fig, (ax,) = new_figure()
    grid = np.geomspace(f.min() / 1.5, f.max() * 1.5, 400)
    markers = ["o", "s", "^", "D"]
    for i, g0 in enumerate(sorted({round(p[1], 2) for p in pts}, reverse=True)):
        sel = [p for p in pts if round(p[1], 2) == g0]
        line = ax.plot(grid, (k2 + 3 * k3 * g0) * (vrc_at_frequency(1.0, grid, fn, q) if fn and q else np.ones_like(grid)),
                       label=f"model at {g0:+g} g")[0]
        ax.errorbar([p[0] for p in sel], [p[2] for p in sel], yerr=[p[3] for p in sel], fmt=markers[i % 4],
                    color=line.get_color(), capsize=3, label=f"measured at {g0:+g} g")
    ax.set_xscale("log")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("apparent VRC (µg/g²)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.legend(loc="best")
    ax.set_title(f"channel {ch['channel']}: VRC(f) measured and identified (error bars: 1 u)")
    return ReportFigure.from_figure(fig, f"Channel {ch['channel']}: each sine run's apparent VRC (weighted fit of "
                                    "VRE = VRC·rms² over its levels) and the identified (k2 + 3·k3·g0)·|H(f)|² "
                                    "for each orientation (physics §1.2, §1.3).")


def pulls_figure(ch: Mapping[str, Any]) -> ReportFigure | None:
    """Each level's (measured - model)/u, one column of points per run."""
    from vrelab.report.plots import new_figure

    runs = ch.get("runs") or []
    if not runs:
        return None
    fig, (ax,) = new_figure()
    labels = []
    for i, r in enumerate(runs):
        z = [x["pull"] for x in r["residuals"]]
        ax.plot(np.full(len(z), i) + np.linspace(-0.15, 0.15, len(z)), z, "o")
        freq = f" {r['freq_hz']:.4g} Hz" if r.get("freq_hz") else ""
        labels.append(f"{r['run']}: {r['label']}" + (freq if freq.strip() not in r["label"] else ""))
    for y in (-3, 3):
        ax.axhline(y, color="0.6", ls="--", lw=0.8)
    ax.axhline(0, color="0.4", lw=0.8)
    ax.set_xticks(range(len(runs)))
    ax.set_xticklabels(labels, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("(measured − model) / u")
    ax.set_title(f"channel {ch['channel']}: residuals of every level (dashed: ±3)")
    return ReportFigure.from_figure(fig, f"Channel {ch['channel']}: each level's pull against the identified model; "
                                    "a run whose points sit beyond ±3 is one the model does not describe.")


def cross_coupling_figure(ch: Mapping[str, Any]) -> ReportFigure | None:
    """IEEE 1293's mount-angle runs (physics §1.6): each run's VRE/σ_m² against its mount angle, per
    plane (1 u error bars), beside the identified model's value at the same run (crosses)."""
    from vrelab.report.plots import new_figure

    cc = ch.get("cross_coupling") or {}
    pts = cc.get("points") or []
    if not pts:
        return None
    fig, (ax,) = new_figure()
    for plane, marker in (("ip", "o"), ("io", "s")):
        sel = [p for p in pts if p["mount_plane"] == plane and not p.get("axial")]
        axial = [p for p in pts if p.get("axial")] if plane == "ip" else []
        sel = axial + sel
        if not sel:
            continue
        x = [p["mount_deg"] for p in sel]
        line = ax.errorbar(x, [p["vre_per_ms_ug_per_g2"]["value"] for p in sel],
                           yerr=[p["vre_per_ms_ug_per_g2"]["u"] for p in sel], fmt=marker, capsize=3,
                           label=f"measured, {plane.upper()} plane" + (" (0°: along the vibration)" if axial else ""))
        ax.plot(x, [p["model_ug_per_g2"] for p in sel], "x", ms=9, color=line[0].get_color(),
                label=f"identified model, {plane.upper()} plane")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xticks([-90, -45, 0, 45, 90])
    ax.set_xlabel("mount angle φ of the input axis to the vibration (°)")
    ax.set_ylabel("VRE / σ_m² (µg/g²)")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"channel {ch['channel']}: the mount-angle runs (IEEE 1293)")
    return ReportFigure.from_figure(fig, f"Channel {ch['channel']}: each run's rectification per proof-mass mean square "
                                    "against its mount angle, and the identified (k2 + 3·k3·w·g)·(w·d)² + Kip·d_i·d_p + "
                                    "Kpp·d_p² + Kio·d_i·d_o + Koo·d_o² at the same run (physics §1.6).")


# the parameter table's order: the nonlinearity, then the cross-coupling terms beside it, then the rest
_FIRST = ("k2_ug_per_g2", "k3_ug_per_g3", "kip_ug_per_g2", "kpp_ug_per_g2", "kio_ug_per_g2", "koo_ug_per_g2")


def _parameter_rows(ch: Mapping[str, Any]) -> list[list[str]]:
    rows = []
    params = ch.get("parameters") or {}
    order = [n for n in _FIRST if n in params] + [n for n in params if n not in _FIRST]
    for name, e in ((n, params[n]) for n in order):
        used = (ch.get("values_used") or {}).get(name)
        a = (ch.get("assumed") or {}).get(name)
        if e is None:
            if used is None:
                shown = ""
            elif a is None:
                shown = f"{used:.6g} (base sensor)"
            else:  # an assumption: the base's value or a bounded fit, with the u the sensor file carries
                where = "bounded fit" if str(a.get("source", "")).startswith("fitted") else "base sensor"
                shown = (f"{used:.6g} ± {a['u']:.2g} (assumed, {where})" if a.get("u") is not None
                         else f"{used:.6g} (assumed, {where}; no stated u)")
            rows.append([name, "null", shown, (ch.get("null_reasons") or {}).get(name, "")])
        else:
            rows.append([name, f"{format_value_u(e['value'], e['u'])} {TABLE[name].text_unit}".strip(),
                         "identified", ""])
    return rows


def channel_section(ch: Mapping[str, Any]) -> ReportSection:
    figs = [f for f in (vrc_model_figure(ch), cross_coupling_figure(ch), pulls_figure(ch)) if f is not None]
    tables = [ReportTable("Parameters", ["parameter", "value ± u", "value used", "why null"], _parameter_rows(ch))]
    runs = ch.get("runs") or []
    tables.append(ReportTable("Runs", ["run", "method", "static g", "frequency / profile", "levels", "χ²"],
                              [[f"{r['run']} ({r['label']})", r["method"], f"{r['static_g']:+g}",
                                f"{r['freq_hz']:.5g} Hz" if r.get("freq_hz") else str(r.get("profile") or ""),
                                str(r["n"]), f"{r['chi2']:.3g}"] for r in runs], numeric=(4, 5)))
    cc = ch.get("cross_coupling") or {}
    if cc.get("points"):
        tables.append(ReportTable(
            "Mount-angle runs (IEEE 1293): VRE per proof-mass mean square, measured and identified"
            + (f" (χ²/dof = {cc['chi2_reduced']:.3g})" if cc.get("chi2_reduced") is not None else ""),
            ["run", "frequency (Hz)", "mount", "static field [i, p, o] (g)", "levels", "VRE/σ² (µg/g²)",
             "model (µg/g²)"],
            [[f"{p['run']} ({p['label']})", f"{p['freq_hz']:.5g}" if p.get("freq_hz") else "",
              "along the vibration" if p.get("axial") else f"{p['mount_deg']:+g}° {p['mount_plane'].upper()} ({p['shaker']})",
              ", ".join(f"{g:+.3g}" for g in p["static_vector_g"]), str(p["n"]),
              format_value_u(p["vre_per_ms_ug_per_g2"]["value"], p["vre_per_ms_ug_per_g2"]["u"]),
              "" if p.get("model_ug_per_g2") is None else f"{p['model_ug_per_g2']:.4g}"] for p in cc["points"]],
            numeric=(1, 4, 5, 6)))
    x2f = ch.get("cross_check_2f") or []
    if x2f:
        tables.append(ReportTable(
            "2f cross-check: the VRC from the DUT's 2f line (less the reference's, divided by the base sensor's "
            "output-filter gain at 2f against DC) beside the DC one",
            ["run", "frequency (Hz)", "static g", "filter gain at 2f", "VRC from 2f (µg/g²)", "VRC from DC (µg/g²)",
             "difference (σ)"],
            [[f"{x['run']} ({x['label']})", f"{x['freq_hz']:.5g}", f"{x['static_g']:+g}",
              f"{x.get('filter_gain_2f', 1.0):.3g}",
              format_value_u(x["vrc_2f_ug_per_g2"]["value"], x["vrc_2f_ug_per_g2"]["u"]),
              format_value_u(x["vrc_dc_ug_per_g2"]["value"], x["vrc_dc_ug_per_g2"]["u"]),
              "" if x.get("difference_sigma") is None else f"{x['difference_sigma']:+.2g}"] for x in x2f],
            numeric=(1, 2, 3, 4, 5, 6)))
    for term in ch.get("budget") or []:
        if term.get("shifts"):
            tables.append(ReportTable(f"Type B: {term['source']} (each parameter's shift, refitted)",
                                      ["parameter", "shift"],
                                      [[n, f"{d:+.3g}"] for n, d in term["shifts"].items()], numeric=(1,)))
    chi2 = ch.get("chi2_reduced")
    return ReportSection(
        title=f"Channel {ch['channel']}",
        what=f"One weighted fit to every level of every run (χ²/dof = {'–' if chi2 is None else f'{chi2:.3g}'}, "
        f"{ch.get('dof')} dof); each level evaluated by the analytic model `vrelab predict` uses.",
        figures=figs, tables=tables, notes=list(ch.get("notes") or []), channel=str(ch["channel"]))


def report_identification_dir(rf: ResultsFolder, argv: Sequence[str] | None = None,
                              title: str | None = None, metadata: ReportMetadata | None = None) -> Path:
    """Write ``report.html`` for an identification folder (``metadata``: the test report's
    identification, item, equipment and approval, as for every report)."""
    doc = rf.doc or {}
    base = doc.get("base_sensor") or {}
    summary = ReportSection(
        title=f"Identification: {doc.get('campaign', '')}",
        what="Each channel's VRE model (physics §6.1) identified from the campaign's levels; what the campaign cannot "
        "determine is null with its reason and taken from the base sensor.",
        facts=[("base sensor", f"{base.get('spec')} (±{base.get('range_g')} g, axis {base.get('axis')}, ODR "
                               f"{base.get('odr_hz') or 'none'})"),
               ("clip model", str(doc.get("clip_model", ""))),
               ("sensor file", f"{F.IDENTIFIED_SENSOR}: --sensor {rf.path / F.IDENTIFIED_SENSOR} --axis <channel>")],
        provenance={"results_file": F.IDENTIFICATION},
        notes=list(doc.get("notes") or []),  # the campaign's failed runs
    )
    sections = [summary] + [channel_section(c) for c in doc.get("channels") or []]
    return write_report(rf.path / F.REPORT, sections,
                        title=report_title(title, metadata, f"Identification report: {doc.get('campaign', '')}"),
                        intro=f"Report of {rf.path.name or rf.path.resolve().name}/{F.IDENTIFICATION} "
                        "(vrelab identify).", provenance=default_provenance(argv), metadata=metadata)
