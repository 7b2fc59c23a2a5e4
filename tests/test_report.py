"""Plots and the HTML report, from results built here (no simulation needed).

Reference values: SPEC 1.1 (from the article's setting, μ = 1 g, ±2 g rails, σ = 1 g rms):
censored -83 mg, truncated -283 mg; SPEC 1.2: VRE = VRC·rms².
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

from vrelab import __version__ as vrelab_version
from vrelab.cli import main
from vrelab.record import Schedule, Segment, write_record_hdf5
from vrelab.report import plots, report_dir
from vrelab.report.html import (
    ReportFigure,
    ReportSection,
    collect_warnings,
    write_report,
)
from vrelab.results import ClipModel, Conditions, Estimate, FitResult, LevelResult, VrcModel, VreResult


def _random_result(rail_g: float = 2.0, departure: float | None = 3.0) -> VreResult:
    rms = [0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 3.5]
    levels = tuple(
        LevelResult(
            r,
            Estimate(-0.0831 * r**2, 0.0004),
            n_samples=50_000,
            n_saturated=0 if r < 1 else int(1000 * r),
            flags=("over-range",) if r >= 3 else (),
        )
        for r in rms
    )
    fits = (
        FitResult(ClipModel({"rail_g": Estimate(rail_g, 0.02)}), 5, 1.1, levels_used=tuple(rms[:5]), departure_rms_g=departure),
        FitResult(VrcModel({"vrc_ug_per_g2": Estimate(50.0, 2.0)}), 2, 0.9, levels_used=(0.25, 0.5)),
    )
    cond = Conditions(sensor="adxl355", model="simulation", profile="random flat 50-2000 Hz", static_g=1.0, range_g=2.048, bandwidth_hz=1000.0, axis="z")
    return VreResult("random", cond, levels, fits, ("drive clipped at 5 sigma",), {"input": "run.h5"}, "simulation")


def _sine_result() -> VreResult:
    levels, fits = [], []
    for f, vrc in [(100.0, 40.0), (1000.0, 60.0), (2400.0, 2000.0)]:
        for a in (0.5, 1.0, 2.0):
            levels.append(LevelResult(a, Estimate(vrc * 1e-6 * a * a, 1e-6), freq_hz=f))
        fits.append(FitResult(VrcModel({"vrc_ug_per_g2": Estimate(vrc, 1.0)}), 3, 1.0, freq_hz=f, levels_used=(0.5, 1.0, 2.0)))
    return VreResult("sine", Conditions(sensor="adxl355", static_g=1.0, range_g=8.192, axis="x", extra={"fn_hz": 2400.0}), tuple(levels), tuple(fits))


def _line(ax, label_part: str):
    lines = [ln for ln in ax.get_lines() if label_part in str(ln.get_label())]
    assert lines, f"no line labelled like {label_part!r}: {[ln.get_label() for ln in ax.get_lines()]}"
    return lines[0]


# --------------------------------------------------------------------------- plots
def test_clip_curves_reproduce_spec_reference_values_censored_83mg_truncated_283mg() -> None:
    """SPEC 1.1: μ = 1 g, ±2 g rails, σ = 1 g rms: censored -83 mg, truncated -283 mg."""
    fig = plots.plot_vre_vs_rms(_random_result(rail_g=2.0))
    ax = fig.axes[0]
    cens, trunc = _line(ax, "censored model"), _line(ax, "truncated model")
    assert np.interp(1.0, *cens.get_data()) == pytest.approx(-83.0, abs=0.6)
    assert np.interp(1.0, *trunc.get_data()) == pytest.approx(-283.0, abs=1.0)
    assert ax.get_ylabel() == "VRE (mg)" and "g rms" in ax.get_xlabel()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("rail ±2.000 ± 0.020 g" in t for t in labels), labels  # the fitted rail in the legend (GUM 7.2.6 digits)
    assert any("VRC 50.0 ± 2.0 µg/g²" in t for t in labels), labels
    assert any("above 3 g rms" in t for t in labels), labels  # where the data leave the model


def test_vre_points_in_mg_and_overrange_levels_drawn_hollow() -> None:
    res = _random_result()
    ax = plots.plot_vre_vs_rms(res).axes[0]
    bars = {c.get_label(): c for c in ax.containers}
    filled = bars["ADXL355, ±2.048 g, Z axis, BW 1000 Hz, +1 g field"].lines[0]  # no over-range flag
    x, y = filled.get_data()
    assert list(x) == [0.25, 0.5, 1.0, 1.5, 2.0]
    assert y == pytest.approx([-0.0831 * r**2 * 1e3 for r in x])
    hollow = bars["ADXL355, ±2.048 g, Z axis, BW 1000 Hz, +1 g field: over-range protection tripped"].lines[0]
    assert hollow.get_markerfacecolor() == "white" and list(hollow.get_xdata()) == [3.0, 3.5]


def test_vrc_line_is_vrc_times_rms_squared() -> None:
    """SPEC 1.2: VRE = VRC·rms²; 50 µg/g² at 2 g rms is 200 µg."""
    c = plots.vrc_curve(50.0, [0.0, 1.0, 2.0])
    assert c.y == pytest.approx([0.0, 50e-6, 200e-6])


def test_rms2_plot_slope_is_the_fitted_vrc_per_frequency() -> None:
    ax = plots.plot_vre_vs_rms2(_sine_result()).axes[0]
    x, y = _line(ax, "2400 Hz: VRC").get_data()
    assert y[-1] / x[-1] == pytest.approx(2.0)  # 2000 µg/g² = 2 mg/g²: VRE in mg, as in the tables
    assert ax.get_ylabel() == "VRE (mg)"


def test_vrc_vs_frequency_marks_resonance_and_uses_log_axes_for_a_peak() -> None:
    ax = plots.plot_vrc_vs_freq(_sine_result(), fn_hz=2400.0).axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"  # 40 .. 2000 µg/g² spans decades
    fn = _line(ax, "resonance fn = 2400 Hz")
    assert fn.get_xdata()[0] == 2400.0
    with pytest.raises(ValueError, match="per-frequency"):
        plots.plot_vrc_vs_freq(_random_result())


def _write_record(path: Path, fs: float, n_per_seg: int, seed: int = 3) -> tuple[np.ndarray, np.ndarray, Schedule]:
    rng = np.random.default_rng(seed)
    dur = n_per_seg / fs
    sched = Schedule(tuple(Segment(i * dur, (i + 1) * dur, lvl) for i, lvl in enumerate([0.0, 0.3, 0.0, 1.0, 0.0])))
    x = np.concatenate([rng.normal(0.0, s.nominal_rms_g, n_per_seg) for s in sched.segments])
    ref = 1.0 + x
    dut = np.clip(ref, -2.0, 2.0)
    blocks = ({"reference": ref[i : i + 7777], "dut": dut[i : i + 7777]} for i in range(0, ref.size, 7777))
    write_record_hdf5(path, fs, blocks, sched)
    return ref, dut, sched


def test_record_envelope_is_exact_and_independent_of_read_block(tmp_path: Path) -> None:
    ref, dut, _ = _write_record(tmp_path / "r.h5", 1000.0, 10_000)
    want = dut.reshape(500, 100)
    # reads smaller than a bin, not aligned to bins, and larger than the record
    envs = [plots.record_envelope(tmp_path / "r.h5", n_bins=500, block_samples=b) for b in (37, 777, 10**6)]
    for env in envs:
        assert env.bin_size == 100 and len(env.t_s) == 500
        for k, fn in enumerate((np.min, np.max, np.mean)):
            np.testing.assert_allclose(env.channels["dut"][k], fn(want, axis=1), rtol=0, atol=1e-12)
    a = envs[0]
    assert a.schedule is not None and len(a.schedule.segments) == 5
    with pytest.raises(ValueError, match="none of the channels"):
        plots.record_envelope(tmp_path / "r.h5", channels=("nope",))


def test_record_envelope_reads_in_bounded_blocks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Memory must not grow with the record: no read larger than block_samples."""
    import h5py

    _write_record(tmp_path / "r.h5", 1000.0, 20_000)
    sizes: list[int] = []
    orig = h5py.Dataset.__getitem__

    def spy(self, key):
        out = orig(self, key)
        if self.name in ("/dut", "/reference"):
            sizes.append(np.size(out))
        return out

    monkeypatch.setattr(h5py.Dataset, "__getitem__", spy)
    plots.record_envelope(tmp_path / "r.h5", n_bins=50, block_samples=4096)  # bins of 2000 samples
    assert sizes and max(sizes) <= 4096 and sum(sizes) == 2 * 100_000


