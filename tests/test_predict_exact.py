"""predict's memoryless chain (polynomial, rails, over-range) held against independent computations.

The Monte Carlo here uses numpy only (no vrelab code for the expectation): Gaussian samples with
the variance each stage sees (σ² = ∫S·|H|²df computed here by the trapezoid rule on a dense grid,
not by vrelab.models.dynamics), the polynomial and the rails applied as plain numpy, the mean
taken. Issue 18's truths: the row-1 part (k2 1500 µg/g², k3 -250 µg/g³, fn 900 Hz, Q 6, rails
-2.05/+2.10 g, flat 20-2000 Hz, 0 g) is +9.14 and +16.17 mg at 1 and 2 g rms by adaptive
quadrature of E[clip(P(x))] split at the kinks (scipy.integrate.quad, reproduced in
``test_row1_part_against_adaptive_quadrature``); the addition of independent shares gave
+14.3 and +40.9 mg.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import integrate, stats

from vrelab.models.memoryless import linear_part, poly_clip_vre
from vrelab.prediction import predict
from vrelab.profiles import parse_profile
from vrelab.sensor import load_sensor


def _part(tmp_path, clip_position: str = "output", extra: str = "") -> str:
    path = tmp_path / f"part_{clip_position}.toml"
    path.write_text(f"""schema = 1
