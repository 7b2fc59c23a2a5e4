"""Interactive twins of the report's matplotlib figures: plotly (zoom, pan, hover values).

Every figure of the report is drawn once, in matplotlib (:mod:`vrelab.report.plots`,
:mod:`vrelab.report.sweep`); the static PNG is what prints. :func:`to_plotly` translates the
drawn figure, artist by artist, into a plotly figure with the same data, colours, axes and
legend, so a figure has one owner and its interactive view cannot drift from it. plotly's own
``plotly.tools.mpl_to_plotly`` is not used: on current matplotlib it drops the artists these
figures are made of (``fill_between`` bands, ``axvline`` / ``axhline`` / ``axvspan`` in blended
coordinates, hollow markers) with a warning, which would show a reader a figure without its
tolerance band or its limit line.

The translation covers the artists vrelab draws (lines and markers, error bars, filled bands,
vertical / horizontal lines and spans, line collections, histograms, scatter points, text and
annotations, titles, log axes, category ticks, per-axes legends). Anything else raises
:class:`Unsupported`; :func:`to_plotly_json` then returns None and the report shows the static
image alone, so a figure is interactive exactly when it is complete.

The plotly.js bundle (:func:`plotly_js`) is embedded once per HTML file by
:mod:`vrelab.report.html`, never loaded from a network.
"""

from __future__ import annotations

import html
import math
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib import colors as mcolors
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection, PathCollection, PolyCollection
from matplotlib.container import BarContainer, ErrorbarContainer
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.text import Annotation, Text
from matplotlib.transforms import Transform

from vrelab._format import format_u, format_value, format_value_u
from vrelab.report._markup import shown_text

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["Unsupported", "plotly_js", "to_plotly", "to_plotly_json"]

# Arrays longer than this go to the browser as float32 (7 significant digits, hover shows 4):
# a record's envelope is thousands of points per trace and the report has a size budget.
_LONG = 256

# keyed by matplotlib's line style: a name, or a (offset, pattern) tuple that falls to "solid"
_DASH: dict[Any, str] = {"-": "solid", "--": "dash", ":": "dot", "-.": "dashdot", "solid": "solid", "dashed": "dash",
         "dotted": "dot", "dashdot": "dashdot"}
_SYMBOL = {"o": "circle", "s": "square", "^": "triangle-up", "v": "triangle-down", "D": "diamond",
           "d": "diamond-tall", "P": "cross", "*": "star", "X": "x", "x": "x-thin", "+": "cross-thin",
           "|": "line-ns", "_": "line-ew", ".": "circle", "<": "triangle-left", ">": "triangle-right",
           "p": "pentagon", "h": "hexagon", "H": "hexagon2", "8": "octagon"}
_OPEN_LINE = {"x-thin", "cross-thin", "line-ns", "line-ew"}  # drawn by their outline only
_NO_LINE = {"None", "none", " ", "", None}
_STEPS = {"default": "linear", "steps-post": "hv", "steps-pre": "vh", "steps": "vh", "steps-mid": "hvh"}


class Unsupported(Exception):
    """An artist the translation does not know: the figure stays static."""


def plotly_js() -> str:
    """The plotly.js bundle shipped with the plotly package (embedded once per report)."""
    from plotly.offline import get_plotlyjs

    bundle: str = get_plotlyjs()  # plotly has no type hints (plotly-stubs on PyPI, not installed)
    return bundle


def _text(s: object) -> str:
    # plotly renders labels as a small HTML subset: escape, so a channel named "<b>" is text
    # (control characters shown by the report's one rule first).
    return html.escape(shown_text(s), quote=False).replace("\n", "<br>")


def _color(c: Any, alpha: float | None = None) -> str:
    # Any: matplotlib's getters type a colour wider (a float among them) than to_rgba's ColorType
    r, g, b, a = mcolors.to_rgba(c)
    if alpha is not None:
        a = alpha
    return f"rgba({round(255 * r)},{round(255 * g)},{round(255 * b)},{a:.3g})"


def _arr(x: ArrayLike) -> Any:
    a = np.asarray(x, dtype=np.float64).ravel()
    if a.size > _LONG:
        return a.astype(np.float32)
    # NaN is a gap in a plotly line; JSON has no NaN: None.
    return [None if not math.isfinite(v) else float(v) for v in a]