def test_time_series_shows_clipping_and_the_segment_shift_near_minus_83mg(tmp_path: Path) -> None:
    """1 g field, ±2 g rails, 1 g rms Gaussian: the clipped mean moves by -83 mg (SPEC 1.1)."""
    _write_record(tmp_path / "r.h5", 4000.0, 200_000)
    fig = plots.plot_time_series(plots.record_envelope(tmp_path / "r.h5"), rails_g=(-2.0, 2.0))
    top, bottom = fig.axes
    clipped = _line(top, "clipped")
    assert len(clipped.get_xdata()) > 0 and set(np.round(clipped.get_ydata(), 9)) <= {2.0, -2.0}
    shifts = [float(re.sub("[^0-9.+-]", "", t.get_text())) for t in bottom.texts if t.get_text().endswith("mg")]
    assert len(shifts) == 2  # the 0.3 g and 1 g rms segments
    # SE of a 200 000-sample mean of the clipped 1 g rms signal is about 2 mg.
    assert shifts[1] == pytest.approx(-83.0, abs=8.0)
    assert abs(shifts[0]) < 8.0  # 0.3 g rms: far from the rails, no shift


def test_psd_plot_counts_lines_outside_tolerance() -> None:
    f = np.geomspace(50, 2000, 100)
    prof = np.full(f.size, 0.003)
    meas = prof.copy()
    meas[10:15] *= 10 ** (4 / 10)  # 4 dB high: outside ±3 dB
    ax = plots.plot_psd(f, meas, prof).axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert ax.get_ylabel() == "PSD (g²/Hz)"
    assert any("(5 lines)" in t.get_text() for t in ax.get_legend().get_texts())
    with pytest.raises(ValueError, match="one shape"):
        plots.plot_psd(f, meas[:-1], prof)


