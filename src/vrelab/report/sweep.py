"""The report of a sweep output folder: figures and tables from the labelled ``result.nc``.

A sweep (``vrelab sweep FILE --out DIR``) leaves an xarray Dataset (:mod:`vrelab.sweep.dataset`)
whose dimensions are the grid axes in file order, preceded by ``unit`` for a Monte Carlo lot
(the drawn parameters are coordinates along ``unit``); ``vre_g`` (and ``u_vre_g`` for the
``simulate`` kind) are float arrays over all dimensions, NaN where a point failed, and
``status`` / ``error`` say why. The figure functions here take that Dataset and return a
matplotlib ``Figure`` (no pyplot, VRE in mg), like :mod:`vrelab.report.plots`:

- a grid: :func:`plot_sweep_grid`, VRE against the first numeric grid axis, one line for each
  combination of the other grid axes (``MAX_LINES`` to a figure, as many figures as it takes);
- a Monte Carlo lot: :func:`plot_lot_spread`, the lot's mean VRE and its 5th-95th percentile
  band against that axis; :func:`plot_lot_histograms`, the spread of VRE across the units at
  each grid point (mean, standard deviation, 5th / 95th percentiles marked), and
  :func:`plot_lot_scatter`, VRE against each drawn parameter. Every grid point is shown: the
  panels and rows run over as many figures as it takes.

:func:`sweep_section` turns the Dataset into a :class:`~vrelab.report.html.ReportSection`;
:func:`report_sweep_dir` writes ``DIR/report.html`` (``vrelab report DIR`` calls it through
:func:`vrelab.report.report_dir` when DIR holds ``result.nc`` and no ``results.json``).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from vrelab import folder as F
from vrelab._format import format_mg
from vrelab._io import sha256_file
from vrelab._load import json_loads
from vrelab.report.html import (
    ReportFigure,
    ReportSection,
    ReportTable,
    default_provenance,
    report_title,
    write_report,
)
from vrelab.report.metadata import ReportMetadata
from vrelab.report.plots import COLORS

if TYPE_CHECKING:
    import xarray as xr

UNIT = "unit"
# More lines than this on one plot cannot be told apart, even in the colour-blind-safe cycle
# with markers: further combinations go to the next figure. Panels and rows likewise.
MAX_LINES = 8
MAX_HIST_PANELS = 6
MAX_SCATTER_ROWS = 4
MAX_FAILED_ROWS = 50

_AXIS_LABELS = {
    "rms_g": "vibration level (g rms)",
    "static_g": "static field (g)",
    "range_g": "range (±g)",
    "offset_g": "offset (g)",
    "freq_hz": "frequency (Hz)",
    "fn_hz": "resonance frequency (Hz)",
    "odr_hz": "output data rate (Hz)",
    "f_lo_hz": "band low edge (Hz)",
    "f_hi_hz": "band high edge (Hz)",
    "q": "resonance Q",
    "k2_ug_per_g2": "k2 (µg/g²)",
    "k3_ug_per_g3": "k3 (µg/g³)",
    "tilt_deg": "tilt (°)",
}
_SUFFIX_UNITS = (("_ug_per_g2", "µg/g²"), ("_ug_per_g3", "µg/g³"), ("_hz", "Hz"), ("_deg", "°"), ("_s", "s"), ("_g", "g"))


def axis_label(name: str) -> str:
    """A parameter's name as an axis label with its unit (read from the name's suffix)."""
    if name in _AXIS_LABELS:
        return _AXIS_LABELS[name]
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix):
            return f"{name} ({unit})"
    return name


def _fmt_value(v: object) -> str:
    if isinstance(v, (float, np.floating)):
        return format(float(v), "g")
    return str(v)


# --------------------------------------------------------------------------- the Dataset
def _import_xarray() -> Any:
    try:
        import xarray
    except ImportError:
        raise ValueError("report: a sweep result needs xarray and h5netcdf: pip install 'vrelab[sweep]'") from None
    return xarray


def load_sweep(path: str | Path) -> Any:
    """Open a sweep's NetCDF, load it into memory (sweeps are small) and close the file.

    A file that is not NetCDF, or not a vrelab sweep result, is a one-line ``ValueError``.
    """
    xr = _import_xarray()
    path = Path(path)
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/h5netcdf raise OSError, ValueError, KeyError... on a bad file
        msg = str(exc).splitlines()[0] if str(exc) else ""
        raise ValueError(f"report: {path} is not a readable NetCDF file ({type(exc).__name__}: {msg})") from None
    if "status" not in ds.data_vars or "error" not in ds.data_vars:
        raise ValueError(f"report: {path} is not a vrelab sweep result (no status/error variables)")
    return ds


def grid_axes(ds: xr.Dataset) -> list[str]:
    """The grid axes in file order (the dimensions of ``status`` without ``unit``)."""
    return [str(d) for d in ds["status"].dims if d != UNIT]  # xarray types names Hashable; a sweep's are str


def drawn_parameters(ds: xr.Dataset) -> list[str]:
    """The Monte Carlo parameters: numeric coordinates along ``unit`` other than ``unit``."""
    if UNIT not in ds.dims:
        return []
    return [str(n) for n, c in ds.coords.items() if n != UNIT and c.dims == (UNIT,) and c.dtype.kind in "fiu"]


def _is_numeric(ds: xr.Dataset, name: str) -> bool:
    return ds[name].dtype.kind in "fiu"


def x_axis(ds: xr.Dataset) -> str | None:
    """The axis VRE is drawn against: the first numeric grid axis, else the first grid axis."""
    axes = grid_axes(ds)
    return next((a for a in axes if _is_numeric(ds, a)), axes[0] if axes else None)


def line_combinations(ds: xr.Dataset, x: str) -> list[dict[str, Any]]:
    """Every combination of the grid axes other than ``x``, in file order (one empty selection
    when ``x`` is the only axis)."""
    others = [a for a in grid_axes(ds) if a != x]
    return [dict(zip(others, vals)) for vals in itertools.product(*(ds[a].values.tolist() for a in others))]


def chunks(items: Sequence[Any], size: int) -> list[tuple[int, list[Any]]]:
    """``items`` in consecutive pieces of at most ``size``: (index of the first, the piece)."""
    return [(i, list(items[i : i + size])) for i in range(0, len(items), size)] or [(0, [])]


def _part(first: int, n: int, total: int, what: str) -> str:
    """" (combinations 9-12 of 12)" when a figure shows part of them, else ""."""
    return f" ({what} {first + 1}–{first + n} of {total})" if n < total else ""


def grid_points(ds: xr.Dataset) -> list[dict[str, Any]]:
    """Every grid point (a selection of the grid axes) in row-major order; one empty selection
    when there is no grid."""
    axes = grid_axes(ds)
    return [dict(zip(axes, vals)) for vals in itertools.product(*(ds[a].values.tolist() for a in axes))]


def describe_point(sel: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {_fmt_value(v)}" for k, v in sel.items()) or "all units"


def _new_figure(nrows: int = 1, ncols: int = 1, height_in: float = 4.6) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=(7.6, height_in), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for ax in axes.flat:
        ax.grid(True, alpha=0.45)
    return fig, axes


def _title(ds: xr.Dataset) -> str:
    return str(ds.attrs.get("title") or "sweep")


# --------------------------------------------------------------------------- figures
def _x_values(ds: xr.Dataset, x: str) -> tuple[np.ndarray, bool]:
    numeric = _is_numeric(ds, x)
    return (ds[x].values.astype(float) if numeric else np.arange(ds.sizes[x], dtype=float)), numeric


def _x_axis_style(ax: Axes, ds: xr.Dataset, x: str, xs: np.ndarray, numeric: bool) -> None:
    if not numeric:
        ax.set_xticks(xs, [str(v) for v in ds[x].values])
    elif xs.size > 1 and xs.min() > 0 and xs.max() / xs.min() > 30:
        ax.set_xscale("log")  # an axis over decades (frequency, ODR) reads on a log scale
    ax.set_xlabel(axis_label(x))


def plot_sweep_grid(ds: xr.Dataset, x: str | None = None, combos: Sequence[dict[str, Any]] | None = None,
                    part: str = "") -> Figure:
    """VRE (mg) against grid axis ``x`` (default :func:`x_axis`), one line per combination of
    the other grid axes (``combos``, default all of them), ±u error bars when the Dataset has
    ``u_vre_g``. Failed points are NaN and leave a gap. A text axis is drawn as categories.
    ``part`` is added to the title (which combinations of how many)."""
    if "vre_g" not in ds.data_vars:
        raise ValueError("report: the sweep result has no vre_g variable to plot")
    x = x or x_axis(ds)
    if x is None or UNIT in ds["vre_g"].dims:
        raise ValueError("report: the VRE-against-grid plot needs a grid without a Monte Carlo unit axis")
    xs, numeric = _x_values(ds, x)
    combos = line_combinations(ds, x) if combos is None else list(combos)
    has_u = "u_vre_g" in ds.data_vars
    fig, axes = _new_figure()
    ax = axes[0, 0]
    markers = "osD^vP*X"
    for i, sel in enumerate(combos):
        y_mg = ds["vre_g"].sel(sel).transpose(x).values * 1e3
        yerr = ds["u_vre_g"].sel(sel).transpose(x).values * 1e3 if has_u else None
        ax.errorbar(
            xs,
            y_mg,
            yerr=yerr,
            fmt="-" + markers[i % len(markers)],
            color=COLORS[i % len(COLORS)],
            ms=4.5,
            lw=1.4,
            capsize=3 if has_u else 0,
            label=(describe_point(sel) if sel else "VRE") + ("" if np.isfinite(y_mg).any() else " (every point failed)"),
        )
    ax.axhline(0, color="0.5", lw=0.8)
    _x_axis_style(ax, ds, x, xs, numeric)
    ax.set_ylabel("VRE (mg)" + (" ± u" if has_u else ""))
    ax.set_title(f"{_title(ds)}: VRE against {x}{part}", fontsize=10)
    if combos and combos[0]:
        ax.legend(fontsize=7.5, loc="best", framealpha=0.9)
    return fig


def plot_lot_spread(ds: xr.Dataset, x: str | None = None, combos: Sequence[dict[str, Any]] | None = None,
                    part: str = "") -> Figure:
    """A Monte Carlo lot's VRE (mg) against grid axis ``x`` (default :func:`x_axis`): for each
    combination of the other grid axes (``combos``, default all) the mean over the units (line
    and markers) and the 5th to 95th percentile band (shaded), both from :func:`lot_statistics`
    of the units that finished ok. A grid point where none did is a gap."""
    if "vre_g" not in ds.data_vars or UNIT not in ds["vre_g"].dims:
        raise ValueError("report: the lot's spread needs vre_g along a Monte Carlo unit axis")
    x = x or x_axis(ds)
    if x is None:
        raise ValueError("report: the lot's spread against a grid axis needs a grid")
    xs, numeric = _x_values(ds, x)
    combos = line_combinations(ds, x) if combos is None else list(combos)
    fig, axes = _new_figure()
    ax = axes[0, 0]
    markers = "osD^vP*X"
    for i, sel in enumerate(combos):
        stats = [lot_statistics(ds["vre_g"].sel({**sel, x: v}).values) for v in ds[x].values]
        mean, p5, p95 = (np.array([st[k] for st in stats]) * 1e3 for k in ("mean", "p5", "p95"))
        color = COLORS[i % len(COLORS)]
        name = describe_point(sel) if sel else "lot"
        ax.fill_between(xs, p5, p95, color=color, alpha=0.18, lw=0, label=f"{name}: 5th–95th percentile")
        ax.plot(xs, mean, "-" + markers[i % len(markers)], color=color, ms=4.5, lw=1.4, label=f"{name}: mean")
    ax.axhline(0, color="0.5", lw=0.8)
    _x_axis_style(ax, ds, x, xs, numeric)
    ax.set_ylabel("VRE (mg)")
    ax.set_title(f"{_title(ds)}: VRE of the {ds.sizes[UNIT]} units against {x}{part}", fontsize=10)
    ax.legend(fontsize=7.5, loc="best", framealpha=0.9)
    return fig


def lot_statistics(vre_g: np.ndarray) -> dict[str, float]:
    """Mean, sample standard deviation (ddof = 1), 5th and 95th percentiles (numpy's default
    linear interpolation) of the finite values, in g; NaN where there are too few."""
    v = np.asarray(vre_g, dtype=float)
    v = v[np.isfinite(v)]
    n = int(v.size)
    return {
        "n": n,
        "mean": float(v.mean()) if n else math.nan,
        "sd": float(v.std(ddof=1)) if n > 1 else math.nan,
        "p5": float(np.percentile(v, 5)) if n else math.nan,
        "p95": float(np.percentile(v, 95)) if n else math.nan,
    }


def plot_lot_histograms(ds: xr.Dataset, points: Sequence[dict[str, Any]] | None = None, part: str = "") -> Figure:
    """The VRE of the units of a Monte Carlo lot, one histogram per grid point (``points``,
    default the first ``MAX_HIST_PANELS``), with the mean (solid), mean ± one standard deviation
    (dashed) and the 5th / 95th percentiles (dotted) marked and given in the legend in mg."""
    if "vre_g" not in ds.data_vars or UNIT not in ds["vre_g"].dims:
        raise ValueError("report: the histogram needs vre_g along a Monte Carlo unit axis")
    points = grid_points(ds)[:MAX_HIST_PANELS] if points is None else list(points)
    ncols = 1 if len(points) == 1 else 2
    nrows = math.ceil(len(points) / ncols)
    fig, axes = _new_figure(nrows, ncols, height_in=4.6 if nrows == 1 else 3.0 * nrows + 0.6)
    for ax, sel in zip(axes.flat, points):
        v_mg = ds["vre_g"].sel(sel).values.astype(float) * 1e3
        s = lot_statistics(v_mg)
        finite = v_mg[np.isfinite(v_mg)]
        if finite.size:
            bins = int(min(30, max(5, math.ceil(math.sqrt(finite.size)))))
            ax.hist(finite, bins=bins, color=COLORS[0], alpha=0.55, edgecolor="white")
            ax.axvline(s["mean"], color="k", lw=1.6, label=f"mean {s['mean']:+.4g} mg")
            if math.isfinite(s["sd"]):
                for sign in (-1, 1):
                    ax.axvline(s["mean"] + sign * s["sd"], color=COLORS[1], ls="--", lw=1.3, label=f"±1 sd ({s['sd']:.3g} mg)" if sign > 0 else None)
            ax.axvline(s["p5"], color=COLORS[2], ls=":", lw=1.8, label=f"5th pct {s['p5']:+.4g} mg")
            ax.axvline(s["p95"], color=COLORS[3], ls=":", lw=1.8, label=f"95th pct {s['p95']:+.4g} mg")
            ax.legend(fontsize=7, loc="best", framealpha=0.9)
        else:
            ax.text(0.5, 0.5, "no unit finished ok", ha="center", va="center", transform=ax.transAxes)
        ax.set_title(f"{describe_point(sel)} ({s['n']} of {v_mg.size} units)", fontsize=9)
        ax.set_xlabel("VRE (mg)")
        ax.set_ylabel("units")
        ax.xaxis.set_major_locator(MaxNLocator(5))  # wide "-147.5" labels collide beyond five
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # a count of units
    for ax in list(axes.flat)[len(points):]:
        ax.set_visible(False)
    fig.suptitle(f"{_title(ds)}: VRE across the lot{part}", fontsize=10)
    return fig


def plot_lot_scatter(ds: xr.Dataset, points: Sequence[dict[str, Any]] | None = None, part: str = "") -> Figure:
    """VRE (mg) of each unit against each drawn parameter: one column per parameter, one row per
    grid point (``points``, default the first ``MAX_SCATTER_ROWS``). Rows do not share a VRE
    scale: the spread within a grid point is what shows which parameter drives it, and the
    level's own VRE would flatten it."""
    params = drawn_parameters(ds)
    if "vre_g" not in ds.data_vars or not params:
        raise ValueError("report: the scatter plot needs vre_g and drawn Monte Carlo parameters")
    points = grid_points(ds)[:MAX_SCATTER_ROWS] if points is None else list(points)
    nrows, ncols = len(points), len(params)
    fig = Figure(figsize=(7.6, 0.6 + 2.9 * nrows if nrows > 1 else 4.2), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex="col", sharey="row")
    for i, sel in enumerate(points):
        v_mg = ds["vre_g"].sel(sel).values * 1e3
        for j, p in enumerate(params):
            ax = axes[i, j]
            ax.grid(True, alpha=0.45)
            ax.scatter(ds[p].values.astype(float), v_mg, s=16, color=COLORS[i % len(COLORS)], alpha=0.85)
            if sel:
                ax.set_title(describe_point(sel), fontsize=9)
            if i == nrows - 1:
                ax.set_xlabel(axis_label(p))
            if j == 0:
                ax.set_ylabel("VRE (mg)")
    fig.suptitle(f"{_title(ds)}: VRE of each unit against the drawn parameters{part}", fontsize=10)
    return fig


