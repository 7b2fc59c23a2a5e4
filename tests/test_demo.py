"""`vrelab demo --quick`: the article's case study runs, reports, and its numbers have the
article's sign and size.

Reference values: SPEC 1.1 (censored model, μ = 1 g, ±2 g rails, σ = 1 g rms: -83 mg; the
article's Figure 1 reads about -100 mg), the article's Figure 2 (effective rail 2.5 g, departure
above about 2.5 g rms), Figure 3 (high-Q X/Y axes rectify more than Z), Figure 4 (125 Hz
bandwidth rectifies less than 1 kHz), the ADXL355 data sheet Rev. D (|VRE| < 0.4 g at 2.5 g rms)
and SPEC 1.3 (sine VRC(f) = k2·|H(f)|², amplified near fn = 2.4 kHz).
"""

from __future__ import annotations

import base64
import json
import re
import time
from pathlib import Path

import pytest

from test_report_browser import markup_only

from vrelab.cli import main
from vrelab.models.clipping import censored_mean_shift


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("demo") / "demo-out"
    import contextlib
    import io

    err, std = io.StringIO(), io.StringIO()
    t0 = time.monotonic()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
        rc = main(["demo", "--quick", "--out", str(out), "--json"])
    return {"rc": rc, "out": out, "stderr": err.getvalue(), "stdout": std.getvalue(), "elapsed": time.monotonic() - t0}


def test_demo_runs_quickly_and_says_where_the_report_is(demo: dict) -> None:
    assert demo["rc"] == 0
    doc = json.loads(demo["stdout"])
    assert Path(doc["report"]) == demo["out"] / "report.html"
    assert demo["elapsed"] < 20.0  # quick mode: a few seconds of simulation
    lines = demo["stderr"].splitlines()
    assert len(lines) == 6 and all(re.match(r"vrelab demo: \[\d/6\] .+: done in [\d.]+ s$", ln) for ln in lines), lines


def test_report_holds_every_study_with_decodable_figures(demo: dict) -> None:
    text = (demo["out"] / "report.html").read_text(encoding="utf-8")
    for title in ("At a glance", "Figure 1", "Figure 2", "Figure 3", "Figure 4", "Datasheet VRE limit", "Sine method"):
        assert f"{title}" in text
    imgs = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', markup_only(text))
    assert len(imgs) == 7  # time series, rail fit, X vs Z, bandwidths, limit, VRC(f), rms²
    assert all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in imgs)
    assert "http://" not in markup_only(text) and "https://" not in markup_only(text)


def test_each_study_folder_reports_on_its_own(demo: dict, capsys: pytest.CaptureFixture[str]) -> None:
    folders = json.loads(demo["stdout"])["folders"]
    assert {"fig1-clipping", "fig2-z-2g", "fig3-x-8g", "fig3-z-8g", "fig4-y-1khz", "fig4-y-125hz", "sine-x-8g"} <= set(folders)
    for f in folders:
        assert (demo["out"] / f / "results.json").is_file() and (demo["out"] / f / "levels.csv").is_file()
    assert (demo["out"] / "fig1-clipping" / "record.h5").is_file()
    assert main(["report", str(demo["out"] / "fig1-clipping")]) == 0
    text = (demo["out"] / "fig1-clipping" / "report.html").read_text()
    assert text.count("<img ") == 2  # VRE vs level, and the record's time series


def _numbers(demo: dict) -> dict:
    return json.loads(demo["stdout"])["numbers"]


def test_figure1_clipping_shift_is_the_censored_model_near_minus_83mg(demo: dict) -> None:
    """SPEC 1.1: -83 mg at 1 g rms (censored); the article reads about -100 mg."""
    n = _numbers(demo)
    assert censored_mean_shift(1.0, 1.0, -2.0, 2.0) == pytest.approx(-0.0831, abs=5e-4)  # the reference itself
    assert -0.120 < n["fig1_vre_1g"] < -0.060
    assert abs(n["fig1_vre_1g"] - n["fig1_censored_model"]) < 4 * n["fig1_u_1g"] + 0.003
    assert abs(n["fig1_vre_03g"]) < 0.005  # 0.3 g rms: the rails are 3.3 sigma away


def test_figure2_rail_near_article_2p5g_and_data_leave_the_model(demo: dict) -> None:
    n = _numbers(demo)
    assert 2.2 < n["fig2_rail_g"] < 3.0  # article: 2.5 g
    assert n["fig2_departure_rms_g"] is not None and 2.0 < n["fig2_departure_rms_g"] <= 4.0


def test_datasheet_limit_vre_within_0p4g_at_2p5grms(demo: dict) -> None:
    """ADXL355 data sheet Rev. D: |VRE| < 0.4 g at 2.5 g rms (±2 g, 1 g, 50 Hz–2 kHz, ODR 4 kHz)."""
    n = _numbers(demo)
    assert -0.4 < n["limit_vre_at_2p5"] < -0.15
    # SPEC 1.1: the article's 2.5 g rail gives -0.33 g censored, -0.71 g truncated at 2.5 g rms
    assert n["limit_article_censored"] == pytest.approx(-0.33, abs=0.01)
    assert n["limit_article_truncated"] == pytest.approx(-0.71, abs=0.01)


def test_figure3_high_q_axis_rectifies_more(demo: dict) -> None:
    n = _numbers(demo)
    assert n["fig3_x_at_5"] < n["fig3_z_at_5"] < 0


def test_figure4_narrow_bandwidth_rectifies_less(demo: dict) -> None:
    n = _numbers(demo)
    assert n["fig4_1khz_at_2"] < n["fig4_125hz_at_2"] < 0
    assert abs(n["fig4_125hz_at_2"]) < 0.7 * abs(n["fig4_1khz_at_2"])


def test_sine_vrc_is_amplified_q_squared_at_resonance(demo: dict) -> None:
    """SPEC 1.3: VRC(f) = k2·|H(f)|²; at fn, |H|² = Q² = 7.4² ≈ 55 (ADXL355 X axis, datasheet Q)."""
    n = _numbers(demo)
    assert n["sine_model_vrc_2400"] == pytest.approx(n["sine_k2_ug"] * 7.4**2, rel=0.01)
    assert n["sine_vrc_2400"] == pytest.approx(n["sine_model_vrc_2400"], abs=4 * n["sine_u_vrc_2400"] + 0.1 * n["sine_model_vrc_2400"])
    assert n["sine_vrc_2400"] > 10 * abs(n["sine_vrc_1000"])  # far below fn: tens of µg/g²


def test_bad_seconds_is_refused_before_running(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--seconds", "0.1", "--out", str(tmp_path / "d")]) == 2
    assert "--seconds must be >= " in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@pytest.mark.browser
def test_demo_report_renders_in_chromium(demo: dict, tmp_path: Path) -> None:
    from test_report_browser import (
        SCREENSHOT_DIR,
        assert_rendered_cleanly,
        render_in_chromium,
    )

    state, events = render_in_chromium(demo["out"] / "report.html", tmp_path, SCREENSHOT_DIR / "demo-report.png")
    assert_rendered_cleanly(state, events, 7)
    assert state["h"] > 8000  # six sections with their tables