# --------------------------------------------------------------------------- HTML
def _png(fig) -> ReportFigure:
    return ReportFigure.from_figure(fig, "caption")


def test_write_report_is_self_contained_and_holds_every_section(tmp_path: Path) -> None:
    res = _random_result()
    secs = [
        ReportSection("Study A", "What A shows.", res, [_png(plots.plot_vre_vs_rms(res))], facts=[("VRE at 1 g rms", "-83 mg")]),
        ReportSection("Study B", "What B shows.", _sine_result(), [_png(plots.plot_vrc_vs_freq(_sine_result()))]),
    ]
    out = write_report(tmp_path / "r.html", secs, title="T", intro="Intro.")
    text = out.read_text(encoding="utf-8")
    assert not list(tmp_path.glob("*.partial"))
    markup = re.sub(r"<script[^>]*>.*?</script>", "", text, flags=re.S)  # plotly.js's source names URLs
    assert not re.search(r"""(src|href)\s*=\s*["'](?!data:|#)""", markup), "external reference in the report"
    assert not re.search(r"<script[^>]*\bsrc\s*=", text), "a script loaded from outside the file"
    imgs = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', markup)
    assert len(imgs) == 2 and all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in imgs)
    # Each figure's interactive twin is data (JSON, never run), plotly.js is in the file once.
    from plotly.offline import get_plotlyjs

    specs = re.findall(r'<script type="application/json" id="[^"]+">(.*?)</script>', text, flags=re.S)
    assert len(specs) == 2 and all(json.loads(s)["data"] for s in specs)
    assert text.count(get_plotlyjs()) == 1
    for s in ("Study A", "Study B", "What A shows.", "Intro.", 'href="#s2"', "VRE at 1 g rms", "vrelab version"):
        assert s in text
    # levels table: VRE ± u in mg with the digits the uncertainty asks for
    assert "-83.10 ± 0.40" in text  # 1 g rms level: -0.0831 g ± 0.0004 g
    assert "effective rail = 2.000 ± 0.020 g" in text