# --------------------------------------------------------------------------- the section
def _spec(ds: xr.Dataset) -> dict[str, Any]:
    try:
        doc = json_loads(str(ds.attrs.get("spec_json", "{}")), "attribute 'spec_json'")
    except ValueError:  # not JSON, or nested beyond the budget: no spec shown
        return {}
    return doc if isinstance(doc, dict) else {}


def _status_counts(ds: xr.Dataset) -> dict[str, int]:
    status = np.asarray(ds["status"].values).astype(str)
    return {k: int((status == k).sum()) for k in ("ok", "failed", "missing")}


def failed_points(ds: xr.Dataset) -> list[tuple[dict[str, Any], str]]:
    """Every failed (or missing) point: its coordinates (unit first) and its error."""
    st = ds["status"]
    status = np.asarray(st.values).astype(str)
    error = np.asarray(ds["error"].values).astype(str)
    out = []
    for idx in zip(*np.nonzero(status != "ok")):
        sel = {str(d): ds[d].values[i].item() for d, i in zip(st.dims, idx)}
        out.append((sel, str(error[idx] or status[idx])))
    return out


def sweep_figures(ds: xr.Dataset) -> tuple[list[ReportFigure], list[str]]:
    """The figures of a sweep Dataset, captioned; and notes on what could not be drawn. Every
    grid point and every combination is shown, over as many figures as it takes."""
    figs: list[ReportFigure] = []
    notes: list[str] = []
    if "vre_g" not in ds.data_vars:
        return figs, ["No figures: the result has no vre_g variable (output.variables left it out)."]
    n_bad = _status_counts(ds)["failed"] + _status_counts(ds)["missing"]
    gap = f" {n_bad} failed points are gaps." if n_bad else ""
    x = x_axis(ds)
    combos = line_combinations(ds, x) if x is not None else []
    if UNIT in ds.dims:
        if x is not None:
            for first, piece in chunks(combos, MAX_LINES):
                part = _part(first, len(piece), len(combos), "combinations")
                figs.append(ReportFigure.from_figure(
                    plot_lot_spread(ds, x, piece, part),
                    f"VRE of the lot's {ds.sizes[UNIT]} units against {x}: their mean (line) and the band from the 5th "
                    f"to the 95th percentile (shaded), one colour per combination of the other grid axes.{part}"))
        points = grid_points(ds)
        for first, piece in chunks(points, MAX_HIST_PANELS):
            part = _part(first, len(piece), len(points), "grid points")
            figs.append(ReportFigure.from_figure(
                plot_lot_histograms(ds, piece, part),
                f"VRE across the {ds.sizes[UNIT]} units of the lot at each grid point: mean (solid), "
                f"±1 standard deviation (dashed), 5th and 95th percentiles (dotted).{part}"))
        if drawn_parameters(ds):
            for first, piece in chunks(points, MAX_SCATTER_ROWS):
                part = _part(first, len(piece), len(points), "grid points")
                figs.append(ReportFigure.from_figure(
                    plot_lot_scatter(ds, piece, part),
                    "VRE of each unit against each parameter drawn for the lot: a trend shows which "
                    f"parameter drives the spread.{part}"))
    elif x is not None:
        err = " Error bars: ±1 standard uncertainty." if "u_vre_g" in ds.data_vars else ""
        for first, piece in chunks(combos, MAX_LINES):
            part = _part(first, len(piece), len(combos), "combinations")
            figs.append(ReportFigure.from_figure(
                plot_sweep_grid(ds, x, piece, part),
                f"VRE against {x}, one line per combination of the other grid axes.{err}{gap}{part}"))
    return figs, notes


