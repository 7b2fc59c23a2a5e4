"""The interactive twins of the report's figures (vrelab.report.interactive): the plotly figure
holds the same data as the matplotlib one it translates, read back here against the results the
figure was drawn from (not against the translation's own arithmetic). That they draw and answer
the mouse in a browser is tests/test_report_browser.py's part.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from test_report import _random_result, _sine_result
from vrelab.report import interactive, plots
from vrelab.report.html import ReportFigure, ReportSection, render_report


def _twin(fig: Figure) -> dict:
    fig.savefig(io.BytesIO(), format="png", dpi=110)  # the layout the twin copies
    return interactive.to_plotly(fig)


def _values(a) -> np.ndarray:
    if isinstance(a, dict):  # plotly's base64 typed array
        import base64

        return np.frombuffer(base64.b64decode(a["bdata"]), dtype=a["dtype"]).astype(float)
    return np.array([np.nan if v is None else v for v in a], dtype=float)


def _trace(spec: dict, name_part: str) -> dict:
    found = [t for t in spec["data"] if name_part in str(t.get("name", ""))]
    assert found, [t.get("name") for t in spec["data"]]
    return found[0]


def test_vre_points_error_bars_and_hollow_overrange_levels_are_the_results() -> None:
    res = _random_result()
    spec = _twin(plots.plot_vre_vs_rms(res))
    label = "ADXL355, ±2.048 g, Z axis, BW 1000 Hz, +1 g field"
    plain = [t for t in spec["data"] if t.get("name") == label][0]
    ok = [lv for lv in res.levels if not lv.flags]
    np.testing.assert_allclose(_values(plain["x"]), [lv.rms_g for lv in ok])
    np.testing.assert_allclose(_values(plain["y"]), [1e3 * lv.vre.value for lv in ok], rtol=1e-12)
    np.testing.assert_allclose(_values(plain["error_y"]["array"]), [1e3 * lv.vre.u for lv in ok], rtol=1e-9)
    hollow = _trace(spec, "over-range protection tripped")
    assert hollow["marker"]["color"] == "white"
    np.testing.assert_allclose(_values(hollow["x"]), [3.0, 3.5])
    assert spec["layout"]["yaxis"]["title"]["text"] == "VRE (mg)"
    # u = 0.4 mg: GUM 7.2.6 quotes it 0.40 and the value to the same hundredth of a mg.
    assert "%{customdata}" in plain["hovertemplate"]
    assert plain["customdata"] == [f"{1e3 * lv.vre.value:+.2f} ± 0.40".lstrip("+") for lv in ok]
    # SPEC 1.1 at the fitted 2 g rail: censored -83 mg at 1 g rms
    cens = _trace(spec, "censored model")
    assert np.interp(1.0, _values(cens["x"]), _values(cens["y"])) == pytest.approx(-83.0, abs=0.6)
    # the departure of the fit: an axvline at 3 g rms, a shape across the axes
    assert {"type": "line", "x0": 3.0, "x1": 3.0, "yref": "y domain"}.items() <= spec["layout"]["shapes"][0].items()


def test_psd_twin_has_log_axes_and_the_plus_minus_3db_band_of_the_profile() -> None:
    f = np.geomspace(50, 2000, 60)
    spec = _twin(plots.plot_psd(f, np.full(f.size, 0.004), np.full(f.size, 0.003)))
    assert spec["layout"]["xaxis"]["type"] == "log" and spec["layout"]["yaxis"]["type"] == "log"
    band = _trace(spec, "±3 dB tolerance")
    y = _values(band["y"])
    assert band["fill"] == "toself"
    assert y.min() == pytest.approx(0.003 * 10 ** -0.3, rel=1e-6) and y.max() == pytest.approx(0.003 * 10 ** 0.3, rel=1e-6)


def test_time_series_twin_keeps_its_panels_rails_and_segments(tmp_path) -> None:
    from test_report import _write_record

    _write_record(tmp_path / "r.h5", 2000.0, 4000)
    fig = plots.plot_time_series(plots.record_envelope(tmp_path / "r.h5", n_bins=500), rails_g=(-2.0, 2.0))
    spec = _twin(fig)
    lay = spec["layout"]
    assert lay["xaxis2"]["matches"] == "x"  # the panels zoom together, as they share x
    rails = [s for s in lay["shapes"] if s["type"] == "line" and s.get("xref") == "x domain" and s["yref"] == "y"]
    assert sorted(s["y0"] for s in rails) == [-2.0, 2.0]
    spans = [s["yref"] for s in lay["shapes"] if s["type"] == "rect"]
    assert spans.count("y domain") == spans.count("y2 domain") == 5  # the schedule's segments, in both panels
    assert lay["yaxis"]["domain"][0] > lay["yaxis2"]["domain"][1]  # the record above the offset shift


def test_rms2_twin_draws_each_frequency_with_its_vrc_line() -> None:
    spec = _twin(plots.plot_vre_vs_rms2(_sine_result()))
    line = _trace(spec, "2400 Hz: VRC")
    x, y = _values(line["x"]), _values(line["y"])
    # the figure's VRE in mg (as the tables) against rms² in g²: the fitted 2000 µg/g² is 2 mg/g²
    assert y[-1] / x[-1] == pytest.approx(2.0)


def test_labels_are_text_not_markup() -> None:
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="<b>channel</b> & co")
    ax.legend()
    spec = _twin(fig)
    assert spec["data"][0]["name"] == "&lt;b&gt;channel&lt;/b&gt; &amp; co"


def test_a_figure_the_translation_does_not_know_stays_static() -> None:
    fig = Figure()
    FigureCanvasAgg(fig)
    fig.subplots().imshow(np.eye(3))
    rf = ReportFigure.from_figure(fig, "an image")
    assert rf.plotly_json is None and rf.png[:4] == b"\x89PNG"
    text = render_report([ReportSection("S", "w.", figures=[rf])], "T")
    assert 'class="iplot"' not in text and "Plotly" not in text  # no twin, no plotly.js
    good = ReportFigure.from_figure(plots.plot_vrc_vs_freq(_sine_result()), "VRC")
    assert json.loads(good.plotly_json)["layout"]["xaxis"]["type"] == "log"


def test_hover_never_shows_an_uncertainty_the_figure_does_not_have() -> None:
    """Points drawn without error bars (a sweep without u_vre_g) and a point whose u is unknown
    show no "± 0" when hovered."""
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.errorbar([1.0, 2.0], [3.0, 4.0], yerr=None, fmt="-o", label="no u")
    ax.errorbar([1.0, 2.0], [5.0, 6.0], yerr=[0.1, np.nan], fmt="o", label="one u")
    ax.legend()
    no_u, one_u = _twin(fig)["data"]
    assert "error_y" not in no_u and "customdata" not in no_u and "±" not in no_u["hovertemplate"]
    assert one_u["customdata"] == ["5.00 ± 0.10", "6"]  # the value at u's last digit; no u, no "±"


def _fig(nrows: int = 1) -> tuple[Figure, list]:
    fig = Figure(figsize=(7.6, 4.6), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, list(fig.subplots(nrows, 1, sharex=True, squeeze=False)[:, 0])


def test_log_axis_labels_every_tick_with_its_whole_value() -> None:
    """A VRC axis from 1200 to 25 000 µg/g²: labels 2000, 5000, 10000, 20000 (plotly's default
    prints "2", "3" ... between decades); a PSD axis below 0.001 writes its power of ten."""
    fig, (ax,) = _fig()
    ax.loglog([80, 300, 1000], [1200, 3300, 25000], "o-")
    ax.set_ylim(1200, 25000)
    ax.set_xlim(70, 1500)
    spec = _twin(fig)
    y, x = spec["layout"]["yaxis"], spec["layout"]["xaxis"]
    assert y["type"] == "log" and y["tickmode"] == "array"
    assert list(y["ticktext"]) == ["2000", "5000", "10000", "20000"]
    np.testing.assert_allclose(y["tickvals"], [2000, 5000, 10000, 20000])
    assert list(x["ticktext"]) == ["100", "200", "500", "1000"]
    fig, (ax,) = _fig()
    ax.loglog([50, 2000], [4e-4, 2e-2])
    ax.set_ylim(4e-4, 2e-2)
    assert list(_twin(fig)["layout"]["yaxis"]["ticktext"]) == ["5×10⁻⁴", "0.001", "0.002", "0.005", "0.01", "0.02"]


def test_stacked_panels_keep_hidden_tick_labels_hidden_and_legends_inside_their_axes() -> None:
    """Two panels sharing time: matplotlib labels only the lower one's ticks (the upper ones sat
    under the lower panel's title); a lower-left legend is anchored at its axes' lower left, so a
    taller plotly legend grows up into its own panel, not down over the ticks and the next panel."""
    fig, (top, bottom) = _fig(2)
    for ax in (top, bottom):
        for k in range(4):
            ax.plot([0, 10], [k, k + 1], label=f"trace {k} with a long legend label")
        ax.legend(loc="lower left")
    bottom.set_title("lower panel")
    spec = _twin(fig)
    lay = spec["layout"]
    assert lay["xaxis"]["showticklabels"] is False
    assert lay["xaxis2"].get("showticklabels", True) is True
    for n, key in ((1, "legend"), (2, "legend2")):
        leg, dom_x, dom_y = lay[key], lay[f"xaxis{n if n > 1 else ''}"]["domain"], lay[f"yaxis{n if n > 1 else ''}"]["domain"]
        assert (leg["xanchor"], leg["yanchor"]) == ("left", "bottom")
        assert dom_x[0] <= leg["x"] < dom_x[1] and dom_y[0] <= leg["y"] < dom_y[1]