def test_warnings_cover_saturation_overrange_departure_and_psd() -> None:
    w = collect_warnings(_random_result(), {"passed": False, "max_dev_db": 4.0, "min_dev_db": -1.0, "tol_db": 3.0}, {"notes": ["outside Gaussian validity"]})
    joined = "\n".join(w)
    assert "drive clipped at 5 sigma" in joined
    assert "Saturation: 5 of 7 levels" in joined and "3.5 g rms" in joined
    assert "Over-range: flagged at 3, 3.5 g rms" in joined
    assert "leave the clip-censored model above 3 g rms" in joined
    assert "PSD out of tolerance" in joined and "+4.0" in joined
    assert "Prediction: outside Gaussian validity" in joined


def test_report_dir_reads_the_output_folder_and_checksums_inputs(tmp_path: Path) -> None:
    res = _random_result()
    (tmp_path / "results.json").write_text(json.dumps(res.to_dict()))
    (tmp_path / "run.h5").write_bytes(b"raw record bytes")
    (tmp_path / "prediction.json").write_text(
        json.dumps({"levels": [{"rms_g": 1.0, "vre_g": -0.083, "tilt_error_deg": 4.76, "shares": {"clipping": -0.0829, "nonlinearity": -0.0001}}]})
    )
    f = np.geomspace(50, 2000, 40)
    rows = "\n".join(f"{a},{0.003 * (3.0 if i == 5 else 1.0)},0.003" for i, a in enumerate(f))
    (tmp_path / "psd.csv").write_text("freq_hz,psd_measured_g2_per_hz,psd_profile_g2_per_hz\n" + rows + "\n")
    (tmp_path / "envelope.csv").write_text("t_s,reference_rms_g,dut_mean_g,segment\n" + "\n".join(f"{t},{0.0 if t < 5 else 1.0},{1.0 if t < 5 else 0.917},{'off' if t < 5 else 'level 1'}" for t in range(10)) + "\n")
    out = report_dir(tmp_path, argv=["vrelab", "report", str(tmp_path)])
    text = out.read_text(encoding="utf-8")
    assert hashlib.sha256((tmp_path / "results.json").read_bytes()).hexdigest() in text
    assert hashlib.sha256(b"raw record bytes").hexdigest() in text  # provenance: the input file
    assert f"vrelab report {tmp_path}" in text
    assert "clipping (mg)" in text and "-82.9" in text  # mechanisms' shares from prediction.json
    assert text.count("<img ") == 4  # VRE vs rms, VRE vs rms², envelope.csv, PSD


def test_sine_folder_gets_vrc_vs_frequency(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    seen: dict = {}
    orig = plots.plot_vrc_vs_freq

    def spy(result, **kw):
        seen.update(kw)
        return orig(result, **kw)

    monkeypatch.setattr(plots, "plot_vrc_vs_freq", spy)
    res = _sine_result()
    # fn from the sensor description in provenance when the conditions do not carry it
    res = dataclasses.replace(res, conditions=dataclasses.replace(res.conditions, extra={}), provenance={"sensor": {"fn_hz": 2400.0}})
    (tmp_path / "results.json").write_text(json.dumps(res.to_dict()))
    text = report_dir(tmp_path).read_text()
    assert text.count("<img ") == 2 and "VRC against sine frequency" in text
    assert seen["fn_hz"] == 2400.0


def test_report_write_is_atomic(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import vrelab.report.html as h

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(h.os, "replace", boom)
    with pytest.raises(OSError):
        write_report(tmp_path / "r.html", [ReportSection("S", "w.")])
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- CLI
def test_cli_report_writes_report_html(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "results.json").write_text(json.dumps(_random_result().to_dict()))
    assert main(["report", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert Path(out["report"]) == tmp_path / "report.html" and (tmp_path / "report.html").is_file()


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "no results.json"),
        ("{not json", "not valid JSON"),
        ("[1, 2]", "must hold a JSON object"),
        ('{"levels": []}', "not a vrelab results file"),
        ('{"method": "random", "levels": [{"rms_g": 1}]}', "not a vrelab results file"),
        ('{"method": "chirp"}', "method must be random or sine"),
    ],
)
def test_cli_report_bad_folder_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str | None, message: str) -> None:
    if content is not None:
        (tmp_path / "results.json").write_text(content)
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err
    assert not (tmp_path / "report.html").exists()


