"""Figures for VRE results: each function takes data and returns a matplotlib ``Figure``.

The figures follow the article's (Figures 1-4) and the units engineers read: VRE in mg (or µg
for VRC plots), vibration in g rms, frequency in Hz, PSD in g²/Hz on log-log axes. Every figure
has a title, axis labels with units, a grid and a legend that carries the conditions.

No pyplot: figures are built as ``matplotlib.figure.Figure`` with the Agg canvas, so nothing
depends on a display or on pyplot's global state (the report renders in worker processes and
tests). Long records are never loaded whole: :func:`record_envelope` reads an HDF5 record in
blocks and keeps a min/max/mean envelope of fixed size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.container import Container
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as V
from vrelab._format import field_label, format_value, format_value_u
from vrelab._load import json_loads
from vrelab.models.clipping import KINDS
from vrelab.models.clipping import Kind as ClipKind
from vrelab.record import Schedule
from vrelab.report.csvdata import fractional_octave_average as fractional_octave_average
from vrelab.report.csvdata import pick_column, read_envelope_csv
from vrelab.report.csvdata import read_psd_csv as read_psd_csv
from vrelab.results import (
    FitResult,
    LevelResult,
    NoiseResult,
    VreResult,
    group_by_frequency,
    same_frequency,
)
from vrelab.units import UG_PER_G

FloatArray = NDArray[np.float64]

# Colour-blind-safe cycle (Okabe-Ito): series stay distinguishable in print and for readers with
# deuteranopia, which the default tab10 red/green pair is not.
COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")
_SIZE_IN = (7.6, 4.6)
_DPI = 110


@dataclass(frozen=True)
class Curve:
    """A model curve to overlay: ``y`` is VRE in g (or VRC in µg/g² on the VRC-vs-f plot)."""

    label: str
    x: FloatArray
    y: FloatArray
    linestyle: str = "-"
    color: str | None = None


@dataclass(frozen=True)
class Series:
    """One result drawn on a shared plot, with its legend label."""

    label: str
    result: VreResult
    curves: tuple[Curve, ...] = ()


def new_figure(nrows: int = 1, height_in: float | None = None, sharex: bool = True) -> tuple[Figure, list[Axes]]:
    fig = Figure(figsize=(_SIZE_IN[0], height_in or _SIZE_IN[1]), dpi=_DPI, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, which="major", alpha=0.45)
        ax.grid(True, which="minor", alpha=0.15)
    return fig, list(axes)


def describe_conditions(result: VreResult, short: bool = False) -> str:
    """One line of the conditions a VRE figure depends on (physics §1.4), for titles and legends."""
    c = result.conditions
    parts: list[str] = []
    if c.sensor:
        parts.append(str(c.sensor).upper() if str(c.sensor).islower() and len(str(c.sensor)) < 12 else str(c.sensor))
    if c.range_g is not None:
        parts.append(f"±{c.range_g:g} g")
    if c.axis:
        parts.append(f"{str(c.axis).upper()} axis")
    if c.bandwidth_hz is not None:
        parts.append(f"BW {c.bandwidth_hz:g} Hz")
    elif c.odr_hz is not None:
        parts.append(f"ODR {c.odr_hz:g} Hz")
    if c.static_g is not None:
        parts.append(f"{c.static_g:+.3g} g field")  # a measured static field: 3 digits
    if c.profile and not short:
        prof = str(c.profile)
        parts.append(prof if len(prof) <= 40 else prof[:39] + "…")  # a title is one line
    reached = levels_reached(result)
    if reached and not short:
        parts.append(reached)
    return ", ".join(parts)


def levels_reached(result: VreResult) -> str | None:
    """The vibration levels a test reached, from its levels: ``"0.3–0.92 g rms"`` (None without any)."""
    rms = [lv.rms_g for lv in result.levels if math.isfinite(lv.rms_g) and lv.rms_g > 0]
    if not rms:
        return None
    lo, hi = format_value(min(rms), digits=3), format_value(max(rms), digits=3)
    return f"{lo} g rms" if lo == hi else f"{lo}–{hi} g rms"


# Fitted parameters the data may not reach (a rail above every level): shown "not determined",
# with the reason, when vrelab.gum.undetermined says so. A VRC, k2 or k3 is linear in the data:
# its u, however large, is its answer (consistent with zero).
_MAY_BE_UNREACHED = ("rail_g", "rail_low_g", "rail_high_g")


def fit_param_text(name: str, value: float | None, u: float | None, unit: str | None = None) -> str:
    """A fitted parameter as ``value ± u unit``, or "not determined (why)" for one the data
    cannot determine (:func:`vrelab.gum.undetermined`), never as a number."""
    from vrelab.gum import undetermined

    why = undetermined(value, u) if name in _MAY_BE_UNREACHED else None
    if why is not None:
        return f"not determined ({why}: the levels do not reach it)"
    return format_value_u(value, u, unit=unit or field_label(name)[1] or None)


def _fit_label(fit: FitResult) -> str:
    """Legend text of a fit: the fitted parameter with its standard error."""
    bits = []
    for name, est in fit.params.items():
        if name in ("rail_g", "rail_low_g", "rail_high_g"):
            which = {"rail_g": "rail ±", "rail_low_g": "lower rail ", "rail_high_g": "upper rail "}[name]
            bits.append(f"{which}{fit_param_text(name, est.value, est.u, 'g')}")
        else:
            label, unit = field_label(name)
            bits.append(f"{'VRC' if name == 'vrc_ug_per_g2' else label} {format_value_u(est.value, est.u, unit=unit or est.unit or None)}")
    return f"fit {fit.model}: " + ", ".join(bits)


def _significant(fit: FitResult) -> bool:
    """A fit worth drawing: a VRC at least twice its standard error (a VRC fitted to levels that
    are all noise draws a line through nothing), a rail determined (:func:`fit_param_text`)."""
    from vrelab.gum import undetermined

    if any(undetermined(e.value, e.u) for n, e in fit.params.items() if n in _MAY_BE_UNREACHED):
        return False
    est = fit.params.get("vrc_ug_per_g2")
    return est is None or (math.isfinite(est.value) and math.isfinite(est.u) and abs(est.value) >= 2 * est.u)


def _rail_fit(result: VreResult) -> FitResult | None:
    return next((f for f in result.fits if "rail_g" in f.params or "rail_high_g" in f.params), None)


# --------------------------------------------------------------------------- model curves
def clip_curves(
    static_g: float,
    rail_g: float,
    rms_g: ArrayLike,
    kinds: Sequence[ClipKind] = KINDS,
    rail_low_g: float | None = None,
    label_suffix: str = "",
) -> list[Curve]:
    """Gaussian clipping-model curves (censored and/or truncated mean shift) for given rails.

    The physics lives in :mod:`vrelab.models.clipping`; this only samples it for a plot.
    """
    from vrelab.models import clipping

    rms = V.positive("rms_g", rms_g)
    low = -rail_g if rail_low_g is None else rail_low_g
    fn = {"censored": clipping.censored_mean_shift, "truncated": clipping.truncated_mean_shift}
    styles = {"censored": "-", "truncated": "--"}
    return [
        Curve(
            f"{kind} model, rails {low:+.3g}/{rail_g:+.3g} g{label_suffix}",
            rms,
            np.asarray(fn[kind](static_g, rms, low, rail_g), dtype=np.float64),
            styles[kind],
        )
        for kind in kinds
    ]


def vrc_curve(vrc_ug_per_g2: float, rms_g: ArrayLike, label: str | None = None) -> Curve:
    """The small-signal nonlinearity line ``VRE = VRC·rms²`` (physics §1.2), VRE in g.

    A measured VRC is the effective k2 at the test's static field (it already holds 3·k3·g0),
    so the line is :func:`vrelab.models.nonlinearity.vre_poly` with k2 = VRC and no other term.
    """
    from vrelab.models.nonlinearity import ug_per_g2_to_per_g, vre_poly

    rms = V.non_negative("rms_g", rms_g)
    vre = np.asarray(vre_poly(rms, ug_per_g2_to_per_g(vrc_ug_per_g2)), dtype=np.float64)
    return Curve(label or f"VRC·rms², VRC = {vrc_ug_per_g2:.3g} µg/g²", rms, vre, ":")


def model_curves(
    result: VreResult,
    rms_max_g: float | None = None,
    kinds: Sequence[ClipKind] = KINDS,
    n: int = 200,
) -> list[Curve]:
    """The curves a result's own fits imply: clipping models at the fitted rail, VRC·rms².

    Needs ``conditions.static_g`` for the clipping models (a rail means nothing without the
    static field it was fitted in); without it, only the VRC line is drawn.
    """
    rms_vals = [lv.rms_g for lv in result.levels if np.isfinite(lv.rms_g)]
    top = rms_max_g or (1.08 * max(rms_vals) if rms_vals else 1.0)
    grid = np.linspace(top / n, top, n)
    curves: list[Curve] = []
    rail = _rail_fit(result)
    if rail is not None and result.conditions.static_g is not None and _significant(rail):
        p = rail.params  # a rail the data do not determine draws no curve (its legend says why)
        high = p["rail_g"].value if "rail_g" in p else p["rail_high_g"].value
        low = p["rail_low_g"].value if "rail_low_g" in p else None
        if math.isfinite(high) and (low is None or math.isfinite(low)):  # a failed fit draws nothing
            curves += clip_curves(result.conditions.static_g, high, grid, kinds, low, label_suffix=" (fitted)")
    vrc = next((f for f in result.fits if f.freq_hz is None and "vrc_ug_per_g2" in f.params), None)
    if vrc is not None and _significant(vrc):
        curves.append(vrc_curve(vrc.params["vrc_ug_per_g2"].value, grid))
    return curves


# --------------------------------------------------------------------------- VRE vs rms
def _draw_levels(ax: Axes, result: VreResult, label: str, color: str, connect: bool = False) -> None:
    """VRE (mg) ± u against level (g rms); over-range levels hollow."""
    lv = [x for x in result.levels if np.isfinite(x.rms_g) and np.isfinite(x.vre.value)]
    if not lv:
        return
    rms = np.array([x.rms_g for x in lv])
    vre = np.array([x.vre.value for x in lv]) * 1e3
    u = np.array([x.vre.u if np.isfinite(x.vre.u) else 0.0 for x in lv]) * 1e3
    xs = rms
    # Hollow marks the over-range protection, the mechanism the clipping models leave out;
    # saturation itself is what they describe (counted in the report's table).
    flagged = np.array([any("over" in f for f in x.flags) for x in lv])
    if connect:
        order = np.argsort(xs)
        ax.plot(xs[order], vre[order], "-", color=color, lw=0.9, alpha=0.6, zorder=2)
    ax.errorbar(xs[~flagged], vre[~flagged], yerr=u[~flagged], fmt="o", ms=5, color=color, capsize=3, label=label, zorder=3)
    if flagged.any():
        ax.errorbar(
            xs[flagged],
            vre[flagged],
            yerr=u[flagged],
            fmt="o",
            ms=6,
            mfc="white",
            color=color,
            capsize=3,
            label=f"{label}: over-range protection tripped",
            zorder=3,
        )


def plot_vre_vs_rms(
    series: VreResult | Sequence[Series],
    curves: Sequence[Curve] | None = None,
    *,
    title: str | None = None,
    limit: tuple[float, float] | None = None,
    show_fits: bool = True,
) -> Figure:
    """VRE (mg) against vibration level (g rms), error bars ±u, model curves overlaid.

    Parameters
    ----------
    series : VreResult or sequence of Series
        One result, or several labelled results on shared axes (e.g. X/Y vs Z axis).
    curves : sequence of Curve, optional
        Model curves; by default those implied by each result's fits (:func:`model_curves`).
    limit : (rms_g, vre_g), optional
        A specification point to mark, e.g. the datasheet's (2.5 g rms, -0.4 g).
    show_fits : bool
        Put each fit with its standard errors in the legend.
    """
    if isinstance(series, VreResult):
        series = [Series(describe_conditions(series, short=True) or "measured", series)]
    fig, (ax,) = new_figure()
    for i, s in enumerate(series):
        color = COLORS[i % len(COLORS)]
        _draw_levels(ax, s.result, s.label, color, connect=len(series) > 1 and not s.curves)
        own = list(s.curves) if s.curves else (model_curves(s.result) if curves is None else [])
        for k, c in enumerate(own):
            # One series: each model its own colour; several: a model takes its series' colour.
            cc = c.color or (COLORS[(k + 1) % len(COLORS)] if len(series) == 1 else color)
            ax.plot(c.x, c.y * 1e3, c.linestyle, color=cc, lw=1.4, label=c.label, alpha=0.9)
        if show_fits:
            for f in s.result.fits:
                if f.freq_hz is None and f.params and _significant(f):
                    ax.plot([], [], " ", label=_fit_label(f))
                if f.departure_rms_g is not None:
                    ax.axvline(f.departure_rms_g, color=color, ls="-.", lw=1, alpha=0.7)
                    ax.plot([], [], "-.", color=color, lw=1, label=f"data leave the {f.model} model above {f.departure_rms_g:.3g} g rms")
    for j, c in enumerate(curves or ()):
        ax.plot(c.x, c.y * 1e3, c.linestyle, color=c.color or COLORS[(j + len(series)) % len(COLORS)], lw=1.4, label=c.label)
    if limit is not None:
        ax.axhline(limit[1] * 1e3, color="0.3", lw=1, ls="--")
        ax.plot([limit[0]], [limit[1] * 1e3], "k*", ms=11, label=f"limit {limit[1] * 1e3:+.0f} mg at {limit[0]:g} g rms")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("vibration level (g rms)")
    ax.set_ylabel("VRE (mg)")
    ax.set_xlim(left=0)
    first = series[0].result if series else None
    ax.set_title(title or ("VRE vs vibration level\n" + (describe_conditions(first) if first else "")).strip(), fontsize=10)
    ax.legend(fontsize=7.5, loc="best", framealpha=0.9)
    return fig


# Paired with COLORS (7 colours, 9 markers: coprime), every one of up to 63 series gets its own
# colour-and-marker pair, so neighbours stay apart in print and in grey.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "h", "*")


def frequency_groups(result: VreResult) -> list[tuple[float | None, list[LevelResult], FitResult | None]]:
    """The levels of a result grouped by drive frequency (:func:`vrelab.results.same_frequency`:
    each level's measured frequency scatters a little about the nominal one), low to high, each
    with its VRC fit; one group (frequency None) for a random test."""
    lv = [x for x in result.levels if np.isfinite(x.rms_g) and np.isfinite(x.vre.value)]
    fits = [f for f in result.fits if "vrc_ug_per_g2" in f.params]
    random = [x for x in lv if x.freq_hz is None]
    groups: list[tuple[float | None, list[LevelResult]]] = [(None, random)] if random else []
    tagged = [(x.freq_hz, x) for x in lv if x.freq_hz is not None]  # a sine level and its frequency
    groups += [(g[0][0], [x for _, x in g]) for g in group_by_frequency(tagged, lambda t: float(t[0]))]
    out = []
    for fq, pts in groups:
        fit = next((f for f in fits if fq is not None and f.freq_hz is not None and same_frequency(f.freq_hz, fq)),
                   next((f for f in fits if f.freq_hz is None), None) if fq is None else None)
        out.append((fit.freq_hz if fit is not None and fit.freq_hz is not None else fq, pts, fit))
    return out


def plot_vre_vs_rms2(result: VreResult, *, title: str | None = None) -> Figure:
    """VRE (mg, as in every table and figure of VRE) against rms² (g²) with the fitted VRC line
    through the origin (IEEE 1293 style).

    One colour-and-marker pair per frequency; each legend entry shows a frequency's marker with
    its fitted line and VRC ± u. Points that entered the fit are filled; others are hollow.
    """
    from matplotlib.legend_handler import HandlerTuple

    fig, (ax,) = new_figure()
    groups = frequency_groups(result)
    handles: list[Artist | Container | tuple[Artist | Container, ...]] = []
    labels: list[str] = []
    for i, (fq, pts, fit) in enumerate(groups):
        color, marker = COLORS[i % len(COLORS)], MARKERS[i % len(MARKERS)]
        used = set(np.round(fit.levels_used, 12)) if fit and fit.levels_used else None
        r2 = np.array([x.rms_g**2 for x in pts])
        y = np.array([x.vre.value for x in pts]) * 1e3  # mg
        u = np.array([x.vre.u if np.isfinite(x.vre.u) else 0.0 for x in pts]) * 1e3
        mask = np.array([used is None or round(x.rms_g, 12) in used for x in pts], dtype=bool)
        name = f"{fq:g} Hz" if fq is not None else "measured"
        pts_h = ax.errorbar(r2[mask], y[mask], yerr=u[mask], fmt=marker, color=color, capsize=3, label="_nolegend_")
        if fit is not None and len(r2):
            est = fit.params["vrc_ug_per_g2"]
            xx = np.linspace(0, 1.05 * r2.max(), 50)
            text = f"{name}: VRC {format_value_u(est.value, est.u)} µg/g²"
            (line,) = ax.plot(xx, est.value * xx * 1e3 / UG_PER_G, "-", color=color, lw=1.3, label=text)
            handles.append((pts_h, line) if mask.any() else line)
            labels.append(text)
        elif mask.any():
            handles.append(pts_h)
            labels.append(name)
        if (~mask).any():
            hollow = ax.errorbar(r2[~mask], y[~mask], yerr=u[~mask], fmt=marker, mfc="white", color=color, capsize=3,
                                 label=f"{name}: not in fit")
            handles.append(hollow)
            labels.append(f"{name}: not in fit")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("vibration level squared, rms² (g²)")
    ax.set_ylabel("VRE (mg)")
    ax.set_xlim(left=0)
    ax.set_title(title or f"VRE vs rms² (slope = VRC)\n{describe_conditions(result, short=True)}", fontsize=10)
    # matplotlib's stub types a handle as Artist | tuple[Artist, ...]; at run time a tuple may
    # hold an errorbar container too (HandlerTuple draws it with its own handler)
    ax.legend(handles, labels, handler_map={tuple: HandlerTuple(ndivide=1)}, fontsize=7.5, loc="best",  # type: ignore[call-overload]
              ncol=2 if len(labels) > 6 else 1)
    return fig


def plot_vrc_vs_freq(
    result: VreResult,
    *,
    fn_hz: float | None = None,
    model: Curve | None = None,
    title: str | None = None,
) -> Figure:
    """VRC (µg/g²) against sine frequency (Hz, log axis), ±u bars, the resonance fn marked.

    ``model`` is an optional VRC(f) curve, e.g. ``VRC·|H(f)|²`` from
    :func:`vrelab.models.dynamics.vrc_at_frequency` (its ``y`` in µg/g²).
    """
    fits = sorted((f for f in result.fits if f.freq_hz is not None and "vrc_ug_per_g2" in f.params), key=lambda f: f.freq_hz or 0.0)
    if not fits:
        raise ValueError("result has no per-frequency VRC fits (needs a sine sweep with fits at freq_hz)")
    fig, (ax,) = new_figure()
    f_hz = np.array([f.freq_hz for f in fits], dtype=float)
    v = np.array([f.params["vrc_ug_per_g2"].value for f in fits])
    u = np.array([f.params["vrc_ug_per_g2"].u for f in fits])
    ax.errorbar(f_hz, v, yerr=np.nan_to_num(u), fmt="o-", color=COLORS[0], capsize=3, label="measured VRC ± u")
    if model is not None:
        ax.plot(model.x, model.y, model.linestyle, color=model.color or COLORS[1], lw=1.3, label=model.label)
    if fn_hz is not None:
        ax.axvline(fn_hz, color=COLORS[2], ls="--", lw=1.2, label=f"resonance fn = {fn_hz:g} Hz")
    ax.set_xscale("log")
    if np.all(v > 0) and v.max() / v.min() > 20:
        ax.set_yscale("log")  # resonance peaks span decades: a linear axis flattens the rest
    else:
        ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("sine frequency (Hz)")
    ax.set_ylabel("VRC (µg/g²)")
    ax.set_title(title or f"VRC vs frequency\n{describe_conditions(result, short=True)}", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    return fig


# --------------------------------------------------------------------------- time series
@dataclass(frozen=True)
class Envelope:
    """A record reduced to ``n_bins`` bins per channel: min, max and mean of each bin.

    With ``bin_size == 1`` the three are the samples themselves.
    """

    t_s: FloatArray  # bin centre
    bin_size: int
    fs_hz: float
    channels: Mapping[str, tuple[FloatArray, FloatArray, FloatArray]]  # name -> (min, max, mean)
    schedule: Schedule | None = None
    meta: Mapping[str, object] = field(default_factory=dict)


def record_envelope(
    path: str | Path,
    channels: Sequence[str] = ("dut", "reference"),
    n_bins: int = 4000,
    block_samples: int = 1 << 20,
    stop_s: float | None = None,
) -> Envelope:
    """Min/max/mean envelope of an HDF5 record written by :func:`vrelab.record.write_record_hdf5`.

    Reads at most ``block_samples`` samples per channel at a time (a bin may span several
    reads), so memory stays ``O(block_samples + n_bins)`` whatever the record's length: a
    10⁹-sample record is never loaded whole. Channels absent from the file are skipped.
    """
    import h5py

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"record file not found: {path}")
    n_bins = int(V.positive_scalar("n_bins", n_bins))
    block = int(V.positive_scalar("block_samples", block_samples))
    with h5py.File(path, "r") as f:
        fs = float(f.attrs["fs_hz"])
        names = [c for c in channels if c in f and isinstance(f[c], h5py.Dataset) and f[c].ndim == 1]
        if not names:
            raise ValueError(f"record {path.name} has none of the channels {', '.join(channels)}")
        n = min(f[c].shape[0] for c in names)
        if stop_s is not None:
            n = min(n, int(round(stop_s * fs)))
        bin_size = max(1, math.ceil(n / n_bins))
        nb = n // bin_size  # a ragged last bin would bias its mean: drop it
        end = nb * bin_size
        acc = {c: (np.full(nb, np.inf), np.full(nb, -np.inf), np.zeros(nb)) for c in names}
        for i in range(0, end, block):
            j = min(i + block, end)
            # Offsets (within this read) where a bin starts, plus the read's first sample,
            # which may fall inside a bin begun in the previous read.
            first_edge = -(-i // bin_size) * bin_size
            cuts = np.unique(np.concatenate(([0], np.arange(first_edge, j, bin_size) - i)))
            bins = (i + cuts) // bin_size
            for c in names:
                x = np.asarray(f[c][i:j], dtype=np.float64)
                mn, mx, sm = acc[c]
                mn[bins] = np.minimum(mn[bins], np.minimum.reduceat(x, cuts))
                mx[bins] = np.maximum(mx[bins], np.maximum.reduceat(x, cuts))
                sm[bins] += np.add.reduceat(x, cuts)
        out = {c: (mn, mx, sm / bin_size) for c, (mn, mx, sm) in acc.items()}
        sched = Schedule.from_array(f["schedule"][()]) if "schedule" in f and len(f["schedule"]) else None
        try:
            meta = json_loads(f.attrs.get("meta", "{}"), "attribute 'meta'")
        except (TypeError, ValueError):
            meta = {}
    t = (np.arange(nb) + 0.5) * bin_size / fs
    return Envelope(t, bin_size, fs, out, sched, meta)


def envelope_from_arrays(
    fs_hz: float, data: Mapping[str, ArrayLike], schedule: Schedule | None = None, n_bins: int = 4000
) -> Envelope:
    """The same envelope from arrays held in memory (tests, short simulated records)."""
    fs = V.positive_scalar("fs_hz", fs_hz)
    arrs = {k: np.asarray(v, dtype=np.float64) for k, v in data.items()}
    n = min(len(a) for a in arrs.values())
    bin_size = max(1, math.ceil(n / n_bins))
    nb = n // bin_size
    out = {}
    for k, a in arrs.items():
        b = a[: nb * bin_size].reshape(nb, bin_size)
        out[k] = (b.min(axis=1), b.max(axis=1), b.mean(axis=1))
    return Envelope(np.asarray((np.arange(nb) + 0.5) * bin_size / fs, dtype=np.float64), bin_size, fs, out, schedule)


def _shade_segments(ax: Axes, schedule: Schedule | None, t_max: float, label_y: float | None = None) -> None:
    if schedule is None:
        return
    for s in schedule.segments:
        if s.start_s > t_max:
            break
        ax.axvspan(s.start_s, min(s.end_s, t_max), color="0.85" if s.is_baseline else "#cfe3f3", alpha=0.55, lw=0, zorder=0)
        if label_y is not None:
            text = "off" if s.is_baseline else f"{s.nominal_rms_g:g} g rms" + (f"\n{s.freq_hz:g} Hz" if s.freq_hz else "")
            ax.text(
                (s.start_s + min(s.end_s, t_max)) / 2, label_y, text, ha="center", va="top", fontsize=7.5, color="0.25", clip_on=True
            )


def plot_time_series(
    env: Envelope,
    *,
    rails_g: tuple[float, float] | None = None,
    title: str | None = None,
    mean_window_s: float | None = None,
    static_g: float | None = None,
) -> Figure:
    """The record against time (article Figure 1 style): DUT and reference, segments shaded.

    Top panel: the DUT output as a min/max band (or the samples when not decimated), the rails
    dashed, so clipping shows as a flat edge; behind it the reference, shifted by ``static_g``
    when given (a reference accelerometer sees the vibration, not gravity: shifted, it is what
    the DUT would read without rails, so what the rails cut off shows). Bottom panel: the DUT's
    moving mean in mg relative to the first vibration-off segment, the offset shift that is VRE.
    """
    fig, (ax, ax2) = new_figure(2, height_in=6.2)
    engine = fig.get_layout_engine()
    assert isinstance(engine, ConstrainedLayoutEngine)  # new_figure's layout
    engine.set(h_pad=0.02)
    t = env.t_s
    have_ref = "reference" in env.channels
    if have_ref:
        mn, mx, me = env.channels["reference"]
        off = static_g or 0.0
        name = f"input: {off:+g} g static + reference vibration" if static_g else "reference (shaker)"
        if env.bin_size == 1:
            ax.plot(t, me + off, color="0.6", lw=0.6, label=name)
        else:
            ax.fill_between(t, mn + off, mx + off, color="0.75", lw=0, label=f"{name}, min/max")
    if "dut" in env.channels:
        mn, mx, me = env.channels["dut"]
        if env.bin_size == 1:
            ax.plot(t, me, color=COLORS[0], lw=0.7, label="sensor output")
        else:
            ax.fill_between(t, mn, mx, color=COLORS[0], alpha=0.65, lw=0, label="sensor output, min/max")
        dut_mean = me
    else:
        dut_mean = None
    if rails_g is not None:
        for r in rails_g:
            ax.axhline(r, color=COLORS[1], ls="--", lw=1.1)
        ax.plot([], [], "--", color=COLORS[1], label=f"rails {rails_g[0]:+g} / {rails_g[1]:+g} g")
        if "dut" in env.channels:
            mn, mx, _ = env.channels["dut"]
            tol = 1e-3 * max(abs(rails_g[0]), abs(rails_g[1]))
            hit = (mx >= rails_g[1] - tol) | (mn <= rails_g[0] + tol)
            if hit.any():
                ax.plot(t[hit], np.where(mx[hit] >= rails_g[1] - tol, rails_g[1], rails_g[0]), "|", color=COLORS[1], ms=6, label="clipped")
    lo, hi = ax.get_ylim()
    _shade_segments(ax, env.schedule, float(t[-1]) if len(t) else 0.0, label_y=hi - 0.03 * (hi - lo))
    ax.set_ylabel("acceleration (g)")
    ax.legend(fontsize=7.5, loc="lower left", ncol=2, framealpha=0.9)
    ax.set_title(title or "Record: sensor output and reference", fontsize=10)

    if dut_mean is not None and len(t):
        # Offset relative to the first vibration-off stretch: the article's Figure 1 reads VRE as
        # the step of the mean, not its absolute value (which holds the static field and offset).
        base_mask = np.zeros(len(t), bool)
        if env.schedule is not None:
            for s in env.schedule.segments:
                if s.is_baseline:
                    base_mask |= (t >= s.start_s) & (t < s.end_s)
                    break
        if not base_mask.any():
            base_mask[: max(1, len(t) // 20)] = True
        base = float(np.mean(dut_mean[base_mask]))
        win = mean_window_s or max(env.bin_size / env.fs_hz, (t[-1] - t[0]) / 60 if len(t) > 1 else 1.0)
        k = max(1, int(round(win * env.fs_hz / env.bin_size)))
        kernel = np.ones(k) / k
        smooth = np.convolve(dut_mean - base, kernel, mode="same")
        edge = k // 2
        valid = slice(edge, len(t) - edge if edge else None)
        ax2.plot(t[valid], 1e3 * smooth[valid], color=COLORS[0], lw=1.2, label=f"sensor mean − baseline ({win:.3g} s moving mean)")
        if env.schedule is not None:
            for s in env.schedule.segments:
                m = (t >= s.start_s) & (t < s.end_s)
                if m.any() and not s.is_baseline:
                    level = 1e3 * float(np.mean(dut_mean[m]) - base)
                    ax2.hlines(level, s.start_s, s.end_s, color=COLORS[1], lw=2)
                    ax2.annotate(
                        f"{level:+.0f} mg",
                        ((s.start_s + s.end_s) / 2, level),
                        textcoords="offset points",
                        # Above a negative shift (room up to the zero line), below a null one
                        # (the zero line is near the top of the panel).
                        xytext=(0, 7) if level < -2.0 else (0, -16),
                        ha="center",
                        fontsize=8.5,
                        color=COLORS[1],
                        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},
                    )
            ax2.plot([], [], "-", color=COLORS[1], lw=2, label="segment mean (VRE, before baseline drift removal)")
        lo2, hi2 = ax2.get_ylim()
        _shade_segments(ax2, env.schedule, float(t[-1]), None)
        ax2.set_ylim(lo2, hi2)
        ax2.axhline(0, color="0.5", lw=0.8)
        ax2.legend(fontsize=7.5, loc="lower left", framealpha=0.9)
    ax2.set_ylabel("offset shift (mg)")
    ax2.set_xlabel("time (s)")
    return fig


@dataclass(frozen=True)
class TimeWindow:
    """A short stretch of a record, sample by sample: time [s], reference and DUT output [g]."""

    label: str
    t_s: FloatArray
    reference_g: FloatArray
    dut_g: FloatArray


def plot_time_windows(
    windows: Sequence[TimeWindow],
    *,
    static_g: float | None = None,
    rails_g: tuple[float, float] | None = None,
    title: str | None = None,
) -> Figure:
    """Milliseconds of a record, one panel per window (shared axes): the input (``static_g`` plus
    the reference's vibration: what the DUT would read without rails) and the sensor output as
    held at its output data rate (steps), the rails dashed.

    Where a VRE figure only implies a mechanism, this shows it: an output flat at a rail
    (clipping), an output dropped to 0 g for the hold time (over-range protection), an output the
    low-pass has smoothed below the rail (bandwidth).
    """
    if not windows:
        raise ValueError("plot_time_windows needs at least one window")
    fig, axes = new_figure(len(windows), height_in=1.2 + 2.6 * len(windows))
    off = static_g or 0.0
    for ax, w in zip(axes, windows):
        t_ms = 1e3 * np.asarray(w.t_s, dtype=np.float64)
        ax.plot(t_ms, np.asarray(w.reference_g) + off, color="0.55", lw=0.9,
                label=f"input: {off:+g} g static + reference vibration" if static_g else "reference")
        ax.plot(t_ms, np.asarray(w.dut_g), color=COLORS[0], lw=1.3, drawstyle="steps-post", label="sensor output")
        if rails_g is not None:
            for r in rails_g:
                ax.axhline(r, color=COLORS[1], ls="--", lw=1.1)
            ax.plot([], [], "--", color=COLORS[1], lw=1.1, label=f"rails {rails_g[0]:+g} / {rails_g[1]:+g} g")
        ax.axhline(0, color="0.5", lw=0.8)
        ax.set_ylabel("acceleration (g)")
        ax.set_title(w.label, fontsize=9)
        ax.legend(fontsize=7.5, loc="lower left", ncol=3, framealpha=0.9)
    axes[-1].set_xlabel("time (ms)")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_envelope_csv(path: str | Path, *, title: str | None = None) -> Figure:
    """Reference rms and DUT mean per analysis window against time, from ``envelope.csv``."""
    cols = read_envelope_csv(path)
    tk = pick_column(cols, "t_s", "time_s", "start_s", "time", "t")
    rk = pick_column(cols, "reference_rms_g", "ref_rms_g", "rms_g", "rms")
    mk = pick_column(cols, "dut_mean_g", "mean_g", "mean")
    if tk is None or mk is None or isinstance(cols[tk], list) or isinstance(cols[mk], list):
        raise ValueError(f"{Path(path).name}: need a time column and a DUT mean column, got {', '.join(cols)}")
    t = np.asarray(cols[tk])
    fig, (ax, ax2) = new_figure(2, height_in=5.4)
    if rk is not None and not isinstance(cols[rk], list):
        ax.plot(t, np.asarray(cols[rk]), color="0.35", lw=1, label="reference rms per window")
    ax.set_ylabel("vibration (g rms)")
    mean = np.asarray(cols[mk], dtype=float)
    finite = mean[np.isfinite(mean)]
    base = float(np.median(finite[: max(1, len(finite) // 20)])) if finite.size else 0.0
    ax2.plot(t, 1e3 * (mean - base), color=COLORS[0], lw=1, label="sensor mean per window − initial")
    lk = pick_column(cols, "segment", "label")
    if lk is not None and isinstance(cols[lk], list):
        labels = cols[lk]
        start = 0
        for i in range(1, len(labels) + 1):
            if i == len(labels) or labels[i] != labels[start]:
                lab = labels[start]
                if lab and lab.lower() not in ("", "transition", "settle", "none"):
                    is_off = lab.lower().startswith(("off", "base"))
                    for a in (ax, ax2):
                        a.axvspan(t[start], t[i - 1], color="0.85" if is_off else "#cfe3f3", alpha=0.55, lw=0, zorder=0)
                start = i
    ax2.axhline(0, color="0.5", lw=0.8)
    ax2.set_ylabel("offset shift (mg)")
    ax2.set_xlabel("time (s)")
    ax.legend(fontsize=8, loc="upper left")
    ax2.legend(fontsize=8, loc="lower left")
    ax.set_title(title or "Analysis windows: vibration level and sensor mean", fontsize=10)
    return fig


# --------------------------------------------------------------------------- PSD
def plot_psd(
    freq_hz: ArrayLike,
    psd_measured: ArrayLike,
    psd_profile: ArrayLike,
    *,
    tol_db: float = 3.0,
    band_hz: tuple[float, float] | None = None,
    title: str | None = None,
    label: str = "reference PSD",
) -> Figure:
    """Measured PSD against the profile with its ±``tol_db`` band, log-log, in g²/Hz.

    Points inside the band (when given) but outside the tolerance are marked.
    """
    # NaN is allowed here: a profile is undefined outside its band (psd.csv leaves it empty).
    f = np.asarray(freq_hz, dtype=np.float64)
    pm = np.asarray(psd_measured, dtype=np.float64)
    pp = np.asarray(psd_profile, dtype=np.float64)
    if not (f.shape == pm.shape == pp.shape):
        raise ValueError(f"freq_hz, psd_measured, psd_profile must have one shape, got {f.shape}, {pm.shape}, {pp.shape}")
    tol_db = V.positive_scalar("tol_db", tol_db)
    fig, (ax,) = new_figure()
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(f) & np.isfinite(pm) & (f > 0) & (pm > 0)
        prof = np.isfinite(f) & np.isfinite(pp) & (f > 0) & (pp > 0)
    ax.loglog(f[ok], pm[ok], color=COLORS[0], lw=1, label=label)
    lo, hi = 10 ** (-tol_db / 10), 10 ** (tol_db / 10)
    ax.loglog(f[prof], pp[prof], color="k", lw=1.3, label="profile")
    ax.fill_between(f[prof], pp[prof] * lo, pp[prof] * hi, color=COLORS[2], alpha=0.2, lw=0, label=f"±{tol_db:g} dB tolerance")
    if band_hz is None and prof.any():
        band_hz = (float(f[prof].min()), float(f[prof].max()))
    if band_hz is not None:
        inb = ok & prof & (f >= band_hz[0]) & (f <= band_hz[1])
        dev = np.full(f.shape, np.nan)
        dev[inb] = 10 * np.log10(pm[inb] / pp[inb])
        bad = inb & (np.abs(dev) > tol_db)
        if bad.any():
            ax.loglog(f[bad], pm[bad], "x", color=COLORS[1], ms=5, label=f"outside ±{tol_db:g} dB ({int(bad.sum())} lines)")
        ax.set_xlim(band_hz[0] / 1.5, band_hz[1] * 1.5)
        if inb.any():
            ax.set_ylim(min(pm[inb].min(), pp[inb].min() * lo) / 3, max(pm[inb].max(), pp[inb].max() * hi) * 3)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("PSD (g²/Hz)")
    ax.set_title(title or "Reference PSD against the profile", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    return fig


def plot_allan(noise: NoiseResult, *, title: str | None = None) -> Figure:
    """The DUT's overlapping Allan deviation on its vibration-off stretches (IEEE Std 1554),
    log-log in µg, with the two lines its noise result reads from it (IEEE Std 952 Annex C): the
    white noise's ``density/√(2τ)`` (one-sided density) and the flicker floor ``0.664·B``."""
    tau = np.asarray(noise.tau_s, dtype=np.float64)
    dev = np.asarray(noise.adev_ug, dtype=np.float64)
    fig, (ax,) = new_figure()
    ok = np.isfinite(tau) & np.isfinite(dev) & (tau > 0) & (dev > 0)
    # ±1 standard uncertainty of each point from its pairs (a deviation from n pairs: 1/√(2n)
    # relative at least; red noise has fewer degrees of freedom than pairs, so the bars are a floor)
    n = np.maximum(np.asarray(noise.n_pairs, dtype=np.float64), 1.0)
    ax.errorbar(tau[ok], dev[ok], yerr=dev[ok] / np.sqrt(2 * n[ok]), fmt="o-", color=COLORS[0], ms=4, lw=1,
                label="Allan deviation (overlapping)")
    if ok.any():
        grid = np.geomspace(tau[ok].min(), tau[ok].max(), 50)
        d, b = noise.density_ug_rthz.value, noise.bias_instability_ug.value
        if math.isfinite(d) and d > 0:
            ax.loglog(grid, d / np.sqrt(2 * grid), "--", color=COLORS[1], lw=1,
                      label=f"white: {d:.3g} µg/√Hz")
        if math.isfinite(b) and b > 0:
            ax.loglog(grid, np.full_like(grid, 0.664 * b), ":", color=COLORS[2], lw=1.3,
                      label=f"flicker floor 0.664·B, B = {b:.3g} µg")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time τ (s)")
    ax.set_ylabel("Allan deviation (µg)")
    ax.set_title(title or f"DUT noise on {noise.off_s:.3g} s with vibration off", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    return fig