name = "part"
description = "issue 18 row 1"
source = "test"
default_range_g = 2
default_axis = "z"
fn_hz = 900.0
q = 6.0
k2_ug_per_g2 = 1500.0
k3_ug_per_g3 = -250.0
clip_position = "{clip_position}"
{extra}
[ranges."2"]
rails_g = [-2.05, 2.10]
""")
    return str(path)


def _sigma_flat(f_lo: float, f_hi: float, rms: float, fn: float, q: float) -> float:
    """σ of flat random vibration through 1/(1 - r² + j r/Q), by the trapezoid rule (independent
    of vrelab.models.dynamics)."""
    f = np.linspace(f_lo, f_hi, 400001)
    r = f / fn
    h2 = 1.0 / ((1 - r * r) ** 2 + (r / q) ** 2)
    return math.sqrt(np.trapezoid(rms**2 / (f_hi - f_lo) * h2, f))


def _mc_mean(rng: np.random.Generator, sigma: float, fn, n: int = 4_000_000, reps: int = 4) -> tuple[float, float]:
    """Mean of fn(x), x ~ N(0, σ²), and its standard error, from ``reps`` batches."""
    means = [float(np.mean(fn(rng.standard_normal(n) * sigma))) for _ in range(reps)]
    return float(np.mean(means)), float(np.std(means, ddof=1) / math.sqrt(reps))


def test_row1_part_against_adaptive_quadrature(tmp_path):
    """Issue 18 row 1: predict gives +9.14 and +16.17 mg (adaptive quadrature, split at the
    roots of P(x) = rail), not the +14.3 / +40.9 mg of independent shares; the shares add up to
    the total and the level is valid (no filter between the polynomial and the rails: exact)."""
    sensor = load_sensor(_part(tmp_path))
    pred = predict(sensor, parse_profile("flat:20-2000"), [1.0, 2.0], static_g=0.0)
    k2, k3 = 1500e-6, -250e-6
    for lv, rms in zip(pred.levels, (1.0, 2.0)):
        s = _sigma_flat(20.0, 2000.0, rms, 900.0, 6.0)
        roots = sorted(z.real for rail in (-2.05, 2.10) for z in np.roots([k3, k2, 1.0, -rail]) if abs(z.imag) < 1e-9)
        cuts = [-40 * s, *[r for r in roots if abs(r) < 40 * s], 40 * s]

        def g(x: float) -> float:
            return float(np.clip(x + k2 * x * x + k3 * x**3, -2.05, 2.10)) * stats.norm.pdf(x, 0.0, s)

        truth = sum(integrate.quad(g, a, b, epsabs=1e-13, epsrel=1e-12, limit=200)[0] for a, b in zip(cuts[:-1], cuts[1:]))
        assert lv.vre_g == pytest.approx(truth, abs=2e-5), (lv.vre_g, truth)
        assert lv.valid and lv.model_error_g == 0.0
        sh = lv.shares
        assert sh["clip_g"] + sh["nonlinearity_g"] + sh["overrange_g"] == pytest.approx(lv.vre_g, abs=1e-15)
    assert pred.levels[0].vre_g == pytest.approx(9.14e-3, abs=0.01e-3)
    assert pred.levels[1].vre_g == pytest.approx(16.17e-3, abs=0.01e-3)


@pytest.mark.parametrize("g0", [-1.0, 0.3, 1.0])
@pytest.mark.parametrize("k2, k3, k4", [(1500e-6, -250e-6, 0.0), (-4000e-6, 800e-6, 0.0), (2000e-6, 0.0, -300e-6)])
@pytest.mark.parametrize("sigma", [0.4, 1.2, 3.0])
def test_memoryless_chain_against_numpy_monte_carlo(g0, k2, k3, k4, sigma):
    """E[clip(P(g0 + x) + offset)] - clip(P(g0) + offset) against a numpy Monte Carlo, over
    static fields, levels and coefficients (asymmetric rails, an offset): within 4 standard
    errors plus 1e-6 g (the batches cannot resolve a tail beyond 4σ: a few samples). Control variate: E[clip(P)] = E[clip(P) - P] + E[P], the first by Monte
    Carlo (zero inside the rails, so a small variance), the second from the Gaussian moments
    E[y²] = g0² + σ², E[y³] = g0³ + 3g0σ², E[y⁴] = g0⁴ + 6g0²σ² + 3σ⁴."""
    low, high, off = -2.05, 2.10, 0.02
    rng = np.random.default_rng([int(10 * g0) + 10, int(10 * sigma), int(1e6 * k2) + 10000, int(1e6 * k4) + 1000])

    def poly(y):
        return y + k2 * y * y + k3 * y**3 + k4 * y**4 + off

    def beyond(x):
        p = poly(g0 + x)
        return np.clip(p, low, high) - p

    mean_p = (g0 + k2 * (g0**2 + sigma**2) + k3 * (g0**3 + 3 * g0 * sigma**2)
              + k4 * (g0**4 + 6 * g0**2 * sigma**2 + 3 * sigma**4) + off)
    ref = float(np.clip(poly(g0), low, high))
    mc, se = _mc_mean(rng, sigma, beyond, n=200_000, reps=4)
    got = poly_clip_vre(g0, sigma, k2, k3, k4, offset_g=off, rail_low_g=low, rail_high_g=high)
    assert got == pytest.approx(mc + mean_p - ref, abs=4 * se + 1e-6), (got, mc + mean_p - ref, se)


@pytest.mark.parametrize("g0", [0.0, 1.0])
def test_memoryless_chain_sine_and_truncated_against_numpy(g0):
    """A sine (phases on a fine uniform grid) and the truncated kind (samples beyond a rail
    discarded), each against plain numpy."""
    k2, k3, low, high = 3000e-6, -500e-6, -2.0, 2.0
    amp = 1.6
    theta = (np.arange(2_000_000) + 0.5) * (2 * np.pi / 2_000_000)
    y = g0 + amp * np.cos(theta)
    p = y + k2 * y * y + k3 * y**3
    ref = g0 + k2 * g0**2 + k3 * g0**3
    assert poly_clip_vre(g0, amp / math.sqrt(2), k2, k3, rail_low_g=low, rail_high_g=high, shape="sine") == pytest.approx(
        float(np.mean(np.clip(p, low, high))) - ref, abs=1e-9)
    rng = np.random.default_rng(7)
    x = g0 + rng.standard_normal(4_000_000) * 1.1
    px = x + k2 * x * x + k3 * x**3
    kept = px[(px > low) & (px < high)]
    se = float(np.std(kept) / math.sqrt(kept.size))
    assert poly_clip_vre(g0, 1.1, k2, k3, rail_low_g=low, rail_high_g=high, kind="truncated") == pytest.approx(
        float(np.mean(kept)) - ref, abs=4 * se)


def test_linear_part_is_stein_gain():
    """For Gaussian x the best linear gain of P(g0 + x) is E[P'(g0 + x)] (Stein's lemma): for a
    cubic, 1 + 2·k2·g0 + 3·k3·(g0² + σ²)."""
    k2, k3, g0, s = 1500e-6, -250e-6, 1.0, 2.0
    gain, rest = linear_part(g0, s, k2, k3)
    assert gain == pytest.approx(1 + 2 * k2 * g0 + 3 * k3 * (g0**2 + s**2), rel=1e-13)
    # the rest: Var(P) - gain²σ² = 2·(k2 + 3·k3·g0)²σ⁴ + 6·k3²σ⁶ (Hermite terms 2 and 3)
    assert rest**2 == pytest.approx(2 * (k2 + 3 * k3 * g0) ** 2 * s**4 + 6 * k3**2 * s**6, rel=1e-9)


@pytest.mark.parametrize("k2_ug", [200.0, 3000.0])
def test_filtered_clip_against_numpy_monte_carlo_of_the_chain(k2_ug):
    """ADXL355 Z, ±2 g rails after the low-pass: the rails see the filtered polynomial output,
    modelled as Gaussian with the polynomial's linear part. A numpy Monte Carlo of the chain
    (Gaussian proof-mass motion drawn in the frequency domain with the profile through
    1/(1 - r² + j r/Q), the polynomial, the output filters as analog responses, the clip) is
    within model_error_g (plus 4 standard errors) of the prediction; valid exactly where that
    error stays within 1 % of |VRE|: k2 = 200 µg/g² valid (and within 1 %), k2 = 3000 µg/g²
    not (bound 3 mg; a longer Monte Carlo, 6 × 2^20 samples, differs by 0.72 ± 0.14 mg of 45,
    more than 1 %)."""
    k2 = k2_ug * 1e-6
    # without the preset's assumed u (issue 28): its k3 and filters' u would widen the u the bound is
    # judged against; here the approximation alone, against 1 % of |VRE|
    sensor = dataclasses.replace(load_sensor("adxl355", range_g=2, axis="z", k2_ug_per_g2=k2_ug), uncertainty={})
    (lv,) = predict(sensor, parse_profile("flat:50-2000"), [1.2], static_g=1.0).levels
    fs, n, reps = 32768.0, 1 << 19, 8
    f = np.fft.rfftfreq(n, 1 / fs)
    band = (f >= 50) & (f <= 2000)
    psd = np.where(band, 1.2**2 / 1950.0, 0.0)
    h_m = sensor.response(f, "proof-mass")
    h_f = np.where(f > 0, sensor.response(np.maximum(f, 1e-9), "output") / h_m, 1.0)
    rng = np.random.default_rng(18)
    means = []
    for _ in range(reps):
        c = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) * np.sqrt(psd * fs * n / 4)
        y = 1.0 + np.fft.irfft(c * h_m, n)  # total input at the proof mass (g0 = 1 g)
        p = y + k2 * y * y  # the polynomial
        z = np.fft.irfft(np.fft.rfft(p) * h_f, n)  # the output filters (gain 1 at DC)
        means.append(float(np.mean(np.clip(z, -2.048, 2.048))) - (1.0 + k2))
    mc, se = float(np.mean(means)), float(np.std(means, ddof=1) / math.sqrt(reps))
    # over-range (-0.02 mg here) is not in the Monte Carlo
    diff = abs(lv.vre_g - lv.shares["overrange_g"] - mc)
    assert diff < lv.model_error_g + 4 * se, (lv.vre_g, mc, se, lv.model_error_g)
    if k2_ug < 1000:
        assert lv.valid and diff < 0.01 * abs(lv.vre_g) + 4 * se
    else:
        assert not lv.valid and any("non-Gaussian" in n for n in lv.notes)


def test_overrange_uses_the_held_stretches_mean_adxl355_x_8g():
    """Issue 18: ADXL355 X on ±8 g (threshold 16 g), 4 g rms 50-2000 Hz at +1 g. vrelab's own
    simulation gives -106 ± 6 mg (issue 18; -110.5 ± 5 mg with seed 3 and 20 s here); the
    over-range share taken with the static field (p·(0 - 1 g)) gave -48.7 mg (total -55 mg,
    11u away), the held stretches' mean (≈ 1.9 g: they start beyond the threshold) about twice
    that (total -96 mg). Flagged (over-range share large), but within 3u + 5 %."""
    from vrelab import shaker

    sensor = load_sensor("adxl355", range_g=8, axis="x")
    flat = parse_profile("flat:50-2000")
    (lv,) = predict(sensor, flat, [4.0], static_g=1.0).levels
    assert not lv.valid and any("over-range" in n for n in lv.notes)
    assert lv.shares["overrange_g"] < -0.080
    (sim,) = shaker.run_random_test(sensor, flat, [4.0], seconds=20.0, baseline_s=2.0, seed=3).levels
    assert abs(sim.vre.value - lv.vre_g) < 3 * sim.vre.u + 0.05 * abs(lv.vre_g), (sim.vre, lv.vre_g)


@pytest.mark.parametrize("g0, delta, expected_deg", [
    (0.9, 1e-3, 0.1318),     # issue 18: asin(0.901) - asin(0.9)
    (0.0, 1e-3, 0.0573),     # horizontal axis: 1 mg is 0.0573°
    (0.99, -1e-3, -0.3965),   # asin(0.989) - asin(0.99): near vertical, ≈ 7× the horizontal value
])
def test_tilt_from_the_axis_orientation(g0, delta, expected_deg):
    """SPEC 1.5: tilt error asin(g0 + δ) - asin(g0) (reference values by hand, 4 digits)."""
    from vrelab.models.design import tilt_error_from_static_deg

    assert tilt_error_from_static_deg(delta, g0) == pytest.approx(expected_deg, abs=1e-4)
    assert math.degrees(math.asin(g0 + delta) - math.asin(g0)) == pytest.approx(expected_deg, abs=1e-4)


@pytest.mark.parametrize("g0, delta", [(1.0, -1e-3), (0.9995, 0.0), (0.9995, 1e-3), (-1.2, 0.0)])
def test_tilt_undefined_near_or_beyond_one_g(g0, delta):
    """Near (within 1 mg) or beyond ±1 g there is no tilt: a ValueError saying so, and predict
    gives null with the reason."""
    from vrelab.models.design import tilt_error_from_static_deg

    with pytest.raises(ValueError, match="1 g"):
        tilt_error_from_static_deg(delta, g0)


def test_predict_tilt_at_0p9_g_and_null_at_1_g():
    """predict --static=0.9: the tilt of each level is asin(0.9 + VRE) - asin(0.9); at +1 g it
    is null with a note."""
    sensor = load_sensor("ideal", k2_ug_per_g2=4000.0)
    flat = parse_profile("flat:20-2000")
    (lv,) = predict(sensor, flat, [0.5], static_g=0.9).levels
    assert lv.tilt_error_deg == pytest.approx(math.degrees(math.asin(0.9 + lv.vre_g) - math.asin(0.9)), rel=1e-12)
    d = predict(sensor, flat, [0.5], static_g=1.0).to_dict()
    assert d["levels"][0]["tilt_error_deg"] is None
    assert any("tilt error undefined" in n for n in d["notes"])