class _Scale:
    """Points to pixels at the PNG's resolution: the figure's layout (domains) was made there."""

    def __init__(self, fig: Figure) -> None:
        self.px = fig.dpi / 72.0

    def __call__(self, pt: float | str) -> float:  # matplotlib's font sizes are typed float | str
        return round(float(pt) * self.px, 2)


def _coords(ax: Axes, transform: Transform) -> tuple[bool, bool]:
    """Which of x, y an artist gives in data coordinates (the others in axes fraction)."""
    if transform.contains_branch(ax.transData):
        return True, True
    x_data, y_data = transform.contains_branch_seperately(ax.transData)
    if not (x_data or y_data) and not transform.contains_branch(ax.transAxes):
        raise Unsupported(f"an artist in coordinates other than data or axes: {transform}")
    return bool(x_data), bool(y_data)


class _AxesTranslator:
    def __init__(self, fig: Figure, ax: Axes, n: int, px: _Scale) -> None:
        self.fig, self.ax, self.n, self.px = fig, ax, n, px
        self.xref = "x" if n == 1 else f"x{n}"
        self.yref = "y" if n == 1 else f"y{n}"
        self.legend = "legend" if n == 1 else f"legend{n}"
        self.show_legend = ax.get_legend() is not None
        self.traces: list[dict[str, Any]] = []
        self.shapes: list[dict[str, Any]] = []
        self.annotations: list[dict[str, Any]] = []
        self.done: set[int] = set()
        # A panel sharing its x axis with the one below has no label of its own: hover shows theirs.
        self.xlabel = ax.get_xlabel() or next((a.get_xlabel() for a in ax.get_shared_x_axes().get_siblings(ax)
                                               if a.get_xlabel()), "x")
        self.ylabel = ax.get_ylabel() or "y"

    # ------------------------------------------------------------------ helpers
    def _legend_entry(self, label: object) -> dict[str, Any]:  # an artist's label: any object, None
        shown = self.show_legend and bool(label) and not str(label).startswith("_")
        out: dict[str, Any] = {"showlegend": shown, "legend": self.legend}
        if label and not str(label).startswith("_"):
            out["name"] = _text(label)
        return out

    def _hover(self, label: object, err: bool = False) -> str:
        name = "" if not label or str(label).startswith("_") else f"{_text(label)}<br>"
        # A point with a bar: its own "y ± u" text, rounded by GUM 7.2.6 as the tables are.
        y = "%{customdata}" if err else "%{y:.4g}"
        return f"{name}{_text(self.xlabel)}: %{{x:.4g}}<br>{_text(self.ylabel)}: {y}<extra></extra>"

    def _ref(self, data: bool, axis: str) -> str:
        ref = self.xref if axis == "x" else self.yref
        return ref if data else f"{ref} domain"

    # ------------------------------------------------------------------ artists
    def line(self, ln: Line2D, label: object = None, yerr: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        if not ln.get_visible():
            return
        xd, yd = _coords(self.ax, ln.get_transform())
        x = np.asarray(ln.get_xdata(orig=False), dtype=float)
        y = np.asarray(ln.get_ydata(orig=False), dtype=float)
        label = ln.get_label() if label is None else label
        ls, marker = ln.get_linestyle(), ln.get_marker()
        has_line = ls not in _NO_LINE
        has_marker = marker not in _NO_LINE
        color = _color(ln.get_color(), ln.get_alpha())
        if not (xd and yd):
            # axvline / axhline: a line across the axes at a data value, a layout shape.
            if not has_line or x.size != 2:
                raise Unsupported("a marker line in axes coordinates")
            shape = {"type": "line", "xref": self._ref(xd, "x"), "yref": self._ref(yd, "y"),
                     "x0": float(x[0]), "x1": float(x[1]), "y0": float(y[0]), "y1": float(y[1]),
                     "line": {"color": color, "width": self.px(ln.get_linewidth()), "dash": _DASH.get(ls, "solid")},
                     "layer": "above"}
            self.shapes.append(shape)
            if label and not str(label).startswith("_") and self.show_legend:
                # A shape has no legend entry of its own: an empty trace carries its label.
                self.traces.append({"type": "scatter", "x": [None], "y": [None], "mode": "lines",
                                    "line": shape["line"], "hoverinfo": "skip", "xaxis": self.xref,
                                    "yaxis": self.yref, **self._legend_entry(label)})
            return
        mode = "+".join(m for m, on in (("lines", has_line), ("markers", has_marker)) if on) or "markers"
        tr: dict[str, Any] = {"type": "scatter", "x": _arr(x), "y": _arr(y), "mode": mode,
                              "xaxis": self.xref, "yaxis": self.yref, **self._legend_entry(label)}
        if has_line:
            if ln.get_drawstyle() not in _STEPS:
                raise Unsupported(f"draw style {ln.get_drawstyle()!r}")
            tr["line"] = {"color": color, "width": self.px(ln.get_linewidth()), "dash": _DASH.get(ls, "solid"),
                          "shape": _STEPS[ln.get_drawstyle()]}
        if has_marker:
            sym = _SYMBOL.get(str(marker))
            if sym is None:
                raise Unsupported(f"marker {marker!r}")
            face = ln.get_markerfacecolor()
            edge = _color(ln.get_markeredgecolor(), ln.get_alpha())
            size = self.px(ln.get_markersize()) * (0.5 if marker == "." else 1.0)
            if sym in _OPEN_LINE:
                tr["marker"] = {"symbol": sym, "size": size, "line": {"color": edge, "width": self.px(max(1.0, ln.get_markeredgewidth()))}}
            elif isinstance(face, str) and face.lower() in ("none", "white", "w"):
                tr["marker"] = {"symbol": sym, "size": size, "color": "white" if face.lower() != "none" else "rgba(0,0,0,0)",
                                "line": {"color": edge, "width": self.px(max(1.0, ln.get_markeredgewidth()))}}
            else:
                tr["marker"] = {"symbol": sym, "size": size, "color": _color(face, ln.get_alpha()),
                                "line": {"color": edge, "width": self.px(ln.get_markeredgewidth()) if ln.get_markeredgewidth() else 0}}
        elif not has_line:
            # A legend-only entry (a fitted parameter's text): nothing to draw, text in the legend.
            tr["marker"] = {"opacity": 0}
        if x.size == 0:
            tr["x"], tr["y"] = [None], [None]
            tr["hoverinfo"] = "skip"
        elif yerr is not None:
            minus, plus = yerr
            sym_err = np.allclose(minus, plus, equal_nan=True)
            tr["error_y"] = {"type": "data", "array": _arr(plus), "visible": True, "color": color,
                             "thickness": self.px(1.0), "width": 3}
            if not sym_err:
                tr["error_y"]["symmetric"] = False
                tr["error_y"]["arrayminus"] = _arr(minus)
            # A point without a bar (no uncertainty) shows its value alone, never "± 0".
            tr["customdata"] = [format_value(v) if not (math.isfinite(p) and math.isfinite(m) and p > 0) else
                                format_value_u(v, p) if sym_err else
                                f"{format_value_u(v, min(p, m)).split(' ± ')[0]} +{format_u(p)} / −{format_u(m)}"
                                for v, p, m in zip(y, plus, minus)]
            tr["hovertemplate"] = self._hover(label, err=True)
        else:
            tr["hovertemplate"] = self._hover(label)
        self.traces.append(tr)

    def errorbar(self, c: ErrorbarContainer) -> None:
        data_line, caplines, barcols = c.lines
        for a in (*caplines, *barcols):
            self.done.add(id(a))
        if data_line is None:
            raise Unsupported("error bars without their data line")
        self.done.add(id(data_line))
        if c.has_xerr:
            raise Unsupported("horizontal error bars")
        if not (c.has_yerr and barcols):  # errorbar(yerr=None): points, no uncertainty to show
            self.line(data_line, label=c.get_label())
            return
        x = np.asarray(data_line.get_xdata(orig=False), dtype=float)
        y = np.asarray(data_line.get_ydata(orig=False), dtype=float)
        minus, plus = np.full_like(y, np.nan), np.full_like(y, np.nan)
        # A point whose error is NaN has an empty segment: no bar to match.
        segs = [a for a in (np.asarray(s, dtype=float) for s in barcols[0].get_segments()) if a.ndim == 2 and len(a) >= 2]
        used = np.zeros(len(segs), bool)
        for i, (xi, yi) in enumerate(zip(x, y)):
            for j, s in enumerate(segs):
                # Segments skip non-finite points: match each point with its own bar.
                if not used[j] and s[0, 0] == xi and min(s[:, 1]) <= yi <= max(s[:, 1]):
                    minus[i], plus[i] = yi - min(s[:, 1]), max(s[:, 1]) - yi
                    used[j] = True
                    break
        self.line(data_line, label=c.get_label(), yerr=(minus, plus))

    def poly(self, coll: PolyCollection) -> None:
        xd, yd = _coords(self.ax, coll.get_transform())
        if not (xd and yd):
            raise Unsupported("a filled area in axes coordinates")
        faces = coll.get_facecolor()
        label = coll.get_label()
        for k, path in enumerate(coll.get_paths()):
            v = np.asarray(path.vertices)
            face = faces[k % len(faces)] if len(faces) else (0, 0, 0, 0)
            entry = self._legend_entry(label if k == 0 else None)
            self.traces.append({"type": "scatter", "x": _arr(v[:, 0]), "y": _arr(v[:, 1]), "mode": "lines",
                                "fill": "toself", "fillcolor": _color(face, coll.get_alpha()), "line": {"width": 0},
                                "hoverinfo": "skip", "xaxis": self.xref, "yaxis": self.yref, **entry,
                                "legendgroup": f"{self.n}-{id(coll)}"})

    def segments(self, coll: LineCollection) -> None:
        xd, yd = _coords(self.ax, coll.get_transform())
        if not (xd and yd):
            raise Unsupported("a line collection in axes coordinates")
        xs: list[float | None] = []
        ys: list[float | None] = []
        for s in coll.get_segments():
            xs += [float(v) for v in s[:, 0]] + [None]
            ys += [float(v) for v in s[:, 1]] + [None]
        colors = coll.get_colors()
        widths = np.atleast_1d(coll.get_linewidth())  # one width per segment (get_linewidths: its alias)
        ls: Any = coll.get_linestyle()[0] if len(coll.get_linestyle()) else (0, None)  # (offset, dashes or None)
        dash = "solid" if ls[1] is None else "dash"
        self.traces.append({"type": "scatter", "x": xs, "y": ys, "mode": "lines",
                            "line": {"color": _color(colors[0] if len(colors) else "k", coll.get_alpha()),
                                     "width": self.px(widths[0] if len(widths) else 1.0), "dash": dash},
                            "hovertemplate": self._hover(coll.get_label()), "xaxis": self.xref, "yaxis": self.yref,
                            **self._legend_entry(coll.get_label())})

    def bars(self, c: BarContainer) -> None:
        rects = [p for p in c.patches]
        for p in rects:
            self.done.add(id(p))
        if not rects:
            return
        _coords(self.ax, rects[0].get_data_transform())
        x = np.array([p.get_x() + p.get_width() / 2 for p in rects])
        w = np.array([p.get_width() for p in rects])
        h = np.array([p.get_height() for p in rects])
        p0 = rects[0]
        self.traces.append({"type": "bar", "x": _arr(x), "y": _arr(h), "width": _arr(w),
                            "marker": {"color": _color(p0.get_facecolor()), "line": {"color": _color(p0.get_edgecolor()), "width": self.px(p0.get_linewidth())}},
                            "hovertemplate": f"{_text(self.xlabel)}: %{{x:.4g}}<br>{_text(self.ylabel)}: %{{y}}<extra></extra>",
                            "xaxis": self.xref, "yaxis": self.yref, **self._legend_entry(c.get_label())})

    def rect(self, p: Rectangle) -> None:
        xd, yd = _coords(self.ax, p.get_data_transform())
        x0, y0 = p.get_x(), p.get_y()
        self.shapes.append({"type": "rect", "xref": self._ref(xd, "x"), "yref": self._ref(yd, "y"),
                            "x0": float(x0), "x1": float(x0 + p.get_width()), "y0": float(y0), "y1": float(y0 + p.get_height()),
                            "fillcolor": _color(p.get_facecolor(), p.get_alpha()), "line": {"width": 0}, "layer": "below"})

    def scatter(self, coll: PathCollection) -> None:
        xd, yd = _coords(self.ax, coll.get_offset_transform())
        if not (xd and yd):
            raise Unsupported("scatter points in axes coordinates")
        off = np.asarray(coll.get_offsets(), dtype=float)
        faces = coll.get_facecolor()
        sizes = coll.get_sizes()
        self.traces.append({"type": "scatter", "x": _arr(off[:, 0]), "y": _arr(off[:, 1]), "mode": "markers",
                            "marker": {"color": _color(faces[0] if len(faces) else "k", coll.get_alpha()),
                                       "size": self.px(math.sqrt(sizes[0]) if len(sizes) else 6.0)},
                            "hovertemplate": self._hover(coll.get_label()), "xaxis": self.xref, "yaxis": self.yref,
                            **self._legend_entry(coll.get_label())})

    def text(self, t: Text) -> None:
        if not t.get_visible() or not t.get_text():
            return
        ann: dict[str, Any] = {"text": _text(t.get_text()), "showarrow": False,
                               "font": {"size": self.px(t.get_fontsize()), "color": _color(t.get_color())},
                               "xanchor": {"center": "center", "left": "left", "right": "right"}[t.get_horizontalalignment()],
                               "yanchor": {"center": "middle", "center_baseline": "middle", "top": "top", "bottom": "bottom",
                                           "baseline": "bottom"}[t.get_verticalalignment()]}
        if isinstance(t, Annotation):
            if t.xycoords != "data" or (t.arrow_patch is not None):
                raise Unsupported("an annotation not anchored in data coordinates, or with an arrow")
            ann.update(xref=self.xref, yref=self.yref, x=float(t.xy[0]), y=float(t.xy[1]))
            if t.anncoords == "offset points":
                dx, dy = t.get_position()
                ann.update(xshift=self.px(dx), yshift=self.px(dy))
            elif t.anncoords != "data":
                raise Unsupported(f"annotation text coordinates {t.anncoords!r}")
        else:
            xd, yd = _coords(self.ax, t.get_transform())
            x, y = t.get_position()
            ann.update(xref=self._ref(xd, "x"), yref=self._ref(yd, "y"), x=float(x), y=float(y))
        box = t.get_bbox_patch()
        if box is not None:
            ann["bgcolor"] = _color(box.get_facecolor())
        self.annotations.append(ann)

    # ------------------------------------------------------------------ the axes
    # Which translation each kind of container or collection gets (a container before the
    # artists it holds, which it marks done).
    _KINDS = ((ErrorbarContainer, "errorbar"), (BarContainer, "bars"), (PolyCollection, "poly"),
              (LineCollection, "segments"), (PathCollection, "scatter"))

    def _any(self, artist: object) -> None:  # a container or a collection, dispatched on its type
        for kind, method in self._KINDS:
            if isinstance(artist, kind):
                getattr(self, method)(artist)
                return
        raise Unsupported(f"{type(artist).__name__} on the axes")

    def translate(self) -> None:
        ax = self.ax
        for artist in [*ax.containers, *ax.collections]:
            if id(artist) not in self.done:
                self._any(artist)
        for ln in ax.lines:
            if id(ln) not in self.done:
                self.line(ln)
        for p in ax.patches:
            if id(p) in self.done:
                continue
            if not isinstance(p, Rectangle):
                raise Unsupported(f"patch {type(p).__name__}")
            self.rect(p)
        for t in ax.texts:
            self.text(t)
        if ax.images or ax.tables or ax.artists:
            raise Unsupported("images, tables or other artists on the axes")

    def axis(self, which: str, domain: tuple[float, float], anchor: str) -> dict[str, Any]:
        ax = self.ax
        scale = ax.get_xscale() if which == "x" else ax.get_yscale()
        lo, hi = ax.get_xlim() if which == "x" else ax.get_ylim()
        label = ax.get_xlabel() if which == "x" else ax.get_ylabel()
        out: dict[str, Any] = {"domain": [max(0.0, domain[0]), min(1.0, domain[1])], "anchor": anchor,
                               "showgrid": True, "gridcolor": "rgba(0,0,0,0.12)", "zeroline": False,
                               "showline": True, "linecolor": "black", "mirror": True, "ticks": "outside",
                               "automargin": False,
                               # Close to the tick labels, as matplotlib sets it: plotly's default standoff
                               # put a panel's x title on the title of the panel below it.
                               "title": {"text": _text(label), "font": {"size": self.px(10)}, "standoff": self.px(3)},
                               "tickfont": {"size": self.px(9)}}
        if scale == "log":
            out["type"] = "log"
            out["range"] = [math.log10(lo), math.log10(hi)]
            # Between decades plotly labels its minor ticks with the bare digit ("2", "3" for
            # 20 000) or an SI prefix ("600μ" beside a unit with a µ of its own): the ticks are
            # given here, 1-2-5 per decade, each label its whole value.
            out["tickmode"] = "array"
            out["tickvals"], out["ticktext"] = _log_ticks(lo, hi)
        elif scale in ("linear", "symlog"):
            # plotly has no symmetric-log axis: linear, with the zoom to read small values.
            out["type"] = "linear"
            out["range"] = [lo, hi]
        else:
            raise Unsupported(f"{which} scale {scale!r}")
        # A panel whose tick labels matplotlib hides (sharex: the panel below labels the time)
        # hides them here too; shown, they sit under the next panel's title.
        params = (ax.xaxis if which == "x" else ax.yaxis).get_tick_params(which="major")
        if not any(params.get(k, False) for k in ("labelbottom", "labeltop", "labelleft", "labelright")):
            out["showticklabels"] = False
        ticks = ax.get_xticklabels() if which == "x" else ax.get_yticklabels()
        texts = [t.get_text() for t in ticks]
        # Log axes label their ticks in mathtext ("$10^{2}$"): plotly's own log ticks say the same.
        if out["type"] == "linear" and texts and any(s and not _is_number(s) and not s.startswith("$") for s in texts):
            # Category ticks (a text grid axis): the same labels at the same places.
            out["tickvals"] = [float(v) for v in (ax.get_xticks() if which == "x" else ax.get_yticks())]
            out["ticktext"] = [_text(s) for s in texts]
        return out


_SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def _tick_label(v: float) -> str:
    """A log tick's whole value: plain from 0.001 to 99 999, else mantissa × 10 to a power."""
    if 1e-3 <= abs(v) < 1e5:
        return f"{v:g}"
    e = math.floor(math.log10(abs(v)) + 1e-9)
    m = round(v / 10**e)
    return (f"{m}×" if m != 1 else "") + "10" + str(e).translate(_SUPERSCRIPT)


def _log_ticks(lo: float, hi: float) -> tuple[list[float], list[str]]:
    """Tick values and labels of a log axis from ``lo`` to ``hi``: 1, 2 and 5 per decade over
    up to three decades, decades alone beyond (labels that would crowd a report's width)."""
    lo, hi = min(lo, hi), max(lo, hi)
    e0, e1 = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    steps = (1, 2, 5) if e1 - e0 <= 3 else (1,)
    vals = [m * 10.0**e for e in range(e0, e1 + 1) for m in steps]
    vals = [float(f"{v:.12g}") for v in vals if lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)]
    if len(vals) < 3:  # less than a decade: every digit
        vals = [float(f"{m * 10.0**e:.12g}") for e in range(e0, e1 + 1) for m in range(1, 10)]
        vals = [v for v in vals if lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)]
    if len(vals) > 12:  # many decades: every other, then every third ...
        k = math.ceil(len(vals) / 12)
        vals = vals[::k]
    return vals, [_tick_label(v) for v in vals]


