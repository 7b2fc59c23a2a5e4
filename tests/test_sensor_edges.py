"""A sensor file means what it says, and the edges (issues 28 and 34).

* a band-limit without an ODR (an analog part, the ADXL354) is its analog output filter, held
  against a numpy Monte Carlo through scipy.signal's analog filter: today's code dropped it;
* a field with no effect given the others (a hold without a threshold...) is refused naming it;
* coefficients, frequencies, rails and uncertainties beyond physical bounds are refused in one
  line (no overflow warning first), angles and static vectors beyond bounds too.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import signal

from vrelab.cli import main
from vrelab.prediction import cancellation, predict
from vrelab.profiles import parse_profile
from vrelab.sensor import load_sensor

ANALOG = """schema = 1
name = "analog"
default_range_g = 2
bandwidth_hz = 1000.0
lowpass_order = 4
fn_hz = 2400.0
q = 7.4
"""


def _monte_carlo_censored_vre(rms_g: float, g0: float, rails: tuple[float, float], seed: int) -> tuple[float, float]:
    """Truth with numpy and scipy.signal alone: flat 50-2000 Hz Gaussian noise (random-phase
    complex Gaussian spectrum, inverse real FFT), through the resonance ``1/(1 - r² + j r/Q)``
    and scipy's analog 4th-order Butterworth at 1 kHz (``signal.butter(analog=True)``,
    ``signal.freqs``), clipped at the rails; VRE = mean - clip(g0). Mean and standard error over
    16 independent records."""
    fs, n = 16384.0, 2**16
    f = np.fft.rfftfreq(n, 1 / fs)
    band = (f >= 50) & (f <= 2000)
    b, a = signal.butter(4, 2 * np.pi * 1000.0, analog=True)
    _, h_lp = signal.freqs(b, a, worN=2 * np.pi * f)
    r = f / 2400.0
    h = h_lp / (1 - r**2 + 1j * r / 7.4)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(16):
        spec = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) * band
        x = np.fft.irfft(spec, n)
        x *= rms_g / x.std()  # the drive's rms (the reference's), before the sensor
        y = np.fft.irfft(np.fft.rfft(x) * h, n)
        out.append(np.clip(g0 + y, *rails).mean() - np.clip(g0, *rails))
    v = np.array(out)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))


def test_a_band_limit_without_an_odr_is_the_analog_output_filter(tmp_path):
    """Issue 28 row 3: bandwidth_hz = 1000, lowpass_order = 4, no odrs_hz. The output rails see
    the vibration through the resonance and the 1 kHz filter; predicting without the filter (what
    the loader did) gives -517 mg at 2 g rms where the Monte Carlo gives about -227 mg."""
    path = tmp_path / "analog.toml"
    path.write_text(ANALOG, encoding="utf-8")
    s = load_sensor(str(path))
    assert s.odr_hz is None and s.bandwidth_hz == 1000.0
    pred = predict(s, parse_profile("flat:50-2000"), [2.0], static_g=1.0)
    lv = pred.levels[0]
    truth, se = _monte_carlo_censored_vre(2.0, 1.0, (-2.0, 2.0), seed=2028)
    # no polynomial: the rails see a Gaussian (exact closed form); the Monte Carlo's own standard
    # error (about 1 mg) and its record-to-record rms scaling set the tolerance: 4 se + 0.5 %
    assert lv.valid
    assert lv.vre_g == pytest.approx(truth, abs=4 * se + 0.005 * abs(truth))
    assert pred.conditions.bandwidth_hz == 1000.0


def test_the_analog_output_filter_is_scipys_analog_butterworth(tmp_path):
    """The stage's response is scipy's analog design (independent: signal.butter + freqs), and
    the simulated chain's discretisation follows it within 0.1 % up to fs/8."""
    path = tmp_path / "analog.toml"
    path.write_text(ANALOG.replace("fn_hz = 2400.0\nq = 7.4\n", ""), encoding="utf-8")
    s = load_sensor(str(path))
    f = np.array([10.0, 500.0, 1000.0, 1500.0, 2000.0])
    b, a = signal.butter(4, 2 * np.pi * 1000.0, analog=True)
    _, h = signal.freqs(b, a, worN=2 * np.pi * f)
    np.testing.assert_allclose(np.abs(s.response(f)), np.abs(h), rtol=1e-9)
    fs = 16000.0
    sos = np.vstack([st.design(fs) for st in s.stages(fs) if hasattr(st, "design")])
    _, hd = signal.sosfreqz(sos, worN=f, fs=fs)
    np.testing.assert_allclose(np.abs(hd), np.abs(h), rtol=1e-3)