def test_cli_report_malformed_optional_files_are_one_line_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "results.json").write_text(json.dumps(_random_result().to_dict()))
    (tmp_path / "prediction.json").write_text('{"levels": [1, 2]}')
    assert main(["report", str(tmp_path)]) == 2
    assert "not a vrelab prediction" in capsys.readouterr().err
    (tmp_path / "prediction.json").unlink()
    (tmp_path / "record.h5").write_bytes(b"not hdf5")
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    (tmp_path / "record.h5").unlink()
    (tmp_path / "psd.csv").write_text("a,b\n1,2\n")
    assert main(["report", str(tmp_path)]) == 2
    assert "need frequency" in capsys.readouterr().err
    assert not (tmp_path / "report.html").exists()


def test_cli_report_missing_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", str(tmp_path / "nope")]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_fractional_octave_average_is_the_mean_of_lines_per_band() -> None:
    f = np.array([100.0, 101.0, 102.0, 200.0, 201.0])
    p = np.array([1.0, 2.0, 3.0, 10.0, 20.0])
    fc, pa, qa = plots.fractional_octave_average(f, p, 3, 2 * p)
    # 1/3-octave bands from 100 Hz: [100, 126), ..., [200, 252)
    assert fc == pytest.approx([101.0, 200.5]) and pa == pytest.approx([2.0, 15.0]) and qa == pytest.approx([4.0, 30.0])


def test_psd_table_is_shown_in_octave_bands_and_tolerance_comes_from_the_analysis(tmp_path: Path) -> None:
    """A flat PSD estimated with 2 degrees of freedom per line scatters far beyond ±3 dB line by
    line (chi² with 2 dof: 5 % of lines below -13 dB): the report shows it band-averaged and
    leaves the verdict to the analysis, whose per-level flag becomes the warning."""
    import dataclasses

    rng = np.random.default_rng(5)
    f = np.linspace(50, 2000, 4000)
    meas = 0.003 * rng.chisquare(2, f.size) / 2
    rows = "\n".join(f"{a},{b},0.003" for a, b in zip(f, meas))
    (tmp_path / "psd.csv").write_text("freq_hz,psd_measured_g2_per_hz,psd_profile_g2_per_hz\n" + rows + "\n")
    res = _random_result()
    (tmp_path / "results.json").write_text(json.dumps(res.to_dict()))
    text = report_dir(tmp_path).read_text()
    assert "1/24-octave" in text and "PSD out of tolerance" not in text
    flagged = dataclasses.replace(res, levels=(dataclasses.replace(res.levels[0], flags=("psd-out-of-tolerance",)),) + res.levels[1:])
    (tmp_path / "results.json").write_text(json.dumps(flagged.to_dict()))
    assert "PSD out of tolerance (analysis flag) at 0.25 g rms" in report_dir(tmp_path).read_text()


# --------------------------------------------------------------------------- the test report
METADATA = """
report_number = "VRE-2025-014"
[laboratory]
name = "Vibration Lab, Example GmbH"
address = "Example Street 1"
[item]
manufacturer = "Analog Devices"
model = "ADXL355"
[items.dut]
serial = "SN 0001"
[equipment]
reference = "PCB 352C33"
reference_calibration = "cert. 2024-118, 2024-11-02, due 2025-11-02"
shaker = "LDS V406"
[procedure]
standard = "IEEE Std 1293-2018"
[approval]
prepared_by = "A. Tester"
approved_by = "C. Manager"
date = 2025-03-14
"""