def _is_number(s: str) -> bool:
    try:
        float(s.replace("\u2212", "-"))
        return True
    except ValueError:
        return False


def to_plotly(fig: Figure) -> dict[str, Any]:
    """The plotly figure (``{"data": [...], "layout": {...}}``, validated by plotly) of a drawn
    matplotlib figure; raises :class:`Unsupported` for an artist it does not translate.

    The figure must have been drawn (``savefig``) so its layout engine has placed the axes:
    their positions become the plotly axes' domains, one legend per axes where matplotlib put it.
    """
    import plotly.graph_objects as go

    px = _Scale(fig)
    height_px = fig.get_figheight() * fig.dpi
    inv = fig.transFigure.inverted()
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]  # report.plots draws on an Agg canvas
    data: list[dict[str, Any]] = []
    # template "none": every style is set here, and plotly's default template would add kilobytes
    # of unused defaults to every figure of the file.
    layout: dict[str, Any] = {"template": "none", "height": round(height_px), "autosize": True,
                              "margin": {"l": 0, "r": 0, "t": 0, "b": 0},
                              "paper_bgcolor": "white", "plot_bgcolor": "white", "hovermode": "closest",
                              "font": {"family": "DejaVu Sans, Arial, sans-serif", "size": px(9)},
                              "shapes": [], "annotations": []}
    axes = [a for a in fig.axes if a.get_visible()]
    index = {id(a): i for i, a in enumerate(axes, 1)}
    for n, ax in enumerate(axes, 1):
        tr = _AxesTranslator(fig, ax, n, px)
        tr.translate()
        pos = ax.get_position()
        xk, yk = tr.xref.replace("x", "xaxis"), tr.yref.replace("y", "yaxis")
        layout[xk] = tr.axis("x", (pos.x0, pos.x1), tr.yref)
        layout[yk] = tr.axis("y", (pos.y0, pos.y1), tr.xref)
        for sib in ax.get_shared_x_axes().get_siblings(ax):
            if sib is not ax and id(sib) in index and index[id(sib)] < n:
                layout[xk]["matches"] = "x" if index[id(sib)] == 1 else f"x{index[id(sib)]}"
                break
        data += tr.traces
        layout["shapes"] += tr.shapes
        layout["annotations"] += tr.annotations
        title = ax.get_title()
        if title:
            layout["annotations"].append({"text": _text(title), "xref": "paper", "yref": "paper", "x": (pos.x0 + pos.x1) / 2,
                                          "y": pos.y1, "yshift": px(4), "xanchor": "center", "yanchor": "bottom",
                                          "showarrow": False, "font": {"size": px(ax.title.get_fontsize())}})
        leg = ax.get_legend()
        if leg is not None:
            bb = leg.get_window_extent(renderer).transformed(inv)
            # Anchored at the corner of matplotlib's box nearest its axes' corner: a plotly legend
            # is taller and wider than matplotlib's (more space per entry, a browser's width),
            # and from that corner it grows into its own axes, never over the ticks outside them
            # or the panel below.
            right = (bb.x0 + bb.x1) / 2 > (pos.x0 + pos.x1) / 2
            top = (bb.y0 + bb.y1) / 2 > (pos.y0 + pos.y1) / 2
            layout[tr.legend] = {"x": min(bb.x1, pos.x1) if right else max(bb.x0, pos.x0),
                                 "y": min(bb.y1, pos.y1) if top else max(bb.y0, pos.y0),
                                 "xanchor": "right" if right else "left", "yanchor": "top" if top else "bottom",
                                 "xref": "paper", "yref": "paper", "bgcolor": "rgba(255,255,255,0.85)",
                                 "bordercolor": "rgba(0,0,0,0.25)", "borderwidth": 1,
                                 "font": {"size": px(leg.get_texts()[0].get_fontsize()) if leg.get_texts() else px(8)}}
    sup = getattr(fig, "_suptitle", None)
    if sup is not None and sup.get_text():
        layout["annotations"].append({"text": _text(sup.get_text()), "xref": "paper", "yref": "paper", "x": 0.5, "y": 1.0,
                                      "xanchor": "center", "yanchor": "top", "showarrow": False,
                                      "font": {"size": px(sup.get_fontsize())}})
    # Validation: a property plotly does not know is an error here, not a blank figure later.
    spec: dict[str, Any] = go.Figure(data=data, layout=layout).to_plotly_json()
    return spec


def to_plotly_json(fig: Figure) -> str | None:
    """:func:`to_plotly` as JSON safe to embed in a ``<script>`` element (plotly escapes ``<``,
    ``>`` and ``/``), or None when the figure holds an artist the translation does not know."""
    import plotly.io as pio

    try:
        spec = to_plotly(fig)
    except Unsupported:
        return None
    text: str = pio.to_json(spec, validate=False, remove_uids=True)
    return text
