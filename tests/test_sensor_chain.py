"""The streaming chain and the chains that sensor descriptions build.

References: SPEC 1.3 (output clip sees sigma_out² = ∫ S |H_mech H_aa H_lpf|² df; a narrower
bandwidth rectifies less: the article's Figure 4, 125 Hz vs 1 kHz), SPEC 1.2 (k2·σ² through the
ideal sensor), ADXL354/355 data sheet Rev. D (22.5 µg/√Hz on ±2 g).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import integrate, signal

from vrelab.sensor import (
    Clip,
    Decimate,
    Noise,
    OverRange,
    Polynomial,
    SensorChain,
    load_sensor,
)


def _band_gaussian(rng, fs, n, f1, f2, rms):
    """Gaussian noise flat between f1 and f2 (zero elsewhere), scaled to ``rms``."""
    spec = rng.standard_normal(n // 2 + 1) + 1j * rng.standard_normal(n // 2 + 1)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec[(f < f1) | (f > f2)] = 0
    x = np.fft.irfft(spec, n)
    return x * rms / x.std()


def test_adxl355_chain_same_output_whatever_the_block_size(rng):
    """Noise, over-range holds, filter states and decimation phase all carried across blocks."""
    sensor = load_sensor("adxl355")
    fs = sensor.internal_rate_hz(2000.0)
    chain = sensor.chain(fs)
    x = 1.0 + _band_gaussian(rng, fs, 3 * int(fs), 50.0, 2000.0, 3.0)
    outs, stats = [], []
    for block in (1000, 8192, x.size):
        runner = chain.start(fs, seed=5)
        outs.append(np.concatenate([runner.process(x[i : i + block]) for i in range(0, x.size, block)]))
        stats.append(runner.stats)
    np.testing.assert_array_equal(outs[0], outs[1])
    np.testing.assert_array_equal(outs[0], outs[2])
    assert stats[0] == stats[1] == stats[2]
    assert stats[0].overrange_events > 0 and stats[0].clipped_samples > 0  # the test exercises both
    assert outs[0].size == x.size // chain.rate_factor


@pytest.mark.parametrize("axis", ["x", "z"])
def test_fused_filters_give_the_stage_by_stage_output(rng, axis):
    """The runner fuses consecutive linear filters (anti-alias -> low-pass) into one sosfilt;
    the output equals every stage's own process applied in turn (same seeds, same rates), to
    rounding, for blocks that cut the record anywhere; the input is not modified."""
    sensor = load_sensor("adxl355", range_g=2, axis=axis, odr_hz=4000)
    fs = 16000.0
    chain = sensor.chain(fs)
    x = 1.0 + _band_gaussian(rng, fs, 48_000, 50.0, 2000.0, 2.5)
    x0 = x.copy()
    ss = np.random.SeedSequence(3)
    # stage by stage, no fusion: each stage's process over the whole record; the decimator
    # keeps the samples on the grid the over-range stage's 2-sample delay moved
    y, rate = x, fs
    for i, stage in enumerate(chain.stages):
        state = stage.init_state(rate, np.random.SeedSequence(entropy=ss.entropy, spawn_key=(i,)))
        if isinstance(stage, Decimate):
            state = OverRange.delay_samples % stage.factor
        y, _ = stage.process(y, state, rate)
        rate /= stage.rate_factor
    for block in (48_000, 4096, 1001):
        out, _ = chain.apply(x, fs, seed=ss, block_size=block)
        np.testing.assert_allclose(out, y, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(x, x0)


@pytest.mark.parametrize("factor", [1, 2, 8])
def test_decimated_output_samples_the_same_instants_after_a_delaying_stage(factor):
    """The over-range stage delays by 2 input samples; the decimator after it keeps the
    samples of the undelayed grid, so the output is the input at the output-rate instants
    (delayed by whole output samples: 2 // factor), whatever the internal rate."""
    fs_out = 1000.0
    fs = fs_out * factor
    t = np.arange(4000 * factor) / fs
    x = np.sin(2 * np.pi * 37.0 * t)
    chain = SensorChain((OverRange(1e6, 1e-3), Decimate(factor)))
    for block in (None, 7, 1000):
        out, _ = chain.apply(x, fs, block_size=block or x.size)
        lag = 2 // factor
        assert out.size == x.size // factor
        np.testing.assert_array_equal(out[lag:], x[::factor][: out.size - lag])


def test_run_iterator_exposes_stats_and_output_rate(rng):
    chain = SensorChain((Polynomial(1e-4), Clip(-1.0, 1.0), Decimate(4)))
    x = 2 * rng.standard_normal(4000)
    out = chain.run((x[i : i + 500] for i in range(0, 4000, 500)), fs_hz=4000.0)
    y = np.concatenate(list(out))
    assert y.size == 1000 and out.fs_out_hz == 1000.0 and chain.fs_out_hz(4000.0) == 1000.0
    clipped = np.count_nonzero(np.abs(x + 1e-4 * x**2) > 1.0)
    assert out.stats.clipped_samples == clipped
    assert out.stats.samples_in == 4000 and out.stats.samples_out == 1000
    assert out.stats.to_dict()["per_stage"][0]["stage"] == "Clip"


def test_chain_seed_reproducible_and_input_untouched(rng):
    chain = SensorChain((Noise(25.0),))
    x = rng.standard_normal(1000)
    x0 = x.copy()
    a, _ = chain.apply(x, 1000.0, seed=3)
    ss = np.random.SeedSequence(3)
    b, _ = chain.apply(x, 1000.0, seed=ss)
    c, _ = chain.apply(x, 1000.0, seed=ss)  # same SeedSequence object twice: not consumed
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(b, c)
    np.testing.assert_array_equal(x, x0)
    y, _ = SensorChain(()).apply(x, 1000.0)
    y[0] = 99.0
    assert x[0] == x0[0]  # an empty chain still returns a new array


def test_chain_rejects_bad_input():
    chain = SensorChain((Clip(-1.0, 1.0),))
    with pytest.raises(ValueError, match="fs_hz"):
        chain.start(0.0)
    with pytest.raises(ValueError, match="seed"):
        chain.start(100.0, seed=-1)
    with pytest.raises(ValueError, match="one-dimensional"):
        chain.start(100.0).process(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="finite"):
        chain.start(100.0).process(np.array([np.nan]))
    with pytest.raises(ValueError, match=r"stages\[1\]"):
        SensorChain((Clip(-1.0, 1.0), "clip"))


def test_ideal_sensor_vrc_k2_rms2_spec_1_2():
    """Ideal preset: VRE = k2·rms² + 3·k3·g0·rms² for a low-frequency sine (SPEC 1.2)."""
    sensor = load_sensor("ideal", range_g=8.0, k2_ug_per_g2=50.0, k3_ug_per_g3=20.0)
    fs = 2000.0
    chain = sensor.chain(fs)
    assert chain.rate_factor == 1
    t = np.arange(int(fs) * 2) / fs
    g0, rms = 1.0, 2.0
    y, stats = chain.apply(g0 + rms * np.sqrt(2) * np.sin(2 * np.pi * 10.0 * t), fs)
    y0, _ = chain.apply(np.full(100, g0), fs)
    assert stats.clipped_samples == 0
    assert y.mean() - y0.mean() == pytest.approx((50e-6 + 3 * 20e-6 * g0) * rms**2, rel=1e-9)


def test_output_variance_matches_linear_responses(rng):
    """The chain's linear part equals the analog responses predict uses (SPEC 1.3, σ_out)."""
    sensor = dataclasses.replace(load_sensor("adxl355", odr_hz=2000.0), noise_ug_per_rthz=0.0, lsb_g=None)
    fs = sensor.internal_rate_hz(1500.0)
    f1, f2, rms = 50.0, 1500.0, 0.3  # far from the rails and the over-range threshold
    x = _band_gaussian(rng, fs, 40 * int(fs), f1, f2, rms)
    y, stats = sensor.chain(fs).apply(x, fs)
    assert stats.clipped_samples == 0
    psd = rms**2 / (f2 - f1)
    var_pred, _ = integrate.quad(lambda f: psd * abs(sensor.response(f, "output")) ** 2, f1, f2, limit=200)
    var_mech, _ = integrate.quad(lambda f: psd * abs(sensor.response(f, "proof-mass")) ** 2, f1, f2, limit=200)
    assert y[200:].var() == pytest.approx(var_pred, rel=0.03)
    assert var_mech > 1.5 * var_pred  # the filters matter: the resonance is not what the clip sees


def test_adxl355_output_noise_density_datasheet():
    """ADXL354/355 Rev. D: 22.5 µg/√Hz on ±2 g, seen in band at the output (ODR 4 kHz)."""
    sensor = load_sensor("adxl355")
    fs = sensor.internal_rate_hz(1000.0)
    y, _ = sensor.chain(fs).apply(np.zeros(int(fs) * 60), fs, seed=1)
    f, p = signal.welch(y, fs=sensor.odr_hz, nperseg=2048)
    band = (f > 5) & (f < 300)
    assert np.sqrt(p[band].mean()) * 1e6 == pytest.approx(22.5, rel=0.05)


def test_narrow_bandwidth_rectifies_less_article_fig4(rng):
    """Article Fig. 4: 125 Hz bandwidth (ODR 500) rectifies much less than 1 kHz (ODR 4000)."""
    vre = {}
    for odr in (4000.0, 500.0):
        sensor = load_sensor("adxl355", odr_hz=odr, axis="z")
        fs = sensor.internal_rate_hz(2000.0)
        chain = sensor.chain(fs)
        x = _band_gaussian(np.random.default_rng(2), fs, 10 * int(fs), 50.0, 2000.0, 1.5)
        base = chain.apply(np.ones(int(fs)), fs)[0].mean()
        vre[odr] = chain.apply(1.0 + x, fs, seed=4)[0].mean() - base
    assert vre[4000.0] < -0.01
    assert abs(vre[500.0]) < 0.2 * abs(vre[4000.0])


def test_overrange_pulls_mean_toward_zero(rng):
    """SPEC 1.3: over-range holds pull the mean toward 0: negative VRE at +1 g, positive at -1 g."""
    fs = 20000.0
    x = _band_gaussian(rng, fs, 4 * int(fs), 50.0, 2000.0, 3.0)
    chain = SensorChain((OverRange(8.0, 0.5e-3),))
    for g0 in (1.0, -1.0):
        y, stats = chain.apply(g0 + x, fs)
        assert stats.overrange_events > 0
        shift = y.mean() - (g0 + x).mean()
        assert np.sign(shift) == -np.sign(g0) and abs(shift) > 0.01


def test_sensor_chain_requires_integer_multiple_of_odr():
    sensor = load_sensor("adxl355")
    with pytest.raises(ValueError, match="integer multiple of the ODR 4000"):
        sensor.chain(21000.0)
    assert sensor.chain(20000.0).fs_out_hz(20000.0) == 4000.0
    assert sensor.fs_out_hz(40000.0) == 4000.0