def _judged_result() -> VreResult:
    """Three levels judged against a 100 mg limit, U given: by the rule (|VRE| + U <= limit pass,
    |VRE| - U > limit fail) 50 ± 10 mg passes, 150 ± 10 mg fails, 95 ± 10 mg is indeterminate."""
    rule = "guarded acceptance: pass when |VRE| + U <= limit; fail when |VRE| - U > limit"
    levels = tuple(
        LevelResult(rms, Estimate(vre, 0.005), n_samples=1000, U_vre_g=0.010, k=2.0, decision=d,
                    budget=({"source": "record (batch means)", "type": "A", "u_g": 0.005},))
        for rms, vre, d in ((0.5, -0.050, "pass"), (1.0, -0.150, "fail"), (0.8, -0.095, "indeterminate"))
    )
    cond = Conditions(sensor="adxl355", profile="random flat 50-2000 Hz", static_g=1.0, range_g=2.048, odr_hz=4000.0,
                      axis="z", extra={"limit_g": 0.1, "decision_rule": rule, "band_hz": [50.0, 2000.0],
                                       "type_b": {"u_reference_pct": 1.0, "u_dut_pct": 0.0}})
    return VreResult("random", cond, levels, (), (), {"input_file": "run.h5", "channels": {"dut": "dut", "reference": "ref"}})


def _sections(text: str) -> dict[str, str]:
    """The report's numbered major sections: heading -> its HTML."""
    parts = re.split(r'<section class="major[^"]*" id="[a-z]+"><h2>', text)[1:]
    return {p.split("</h2>", 1)[0]: p.split("</h2>", 1)[1] for p in parts}


def test_test_report_parts_metadata_and_what_the_results_know(tmp_path: Path) -> None:
    res = _judged_result()
    (tmp_path / "results.json").write_text(json.dumps(res.to_dict()))
    (tmp_path / "run.h5").write_bytes(b"the recorded file")
    (tmp_path / "meta.toml").write_text(METADATA)
    text = report_dir(tmp_path, metadata=tmp_path / "meta.toml").read_text(encoding="utf-8")
    secs = _sections(text)
    assert list(secs) == ["1 Test item", "2 Equipment", "3 Conditions", "4 Procedure", "5 Results", "6 Decisions",
                          "7 Approval"]
    head = text.split("<main>", 1)[0]
    for s in ("VRE-2025-014", "Vibration Lab, Example GmbH, Example Street 1", "2025-03-14", "meta.toml"):
        assert s in head
    assert "<th>customer</th><td>not given</td>" in head  # absent: said, not invented
    item = secs["1 Test item"]
    assert "SN 0001" in item and "Analog Devices" in item and "ADXL355" in item
    assert "±2.048 g" in item and "4000 Hz" in item and "adxl355" in item  # from the results
    equip = secs["2 Equipment"]
    assert "PCB 352C33" in equip and "due 2025-11-02" in equip and "LDS V406" in equip
    assert "<th>data acquisition</th><td>not given</td>" in equip and "<th>reference channel in the record</th><td>ref</td>" in equip
    assert f"vrelab {vrelab_version}" in equip
    cond = secs["3 Conditions"]
    assert "<th>relative humidity</th><td>not given</td>" in cond
    assert "random flat 50-2000 Hz" in cond and "+1 g" in cond and "50–2000 Hz" in cond and "3: 0.5–1 g rms" in cond
    proc = secs["4 Procedure"]
    assert "IEEE Std 1293-2018" in proc and "<th>deviations</th><td>not given</td>" in proc
    assert "reference sensitivity 1 %" in proc  # the declared Type B term
    assert hashlib.sha256(b"the recorded file").hexdigest() in proc
    assert hashlib.sha256((tmp_path / "results.json").read_bytes()).hexdigest() in proc
    appr = secs["7 Approval"]
    assert "A. Tester" in appr and "C. Manager" in appr
    assert re.search(r"<th>Reviewed by</th><td>not given</td>", appr)
    assert appr.count('<td class="sign"></td>') == 3  # three signature lines, never filled in


