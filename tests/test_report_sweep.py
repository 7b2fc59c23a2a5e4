"""`vrelab report DIR` on sweep output folders: real (analytic ``model`` kind) sweeps run through
``vrelab.sweep.run_sweep``, then reported through the CLI.

Reference value: SPEC 1.1 (the article's setting, μ = 1 g, ±2 g rails, σ = 1 g rms): the
censored-Gaussian VRE is -83 mg. Lot statistics are checked against numpy on the Dataset read
back with xarray, not against the report's own numbers.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from test_report_browser import (
    SCREENSHOT_DIR,
    assert_rendered_cleanly,
    markup_only,
    render_in_chromium,
)
from vrelab.cli import main
from vrelab.report import sweep as S
from vrelab.sweep import parse_spec, run_sweep

RMS = [0.5, 1.0, 1.5, 2.0, 2.5]
STATIC = [1.0, -1.0, 0.5]
RESONANCE = {"fn_hz": 3000.0, "f_lo_hz": 50.0, "f_hi_hz": 2000.0}


def _grid(out: Path) -> Path:
    run_sweep(parse_spec({"kind": "model", "name": "grid", "seed": 11, "grid": {"rms_g": RMS, "static_g": STATIC}}), out)
    return out


def _lot(out: Path) -> Path:
    doc = {
        "kind": "model",
        "name": "lot",
        "seed": 20161121,
        "fixed": RESONANCE,
        "grid": {"rms_g": [1.0, 2.0]},
        "montecarlo": {
            "units": 12,
            "k2_ug_per_g2": {"dist": "normal", "mean": 0.0, "sd": 3000.0},
            "q": {"dist": "uniform", "low": 5.0, "high": 9.0},
        },
    }
    run_sweep(parse_spec(doc), out)
    return out


def _with_failures(out: Path) -> Path:
    # A sine through a resonance needs freq_hz: the sine points fail, the Gaussian ones do not.
    doc = {"kind": "model", "name": "half-failed", "seed": 1, "fixed": {**RESONANCE, "q": 5.0}, "grid": {"rms_g": [1.0, 2.0], "shape": ["gaussian", "sine"]}}
    run_sweep(parse_spec(doc), out)
    return out


def _open(folder: Path) -> xr.Dataset:
    with xr.open_dataset(folder / "result.nc", engine="h5netcdf") as ds:
        return ds.load()


def _report(folder: Path, capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["report", str(folder)]) == 0
    assert "report written" in capsys.readouterr().out
    text = markup_only((folder / "report.html").read_text(encoding="utf-8"))
    assert not re.search(r"https?://", text), "the report must not reference the network"
    srcs = re.findall(r'<img class="static" src="([^"]{0,30})', text)
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    return text


def _one_line_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    return err


# --------------------------------------------------------------------------- through the CLI
def test_grid_report_one_figure_grid_values_and_provenance(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _grid(tmp_path / "grid")
    text = _report(folder, capsys)
    assert text.count("<img ") == 1
    assert "0.5, 1, 1.5, 2, 2.5" in text and "1, -1, 0.5" in text  # the grid axes' values
    assert "15: 15 ok, 0 failed" in text
    assert "seed</th><td>11<" in text and "kind</th><td>model<" in text
    assert hashlib.sha256((folder / "result.nc").read_bytes()).hexdigest() in text
    assert "command line: vrelab" in text and "date utc: 20" in text and "vrelab version" in text
    assert not (folder / "results.json").exists()


def test_grid_plot_draws_vre_in_mg_for_each_static_field_and_matches_spec_83mg(tmp_path: Path) -> None:
    """SPEC 1.1: μ = 1 g, ±2 g rails (the model kind's default range), σ = 1 g rms: -83 mg."""
    ds = _open(_grid(tmp_path / "grid"))
    ax = S.plot_sweep_grid(ds).axes[0]
    assert [c.get_label() for c in ax.containers] == [f"static_g = {s:g}" for s in STATIC]
    assert ax.get_lines()[0] is ax.containers[0].lines[0]  # the first line drawn is static_g = 1
    x, y = ax.get_lines()[0].get_data()
    np.testing.assert_array_equal(x, RMS)
    np.testing.assert_array_equal(y, ds["vre_g"].sel(static_g=1.0).values * 1e3)
    assert y[RMS.index(1.0)] == pytest.approx(-83.0, abs=0.6)
    assert ax.get_ylabel() == "VRE (mg)" and ax.get_xlabel() == "vibration level (g rms)"


def test_lot_report_histograms_scatter_and_statistics_match_numpy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _lot(tmp_path / "lot")
    text = _report(folder, capsys)
    assert text.count("<img ") == 3  # the spread against rms_g, histograms, scatter against the drawn parameters
    assert "24: 24 ok, 0 failed" in text and "Monte Carlo units</th><td>12<" in text
    ds = _open(folder)
    v_mg = ds["vre_g"].sel(rms_g=2.0).values * 1e3
    assert np.ptp(v_mg) > 1.0  # the drawn k2 spreads the lot (else the checks below are weak)
    fig = S.plot_lot_histograms(ds)
    ax = fig.axes[1]  # the rms_g = 2 panel
    assert "rms_g = 2" in ax.get_title()
    xs = {str(ln.get_label()).split(" ")[0]: ln.get_xdata()[0] for ln in ax.get_lines() if not str(ln.get_label()).startswith("_")}
    assert xs["mean"] == pytest.approx(np.mean(v_mg), rel=1e-12)
    assert xs["5th"] == pytest.approx(np.percentile(v_mg, 5), rel=1e-12)
    assert xs["95th"] == pytest.approx(np.percentile(v_mg, 95), rel=1e-12)
    assert xs["±1"] == pytest.approx(np.mean(v_mg) + np.std(v_mg, ddof=1), rel=1e-12)
    assert f"{np.mean(v_mg):+.4g}" in text  # the statistics table
    scatter = S.plot_lot_scatter(ds)
    assert [a.get_xlabel() for a in scatter.axes[-2:]] == ["k2 (µg/g²)", "resonance Q"]
    k2_ax = scatter.axes[2]  # row rms_g = 2, column k2
    assert k2_ax.get_title() == "rms_g = 2"
    pts = k2_ax.collections[0].get_offsets()
    np.testing.assert_array_equal(pts[:, 0], ds["k2_ug_per_g2"].values)
    np.testing.assert_array_equal(pts[:, 1], v_mg)


def test_failed_points_are_counted_and_their_error_shown(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _with_failures(tmp_path / "failed")
    text = _report(folder, capsys)
    assert "4: 2 ok, 2 failed" in text
    assert text.count("ValueError: freq_hz is needed with fn_hz for a sine") == 2  # one row per failed point
    assert "rms_g = 2, shape = sine" in text
    assert "2 of 4 points failed" in text  # the warning
    assert text.count("<img ") == 1  # the Gaussian line; the sine line is all gaps
    labels = [c.get_label() for c in S.plot_sweep_grid(_open(folder)).axes[0].containers]
    assert labels == ["shape = gaussian", "shape = sine (every point failed)"]


def test_more_combinations_than_lines_go_to_more_figures_and_every_one_is_drawn(tmp_path: Path) -> None:
    doc = {"kind": "model", "name": "wide", "grid": {"rms_g": [0.5, 1.0], "static_g": [1.0, 0.0, -1.0], "range_g": [2.0, 4.0, 8.0, 16.0]}}
    run_sweep(parse_spec(doc), tmp_path / "wide")
    ds = _open(tmp_path / "wide")
    figs, _ = S.sweep_figures(ds)
    assert len(figs) == 2
    assert figs[0].caption.endswith("(combinations 1–8 of 12)") and figs[1].caption.endswith("(combinations 9–12 of 12)")
    combos = S.line_combinations(ds, "rms_g")
    labels = []
    for _first, piece in S.chunks(combos, S.MAX_LINES):
        labels += [t.get_text() for t in S.plot_sweep_grid(ds, "rms_g", piece).axes[0].get_legend().get_texts()]
    assert labels == [f"static_g = {g:g}, range_g = {r:g}" for g in (1.0, 0.0, -1.0) for r in (2.0, 4.0, 8.0, 16.0)]


def _lot8(out: Path) -> Path:
    """A lot over 8 grid points: more than a figure's histogram panels (6) and scatter rows (4)."""
    doc = {"kind": "model", "name": "lot8", "seed": 7, "fixed": {**RESONANCE, "q": 5.0},
           "grid": {"rms_g": [0.5, 1.5, 2.5, 3.0], "static_g": [1.0, -1.0]},
           "montecarlo": {"units": 8, "k2_ug_per_g2": {"dist": "normal", "mean": 0.0, "sd": 3000.0}}}
    run_sweep(parse_spec(doc), out)
    return out


def test_a_lot_of_more_grid_points_than_a_figure_holds_shows_them_all(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _lot8(tmp_path / "lot8")
    text = _report(folder, capsys)
    full = (folder / "report.html").read_text(encoding="utf-8")
    assert "first 6 of" not in text and "(grid points 7–8 of 8)" in text and "(grid points 5–8 of 8)" in text
    assert text.count("<img ") == 1 + 2 + 2  # the spread, 8/6 histogram figures, 8/4 scatter figures
    # every grid point has its histogram panel (its title, in the figures' interactive twins)
    for rms in (0.5, 1.5, 2.5, 3.0):
        for g0 in (1, -1):
            assert f"rms_g = {rms:g}, static_g = {g0:g} (8 of 8 units)" in full
    stats = text.split("VRE across the lot</h4>", 1)[1].split("</table>", 1)[0]
    assert stats.count("<tr>") == 1 + 8  # the header and every grid point


def test_lot_spread_is_the_units_mean_and_5_to_95_percentile_band_per_grid_point(tmp_path: Path) -> None:
    ds = _open(_lot8(tmp_path / "lot8"))
    ax = S.plot_lot_spread(ds).axes[0]
    for g0 in (1.0, -1.0):
        v_mg = ds["vre_g"].sel(static_g=g0).transpose("rms_g", "unit").values * 1e3
        mean = [ln for ln in ax.get_lines() if ln.get_label() == f"static_g = {g0:g}: mean"][0]
        np.testing.assert_allclose(mean.get_xdata(), [0.5, 1.5, 2.5, 3.0])
        np.testing.assert_allclose(mean.get_ydata(), v_mg.mean(axis=1), rtol=1e-12)
        band = [c for c in ax.collections if c.get_label() == f"static_g = {g0:g}: 5th–95th percentile"][0]
        verts = band.get_paths()[0].vertices
        np.testing.assert_allclose(sorted(verts[:, 1])[0], np.percentile(v_mg, 5, axis=1).min(), rtol=1e-12)
        np.testing.assert_allclose(sorted(verts[:, 1])[-1], np.percentile(v_mg, 95, axis=1).max(), rtol=1e-12)
    assert np.ptp(ds["vre_g"].sel(rms_g=3.0).values) > 1.0  # the drawn k2 spreads the lot: a band, not a line


def test_folder_with_neither_result_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = _one_line_error(["report", str(tmp_path)], capsys)
    assert "results.json" in err and "result.nc" in err
    assert not (tmp_path / "report.html").exists()


@pytest.mark.parametrize("content", [b"", b"not a NetCDF file at all\n" * 10])
def test_corrupt_netcdf_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes) -> None:
    (tmp_path / "result.nc").write_bytes(content)
    err = _one_line_error(["report", str(tmp_path)], capsys)
    assert "result.nc" in err and "not a readable NetCDF" in err
    assert not (tmp_path / "report.html").exists()


def test_netcdf_that_is_not_a_sweep_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(tmp_path / "result.nc", engine="h5netcdf")
    err = _one_line_error(["report", str(tmp_path)], capsys)
    assert "not a vrelab sweep result" in err


@pytest.mark.browser
def test_sweep_report_renders_in_chromium_with_all_images(tmp_path: Path) -> None:
    folder = _lot(tmp_path / "lot")
    assert main(["report", str(folder)]) == 0
    png = SCREENSHOT_DIR / "report-sweep-lot.png"
    state, events = render_in_chromium(folder / "report.html", tmp_path, png)
    assert_rendered_cleanly(state, events, 3)
    assert png.stat().st_size > 20_000


def test_error_bars_are_plus_minus_u_in_mg_when_the_result_has_u_vre_g(tmp_path: Path) -> None:
    """The simulate kind adds u_vre_g (too slow to run here): grafted on a real grid result."""
    ds = _open(_grid(tmp_path / "grid"))
    u = xr.full_like(ds["vre_g"], 0.0)
    u.values[:] = np.linspace(0.001, 0.003, u.size).reshape(u.shape)
    ds["u_vre_g"] = u
    ax = S.plot_sweep_grid(ds).axes[0]
    assert ax.get_ylabel() == "VRE (mg) ± u"
    bars = ax.containers[1]  # static_g = -1
    segs = np.array(bars.lines[2][0].get_segments())
    np.testing.assert_allclose(segs[:, 0, 1], (ds["vre_g"] - u).sel(static_g=-1.0).values * 1e3, rtol=1e-12)
    np.testing.assert_allclose(segs[:, 1, 1], (ds["vre_g"] + u).sel(static_g=-1.0).values * 1e3, rtol=1e-12)
    figs, _ = S.sweep_figures(ds)
    assert "±1 standard uncertainty" in figs[0].caption
