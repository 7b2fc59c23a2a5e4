"""``vrelab compare --html OUT``: one page of the report's building blocks (:mod:`vrelab.report.html`):
VRE ± U per candidate against the budget, and VRE against level for the best few."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from vrelab.comparison.results import CandidateRow, Comparison

# the figure of VRE ± U shows this many valid candidates (in rank order; the table has them all)
_SHOWN = 40
# the best few drawn against level, and the levels each is drawn at (log-spaced from a tenth of
# the lowest level asked to twice the highest: where clipping sets in shows)
_BEST = 4
_CURVE_LEVELS = 7


def _vre_figure(rows: Sequence[CandidateRow], budget_text: str) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    shown = [r for r in rows if r.worst is not None][:_SHOWN]
    fig = Figure(figsize=(8.0, 1.2 + 0.28 * max(len(shown), 1)), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)  # the report's figures draw on an Agg canvas (report.interactive reads its renderer)
    ax = fig.add_subplot()
    colors = {"pass": "#1b7837", "undecided": "#b8860b", "fail": "#b2182b"}
    for n, r in enumerate(shown):
        w = r.worst
        assert w is not None
        ratio = abs(w.vre_g) / w.limit_g
        ax.errorbar([ratio], [n], xerr=[[w.expanded_g / w.limit_g], [w.expanded_g / w.limit_g]], fmt="o",
                    color=colors.get(r.verdict, "gray"), capsize=3)
    ax.axvline(1.0, color="black", ls="--", lw=1.2, label=f"budget ({budget_text})")
    ax.set_yticks(range(len(shown)), [r.candidate.label for r in shown])
    ax.invert_yaxis()
    ax.set_xlabel("|VRE| ± U (k = 2) at the worst level and static field, as a fraction of the budget")
    ax.set_xlim(left=0.0)
    ax.legend(loc="lower right")
    ax.grid(True, axis="x", alpha=0.3)
    return fig


def _level_figure(cmp: Comparison, best: Sequence[CandidateRow]) -> Figure:
    """VRE ± U against level for the best few, each at its worst static field (a prediction each)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from vrelab.comparison.run import load_candidate
    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile

    c = cmp.conditions
    env = parse_profile(c["environment"])
    levels = np.geomspace(min(c["levels_g"]) / 10, 2 * max(c["levels_g"]), _CURVE_LEVELS)
    fig = Figure(figsize=(8.0, 4.6), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for r in best:
        w = r.worst
        assert w is not None
        mount = c["mount"]
        sensor = load_candidate({"part": r.candidate.part, "range_g": r.candidate.range_g, "odr_hz": r.candidate.odr_hz,
                                 "axis": r.candidate.axis, "mount": (mount["fn_hz"], mount["q"]) if mount else None})
        pred = predict(sensor, env, levels, static_g=w.static_g)
        vre = np.array([lv.vre_g for lv in pred.levels]) * 1e3
        u = np.array([2 * (lv.u_vre_g or 0.0) for lv in pred.levels]) * 1e3
        line = ax.plot(levels, vre, "o-", label=f"{r.candidate.label} (static {w.static_g:.3g} g)")[0]
        ax.fill_between(levels, vre - u, vre + u, color=line.get_color(), alpha=0.15)
    # the budget as a VRE at the first candidate's worst static field (a tilt budget varies with it)
    limit = best[0].worst.limit_g * 1e3 if best[0].worst is not None else None
    if limit is not None:
        for sign in (1, -1):
            ax.axhline(sign * limit, color="black", ls="--", lw=1.2,
                       label=f"budget ({c['budget']}: ±{limit:.3g} mg)" if sign > 0 else None)
    for x in c["levels_g"]:
        ax.axvline(x, color="gray", ls=":", lw=1)
    ax.set_xscale("log")
    # symlog: a VRE crosses zero and spans decades; linear within a tenth of the budget
    ax.set_yscale("symlog", linthresh=max(limit or 0.0, 1e-6) / 10)
    ax.set_xlabel("vibration level (g rms)")
    ax.set_ylabel("VRE (mg), band: ± U (k = 2)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return fig


def _table(cmp: Comparison) -> Any:
    from vrelab.report.html import ReportTable

    rows = []
    for n, r in enumerate(cmp.rows, 1):
        d = r.to_dict()
        if not r.valid:
            rows.append((str(n), d["label"], "invalid", "", "", "", "", d["reason"] or ""))
            continue
        tilt = _plus(d["tilt_error_deg"], d["U_tilt_error_deg"]) if d["tilt_error_deg"] is not None else "-"
        du = d["dominant_u"]
        rows.append((str(n), d["label"], d["verdict"],
                     _plus(d["vre_g"] * 1e3, d["U_vre_g"] * 1e3 if d["U_vre_g"] is not None else None),
                     f"{d['vrc_ug_per_g2']:.4g}", tilt, f"{d['margin']:.3g}",
                     f"{d['dominant_mechanism']}; u: {du['source'] if du else 'none stated'}"
                     + (f" ({d['reason']})" if d["reason"] else "")))
    return ReportTable("Candidates, ranked", ("#", "candidate", "verdict", "VRE ± U (mg)", "VRC (µg/g²)",
                                              "tilt ± U (deg)", "margin", "dominant mechanism; u"),
                       rows, numeric=(0, 3, 4, 5, 6))


def _plus(value: float, big_u: float | None) -> str:
    """``value ± U``; where no u is stated, no U: ``value ± ?``."""
    return f"{value:.4g} ± " + (f"{big_u:.2g}" if big_u is not None else "?")


def write_page(cmp: Comparison, out: str | Path, argv: Sequence[str] | None = None) -> Path:
    """Write the page to ``out`` (a file; its folder must exist) and return its path."""
    from vrelab.report.html import ReportFigure, ReportSection, default_provenance, write_report

    path = Path(out)
    if not path.parent.is_dir():
        raise ValueError(f"--html: the folder of {out} does not exist")
    c = cmp.conditions
    best = [r for r in cmp.rows if r.worst is not None][:_BEST]
    figures = [ReportFigure.from_figure(_vre_figure(cmp.rows, c["budget"]),
                                        "Each candidate's |VRE| ± U (k = 2) at its worst level and static field, "
                                        "as a fraction of the budget: left of the dashed line with its whole bar, "
                                        "it passes.")]
    if best:
        figures.append(ReportFigure.from_figure(_level_figure(cmp, best),
                                                "VRE against level for the best candidates (dotted: the levels asked)."))
    counts = cmp.to_dict()["counts"]
    what = (f"{len(cmp.rows)} candidates in {c['environment']} at {', '.join(f'{x:g}' for x in c['levels_g'])} g rms "
            f"against a budget of {c['budget']}: " + ", ".join(f"{n} {v}" for v, n in counts.items()) + "; best: "
            + (cmp.best.candidate.label if cmp.best else "none passes") + ".")
    facts = [("environment", f"{c['environment']} ({c['band_hz'][0]:g}-{c['band_hz'][1]:g} Hz)"),
             ("levels", ", ".join(f"{x:g} g rms" for x in c["levels_g"])),
             ("static fields", ", ".join(f"{g:.4g} g" for g in c["static_g"])),
             ("budget", f"{c['budget']} (pass: |VRE| + U ≤ budget; fail: |VRE| − U > budget; U = 2u)"),
             ("mount", f"{c['mount']['fn_hz']:g} Hz, Q {c['mount']['q']:g}" if c["mount"] else "rigid")]
    notes = sorted({n for r in cmp.rows for n in r.notes})
    section = ReportSection(title="Which part, range and output rate", what=what, figures=figures, facts=facts,
                            extra_warnings=notes, tables=[_table(cmp)])
    return write_report(path, [section], title="vrelab compare", intro=what, provenance=default_provenance(argv))