def test_decisions_state_the_rule_and_show_each_level_as_the_results_judged_it(tmp_path: Path) -> None:
    (tmp_path / "results.json").write_text(json.dumps(_judged_result().to_dict()))
    dec = _sections(report_dir(tmp_path).read_text(encoding="utf-8"))["6 Decisions"]
    assert "pass when |VRE| + U &lt;= limit; fail when |VRE| - U &gt; limit" in dec
    assert "1 pass, 1 fail, 1 indeterminate (3 levels)" in dec
    rows = re.findall(r"<tr>(.*?)</tr>", dec.split("<tbody>", 1)[1])
    cells = [re.findall(r"<td[^>]*>(.*?)</td>", r) for r in rows]
    # |VRE| - U ... |VRE| + U in mg, from VRE and U = 10 mg; the decision as the results hold it
    assert [(c[6], c[7], c[8]) for c in cells] == [("40 … 60", "100", "pass"), ("140 … 160", "100", "fail"),
                                                  ("85 … 105", "100", "indeterminate")]


def test_without_a_limit_the_decisions_say_so_and_without_metadata_everything_is_not_given(tmp_path: Path) -> None:
    import dataclasses

    # a measurement: a simulation study leaves the laboratory's fields out (tests/test_report_loose_ends.py)
    (tmp_path / "results.json").write_text(json.dumps(dataclasses.replace(_random_result(), kind="measurement").to_dict()))
    text = report_dir(tmp_path).read_text(encoding="utf-8")
    secs = _sections(text)
    assert "No limit was given to any result, so no level was judged" in secs["6 Decisions"]
    assert "<th>report number</th><td>not given</td>" in text
    assert secs["7 Approval"].count("<td>not given</td>") == 6  # three names, three dates
    assert "--metadata FILE.toml" in text  # how to fill them


@pytest.mark.parametrize(
    "doc, words",
    [
        ('[item]\ncolour = "blue"\n', "unknown key 'colour' in [item]"),
        ("[item]\nserial = 1234\n", '[item] serial must be a string, got integer (quote it: serial = "1234")'),
        ("[approval]\ndate = true\n", "[approval] date must be a string or a TOML date, got boolean"),
        ('[lab]\nname = "x"\n', "unknown table [lab]"),
        ("report_number = 17\n", "report_number must be a string, got integer"),
        ('[items]\nsn1 = "x"\n', "[items] holds one table per channel ([items.sn1])"),
        ('[procedure]\ntext = ""\n', "[procedure] text is empty"),
        ("[item\n", "not valid TOML"),
    ],
)
def test_bad_metadata_is_one_line_from_the_api_and_the_cli_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], doc: str, words: str
) -> None:
    from vrelab.report import load_metadata

    (tmp_path / "results.json").write_text(json.dumps(_random_result().to_dict()))
    meta = tmp_path / "m.toml"
    meta.write_text(doc)
    with pytest.raises(ValueError) as exc:
        load_metadata(meta)
    assert words in str(exc.value) and str(meta) in str(exc.value) and "\n" not in str(exc.value)
    assert main(["report", str(tmp_path), "--metadata", str(meta)]) == 2
    err = capsys.readouterr().err
    assert err == f"vrelab: error: {exc.value}\n"
    assert not (tmp_path / "report.html").exists()


def test_per_channel_items_must_name_a_channel_of_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "results.json").write_text(json.dumps(_judged_result().to_dict()))
    (tmp_path / "m.toml").write_text('[items.sn9]\nserial = "SN 9"\n')
    assert main(["report", str(tmp_path), "--metadata", str(tmp_path / "m.toml")]) == 2
    assert "[items.sn9]: no channel 'sn9' in this report (channels: dut)" in capsys.readouterr().err
    assert not (tmp_path / "report.html").exists()


