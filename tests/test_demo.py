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
import shutil
from pathlib import Path

import numpy as np
import pytest

from test_report_browser import markup_only
from vrelab.cli import main
from vrelab.models.clipping import censored_mean_shift

N_FIGURES = 11


@pytest.fixture(scope="module")
def demo(quick_demo_out: dict) -> dict:
    """`vrelab demo --quick --json --metadata` (test_report_browser.METADATA), run once per run by tests/conftest.py and
    shared with tests/test_report_layout.py: read only (a test that writes copies first)."""
    return quick_demo_out


def test_demo_runs_and_says_where_the_report_is(demo: dict) -> None:
    # how long it takes is bench/'s to measure, not a test's (a busy machine took 40 s)
    assert demo["rc"] == 0
    doc = json.loads(demo["stdout"])
    assert Path(doc["report"]) == demo["out"] / "report.html"
    lines = demo["stderr"].splitlines()
    assert len(lines) == 6 and all(re.match(r"vrelab demo: \[\d/6\] .+: done in [\d.]+ s$", ln) for ln in lines), lines


def test_report_holds_every_study_with_decodable_figures(demo: dict) -> None:
    text = (demo["out"] / "report.html").read_text(encoding="utf-8")
    for title in ("At a glance", "Figure 1", "Figure 2", "Figure 3", "Figure 4", "Datasheet VRE limit", "Sine method"):
        assert f"{title}" in text
    imgs = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', markup_only(text))
    # Figure 1's time series; Figure 2's rail fit, drive PSD and time history; Figure 3's and 4's
    # comparison and time histories; the limit; VRC(f) and VRE against rms²
    assert len(imgs) == N_FIGURES == 11
    assert all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in imgs)
    assert "http://" not in markup_only(text) and "https://" not in markup_only(text)
    assert "Drive check: reference PSD at 2.5 g rms" in text and "±3 dB tolerance" in text
    assert text.count("Time history:") >= 3 and "over-range hold" in text
    # the metadata reached the demo's test report
    assert "VRE-2025-014" in text and "PCB 352C33" in text


def _levels_table(text: str, heading: str) -> list[str]:
    """The VRE column (mg, as shown: value ± u) of the levels table under ``heading``."""
    table = text.split(f"<h4>{heading}</h4>", 1)[1].split("</table>", 1)[0]
    head = re.findall(r"<th[^>]*>(.*?)</th>", table)
    col = head.index("VRE ± u (mg)")
    rows = [re.findall(r"<td[^>]*>(.*?)</td>", r) for r in re.findall(r"<tr>(.*?)</tr>", table.split("<tbody>", 1)[1])]
    return [r[col].split(" ± ")[0] for r in rows]


@pytest.mark.parametrize(
    "heading, folder",
    [("X axis (Q 7.4): Levels", "fig3-x-8g"), ("Z axis (Q 1.5): Levels", "fig3-z-8g"),
     ("1 kHz bandwidth: Levels", "fig4-y-1khz"), ("125 Hz bandwidth: Levels", "fig4-y-125hz")],
)
def test_figures_3_and_4_tabulate_both_configurations(demo: dict, heading: str, folder: str) -> None:
    text = (demo["out"] / "report.html").read_text(encoding="utf-8")
    shown = _levels_table(text, heading)
    saved = json.loads((demo["out"] / folder / "results.json").read_text())["levels"]
    assert len(shown) == len(saved) > 1
    for cell, lv in zip(shown, saved):  # the same VRE, rounded to the digits shown
        decimals = len(cell.split(".")[1]) if "." in cell else 0
        assert abs(float(cell) - 1e3 * lv["vre_g"]) <= 0.5 * 10**-decimals + 1e-9


def test_demo_report_stays_under_8_mb(demo: dict) -> None:
    """The file a user mails: plotly.js (about 4.8 MB) once, each figure's PNG and twin. The full
    demo has the same figures with more levels in its tables (measured 6.5 MB against 6.4 MB)."""
    assert (demo["out"] / "report.html").stat().st_size < 8_000_000


