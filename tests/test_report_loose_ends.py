"""The report without loose ends (issue 33): what the results or the metadata know is never "not
given"; dates checked; A4 unless the metadata says letter; a parameter the data cannot determine
shown as "not determined", never as a number; repeated warnings collapsed with a count; one unit
and one sign per quantity; a simulation study without rows of laboratory fields "not given".

Each report here is written from a few hand-made results (milliseconds), not a run."""

from __future__ import annotations

import datetime as dt
import json
import re
from pathlib import Path

import pytest

from vrelab.report import plots, report_dir
from vrelab.report.html import collapse_warnings
from vrelab.report.metadata import parse_metadata
from vrelab.report.testreport import page_css
from vrelab.results import ClipModel, Conditions, Estimate, FitResult, LevelResult, VrcModel, VreResult


def _measured(rail: Estimate | None = None, warnings: tuple[str, ...] = ()) -> VreResult:
    """A reduced recording as a campaign run's channel holds it: no sensor, range, axis, ODR in its
    conditions (a file does not say them), the sample rate in its provenance."""
    rms = (0.25, 0.5, 1.0)
    levels = tuple(LevelResult(r, Estimate(-0.001 * r**2, 0.0002), n_samples=6000) for r in rms)
    fits = (FitResult(ClipModel({"rail_g": rail}), 3, 1.0, levels_used=rms),) if rail is not None else ()
    cond = Conditions(model="measured", static_g=1.0)
    prov = {"fs_hz": 6000.0, "input_file": "run.tdms", "channels": {"dut": "sn1_z", "reference": "ref"}}
    return VreResult("random", cond, levels, fits, warnings, prov, "measurement")


def _report(tmp_path: Path, result: VreResult, metadata: str | None = None) -> str:
    (tmp_path / "results.json").write_text(json.dumps(result.to_dict()))
    meta = None
    if metadata is not None:
        meta = tmp_path / "meta.toml"
        meta.write_text(metadata)
    return report_dir(tmp_path, metadata=meta).read_text(encoding="utf-8")


def _section(text: str, heading: str) -> str:
    return text.split(f"<h2>{heading}</h2>", 1)[1].split("</section>", 1)[0]


def test_recorded_fields_come_from_the_record_and_the_metadata_never_not_given(tmp_path: Path) -> None:
    """The example campaign's report said "not given" for sensor, range, axis and ODR: a
    recording's results hold its sample rate, and the metadata's [item] the rest."""
    meta = '[item]\nmanufacturer = "Analog Devices"\nmodel = "ADXL355"\nrange = "±2 g"\naxis = "Z"\n'
    item = _section(_report(tmp_path, _measured(), meta), "1 Test item")
    known = item.split("Recorded in the results", 1)[1]
    row = re.findall(r"<td[^>]*>(.*?)</td>", known.split("<tbody>", 1)[1].split("</tr>", 1)[0])
    assert row[1:5] == ["Analog Devices ADXL355 (metadata [item])", "±2 g (metadata [item] range)",
                        "Z (metadata [item] axis)", "6000 Hz (the record&#x27;s sample rate)"]


_LAB = """report_number = "R-1"
[equipment]
reference_calibration = "cert. 2024-118, calibrated 2024-11-02, due 2025-11-02"
[approval]
prepared_by = "A. Tester"
date = 2025-03-14
"""


def test_dates_an_issue_before_generation_and_a_calibration_past_due_are_flagged(tmp_path: Path) -> None:
    """ISO/IEC 17025 7.8.2.1: a date of issue 2025-03-14 on a report generated today, and the
    reference's calibration due 2025-11-02 at a test on 2025-12-01: both in the report's warnings;
    the approval rows carry the date of issue where no date of their own is given."""
    text = _report(tmp_path, _measured(), _LAB + '[procedure]\ntest_date = 2025-12-01\n')
    head = text.split("<main>", 1)[0]
    warn = re.search(r'<ul class="warn dates">(.*?)</ul>', head)
    assert warn, "no date warning in the report's header"
    today = dt.datetime.now(dt.UTC).date()
    assert f"date of issue 2025-03-14 is {(today - dt.date(2025, 3, 14)).days} days before" in warn.group(1)
    assert "past due at the test: due 2025-11-02, tested 2025-12-01" in warn.group(1)
    assert "date of issue 2025-03-14 is before the test (2025-12-01" in warn.group(1)
    appr = _section(text, "7 Approval")
    assert re.search(r"<th>Prepared by</th><td>A. Tester</td><td>2025-03-14 \(date of issue\)</td>", appr)


def test_consistent_dates_raise_no_warning(tmp_path: Path) -> None:
    """The same checks on dates that agree (issued today, tested within the calibration): nothing
    said (the test above cannot pass by flagging everything)."""
    today = dt.datetime.now(dt.UTC).date()
    meta = _LAB.replace("date = 2025-03-14", f"date = {today}") + "[procedure]\ntest_date = 2025-06-01\n"
    assert '<ul class="warn dates">' not in _report(tmp_path, _measured(), meta)