def sweep_tables(ds: xr.Dataset) -> list[ReportTable]:
    """The failed points with their errors, and for a lot the VRE statistics per grid point."""
    tables: list[ReportTable] = []
    if UNIT in ds.dims and "vre_g" in ds.data_vars:
        rows = []
        for sel in grid_points(ds):
            s = lot_statistics(ds["vre_g"].sel(sel).values)
            rows.append([describe_point(sel), str(s["n"])] + [format_mg(s[k], signed=k != "sd") for k in ("mean", "sd", "p5", "p95")])
        tables.append(ReportTable("VRE across the lot", ("grid point", "units ok", "mean (mg)", "sd (mg)", "5th pct (mg)", "95th pct (mg)"), rows, numeric=(1, 2, 3, 4, 5)))
    bad = failed_points(ds)
    if bad:
        rows = [[describe_point(sel), err] for sel, err in bad[:MAX_FAILED_ROWS]]
        title = "Failed points" + (f" (first {MAX_FAILED_ROWS} of {len(bad)})" if len(bad) > MAX_FAILED_ROWS else "")
        tables.append(ReportTable(title, ("point", "error"), rows))
    return tables


def _describe_dist(d: dict[str, Any]) -> str:
    args = ", ".join(f"{k} = {_fmt_value(v)}" for k, v in d.items() if k != "dist")
    return f"{d.get('dist', '?')} ({args})"


