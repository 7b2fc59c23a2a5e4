"""Stages of the sensor chain, each held against an independent computation.

References: SPEC 1.3 (resonance H = 1/(1 - r² + j r/Q), unity DC gain, gain Q at fn), SPEC 1.2
(polynomial mean shift), SPEC 1.1 (censoring), ADXL354/355 data sheet Rev. D (0.5 ms over-range
hold). Analog responses come from scipy.signal.freqs on the textbook transfer functions, not
from the stages' own ``response``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy import signal

from vrelab.sensor.stages import (
    AntiAlias,
    Clip,
    Decimate,
    HighPass,
    LowPass,
    Noise,
    Offset,
    OverRange,
    Polynomial,
    Quantize,
    Resonator,
    Stage,
    StageBase,
)
from vrelab.sensor.chain import SensorChain


def _run(stage, x, fs, block=None, seed=None):
    state = stage.init_state(fs, seed)
    if block is None:
        y, state = stage.process(x, state, fs)
        return y, state
    out = []
    for i in range(0, x.size, block):
        y, state = stage.process(x[i : i + block], state, fs)
        out.append(y)
    return np.concatenate(out), state


def _sine_gain(stage, f, fs, periods=400):
    """Steady-state gain of a stage for a sine at f, by least squares on the last half."""
    n = int(round(periods * fs / f))
    t = np.arange(n) / fs
    y, _ = _run(stage, np.sin(2 * np.pi * f * t), fs)
    tail = slice(n // 2, n)
    basis = np.column_stack([np.sin(2 * np.pi * f * t[tail]), np.cos(2 * np.pi * f * t[tail])])
    coef, *_ = np.linalg.lstsq(basis, y[tail], rcond=None)
    return float(np.hypot(*coef))


# ---------------------------------------------------------------------------- resonator


@pytest.mark.parametrize("q", [7.4, 1.5, 20.0])
def test_resonator_gain_q_at_fn_and_unity_at_dc_spec_1_3(q):
    """SPEC 1.3: |H(fn)| = Q, H(0) = 1; measured in the time domain with sines."""
    fn, fs = 2400.0, 20000.0
    stage = Resonator(fn, q)
    assert _sine_gain(stage, fn, fs) == pytest.approx(q, rel=0.01)
    y, _ = _run(stage, np.full(2000, 1.0), fs)
    assert y[-1] == pytest.approx(1.0, rel=1e-9)  # DC gain exactly 1 (steady state from the start)
    assert _sine_gain(stage, 20.0, fs, periods=20) == pytest.approx(1.0, rel=1e-3)


@pytest.mark.parametrize("q", [7.4, 1.5])
@pytest.mark.parametrize("fs_over_fn", [8.0, 8.33, 16.0, 50.0])
def test_resonator_matches_analog_within_1pct_to_fs_over_8(q, fs_over_fn):
    """Discrete |H| vs the analog wn²/(s² + s wn/Q + wn²) (scipy.signal.freqs) up to fs/8."""
    fn = 2400.0
    fs = fs_over_fn * fn
    wn = 2 * np.pi * fn
    f = np.linspace(1.0, fs / 8, 600)
    _, h_analog = signal.freqs([wn**2], [1.0, wn / q, wn**2], worN=2 * np.pi * f)
    _, h = signal.sosfreqz(Resonator(fn, q).design(fs), worN=f, fs=fs)
    np.testing.assert_allclose(np.abs(h), np.abs(h_analog), rtol=0.01)


@pytest.mark.parametrize("q", [0.5, 1.5, 7.4, 100.0])
@pytest.mark.parametrize("fs_over_fn", [5.0, 6.67, 10.0, 50.0])
def test_resonator_matches_analog_within_0p05pct_to_fs_over_8_from_fs_over_5(q, fs_over_fn):
    """The rate rule of the simulated test (vrelab.shaker: fs >= 5·fn and >= 8·f_max) relies on
    the discretised resonance matching the analog |H| (scipy.signal.freqs) to 0.05 % up to fs/8."""
    fn = 2400.0
    fs = fs_over_fn * fn
    wn = 2 * np.pi * fn
    f = np.linspace(1.0, fs / 8, 600)
    _, h_analog = signal.freqs([wn**2], [1.0, wn / q, wn**2], worN=2 * np.pi * f)
    _, h = signal.sosfreqz(Resonator(fn, q).design(fs), worN=f, fs=fs)
    np.testing.assert_allclose(np.abs(h), np.abs(h_analog), rtol=5e-4)


@pytest.mark.parametrize("order", [2, 3, 4])
def test_anti_alias_matches_analog_within_0p05pct_to_fs_over_8_at_fs_5fc(order):
    fc = 1500.0
    fs = 5 * fc
    f = np.linspace(1.0, fs / 8, 500)
    b, a = signal.butter(order, 2 * np.pi * fc, analog=True)
    _, h_analog = signal.freqs(b, a, worN=2 * np.pi * f)
    _, h = signal.sosfreqz(AntiAlias(fc, order).init_state(fs, None).sos, worN=f, fs=fs)
    np.testing.assert_allclose(np.abs(h), np.abs(h_analog), rtol=5e-4)


def test_resonator_needs_fn_below_nyquist():
    with pytest.raises(ValueError, match="fn_hz"):
        Resonator(6000.0, 2.0).init_state(10000.0, None)


# ---------------------------------------------------------------------------- filters


def test_anti_alias_matches_analog_butterworth_to_fs_over_8():
    fs, fc = 20000.0, 1500.0
    f = np.linspace(1.0, fs / 8, 500)
    b, a = signal.butter(2, 2 * np.pi * fc, analog=True)
    _, h_analog = signal.freqs(b, a, worN=2 * np.pi * f)
    state = AntiAlias(fc, 2).init_state(fs, None)
    _, h = signal.sosfreqz(state.sos, worN=f, fs=fs)
    np.testing.assert_allclose(np.abs(h), np.abs(h_analog), rtol=0.01)


@pytest.mark.parametrize("kind", ["butterworth", "bessel"])
def test_lowpass_minus_3db_at_corner(kind):
    """ADXL355 digital low-pass: corner = ODR/4 = 1 kHz at ODR 4 kHz; -3 dB there."""
    fs = 20000.0
    stage = LowPass(1000.0, 4, kind)
    assert _sine_gain(stage, 1000.0, fs) == pytest.approx(1 / np.sqrt(2), rel=0.01)
    assert abs(stage.response(np.array([1000.0]))[0]) == pytest.approx(1 / np.sqrt(2), rel=1e-6)
    assert _sine_gain(stage, 50.0, fs, periods=40) == pytest.approx(1.0, rel=1e-3)


def test_highpass_removes_dc():
    """Why presets keep the HPF off: it removes the very DC shift (VRE)."""
    fs = 1000.0
    y, _ = _run(HighPass(1.0), np.r_[np.zeros(10), np.ones(20000)], fs)
    assert abs(y[-1]) < 1e-6
    assert abs(HighPass(1.0).response(np.array([1.0]))[0]) == pytest.approx(1 / np.sqrt(2))


def test_filter_state_carried_across_blocks_exactly(rng):
    x = rng.standard_normal(5000)
    for stage in (Resonator(2400.0, 7.4), AntiAlias(1500.0), LowPass(1000.0), HighPass(5.0)):
        whole, _ = _run(stage, x, 20000.0)
        pieces, _ = _run(stage, x, 20000.0, block=333)
        np.testing.assert_array_equal(whole, pieces)


# ---------------------------------------------------------------------------- static maps


def test_polynomial_mean_shift_sine_closed_form_spec_1_2():
    """SPEC 1.2: VRE = k2 (E[(g0+x)²]-g0²) + k3 (E[(g0+x)³]-g0³) + k4 (E[(g0+x)⁴]-g0⁴).

    Sine of amplitude A: E[x²] = A²/2, E[x⁴] = 3A⁴/8, odd moments 0, so
    VRE = k2 A²/2 + 3 k3 g0 A²/2 + k4 (6 g0² A²/2 + 3A⁴/8). Sampled over whole periods with more
    than 4 samples per period the sample moments are exact.
    """
    k2, k3, k4, g0, amp = 100e-6, 40e-6, 5e-6, 1.0, 2.0
    fs, f = 1000.0, 10.0
    t = np.arange(int(fs / f) * 50) / fs
    stage = Polynomial(k2, k3, k4)
    y, _ = stage.process(g0 + amp * np.cos(2 * np.pi * f * t), None, fs)
    y0, _ = stage.process(np.full(10, g0), None, fs)
    expected = k2 * amp**2 / 2 + 3 * k3 * g0 * amp**2 / 2 + k4 * (6 * g0**2 * amp**2 / 2 + 3 * amp**4 / 8)
    assert y.mean() - y0.mean() == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize(
    "k", [(0.0, 0.0, 0.0), (2e-5, 0.0, 0.0), (2e-5, -3e-4, 0.0), (0.0, 0.0, 5e-3), (1e-2, 2e-3, -4e-4)]
)
def test_polynomial_equals_its_power_series_and_leaves_input(rng, k):
    """SPEC 1.2: y = a + k2·a² + k3·a³ + k4·a⁴, summed term by term (numpy.polynomial)."""
    x = 1.0 + 2.0 * rng.standard_normal(5000)
    x0 = x.copy()
    y, _ = _run(Polynomial(*k), x, 1000.0)
    expected = np.polynomial.polynomial.polyval(x, [0.0, 1.0, *k])
    np.testing.assert_allclose(y, expected, rtol=1e-13, atol=1e-13)
    np.testing.assert_array_equal(x, x0)
    assert y is not x


def test_clip_counts_and_censors():
    x = np.array([-3.0, -2.0, -1.0, 0.0, 2.5, 2.0, 7.0, 1.99])
    y, state = _run(Clip(-2.0, 2.0), x, 100.0)
    np.testing.assert_array_equal(y, [-2.0, -2.0, -1.0, 0.0, 2.0, 2.0, 2.0, 1.99])
    assert Clip(-2.0, 2.0).stats(state) == {"clipped_low": 1, "clipped_high": 2, "clipped_samples": 3}
    _, state = _run(Clip(-2.0, 2.0), x, 100.0, block=3)
    assert state.low + state.high == 3


def test_quantize_rounds_to_lsb():
    lsb = 1 / 256000  # ADXL355 ±2 g: 256000 LSB/g (data sheet Rev. D)
    x = np.array([0.0, 0.4 * lsb, 0.6 * lsb, -1.4 * lsb, 1.0, 123.7 * lsb])
    y, _ = Quantize(lsb).process(x, None, 1.0)
    np.testing.assert_allclose(y / lsb, [0, 0, 1, -1, 256000, 124], atol=1e-9)
    xs = np.random.default_rng(3).uniform(-2, 2, 10000)
    ys, _ = Quantize(lsb).process(xs, None, 1.0)
    assert np.max(np.abs(ys - xs)) <= lsb / 2 * (1 + 1e-9)


def test_offset_adds():
    y, _ = Offset(0.025).process(np.zeros(3), None, 1.0)
    np.testing.assert_array_equal(y, [0.025] * 3)


# ---------------------------------------------------------------------------- over-range


def _reference_overrange(x, thr, h, value, retrigger, tau_samples=0.0):
    """Per-sample loop: the obvious (slow) implementation to check the vectorised one."""
    y = x.copy()
    remaining, m, y0, prev, prev_held = 0, 0, 0.0, 0.0, False
    for i, v in enumerate(x):
        if abs(v) > thr and (retrigger or remaining == 0):
            if not prev_held:  # a new episode: remember the output just before it
                m, y0 = 0, prev
            remaining = h  # a hold that follows another without a gap continues its decay
        prev_held = remaining > 0
        if remaining > 0:
            m += 1
            y[i] = value if tau_samples == 0 else value + (y0 - value) * np.exp(-m / tau_samples)
            remaining -= 1
        prev = v
    return y


def test_overrange_hold_exact_samples_and_retrigger():
    """ADXL355 data sheet Rev. D: 0.5 ms hold -> 5 samples at 10 kHz; output goes to 0."""
    fs = 10000.0
    x = np.ones(60)
    x[[10, 12, 30, 50, 51]] = 9.0  # trips above 8 g (the ±2 g threshold)
    expected = np.ones(60)
    expected[10:17] = 0.0  # 10..14, restarted at 12 -> 12..16
    expected[30:35] = 0.0
    expected[50:56] = 0.0  # 50..54, restarted at 51 -> 51..55
    stage = OverRange(8.0, 0.5e-3, 0.0, retrigger=True)
    for block in (None, 1, 7, 32):  # 32 puts a block edge inside the hold at 30
        y, state = _run(stage, x, fs, block=block)
        np.testing.assert_array_equal(y, expected)
        assert stage.stats(state) == {"overrange_events": 3, "overrange_samples": 18}


def test_overrange_without_retrigger_ignores_trips_during_hold():
    fs = 10000.0
    x = np.ones(40)
    x[[10, 12, 15]] = 9.0
    expected = np.ones(40)
    expected[10:15] = 0.0  # 12 ignored; 15 is after the hold -> new hold 15..19
    expected[15:20] = 0.0
    stage = OverRange(8.0, 0.5e-3, 0.0, retrigger=False)
    for block in (None, 1, 4, 13, 15):  # 15: the second hold starts right at a block edge
        y, state = _run(stage, x, fs, block=block)
        np.testing.assert_array_equal(y, expected)
        assert state.events == 1  # 10..19 is one continuous episode


@pytest.mark.parametrize("retrigger", [True, False])
@pytest.mark.parametrize("tau_samples", [0.0, 3.0])
def test_overrange_matches_per_sample_loop(rng, retrigger, tau_samples):
    fs = 20000.0
    x = 1.0 + 3.0 * rng.standard_normal(20000)
    stage = OverRange(7.0, 0.5e-3, -0.25, retrigger=retrigger, float_tau_s=tau_samples / fs)
    expected = _reference_overrange(x, 7.0, 10, -0.25, retrigger, tau_samples)
    assert np.count_nonzero(expected != x) > 100
    for block in (None, 1, 97, 4096):
        y, _ = _run(stage, x, fs, block=block)
        np.testing.assert_allclose(y, expected, rtol=0, atol=1e-12)


def test_overrange_float_tau_exponential_approach():
    """float_tau_s: y = v + (y0 - v) exp(-m/(tau fs)), m = 1, 2, ... samples into the hold."""
    fs = 1000.0
    x = np.full(30, 0.5)
    x[5] = 10.0
    stage = OverRange(8.0, 0.01, 0.0, float_tau_s=2.0 / fs)  # 10-sample hold, tau = 2 samples
    for block in (None, 1, 7):
        y, _ = _run(stage, x, fs, block=block)
        np.testing.assert_allclose(y[5:15], 0.5 * np.exp(-np.arange(1, 11) / 2.0), rtol=1e-12)
        np.testing.assert_array_equal(y[15:], 0.5)
        np.testing.assert_array_equal(y[:5], 0.5)


def test_overrange_does_not_modify_input(rng):
    x = 5 * rng.standard_normal(1000)
    x0 = x.copy()
    _run(OverRange(8.0, 1e-3), x, 1000.0, block=100)
    np.testing.assert_array_equal(x, x0)


# ---------------------------------------------------------------------------- decimate, noise


def test_decimate_phase_carried_across_blocks(rng):
    x = rng.standard_normal(1001)
    for block in (1, 3, 5, 7, 64, 1001):
        y, _ = _run(Decimate(5), x, 20000.0, block=block)
        np.testing.assert_array_equal(y, x[::5])
    assert Decimate(5).rate_factor == 5


def test_noise_density_by_welch_within_5pct():
    """σ = d sqrt(fs/2): the one-sided PSD is d² (g²/Hz), measured with scipy.signal.welch."""
    fs, density = 20000.0, 22.5  # ADXL355 ±2 g, data sheet Rev. D
    y, _ = _run(Noise(density), np.zeros(1 << 19), fs, seed=np.random.SeedSequence(7))
    f, p = signal.welch(y, fs=fs, nperseg=4096)
    band = (f > 10) & (f < 9000)
    assert np.sqrt(p[band].mean()) * 1e6 == pytest.approx(density, rel=0.05)


def test_noise_same_whatever_the_block_size():
    ss = np.random.SeedSequence(11)
    stage = Noise(25.0, frame_size=1000)
    x = np.zeros(5500)
    whole, _ = _run(stage, x, 4000.0, seed=ss)
    for block in (1, 999, 1000, 2048):
        y, _ = _run(stage, x, 4000.0, block=block, seed=ss)
        np.testing.assert_array_equal(y, whole)
    other, _ = _run(stage, x, 4000.0, seed=np.random.SeedSequence(12))
    assert not np.array_equal(other, whole)


# ---------------------------------------------------------------------------- protocol, validation


def test_every_stage_follows_the_protocol():
    stages = [
        Resonator(1.0, 1.0), AntiAlias(1.0), LowPass(1.0), HighPass(1.0), Polynomial(), Offset(),
        Clip(-1.0, 1.0), Quantize(1.0), Decimate(2), Noise(1.0), OverRange(1.0, 1.0),
    ]
    for s in stages:
        assert isinstance(s, Stage)
    assert Polynomial().is_static and Clip(-1, 1).is_static and Quantize(1.0).is_static
    assert not Resonator(1.0, 1.0).is_static and not OverRange(1.0, 1.0).is_static

    @dataclass(frozen=True)
    class Gain(StageBase):  # a user stage: only process() to write
        k: float

        def process(self, x, state, fs_hz):
            return self.k * x, state

    y, stats = SensorChain((Gain(2.0), Decimate(2))).apply(np.arange(6.0), 10.0)
    np.testing.assert_array_equal(y, [0.0, 4.0, 8.0])


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: Resonator(2400.0, -1), "Resonator q must be > 0, got -1"),
        (lambda: Resonator(float("nan"), 1.0), "Resonator fn_hz must be finite"),
        (lambda: Polynomial(k2_per_g="a"), "Polynomial k2_per_g must be a number"),
        (lambda: OverRange(8.0, 0.0), "OverRange hold_s must be > 0, got 0.0"),
        (lambda: OverRange(-8.0, 1e-3), "OverRange threshold_g must be > 0"),
        (lambda: OverRange(8.0, 1e-3, float_tau_s=-1.0), "OverRange float_tau_s must be >= 0"),
        (lambda: Clip(2.0, -2.0), "Clip low_g must be < high_g"),
        (lambda: AntiAlias(1500.0, order=0), "AntiAlias order must be an integer >= 1, got 0"),
        (lambda: LowPass(1000.0, kind="cheby"), "LowPass kind must be one of butterworth, bessel"),
        (lambda: Decimate(2.5), "Decimate factor must be an integer >= 1, got 2.5"),
        (lambda: Quantize(0.0), "Quantize lsb_g must be > 0, got 0.0"),
        (lambda: Noise(-1.0), "Noise density_ug_per_rthz must be >= 0"),
        (lambda: Offset(float("inf")), "Offset offset_g must be finite"),
    ],
)
def test_stage_validation_names_field_and_value(make, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        make()
