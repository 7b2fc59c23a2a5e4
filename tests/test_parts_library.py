"""Issue 32's parts library: `vrelab sensor list/show`, a datasheet's %FS nonlinearity as k2/k3 u,
and each preset's own datasheet VRE statement reproduced (or the reason it is not)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vrelab.cli import main
from vrelab.sensor import list_presets, load_sensor
from vrelab.sensor.configs import nonlinearity_bounds


def _minimax_line_deviation(y: np.ndarray, x: np.ndarray) -> float:
    """The smallest largest |y - (a + b·x)| over a line (the Chebyshev fit), as a linear
    programme (scipy.optimize.linprog): minimise t subject to ±(y - a - b·x) ≤ t. Independent
    of the closed form it checks."""
    from scipy.optimize import linprog

    n = x.size
    ones = np.ones(n)
    # variables (a, b, t); rows: y - a - b x <= t  and  a + b x - y <= t
    a_ub = np.vstack([np.column_stack([-ones, -x, -ones]), np.column_stack([ones, x, -ones])])
    b_ub = np.concatenate([-y, y])
    res = linprog([0.0, 0.0, 1.0], A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * 3, method="highs")
    assert res.success
    return float(res.x[2])


@pytest.mark.parametrize("fs_g", [2.0, 10.0, 40.0])
def test_nonlinearity_bound_is_the_minimax_deviation_of_each_term(fs_g):
    """A k2 (k3) at the bound deviates from its best straight line over ±FS by exactly NL·FS:
    the datasheet's "±0.1 % FS" (ADXL354/355 Rev. D, Table 1). The grid holds ±FS and 0, where
    x² and T3 equioscillate, so the fitted deviation is exact to the LP's tolerance."""
    nl = 0.001
    k2, k3 = nonlinearity_bounds(0.1, fs_g)
    x = np.linspace(-fs_g, fs_g, 2001)
    # in units of NL·FS, so the LP's absolute feasibility tolerance (1e-7, HiGHS) is relative
    assert _minimax_line_deviation(k2 * x**2 / (nl * fs_g), x) == pytest.approx(1.0, abs=1e-6)
    assert _minimax_line_deviation(k3 * x**3 / (nl * fs_g), x) == pytest.approx(1.0, abs=1e-6)
    # a least-squares line (numpy.polyfit) deviates more from the same term: the minimax bound is the widest
    ls = np.max(np.abs(k2 * x**2 - np.polyval(np.polyfit(x, k2 * x**2, 1), x)))
    assert ls > nl * fs_g


@pytest.mark.parametrize("name, range_g, k2_u, k3_u", [
    # the hand-written numbers of the presets before the nonlinearity field (commit 3dfc271), rounded to 4 digits
    ("adxl355", 2, 577.4, 577.4), ("adxl355", 4, 288.7, 144.3), ("adxl355", 8, 144.3, 36.08),
    ("adxl354", 2, 577.4, 577.4), ("adxl354", 8, 144.3, 36.08),
    ("adxl357", 10, 115.5, 23.09), ("adxl357", 20, 57.74, 5.774), ("adxl357", 40, 28.87, 1.443),
])
def test_nonlinearity_pct_fs_gives_the_presets_former_k2_k3_u(name, range_g, k2_u, k3_u):
    s = load_sensor(name, range_g=range_g)
    assert s.nonlinearity_pct_fs == 0.1
    # the old numbers were written to 4 significant digits: agree to 5e-4 relative
    assert s.uncertainty["k2_ug_per_g2"] == pytest.approx(k2_u, rel=5e-4)
    assert s.uncertainty["k3_ug_per_g3"] == pytest.approx(k3_u, rel=5e-4)


def test_a_files_own_k2_u_wins_over_the_nonlinearity_and_a_user_k2_drops_it(tmp_path):
    text = ('schema = 1\nname = "p"\ndefault_range_g = 2\nk2_ug_per_g2 = 10.0\nnonlinearity_pct_fs = 0.5\n'
            '[uncertainty]\nk2_ug_per_g2 = 3.0\n[facts]\nk2_ug_per_g2 = "assumption: x"\n'
            'nonlinearity_pct_fs = "datasheet X: 0.5 % FS"\n')
    path = tmp_path / "p.toml"
    path.write_text(text, encoding="utf-8")
    s = load_sensor(str(path))
    assert s.uncertainty["k2_ug_per_g2"] == 3.0
    # |k3| ≤ 4·0.005/(2 g)² = 5000 µg/g³, / √3
    assert s.uncertainty["k3_ug_per_g3"] == pytest.approx(5000 / math.sqrt(3))
    assert "k2_ug_per_g2" not in load_sensor(str(path), k2_ug_per_g2=5.0).uncertainty


def _run(argv, capsys):
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