def test_overrange_window_finder_wants_a_whole_hold_at_zero() -> None:
    """What the demo centres its time histories on: a stretch of one hold time (0.5 ms, 4 samples
    at 8 kHz) with the output within 10 mg of 0 g; a zero crossing of a few samples is not one."""
    from vrelab.demo import _overrange_at

    ref = np.full(100, 3.0)
    dut = np.linspace(-1.0, 1.0, 100)  # crosses 0 g: two samples within 10 mg
    assert _overrange_at({"reference": ref, "dut": dut}, 8000.0, 0.0005) is None
    dut[60:66] = 0.002  # six samples held near 0 g
    assert _overrange_at({"reference": ref, "dut": dut}, 8000.0, 0.0005) == 62


def test_each_study_folder_reports_on_its_own(demo: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folders = json.loads(demo["stdout"])["folders"]
    assert {"fig1-clipping", "fig2-z-2g", "fig3-x-8g", "fig3-z-8g", "fig4-y-1khz", "fig4-y-125hz", "sine-x-8g"} <= set(folders)
    for f in folders:
        assert (demo["out"] / f / "results.json").is_file() and (demo["out"] / f / "levels.csv").is_file()
    assert (demo["out"] / "fig1-clipping" / "record.h5").is_file()
    study = shutil.copytree(demo["out"] / "fig1-clipping", tmp_path / "fig1-clipping")  # the demo's folder is shared
    assert main(["report", str(study)]) == 0
    text = (study / "report.html").read_text()
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


def test_demo_report_reads_in_one_voice_with_gum_digits(demo: dict) -> None:
    """The rendered text: every value ± u by GUM 7.2.6, the prediction table without exponents
    (shares below 0.001 mg are 0), the limit compared in 5.6 and no decision claimed without a
    limit given to a result (6), the test item naming which sections used which sensor, and the
    sensor's fields with names and units (its k2 of 2e-05 1/g is the preset's 20 µg/g²)."""
    from test_format import gum_violations, visible_text

    text = visible_text((demo["out"] / "report.html").read_text(encoding="utf-8"))
    assert gum_violations(text) == []
    pred = text[text.index("Prediction: mechanisms' shares"):]
    pred = pred[:pred.index("Provenance")]
    assert not re.search(r"\de[-+]?\d", pred) and "Predicted values to 0.001 mg" in pred
    limit = text[text.index("5.6 Datasheet VRE limit", text.index("5.6 Datasheet VRE limit") + 1):]
    limit = limit[:limit.index("5.7 ")]
    assert "a comparison of a simulation, not a decision" in limit and "verdict" not in limit
    assert "No limit was given to any result, so no level was judged" in text
    assert re.search(r"\[ideal\] \(section 5\.2\); simulated: ADXL355 .*\[adxl355\] \(sections 5\.3, ", text)
    assert re.search(r"k2\s+20 µg/g²", text) and "rails g" not in text and "null" not in text


def test_bad_seconds_is_refused_before_running(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--seconds", "0.1", "--out", str(tmp_path / "d")]) == 2
    assert "--seconds must be >= " in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@pytest.mark.browser
def test_demo_report_renders_in_chromium(demo_visit: dict) -> None:
    """The demo's report in headless Chromium (tests/conftest.py's demo_visit: loaded once per run,
    with tests/test_report_layout.py's measurements), its figures hovered and zoomed, printed on A4."""
    from test_report_browser import assert_prints_cleanly, assert_rendered_cleanly

    state, events, pdf = demo_visit["state"], demo_visit["events"], demo_visit["pdf"]
    assert_rendered_cleanly(state, events, N_FIGURES)
    assert state["h"] > 8000  # six sections with their tables
    pages = assert_prints_cleanly(state, pdf, min_pages=12)
    assert "Report VRE-2025-014" in pages[0]["text"] and "7 Approval" in pages[-1]["text"]
    # a value folded away on screen (the sensor's description) is printed whole, as a table a
    # person reads: field names, units, no JSON escapes ("\u00b12 g") and no "null"
    # (whitespace folded: a narrow key column may wrap "overrange retrigger" between its words)
    printed = " ".join("".join(p["text"] for p in pages).split())
    assert "overrange retrigger" in printed and "22.5 µg/√Hz" in printed
    assert "\\u00" not in printed and "null" not in printed and '{"name"' not in printed