def _facts(ds: xr.Dataset) -> list[tuple[str, str]]:
    spec = _spec(ds)
    counts = _status_counts(ds)
    n = sum(counts.values())
    facts = [
        ("kind", str(ds.attrs.get("kind", spec.get("kind", "?")))),
        ("seed", str(ds.attrs.get("seed", spec.get("seed", "?")))),
        ("points", f"{n}: {counts['ok']} ok, {counts['failed']} failed" + (f", {counts['missing']} missing" if counts["missing"] else "")),
    ]
    for a in grid_axes(ds):
        facts.append((f"grid axis {a} ({ds.sizes[a]})", ", ".join(_fmt_value(v) for v in ds[a].values.tolist())))
    if UNIT in ds.dims:
        dists = (spec.get("montecarlo") or {}) if isinstance(spec.get("montecarlo"), dict) else {}
        facts.append(("Monte Carlo units", str(ds.sizes[UNIT])))
        for p in drawn_parameters(ds):
            d = dists.get(p)
            facts.append((f"drawn {p}", _describe_dist(d) if isinstance(d, dict) else str(ds[p].attrs.get("long_name", ""))))
    fixed = spec.get("fixed")
    if isinstance(fixed, dict) and fixed:
        facts.append(("fixed", ", ".join(f"{k} = {_fmt_value(v)}" for k, v in fixed.items())))
    variables = [str(v) for v in ds.data_vars if v not in ("status", "error")]
    facts.append(("variables", ", ".join(variables)))
    return facts