def test_sensor_list_names_every_preset_with_its_ranges_and_statement(capsys):
    rc, out, err = _run(["sensor", "list", "--json"], capsys)
    assert rc == 0, err
    parts = {p["name"]: p for p in json.loads(out)["sensors"]}
    assert set(parts) == set(list_presets())
    assert parts["adxl355"]["ranges_g"] == [2.0, 4.0, 8.0] and max(parts["adxl355"]["odrs_hz"]) == 4000.0
    assert parts["adxl354"]["odrs_hz"] == []
    rc, out, _ = _run(["sensor", "list"], capsys)
    assert rc == 0 and all(name in out for name in parts)


def test_sensor_show_gives_every_fact_and_every_u_with_its_reason(capsys):
    rc, out, err = _run(["sensor", "show", "adxl355", "--range", "8", "--json"], capsys)
    assert rc == 0, err
    d = json.loads(out)
    facts = {f["field"]: f for f in d["facts"]}
    assert facts["fn_hz"]["value"] == 2400.0 and facts["fn_hz"]["kind"] == "datasheet"
    assert facts["k2_per_g"]["kind"] == "assumption"
    u = {a["parameter"]: a for a in d["assumptions"]}
    assert u["k2_ug_per_g2"]["u"] == pytest.approx(250 / math.sqrt(3))  # 2·0.001/8 g, rectangular
    assert "0.1 % FS" in u["k2_ug_per_g2"]["reason"]
    assert all(a["reason"] and a["reason"] != "unmarked" for a in d["assumptions"])
    rc, out, _ = _run(["sensor", "show", "adxl355"], capsys)
    assert rc == 0 and "because:" in out and "fn_hz = 2400" in out


def test_sensor_show_reads_a_sensor_file(tmp_path: Path, capsys):
    path = tmp_path / "mine.toml"
    path.write_text('schema = 1\nname = "mine"\nfn_hz = 3000.0\nq = 2.0\n[facts]\nfn_hz = "datasheet Mine: 3 kHz"\n',
                    encoding="utf-8")
    rc, out, err = _run(["sensor", "show", str(path), "--json"], capsys)
    assert rc == 0, err
    d = json.loads(out)
    assert d["name"] == "mine" and {f["field"]: f["kind"] for f in d["facts"]}["fn_hz"] == "datasheet"
    assert {f["field"]: f["fact"] for f in d["facts"]}["q"].startswith("unmarked")


# ---------------------------------------------------------------------- sinc decimation filters

_SINC_PART = """schema = 1
name = "sinc_part"
default_range_g = 2
odrs_hz = [4000.0]
bandwidth_hz = {bw}
lowpass_kind = "sinc"
lowpass_order = 3
lowpass_corner = "{conv}"
[ranges."2"]
rails_g = [-2.0, 2.0]
"""


def _sinc_part(tmp_path: Path, bw: float = 1000.0, conv: str = "-6dB") -> Path:
    path = tmp_path / "sinc_part.toml"
    path.write_text(_SINC_PART.format(bw=bw, conv=conv), encoding="utf-8")
    return path


@pytest.mark.parametrize("conv, gain", [("-3dB", 1 / math.sqrt(2)), ("-6dB", 0.5)])
def test_sinc_corner_is_at_the_stated_gain_and_the_fir_matches_the_closed_form(conv, gain):
    """|H| = |sinc(f·T)|^3 (a CIC3, Hogenauer 1981) is the convention's gain at the corner, and the
    simulated FIR (the sampled B-spline) matches it in the pass band: the spectrum folded from fs
    falls as (corner/fs)^3, 0.03 % at fs = 16·corner (scipy.signal.freqz of the taps)."""
    from scipy import signal

    from vrelab.sensor.sinc import SincLowPass

    st = SincLowPass(1000.0, 3, conv)
    assert abs(st.response(1000.0)) == pytest.approx(gain, rel=1e-9)
    assert abs(np.sinc(1000.0 * st.averaging_s)) ** 3 == pytest.approx(gain, rel=1e-9)
    f = np.linspace(1.0, 1000.0, 100)
    _, h = signal.freqz(st.taps(16000.0), 1, worN=f, fs=16000.0)
    assert np.max(np.abs(np.abs(h) / np.abs(st.response(f)) - 1)) < 1e-3


def test_sinc_stage_streams_in_blocks_with_the_whole_records_answer():
    """The FIR's state crosses block edges: blocks of 1000 give the one-block output (to rounding),
    and the state is the taps, not the record."""
    from vrelab.sensor.sinc import SincLowPass

    st = SincLowPass(1000.0, 3, "-6dB")
    x = np.random.default_rng(3).standard_normal(10_000)
    whole, _ = st.process(x, st.init_state(16000.0, None), 16000.0)
    state, parts = st.init_state(16000.0, None), []
    for i in range(0, x.size, 1000):
        y, state = st.process(x[i:i + 1000], state, 16000.0)
        parts.append(y)
    assert np.allclose(np.concatenate(parts), whole, rtol=0, atol=1e-12)
    assert state.zi is not None and state.zi.size < 100


