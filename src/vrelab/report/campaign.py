"""The campaign report (``vrelab report DIR`` on a ``vrelab campaign --out DIR`` folder).

First the campaign: its runs (status, error, where each run's section is), then per channel
VRC against frequency (log axes, one marker per orientation, error bars of 1 u) with its k2,
k3 and rail and their uncertainties; then each run's channels as the single-file report shows
them (levels, fits, figures), read from the run's folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from vrelab import folder as F
from vrelab._format import format_value, format_value_u
from vrelab.folder import ResultsFolder
from vrelab.report.html import (
    ReportFigure,
    ReportSection,
    ReportTable,
    default_provenance,
    describe,
    report_title,
    result_section,
    write_report,
)
from vrelab.report.metadata import ReportMetadata
from vrelab.report.testreport import RESULTS_NUMBER


def vrc_figure(channel: Mapping[str, Any]) -> ReportFigure | None:
    """VRC(f) of one channel: log frequency axis; the VRC with its sign on every channel (one
    convention across the report's figures and tables), on a log axis when every value is
    positive, symmetric-log otherwise."""
    from vrelab.report.plots import new_figure

    pts = channel.get("vrc_by_freq") or []
    if not pts:
        return None
    f = np.array([p["freq_hz"] for p in pts], dtype=float)
    v = np.array([p["vrc_ug_per_g2"]["value"] for p in pts], dtype=float)
    u = np.array([p["vrc_ug_per_g2"]["u"] for p in pts], dtype=float)
    g = np.array([p["static_g"] for p in pts], dtype=float)
    fig, (ax,) = new_figure()
    if (v > 0).all():
        ax.set_yscale("log")
        ylabel = "VRC (µg/g²)"
    else:
        ax.set_yscale("symlog", linthresh=max(float(np.min(np.abs(v[v != 0]))) if (v != 0).any() else 1.0, 1.0))
        ylabel = "VRC (µg/g², symmetric log)"
    markers = ["o", "s", "^", "D", "v", "P"]
    for i, g0 in enumerate(sorted(set(np.round(g, 2)), reverse=True)):
        sel = np.isclose(np.round(g, 2), g0)
        order = np.argsort(f[sel])
        ax.errorbar(f[sel][order], v[sel][order], yerr=u[sel][order], fmt=markers[i % len(markers)] + "-",
                    capsize=3, label=f"static field {g0:+g} g")
    ax.set_xscale("log")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.legend(loc="best")
    ax.set_title(f"channel {channel['channel']}: VRC against frequency (error bars: 1 standard uncertainty)")
    return ReportFigure.from_figure(fig, f"Channel {channel['channel']}: VRC at every sine frequency and orientation. "
                                    "A rise toward the proof mass's resonance is VRC·|H(f)|² (physics §1.3).")


def _est(e: Mapping[str, Any] | None, unit: str, name: str = "") -> str:
    from vrelab.report.plots import fit_param_text

    return "not determined (see the notes)" if e is None else fit_param_text(name, e["value"], e["u"], unit)


def _noise_est(e: Mapping[str, Any], unit: str) -> str:
    """A noise figure, or why there is none (a flicker term the stretches were too short to fit)."""
    if e.get("value") is None or e.get("u") is None:
        return "not resolved (vibration-off stretches too short)"
    return format_value_u(e["value"], e["u"], unit=unit)


def _adev_min(allan: Mapping[str, Any] | None) -> str:
    pts = [(d, t) for d, t in zip((allan or {}).get("adev_ug") or [], (allan or {}).get("tau_s") or [])
           if d is not None and t is not None]
    if not pts:
        return ""
    d, t = min(pts)
    return f"{d:.3g} µg at {t:.3g} s"


def channel_section(channel: Mapping[str, Any]) -> ReportSection:
    fig = vrc_figure(channel)
    pts = channel.get("vrc_by_freq") or []
    shifted = any("static_shift_g" in p for p in pts)
    rows = [(f"{p['freq_hz']:.5g}", f"{p['static_g']:+g}", format_value_u(p["vrc_ug_per_g2"]["value"],
             p["vrc_ug_per_g2"]["u"]), str(p.get("n_levels", "")), f"{p['run']} ({p['label']})")
            + ((format_value(p.get("static_shift_g"), digits=3),) if shifted else ())
            for p in pts]
    # a fit's parameters: nested under "parameters", or beside "model" in a folder of an earlier version
    per_freq = [(f"{f['freq_hz']:.5g}" if f.get("freq_hz") is not None else "",
                 format_value_u(p["k2_ug_per_g2"]["value"], p["k2_ug_per_g2"]["u"]),
                 format_value_u(p["k3_ug_per_g3"]["value"], p["k3_ug_per_g3"]["u"]), str(f["n_points"]))
                for f in channel.get("k2_k3_by_freq") or [] for p in [f.get("parameters") or f]]
    tables = [ReportTable("VRC by frequency and orientation", ["freq (Hz)", "static field (g)", "VRC ± u (µg/g²)",
                                                               "levels", "run"]
                          + (["drive's shift of g0 (g; physics §4.4)"] if shifted else []), rows,
                          numeric=(0, 1, 2, 3, 5) if shifted else (0, 1, 2, 3))]
    if per_freq:
        tables.append(ReportTable("k2 and k3 per frequency (VRC(g0) = k2 + 3·k3·g0)",
                                  ["freq (Hz)", "k2 ± u (µg/g²)", "k3 ± u (µg/g³)", "orientations"], per_freq,
                                  numeric=(0, 1, 2, 3)))
    noise = [(f"{n['run']} ({n['label']})", f"{n['off_s']:.3g}" if n.get("off_s") is not None else "",
              _noise_est(n["density_ug_rthz"], "µg/√Hz"), _noise_est(n["bias_instability_ug"], "µg"),
              _adev_min(n.get("allan")))
             for n in channel.get("noise_by_run") or []]
    if noise:
        tables.append(ReportTable("Noise with vibration off, by run (physics §4.4; IEEE 952 conventions, density one-sided)",
                                  ["run", "off (s)", "density ± u", "bias instability ± u", "Allan deviation minimum"],
                                  noise, numeric=(1,)))
    return ReportSection(
        title=f"Channel {channel['channel']}",
        what=f"apparent k2 = {_est(channel.get('k2_ug_per_g2'), 'µg/g²')}, k3 = {_est(channel.get('k3_ug_per_g3'), 'µg/g³')}, "
        f"effective rail = {_est(channel.get('rail_g'), 'g', 'rail_g')} (standard uncertainties).",
        figures=[fig] if fig else [],
        facts=[("k2 (apparent: combined over frequencies, see the notes)", _est(channel.get("k2_ug_per_g2"), "µg/g²")),
               ("k3 (combined over frequencies)", _est(channel.get("k3_ug_per_g3"), "µg/g³")),
               ("effective rail", _est(channel.get("rail_g"), "g", "rail_g"))],
        notes=list(channel.get("notes") or []),
        tables=tables,
        channel=str(channel["channel"]),
    )


def _runs_table(runs: Sequence[Mapping[str, Any]], anchors: Mapping[int, tuple[int, int]]) -> ReportTable:
    """One row per run; its link names the numbered sections it points to (5.4–5.5, as the
    headings read) and the anchor is the first of them."""
    from vrelab.report.plots import fit_param_text

    rows: list[tuple[Any, ...]] = []
    for r in runs:
        fits = []
        for c in r.get("channels") or []:
            fit = c.get("fit") or {}
            if "vrc_ug_per_g2" in fit:
                fits.append(f"{c['channel']}: VRC {format_value_u(fit['vrc_ug_per_g2']['value'], fit['vrc_ug_per_g2']['u'], unit='µg/g²')}")
            if "rail_g" in fit:
                fits.append(f"{c['channel']}: rail {fit_param_text('rail_g', fit['rail_g']['value'], fit['rail_g']['u'], 'g')}")
        status = "ok" if r["status"] == "ok" else f"FAILED: {r.get('error')}"
        where: Any = "—"
        if r["index"] in anchors:
            first, n = anchors[r["index"]]
            span = f"{RESULTS_NUMBER}.{first}" + (f"–{RESULTS_NUMBER}.{first + n - 1}" if n > 1 else "")
            where = (f"{span} (run {r['index']})", f"#s{first}")
        rows.append((str(r["index"]), r["label"], r["file"], r["method"], status, "; ".join(fits), where))
    return ReportTable("Runs", ["run", "label", "file", "method", "status", "fits (± standard uncertainty)", "sections"], rows,
                       numeric=(0,), breakable=(2,))


def report_campaign_dir(rf: ResultsFolder, argv: Sequence[str] | None = None, title: str | None = None,
                        metadata: ReportMetadata | None = None) -> Path:
    """Write ``report.html`` for a campaign folder."""
    folder = rf.path
    doc = rf.doc or {}
    runs = doc.get("runs") or []
    channels = doc.get("channels") or []
    run_sections: list[tuple[int, list[ReportSection]]] = []
    for r in runs:
        if r.get("status") != "ok" or not r.get("folder"):
            continue
        sub = folder / r["folder"]
        names = F.channel_folder_names([c["channel"] for c in r.get("channels") or []])
        secs = []
        for name, d in names.items():
            sf = F.read_folder(sub / d)
            if sf.result is None:
                raise ValueError(f"{sub / d}: no result in this run's channel folder")
            secs.append(result_section(sf, f"Run {r['index']} ({r['label']}), channel {name}: {describe(sf.result)}",
                                       channel=name, base=folder))
        run_sections.append((r["index"], secs))
    first = 2 + len(channels)
    anchors: dict[int, tuple[int, int]] = {}  # run → (its first section's number, how many)
    k = first
    for idx, secs in run_sections:
        anchors[idx] = (k, len(secs))
        k += len(secs)
    n_failed = int(doc.get("n_failed") or 0)
    summary = ReportSection(
        title=f"Campaign: {doc.get('name', '')}",
        what=f"{len(runs)} run(s), {n_failed} failed; {len(channels)} channel(s). Each run's DUT channels were "
        "reduced against its reference; per channel the VRC at every sine frequency and orientation, k2 and k3 "
        "from the orientations and the effective rail from the random runs.",
        facts=[("manifest", str((doc.get("provenance") or {}).get("manifest", ""))),
               ("manifest SHA-256", str((doc.get("provenance") or {}).get("manifest_sha256", ""))),
               ("description", str(doc.get("description") or "—"))],
        tables=[_runs_table(runs, anchors)],
        extra_warnings=[f"run {r['index']} ({r['label']}) failed: {r.get('error')}" for r in runs if r["status"] != "ok"],
        provenance={"results_file": F.RESULTS, **{k: v for k, v in (doc.get("provenance") or {}).items()
                                                  if k in ("manifest", "manifest_sha256")}},
    )
    sections = [summary] + [channel_section(c) for c in channels] + [s for _, secs in run_sections for s in secs]
    return write_report(
        folder / F.REPORT,
        sections,
        title=report_title(title, metadata, f"Campaign report: {doc.get('name', folder.name)}"),
        intro=f"Report of {folder.name or folder.resolve().name}/{F.RESULTS} (vrelab campaign).",
        provenance=default_provenance(argv),
        metadata=metadata,
    )