def test_rms2_plot_pairs_each_measured_frequency_with_its_fit_and_keeps_nine_apart() -> None:
    """A level's measured drive frequency scatters about the nominal one (99.9999995 Hz for a
    100 Hz step): it still belongs to the 100 Hz fit, whose line is drawn and in the legend.
    Nine frequencies (the demo's sweep) get nine different colour-and-marker pairs."""
    freqs = [100.0, 300.0, 1000.0, 1600.0, 2000.0, 2200.0, 2400.0, 2600.0, 3000.0]
    levels, fits = [], []
    for k, f in enumerate(freqs):
        for a in (0.5, 1.0):
            levels.append(LevelResult(a, Estimate(10 * (k + 1) * 1e-6 * a * a, 1e-6), freq_hz=f * (1 - 4.5e-9)))
        fits.append(FitResult(VrcModel({"vrc_ug_per_g2": Estimate(10.0 * (k + 1), 1.0)}), 2, 1.0, freq_hz=f, levels_used=(0.5, 1.0)))
    res = VreResult("sine", Conditions(sensor="adxl355", static_g=1.0), tuple(levels), tuple(fits))
    ax = plots.plot_vre_vs_rms2(res).axes[0]
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == [f"{f:g} Hz: VRC {10 * (k + 1)}.0 ± 1.0 µg/g²" for k, f in enumerate(freqs)]
    x, y = _line(ax, "100 Hz: VRC").get_data()
    assert y[-1] / x[-1] == pytest.approx(10.0e-3)  # 10 µg/g² in mg/g² (VRE in mg)
    style = {(c.lines[0].get_color(), c.lines[0].get_marker()) for c in ax.containers}
    assert len(ax.containers) == 9 and len(style) == 9


def test_the_metadata_examples_of_the_readme_and_of_examples_are_valid() -> None:
    """The tour's TOML (docs/tour.md) and examples/report-metadata.toml load; the example's
    [items.*] are the example campaign's parts, so `vrelab report camp --metadata
    examples/report-metadata.toml` runs as README and the tour write it."""
    import tomllib

    from vrelab.report import load_metadata
    from vrelab.report.metadata import parse_metadata

    root = Path(__file__).resolve().parent.parent
    readme = (root / "docs" / "tour.md").read_text(encoding="utf-8")
    block = readme.split("**The test report.**", 1)[1].split("```toml\n", 1)[1].split("```", 1)[0]
    assert parse_metadata(tomllib.loads(block)).get("", "report_number") == "VRE-2025-014"
    example = load_metadata(root / "examples" / "report-metadata.toml")
    manifest = tomllib.loads((root / "examples" / "campaign" / "campaign.toml").read_text())
    parts = {name for run in manifest["run"] for name in (run["dut"] if isinstance(run["dut"], (list, dict)) else [run["dut"]])}
    assert set(example.items) == {"sn1", "sn2"} <= parts


def test_prediction_table_rounds_at_its_resolution_and_lists_reasons_below(tmp_path: Path) -> None:
    """Shares far below 1 µg (the ADXL355's over-range share at low levels: -8.943e-112 mg in the
    demo) are 0 in the rendered table; the 'model valid' cell stays short, its reason is listed once
    under the table; the provenance reads as fields with units, not JSON."""
    from test_format import visible_text

    res = _random_result()
    (tmp_path / "results.json").write_text(json.dumps(res.to_dict()))
    why = "over-range holds fill 36 % of the time: holds overlap, the rare-event model fails — simulate"
    (tmp_path / "prediction.json").write_text(json.dumps({"levels": [
        {"rms_g": 0.5, "vre_g": -0.00019782, "tilt_error_deg": -0.011334, "valid": True, "notes": [],
         "shares": {"clip_g": -0.0002052, "overrange_g": -8.943e-115}},
        {"rms_g": 4.0, "vre_g": -0.78949, "tilt_error_deg": -45.2345, "valid": False, "notes": [why],
         "shares": {"clip_g": -0.489144, "overrange_g": 1.4e-65}}]}))
    html_text = report_dir(tmp_path, argv=["vrelab", "report", str(tmp_path)]).read_text(encoding="utf-8")
    text = visible_text(html_text)
    table = text[text.index("Prediction: mechanisms' shares"):text.index("Provenance")]
    assert not re.search(r"\de[-+]?\d", table), table  # no exponent anywhere in the table
    cells = table.split()
    assert "-0.198" in cells and "-789.490" in cells and "-0.205" in cells and "0" in cells
    assert "no (note 1)" in table and why not in table.split("no (note 1)")[0]  # the reason once, numbered, below
    assert f"{why} (at 4 g rms)" in table
    prov = text[text.index("Provenance"):]
    assert "null" not in prov and "{" not in prov and "\\u00" not in prov
