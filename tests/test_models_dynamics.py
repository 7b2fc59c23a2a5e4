"""Frequency dependence (SPEC 1.3): resonance, effective rms, crossing rates."""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest
from scipy import signal

from vrelab.models.dynamics import (
    effective_rms,
    resonator,
    rice_upcrossing_rate,
    rms_through,
    second_order_response,
    vrc_at_frequency,
    zero_crossing_rate_hz,
)


@pytest.mark.parametrize("q", [0.7, 1.5, 7.4, 50.0])
def test_vrc_at_resonance_is_vrc_times_q_squared(q):
    """SPEC 1.3: |H(fn)| = Q, so VRC_eff(fn) = VRC·Q²; DC gain 1."""
    assert vrc_at_frequency(100.0, 2400.0, 2400.0, q) == pytest.approx(100.0 * q * q, rel=1e-14)
    assert vrc_at_frequency(100.0, 0.0, 2400.0, q) == 100.0


def test_response_matches_scipy_freqs():
    """H(f) against scipy.signal.freqs of ωn²/(s² + ωn/Q·s + ωn²)."""
    fn, q = 2400.0, 7.4
    wn = 2 * np.pi * fn
    f = np.geomspace(10, 1e5, 50)
    _, h_ref = signal.freqs([wn**2], [1.0, wn / q, wn**2], worN=2 * np.pi * f)
    np.testing.assert_allclose(second_order_response(f, fn, q), h_ref, rtol=1e-12)


def test_white_noise_through_resonator_matches_miles_closed_form():
    """∫_0^∞ |H|² df = π·fn·Q/2 (Miles 1954; constant checked here by mpmath quadrature)."""
    fn, q = 2400.0, 7.4
    closed = math.pi * fn * q / 2
    mp_ref = mp.quad(lambda f: 1 / ((1 - (f / fn) ** 2) ** 2 + (f / (fn * q)) ** 2), [0, fn, mp.inf])
    assert float(mp_ref) == pytest.approx(closed, rel=1e-12)
    s0 = 1e-3
    # the band misses ∫_0^1mHz |H|² ≈ 1e-3 Hz and the tail above 1e8 Hz (~ fn⁴/(3·1e24))
    sigma = effective_rms(lambda f: np.full_like(f, s0), [resonator(fn, q)], 1e-3, 1e8)
    assert sigma**2 == pytest.approx(s0 * (closed - 1e-3), rel=1e-10)


def test_high_q_peak_is_not_stepped_over():
    """Q = 1000 (0.1 % wide peak): still π·fn·Q/2 to 1e-8 over a wide band."""
    fn, q = 1000.0, 1000.0
    sigma = effective_rms(lambda f: np.ones_like(f), [resonator(fn, q)], 1e-6, 1e9)
    assert sigma**2 == pytest.approx(math.pi * fn * q / 2, rel=1e-8)


def test_flat_band_rms_and_crossing_rate():
    """Flat S0 on [f1, f2]: σ² = S0·(f2-f1), ν0² = (f2³-f1³)/(3(f2-f1)) (Rice, m2/m0)."""
    f1, f2, s0 = 50.0, 2000.0, 0.01
    table = ([f1, f2], [s0, s0])
    assert effective_rms(table, [], 10.0, 5000.0) == pytest.approx(math.sqrt(s0 * (f2 - f1)), rel=1e-10)
    nu0 = zero_crossing_rate_hz(table, [], 10.0, 5000.0)
    assert nu0 == pytest.approx(math.sqrt((f2**3 - f1**3) / (3 * (f2 - f1))), rel=1e-10)


def test_crossing_rate_matches_simulated_gaussian_noise():
    """Rice: seeded band-limited noise, counted up-crossings of +2σ vs ν0·exp(-2), within 5 %."""
    rng = np.random.default_rng(5)
    fs, n = 20_000.0, 2_000_000
    sos = signal.butter(8, [200.0, 1000.0], btype="bandpass", fs=fs, output="sos")
    x = signal.sosfilt(sos, rng.normal(size=n))[5000:]
    sigma = x.std()
    level = 2 * sigma
    counted = np.count_nonzero((x[:-1] < level) & (x[1:] >= level)) / (x.size / fs)
    f = np.linspace(1.0, fs / 2, 20001)
    _, h = signal.sosfreqz(sos, worN=f, fs=fs)
    nu0 = zero_crossing_rate_hz((f, np.abs(h) ** 2 + 1e-300), [], 1.0, fs / 2)
    assert counted == pytest.approx(rice_upcrossing_rate(level, 0.0, sigma, nu0), rel=0.05)


def test_rms_through_and_rice_edge_cases():
    fn, q = 2400.0, 7.4
    assert rms_through(2400.0, 1.0, [resonator(fn, q)]) == pytest.approx(q)
    assert rms_through([0.0, 2400.0], 2.0, []) == pytest.approx([2.0, 2.0])
    assert rice_upcrossing_rate(1.0, 0.0, 0.0, 500.0) == 0.0
    assert rice_upcrossing_rate(0.0, 0.0, 1.0, 500.0) == 500.0