@pytest.mark.parametrize("body, field", [
    ("lowpass_order = 4\n", "lowpass_order has no effect without bandwidth_hz"),
    ('lowpass_kind = "bessel"\n', "lowpass_kind has no effect without bandwidth_hz"),
    ("anti_alias_order = 2\n", "anti_alias_order has no effect without anti_alias_hz"),
    ("overrange_hold_s = 0.0005\n", "overrange_hold_s has no effect without overrange_threshold_g"),
    ("overrange_value_g = 0.5\n", "overrange_value_g has no effect without overrange_threshold_g"),
    ("overrange_float_tau_s = 0.001\n", "overrange_float_tau_s has no effect without overrange_threshold_g"),
    ("overrange_retrigger = false\n", "overrange_retrigger has no effect without overrange_threshold_g"),
    ("bandwidth_per_odr = 0.25\n", "bandwidth_per_odr has no effect without odrs_hz"),
    ("default_odr_hz = 4000.0\n", "default_odr_hz has no effect without odrs_hz"),
])
def test_a_field_with_no_effect_is_refused_naming_it(tmp_path, body, field):
    path = tmp_path / "s.toml"
    path.write_text('schema = 1\nname = "s"\n' + body, encoding="utf-8")
    with pytest.raises(ValueError, match=field):
        load_sensor(str(path))