def test_a_rail_the_levels_do_not_reach_is_not_determined_never_a_number(tmp_path: Path) -> None:
    """A rail fitted as (0.0 ± 1.6)·10¹³ g is shown as "not determined" with the reason (its u
    against vrelab.gum.MAX_REL_U), in the fits table and the figure's legend."""
    res = _measured(rail=Estimate(12.0, 1.6e13))
    text = _report(tmp_path, res)
    assert "10¹³" not in text and "u = 1.3e+12 × the value" in text
    assert plots.fit_param_text("rail_g", 0.0, 1.6e13, "g").startswith("not determined (u = 1.6e+13 with a value of 0")
    assert "effective rail = not determined" in text
    assert "not determined" in plots._fit_label(res.fits[0])
    # a determined rail stays a number
    assert plots.fit_param_text("rail_g", 1.957, 0.028, "g") == "1.957 ± 0.028 g"


def test_repeated_warnings_are_collapsed_with_a_count(tmp_path: Path) -> None:
    segs = tuple(f"segment {a}-{a + 2} s is short for settle_s=0.5 s: trimmed 0.5 s per edge" for a in range(0, 14, 2))
    got = collapse_warnings([*segs, "drive clipped", "drive clipped"])
    assert got == [segs[0] + " (×7; the others: 2-4, 4-6, 6-8, 8-10, 10-12, 12-14)", "drive clipped (×2)"]
    text = _report(tmp_path, _measured(warnings=segs))
    assert text.count("is short for settle_s") == 1 and "(×7;" in text


def test_a4_unless_the_metadata_says_letter() -> None:
    assert "size: A4;" in page_css(parse_metadata({}), "t")
    assert "size: letter;" in page_css(parse_metadata({"paper": "Letter"}), "t")
    with pytest.raises(ValueError, match="paper must be one of A4, letter, got 'A5'"):
        parse_metadata({"paper": "A5"})


def test_a_simulation_study_lists_no_laboratory_fields_not_given(tmp_path: Path) -> None:
    """The demo opened with 20 laboratory fields "not given": a simulation has no laboratory."""
    res = _measured()
    sim = VreResult(res.method, Conditions(sensor="adxl355", model="simulation", static_g=1.0, range_g=2.0, axis="z",
                                           odr_hz=4000.0, bandwidth_hz=1000.0),
                    res.levels, (), (), {"created_utc": "2026-01-02T03:04:05+00:00"}, "simulation")
    text = _report(tmp_path, sim)
    front = text.split('<section class="major" id="results">', 1)[0]
    # the laboratory's fields (label, value rows); the results' own fields may still lack a value
    assert re.findall(r"<th>([^<]*)</th><td>not given", front) == []
    assert "<th>manufacturer</th>" not in front  # no item table of "not given"
    assert "a simulation study" in front and "2026-01-02 (the simulation&#x27;s date)" in front
    # a measurement's report still says what the laboratory left out
    assert len(re.findall(r"</th><td>not given", _report(tmp_path, _measured()).split('id="results"', 1)[0])) >= 10


def test_vre_in_mg_in_every_figure_and_vrc_with_its_sign_on_every_channel(monkeypatch: pytest.MonkeyPatch) -> None:
    """VRE is in mg in the tables; the rms² figure was in µg. The campaign's VRC(f) figure drew
    −VRC for a channel whose VRCs were all negative and VRC for the other."""
    from vrelab.report.campaign import vrc_figure

    levels = tuple(LevelResult(a, Estimate(-2000e-6 * a * a, 1e-6), freq_hz=300.0) for a in (0.5, 1.0, 2.0))
    fit = FitResult(VrcModel({"vrc_ug_per_g2": Estimate(-2000.0, 1.0)}), 3, 1.0, freq_hz=300.0, levels_used=(0.5, 1.0, 2.0))
    ax = plots.plot_vre_vs_rms2(VreResult("sine", Conditions(static_g=1.0), levels, (fit,))).axes[0]
    assert ax.get_ylabel() == "VRE (mg)"
    x, y = next(ln for ln in ax.get_lines() if "VRC" in str(ln.get_label())).get_data()
    assert y[-1] / x[-1] == pytest.approx(-2.0)  # -2000 µg/g² = -2 mg/g²
    pts = [{"freq_hz": f, "static_g": 1.0, "vrc_ug_per_g2": {"value": -v, "u": 10.0}} for f, v in ((80, 1500), (300, 1700))]
    from vrelab.report import campaign

    monkeypatch.setattr(campaign.ReportFigure, "from_figure", staticmethod(lambda fig, caption="": fig))
    ax = vrc_figure({"channel": "sn2", "vrc_by_freq": pts}).axes[0]  # type: ignore[union-attr]
    assert ax.get_ylabel().startswith("VRC (µg/g²")
    assert all(y < 0 for line in ax.get_lines() for y in line.get_ydata() if y == y)