def summary_sentence(ds: xr.Dataset) -> str:
    """One sentence of what the sweep shows."""
    counts = _status_counts(ds)
    n = sum(counts.values())
    kind = ds.attrs.get("kind", "?")
    axes = grid_axes(ds)
    what = (f"Monte Carlo lot of {ds.sizes[UNIT]} units" if UNIT in ds.dims else "Parameter sweep") + f" ({kind} points)"
    if axes:
        what += " over " + " × ".join(f"{a} ({ds.sizes[a]})" for a in axes)
    s = f"{what}: {counts['ok']} of {n} points ok"
    if "vre_g" in ds.data_vars:
        v = ds["vre_g"].values
        v = v[np.isfinite(v)]
        if v.size:
            s += f"; VRE from {v.min() * 1e3:+.4g} to {v.max() * 1e3:+.4g} mg"
    return s + "."


def sweep_section(ds: xr.Dataset, title: str | None = None, provenance: dict[str, Any] | None = None) -> ReportSection:
    """The report section of a sweep Dataset: summary, figures, tables, failed points."""
    figs, notes = sweep_figures(ds)
    counts = _status_counts(ds)
    warnings = []
    if counts["failed"]:
        warnings.append(f"{counts['failed']} of {sum(counts.values())} points failed: see the table of failed points.")
    if counts["missing"]:
        warnings.append(f"{counts['missing']} points are missing (the sweep did not finish them).")
    prov = {"sweep_fingerprint": ds.attrs.get("fingerprint"), "written_by": ds.attrs.get("source")}
    prov.update(provenance or {})
    return ReportSection(
        title=title or _title(ds),
        what=summary_sentence(ds),
        figures=figs,
        facts=_facts(ds),
        notes=notes,
        extra_warnings=warnings,
        tables=sweep_tables(ds),
        provenance={k: v for k, v in prov.items() if v is not None},
    )


def report_sweep_dir(folder: str | Path, argv: Sequence[str] | None = None, title: str | None = None,
                     metadata: ReportMetadata | None = None) -> Path:
    """Write ``folder/report.html`` from the sweep result ``folder/result.nc``."""
    folder = Path(folder)
    nc = folder / F.SWEEP_RESULT
    ds = load_sweep(nc)
    prov = {"result_file": nc.name, "result_sha256": sha256_file(nc)}
    sec = sweep_section(ds, title, prov)
    return write_report(
        folder / F.REPORT,
        [sec],
        title=report_title(title, metadata, f"Sweep report: {_title(ds)}"),
        intro=f"Report of {folder.name or folder.resolve().name}/{F.SWEEP_RESULT}.",
        provenance=default_provenance(argv),
        metadata=metadata,
    )