@pytest.mark.parametrize("body, field", [
    ("k2_ug_per_g2 = 1e308\n", "k2_ug_per_g2 must be at most 1e\\+06"),
    ("k3_ug_per_g3 = -1e12\n", "k3_ug_per_g3 must be at least -1e\\+06"),
    ("kip_ug_per_g2 = 1e300\n", "kip_ug_per_g2 must be at most"),
    ("fn_hz = 1e-300\nq = 2.0\n", "fn_hz must be at least 0.1"),
    ("fn_hz = 2400.0\nq = 1e300\n", "q must be at most 100000"),
    ("rails_g = [-1e300, 1e300]\n", "rails_g must be at least -1e\\+06"),
    ("overrange_threshold_g = 1e300\noverrange_hold_s = 1e-3\n", "overrange_threshold_g must be at most"),
    ("noise_ug_per_rthz = 1e300\n", "noise_ug_per_rthz must be at most"),
    ("offset_g = -1e300\n", "offset_g must be at least"),
    ("bandwidth_hz = 1e-300\n", "bandwidth_hz must be at least"),
])
def test_values_beyond_physical_bounds_are_refused_in_one_line(tmp_path, body, field):
    """Issue 34 'noise': k2 = 1e308, fn_hz = 1e-300, rails ±1e300 gave numpy overflow warnings
    before the answer; now one ValueError naming the field and nothing else."""
    path = tmp_path / "s.toml"
    path.write_text('schema = 1\nname = "s"\n' + body, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning fails the test
        with pytest.raises(ValueError, match=field) as err:
            load_sensor(str(path))
    assert "\n" not in str(err.value)


def test_a_covariance_or_assumed_u_wider_than_any_physical_bound_is_refused(tmp_path):
    """Issue 34 'silent accept': a covariance diagonal of 1e300 gave u_vre_g 2e128 g, valid."""
    path = tmp_path / "s.toml"
    path.write_text('schema = 1\nname = "s"\nk2_ug_per_g2 = 20.0\n[axes.x.covariance]\nparams = ["k2_ug_per_g2"]\n'
                    "matrix = [[1e300]]\n", encoding="utf-8")
    with pytest.raises(ValueError, match="standard uncertainty of k2_ug_per_g2.*outside any physical bound"):
        load_sensor(str(path))
    path.write_text('schema = 1\nname = "s"\nk2_ug_per_g2 = 20.0\n[uncertainty]\nk2_ug_per_g2 = 1e300\n',
                    encoding="utf-8")
    with pytest.raises(ValueError, match="standard uncertainty of k2_ug_per_g2.*outside any physical bound"):
        load_sensor(str(path))
    # a wide but physical u still loads (a campaign that barely bounds k2)
    path.write_text('schema = 1\nname = "s"\nk2_ug_per_g2 = 20.0\n[uncertainty]\nk2_ug_per_g2 = 5000.0\n',
                    encoding="utf-8")
    assert load_sensor(str(path)).uncertainty == {"k2_ug_per_g2": 5000.0}


@pytest.mark.parametrize("argv, words", [
    (["--static", "0", "--k2=1e300"], "k2_ug_per_g2 must be at most"),
    (["--static", "0", "--k2=1e12"], "k2_ug_per_g2 must be at most"),
    (["--static", "0", "--k2=20", "--mount-deg=1e300"], "--mount-deg must be within ±360"),
    (["--k2=20", "--static-vector=1e6,0,0"], "--static-vector's magnitude must be within ±100000 g"),
])
def test_cli_edges_are_refused_in_one_line(capsys, argv, words):
    """Issue 28 row 6: k2 = 1e300 gave VRE 0 valid (shares ±1e294 cancel), 1e12 gave +1.998 g,
    --mount-deg=1e300 was valid, --static-vector=1e6,0,0 accepted (the README bounds it at 1e5 g)."""
    rc = main(["predict", "--sensor", "ideal", *argv, "--profile", "flat:50-2000", "--levels", "1"])
    out, err = capsys.readouterr()
    assert rc == 2 and out == ""
    assert words in err and err.count("\n") == 1


def test_shares_that_cancel_beyond_float64_are_not_valid():
    """Within the bounds a prediction can still sum shares of 1e20 g that cancel (k4 = 1e6 µg/g⁴,
    1e5 g rms): the sum then is rounding noise, and the level says so (the true VRE of rails at
    ±1e6 g cannot exceed 1e6 g; the sum gave 1.016e6 g)."""
    s = load_sensor("ideal", range_g=1e6, overrides={"k4_ug_per_g4": 1e6})
    lv = predict(s, 1e-3, [1e5], static_g=0.0).levels[0]
    assert not lv.valid
    assert any("float64" in n for n in lv.notes)
    # and a plain case keeps its validity: ideal ±2 g, 1 g field, 1 g rms (SPEC 1.1's -83 mg)
    ok = predict(load_sensor("ideal"), parse_profile("flat:50-2000"), [1.0], static_g=1.0).levels[0]
    assert ok.valid and cancellation(ok.shares, ok.vre_g) is None


def test_a_prediction_beyond_the_time_budget_is_refused_before_it_starts(monkeypatch, capsys):
    """Issue 34 'hang': predict with 100 000 levels ran for minutes. The simulation's time budget
    (VRELAB_TIME_BUDGET_H) now bounds a prediction too, estimated before any level: 1000 ADXL355
    levels, each with its over-range threshold's u propagated (5 predictions a level), at the
    budget's 5 ms a level are about 25 s, beyond a budget of 0.001 h (3.6 s; the same rule refuses
    100 000 levels under a 0.1 h budget)."""
    monkeypatch.setenv("VRELAB_TIME_BUDGET_H", "0.001")
    rc = main(["predict", "--sensor", "adxl355", "--profile", "flat:50-2000", "--levels", "0.005:5:0.005"])
    out, err = capsys.readouterr()
    assert rc == 2 and out == "" and err.count("\n") == 1
    assert "1000 levels" in err and "VRELAB_TIME_BUDGET_H" in err
    # within the budget it runs (three levels)
    assert main(["predict", "--sensor", "adxl355", "--profile", "flat:50-2000", "--levels", "1,2,3", "--json"]) == 0