def test_bad_band_raises():
    with pytest.raises(ValueError, match="f_hi_hz"):
        effective_rms(lambda f: np.ones_like(f), [], 100.0, 10.0)
    with pytest.raises(ValueError, match="q"):
        second_order_response(10.0, 100.0, 0.0)


def test_dense_psd_table_through_resonator_matches_callable():
    """A 5000-point table of a smooth PSD through a Q = 7.4 resonance: same σ and ν0 as the
    callable (the table's log-log interpolation of a power law is exact)."""
    fn, q = 2400.0, 7.4
    f = np.geomspace(20.0, 20000.0, 5000)
    psd = lambda x: 0.02 * (np.asarray(x) / 100.0) ** -0.5  # noqa: E731  (a power law)
    h = [resonator(fn, q)]
    ref = effective_rms(psd, h, 20.0, 20000.0)
    assert effective_rms((f, psd(f)), h, 20.0, 20000.0) == pytest.approx(ref, rel=1e-9)
    nu_ref = zero_crossing_rate_hz(psd, h, 20.0, 20000.0)
    assert zero_crossing_rate_hz((f, psd(f)), h, 20.0, 20000.0) == pytest.approx(nu_ref, rel=1e-9)


@pytest.mark.parametrize("q", [7.4, 1000.0])
def test_dense_white_table_through_high_q_resonance_matches_miles(q):
    """Dense table path (3000 points) at Q up to 1000: π·fn·Q/2 (Miles) to 1e-10."""
    fn = 1000.0
    f = np.geomspace(1e-3, 1e8, 3000)
    sigma2 = effective_rms((f, np.ones_like(f)), [resonator(fn, q)], 1e-3, 1e8) ** 2
    assert sigma2 == pytest.approx(math.pi * fn * q / 2 - 1e-3, rel=1e-10)


def _moment_by_scipy_quad(psd, responses, lo, hi, power, cuts):
    """The reference: scipy.integrate.quad one frequency at a time on each piece (what
    models.dynamics used before its vectorised rule), epsrel 1e-10, in ln f."""
    from scipy import integrate

    def g(u):
        f = np.array([math.exp(u)])
        m = np.ones_like(f)
        for h in responses:
            m = m * np.abs(np.asarray(h(f))) ** 2
        return float((f ** (power + 1) * np.asarray(psd(f)) * m)[0])

    edges = sorted({lo, hi, *(c for c in cuts if lo < c < hi)})
    return sum(integrate.quad(g, math.log(a), math.log(b), limit=400, epsabs=0.0, epsrel=1e-10)[0]
               for a, b in zip(edges[:-1], edges[1:]))


def _low_pass(fc, order):
    return lambda f: 1.0 / np.sqrt(1.0 + (np.asarray(f) / fc) ** (2 * order))


@pytest.mark.parametrize(("fn", "q", "band", "power"), [
    (2400.0, 7.4, (50.0, 2000.0), 0), (2400.0, 7.4, (50.0, 2000.0), 2), (1000.0, 1000.0, (20.0, 5000.0), 0),
    (1000.0, 1000.0, (20.0, 5000.0), 2), (2400.0, 50.0, (2390.0, 2410.0), 0), (300.0, 0.5, (10.0, 10000.0), 2),
    (20000.0, 3.0, (100.0, 150.0), 0)])
def test_vectorised_quadrature_matches_scipy_quad(fn, q, band, power):
    """The vectorised Gauss-Kronrod rule against scipy's quad: high Q, narrow bands, resonances in and
    out of the band, filters, and a PSD with jumps inside a piece (a box not at the cuts). Both are
    held to 1e-10 relative: 1e-9 is ten times that (as tests/test_predict_stages.py)."""
    lo, hi = band
    a, b = lo + 0.1 * (hi - lo), hi - 0.2 * (hi - lo)

    def psd(f):
        return np.where((f >= a) & (f <= b), 0.004, 0.001) * (f / lo) ** -0.3

    responses = [resonator(fn, q), _low_pass(0.8 * fn, 4), _low_pass(3000.0, 2)]
    m = effective_rms(psd, responses, lo, hi) ** 2
    ref = _moment_by_scipy_quad(psd, responses, lo, hi, 0, [fn])
    if power == 2:
        m = zero_crossing_rate_hz(psd, responses, lo, hi) ** 2 * m
        ref = _moment_by_scipy_quad(psd, responses, lo, hi, 2, [fn])
    assert m == pytest.approx(ref, rel=1e-9)


def test_quadrature_asks_many_frequencies_at_once():
    """The integrand is evaluated on arrays of nodes, a few dozen calls for a Q = 1000 peak and a
    PSD jump inside a piece (scipy's quad asked one frequency at a time: thousands of calls)."""
    calls = []

    def psd(f):
        calls.append(np.size(f))
        return np.where(f < 700.0, 0.002, 0.001)

    effective_rms(psd, [resonator(1000.0, 1000.0)], 20.0, 5000.0)
    assert len(calls) <= 100 and sum(calls) / len(calls) > 21