def test_sinc_predict_and_simulate_agree_with_the_closed_form_variance(tmp_path):
    """Spectral prediction with |H|²: white noise through the simulated sinc3 has the variance
    S·∫|sinc(fT)|⁶ df (closed form, scipy.integrate.quad), and the output variance predict's
    sensor response gives (Sensor.response) is the same integral."""
    from scipy import integrate

    s = load_sensor(str(_sinc_part(tmp_path)))
    fs = 16000.0
    stage = next(st for st in s.stages() if type(st).__name__ == "SincLowPass")
    t = stage.averaging_s
    closed = integrate.quad(lambda f: np.sinc(f * t) ** 6, 0, fs / 2, limit=400)[0]
    via_response = integrate.quad(lambda f: abs(s.response(np.array([f]))[0]) ** 2, 0, fs / 2, limit=400)[0]
    assert via_response == pytest.approx(closed, rel=1e-6)
    x = np.random.default_rng(7).standard_normal(400_000)  # unit variance: one-sided density 2/fs
    y, _ = stage.process(x, stage.init_state(fs, None), fs)
    # the variance of 4e5 samples filtered to a ~1 kHz band: relative sd ≈ sqrt(2/(N·B/fs·...)) < 1 %
    assert np.var(y[1000:]) == pytest.approx(closed * 2 / fs, rel=0.03)


def test_a_sinc_decimators_corner_may_sit_at_the_output_nyquist(tmp_path):
    """The ADXL380's 4 kHz at an 8 kHz ODR: a sinc corner at ODR/2 loads; a Butterworth's is refused."""
    s = load_sensor(str(_sinc_part(tmp_path, bw=2000.0, conv="-3dB")))
    assert s.bandwidth_hz == 2000.0
    path = tmp_path / "butter.toml"
    path.write_text(_SINC_PART.format(bw=2000.0, conv="-3dB").replace('"sinc"', '"butterworth"'), encoding="utf-8")
    with pytest.raises(ValueError, match="below ODR/2"):
        load_sensor(str(path))
    path.write_text(_SINC_PART.format(bw=2500.0, conv="-3dB"), encoding="utf-8")
    with pytest.raises(ValueError, match="at most ODR/2"):
        load_sensor(str(path))


def test_sinc_predict_vs_simulate_clipping_vre(tmp_path):
    """The one simulation of this file: a sinc3 (-6 dB at 1 kHz) before ±2 g output rails, 1.2 g
    rms flat 50-2000 Hz in a 1 g field. predict (spectral, |H|²) and the simulated shaker test agree
    within their combined expanded uncertainty."""
    import vrelab
    from vrelab.profiles import parse_profile

    s = load_sensor(str(_sinc_part(tmp_path)))
    pred = vrelab.predict(s, parse_profile("flat:50-2000"), [1.2], static_g=1.0).levels[0]
    sim = vrelab.simulate(s, "flat:50-2000", [1.2], static_g=1.0, seconds=8.0, seed=1)
    d = sim.to_dict()
    lv = d["levels"][0]
    assert abs(lv["vre_g"]) > 0.005  # the rails rectify: a comparison that means something
    u = math.hypot(lv["u_vre_g"], pred.u_vre_g or 0.0, pred.model_error_g or 0.0)  # the ideal rails: no assumed u
    assert abs(lv["vre_g"] - pred.vre_g) < 2 * u + 1e-4, (lv, pred)


# ---------------------------------------------------------------------- each part's own VRE statement

def _statement_parts() -> list[str]:
    from vrelab.sensor.catalog import part_summary

    return [n for n in list_presets() if part_summary(n)["vre_statement"] is not None]


def test_the_parts_with_a_datasheet_vre_statement():
    assert {"adxl356", "adxl357", "adxl358", "adxl359", "adxl380", "ma352"} <= set(_statement_parts())


@pytest.mark.parametrize("name", _statement_parts())
def test_each_preset_reproduces_its_datasheets_vre_statement_within_its_u(name):
    """Predict at the statement's condition (its range, level, profile, static field, axis). A
    "max" statement: the prediction's upper bound |VRE| + U (k = 2) stays below it; a "typ"
    one: ||VRE| − value| within U plus the datasheet's own spread (the statement's sign is not
    quoted: magnitudes). A statement the preset cannot reproduce says why (reproducible =
    false with why_not), and `sensor show` prints it."""
    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile
    from vrelab.sensor.catalog import part_summary

    st = part_summary(name)["vre_statement"]
    if not st["reproducible"]:
        assert len(st["why_not"]) > 40
        return
    s = load_sensor(name, range_g=st["range_g"], axis=st["axis"], odr_hz=st["odr_hz"])
    vib = parse_profile(st["profile"]) if st["level_grms"] is not None else st["freq_hz"]
    level = st["level_grms"] if st["level_grms"] is not None else st["amplitude_g"] / math.sqrt(2)
    (lv,) = predict(s, vib, [level], static_g=st["static_g"]).levels
    big_u = 2 * math.hypot(lv.u_vre_g or 0.0, lv.model_error_g or 0.0)
    assert big_u > 0  # every preset's assumptions carry a u
    # a VRC statement (the M-A352's) compares in VRC units: VRE / (the level in g rms)², exact level
    scale = 1.0 if st["value_g"] is not None else 1e6 / level**2
    got, big_u = abs(lv.vre_g) * scale, big_u * scale
    stated = st["value_g"] if st["value_g"] is not None else st["vrc_ug_per_g2"]
    if st["bound"] == "max":
        assert got + big_u < stated, (name, got, big_u)
    else:
        assert abs(got - stated) <= big_u + (st["spread_g"] or 0.0) * scale, (name, got, big_u)


def test_the_presets_page_carries_the_generated_parts_table():
    """docs/presets.md's parts table is parts_table()'s output (regenerate it with
    ``python -c "from vrelab.sensor.catalog import parts_table; print(parts_table())"``)."""
    from vrelab.sensor.catalog import parts_table

    page = (Path(__file__).resolve().parents[1] / "docs" / "presets.md").read_text(encoding="utf-8")
    start = page.index("<!-- parts table: generated by vrelab.sensor.catalog.parts_table -->\n")
    end = page.index("<!-- end parts table -->")
    assert page[page.index("\n", start) + 1:end] == parts_table()


# ---------------------------------------------------------------------- the data sheets' own words

# Each statement as its data sheet prints it (typed here from the data sheet, not read from the
# preset): ADXL358 Rev. 0 (5/2023) and ADXL359 Rev. 0 (6/2022), Table 1, "Vibration Rectification
# Error (VRE): offset due to 7.5 g rms vibration, ±10 g range, in a 1 g orientation, <0.1 g";
# Epson M-A352AD10 Rev.20251023, Table 2.3, "VRC, at 50Hz, 25°C, VCC3.3V, ±50 µG/G²" (max).
_QUOTED = {
    "adxl358": {"value_g": 0.1, "level_grms": 7.5, "range_g": 10.0, "static_g": 1.0},
    "adxl359": {"value_g": 0.1, "level_grms": 7.5, "range_g": 10.0, "static_g": 1.0},
    "ma352": {"vrc_ug_per_g2": 50.0, "freq_hz": 50.0, "range_g": 15.0},
}


@pytest.mark.parametrize("name", sorted(_QUOTED))
def test_each_new_parts_statement_is_its_data_sheets(name):
    from vrelab.sensor.catalog import part_summary

    st = part_summary(name)["vre_statement"]
    assert st["bound"] == "max"
    for key, value in _QUOTED[name].items():
        assert st[key] == value, (name, key)


def test_the_adxl359_anti_alias_is_the_sinc3s_minus_3_db_point():
    """ADXL359 Rev. 0 (Filter): the analog anti-alias is "approximately 1.5 kHz, the frequency at
    which the output response is attenuated by approximately 50 %", shaped as a sinc3. The preset's
    Butterworth sits at that sinc3's −3 dB point: |sinc(x)|³ = 1/√2 where |sinc(x)|³ = 1/2 is 1.5 kHz
    (roots by scipy.optimize.brentq, independent of the preset)."""
    from scipy.optimize import brentq

    x6 = brentq(lambda x: np.sinc(x) ** 3 - 0.5, 0.01, 0.99)
    x3 = brentq(lambda x: np.sinc(x) ** 3 - 2 ** -0.5, 0.01, 0.99)
    assert load_sensor("adxl359").anti_alias_hz == pytest.approx(1500.0 * x3 / x6, abs=0.5)  # written to 1 Hz


def test_the_ma352_output_is_half_at_its_stated_minus_6_db_corner():
    """M-A352AD10 Rev.20251023 quotes its bandwidth at −6 dB (Table 2.3) and ships 512 taps at Fc
    60 Hz (Table 5.4): the preset's chain halves 60 Hz, relative to DC (the 850 Hz resonance adds
    0.5 % there: (1 − (60/850)²)⁻¹, so the tolerance)."""
    s = load_sensor("ma352")
    h = np.abs(s.response(np.array([0.01, 60.0])))
    assert h[1] / h[0] == pytest.approx(0.5, rel=0.01)
