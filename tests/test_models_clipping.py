"""Clipping models (SPEC 1.1) held against reference values and independent computations.

References: SPEC section 1.1 restates the seed article (Analog Devices, VRE in MEMS
accelerometers, ADXL355 case study) and the ADXL355 datasheet figure; independent numbers come
from mpmath at 100 digits, scipy.stats.truncnorm, scipy.integrate.quad and seeded Monte Carlo.
"""

from __future__ import annotations

import warnings

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from vrelab.models.clipping import (
    censored_mean_shift,
    clip_mean_shift,
    mean_shift,
    sine_clip_mean_shift,
    truncated_mean_shift,
)

mp.mp.dps = 100


def _mp_censored(mu: float, s: float, low: float, high: float) -> float:
    """σ·[G(-α) - G(β)] at 100 digits, G(t) = φ(t) - t·Φ(-t) (E[(Z-t)+])."""
    mu, s, low, high = map(mp.mpf, (mu, s, low, high))
    a, b = (low - mu) / s, (high - mu) / s

    def g(t):
        return mp.npdf(t) - t * mp.ncdf(-t)

    return float(s * (g(-a) - g(b)))


def _mp_truncated(mu: float, s: float, low: float, high: float) -> float:
    """σ·(φ(α)-φ(β))/(Φ(β)-Φ(α)) at 100 digits, denominator from the tail nearer μ."""
    mu, s, low, high = map(mp.mpf, (mu, s, low, high))
    a, b = (low - mu) / s, (high - mu) / s
    den = mp.ncdf(b) - mp.ncdf(a) if a < 0 else mp.ncdf(-a) - mp.ncdf(-b)
    return float(s * (mp.npdf(a) - mp.npdf(b)) / den)


# --- reference values -------------------------------------------------------------------------


def test_article_figure1_2g_rails_1g_field_1g_rms():
    """SPEC 1.1: μ = 1 g, ±2 g, σ = 1 g: censored -83 mg, truncated -283 mg."""
    assert censored_mean_shift(1.0, 1.0, -2.0, 2.0) == pytest.approx(-0.083, abs=0.5e-3)
    assert truncated_mean_shift(1.0, 1.0, -2.0, 2.0) == pytest.approx(-0.283, abs=0.5e-3)


def test_article_figure1_no_visible_shift_at_0p3g_rms():
    """Article Figure 1: no visible shift at 0.3 g rms on a ±2 g sensor in a 1 g field.

    "Not visible" on the figure's ~100 mg scale: both models stay under 1 mg (censored -34 µg,
    truncated -0.46 mg; the mpmath values below), against -83/-283 mg at 1 g rms.
    """
    c = censored_mean_shift(1.0, 0.3, -2.0, 2.0)
    t = truncated_mean_shift(1.0, 0.3, -2.0, 2.0)
    assert abs(c) < 1e-3 and abs(t) < 1e-3
    assert c == pytest.approx(_mp_censored(1.0, 0.3, -2.0, 2.0), rel=1e-12)
    assert t == pytest.approx(_mp_truncated(1.0, 0.3, -2.0, 2.0), rel=1e-12)


def test_adxl355_datasheet_2p5g_rail_2p5g_rms():
    """SPEC 1.1: the article's fitted 2.5 g rail at 2.5 g rms: censored -0.33 g, truncated -0.71 g."""
    assert censored_mean_shift(1.0, 2.5, -2.5, 2.5) == pytest.approx(-0.33, abs=0.005)
    assert truncated_mean_shift(1.0, 2.5, -2.5, 2.5) == pytest.approx(-0.71, abs=0.005)


def test_sine_check_value_minus_68p3_mg():
    """SPEC 1.1: 1 g field, ±2 g rails, 1 g rms sine (A = √2): -68.3 mg."""
    assert sine_clip_mean_shift(1.0, np.sqrt(2.0), -2.0, 2.0) == pytest.approx(-0.0683, abs=0.05e-3)
    assert mean_shift(1.0, 1.0, -2.0, 2.0, shape="sine") == pytest.approx(-0.0683, abs=0.05e-3)


# --- independent computations -----------------------------------------------------------------

_GRID = [
    # (μ, σ, L, U): ordinary, one rail near, both far, mean outside, tiny and huge σ
    (1.0, 1.0, -2.0, 2.0),
    (1.0, 0.3, -2.0, 2.0),
    (0.2, 5.0, -2.0, 2.0),
    (1.0, 0.05, -2.0, 2.0),
    (3.0, 0.5, -2.0, 2.0),
    (-1.0, 2.5, -2.5, 2.5),
    (0.0, 1.0, 5.0, 40.0),
    (0.0, 1.0, 20.0, 20.5),
    (0.0, 1.0, -30.0, -29.99),
    (1.0, 1e-6, 1.0 + 3e-6, 1.0 + 4e-6),
    (1.0, 1e6, -2.0, 2.0),
    (1.0, 1e3, -2.0, 2.0),
    (0.5, 1e-3, -2.0, 2.0),
]


@pytest.mark.parametrize("mu,s,low,high", _GRID)
def test_censored_matches_mpmath(mu, s, low, high):
    """Against σ·[G(-α) - G(β)] evaluated by mpmath at 100 digits."""
    ref = _mp_censored(mu, s, low, high)
    got = censored_mean_shift(mu, s, low, high)
    assert got == pytest.approx(ref, rel=1e-11, abs=1e-300)


@pytest.mark.parametrize("mu,s,low,high", _GRID)
def test_truncated_matches_mpmath(mu, s, low, high):
    """Against σ·(φ(α)-φ(β))/(Φ(β)-Φ(α)) by mpmath at 100 digits."""
    ref = _mp_truncated(mu, s, low, high)
    got = truncated_mean_shift(mu, s, low, high)
    assert got == pytest.approx(ref, rel=1e-11, abs=1e-300)


@pytest.mark.parametrize("mu,s,low,high", [(1.0, 1.0, -2.0, 2.0), (0.3, 0.7, -1.0, 2.0), (2.5, 1.0, -2.0, 2.0)])
def test_censored_matches_mpmath_quadrature(mu, s, low, high):
    """Against mpmath quadrature of E[clip(X)] - μ = ∫(clip(x) - x)·pdf(x) dx, split at the rails."""
    mu_m, s_m, lo_m, hi_m = map(mp.mpf, (mu, s, low, high))

    def pdf(x):
        return mp.npdf(x, mu_m, s_m)

    ref = mp.quad(lambda x: (lo_m - x) * pdf(x), [-mp.inf, lo_m]) - mp.quad(
        lambda x: (x - hi_m) * pdf(x), [hi_m, mp.inf]
    )
    assert censored_mean_shift(mu, s, low, high) == pytest.approx(float(ref), rel=1e-12)


@pytest.mark.parametrize("mu,s,low,high", [(1.0, 1.0, -2.0, 2.0), (0.0, 1.0, 3.0, 9.0), (1.0, 3.0, -2.0, 2.5)])
def test_truncated_matches_mpmath_quadrature(mu, s, low, high):
    """Against the truncated mean by mpmath quadrature: ∫x·pdf / ∫pdf over [L, U], minus μ."""
    mu_m, s_m, lo_m, hi_m = map(mp.mpf, (mu, s, low, high))
    num = mp.quad(lambda x: x * mp.npdf(x, mu_m, s_m), [lo_m, hi_m])
    den = mp.quad(lambda x: mp.npdf(x, mu_m, s_m), [lo_m, hi_m])
    assert truncated_mean_shift(mu, s, low, high) == pytest.approx(float(num / den - mu_m), rel=1e-12)


def test_truncated_matches_scipy_truncnorm():
    """Against scipy.stats.truncnorm.mean to 1e-9 relative where scipy's answer is reliable.

    Where the shift is below 1e-3 σ (mean near the window's centre), scipy's own rounding
    dominates (it loses up to all digits far in the tails; mpmath agrees with us there, see the
    mpmath tests), so the comparison is limited to |VRE| > 1e-3 σ.
    """
    rng = np.random.default_rng(11)
    n = 4000
    a = rng.uniform(-30.0, 30.0, n)
    b = a + 10 ** rng.uniform(-3.0, 1.5, n)
    mu = rng.uniform(-3.0, 3.0, n)
    s = 10 ** rng.uniform(-3.0, 3.0, n)
    low, high = mu + a * s, mu + b * s
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns on its far-tail points
        ref = stats.truncnorm.mean((low - mu) / s, (high - mu) / s, loc=mu, scale=s) - mu
    got = truncated_mean_shift(mu, s, low, high)
    use = np.isfinite(ref) & (np.abs(ref) > 1e-3 * s)
    assert use.sum() > 0.8 * n
    np.testing.assert_allclose(got[use], ref[use], rtol=1e-9)


def test_censored_matches_monte_carlo():
    """Seeded Monte Carlo, 10⁶ samples; tolerance 5 standard errors of the sample mean."""
    rng = np.random.default_rng(20161121)
    for mu, s, low, high in [(1.0, 1.0, -2.0, 2.0), (1.0, 2.5, -2.5, 2.5), (-0.5, 0.8, -1.0, 1.5)]:
        x = rng.normal(mu, s, 1_000_000)
        d = np.clip(x, low, high) - x
        se = d.std(ddof=1) / np.sqrt(d.size)
        assert abs(censored_mean_shift(mu, s, low, high) - d.mean()) < 5 * se


def test_truncated_matches_monte_carlo():
    """Seeded Monte Carlo: mean of the kept samples minus μ, 5 standard errors."""
    rng = np.random.default_rng(7)
    mu, s, low, high = 1.0, 1.0, -2.0, 2.0
    x = rng.normal(mu, s, 1_000_000)
    kept = x[(x > low) & (x < high)]
    se = kept.std(ddof=1) / np.sqrt(kept.size)
    assert abs(truncated_mean_shift(mu, s, low, high) - (kept.mean() - mu)) < 5 * se


def test_clip_mean_shift_pdf_reproduces_gaussian_closed_forms():
    """quad over the Gaussian pdf (python-control's closed form vs numerics idea) = closed forms."""
    pdf = stats.norm(0.0, 1.3).pdf
    for kind, closed in (("censored", censored_mean_shift), ("truncated", truncated_mean_shift)):
        got = clip_mean_shift(0.7, -2.0, 2.5, pdf=pdf, kind=kind)
        assert got == pytest.approx(closed(0.7, 1.3, -2.0, 2.5), rel=1e-9)


def test_clip_mean_shift_samples_is_the_sample_average():
    """Samples: mean(clip(μ+x)) - mean(μ+x), by hand on three numbers."""
    x = np.array([-3.0, 0.0, 4.0])
    # μ = 1: inputs -2, 1, 5 -> clipped -2, 1, 2; means 1/3 and 4/3
    assert clip_mean_shift(1.0, -2.0, 2.0, samples=x) == pytest.approx(1 / 3 - 4 / 3)
    # truncated keeps -2 and 1 (on or inside the rails)
    assert clip_mean_shift(1.0, -2.0, 2.0, samples=x, kind="truncated") == pytest.approx(-0.5 - 4 / 3)


def test_clip_mean_shift_non_gaussian_uniform_pdf_closed_form():
    """Uniform vibration on [-c, c] with only the upper rail crossed: loss = (c+μ-U)²/(4c)."""
    c, mu, high = 2.0, 1.0, 2.0
    pdf = stats.uniform(-c, 2 * c).pdf
    assert clip_mean_shift(mu, -10.0, high, pdf=pdf) == pytest.approx(-((c + mu - high) ** 2) / (4 * c), rel=1e-9)


@pytest.mark.parametrize(
    "mu,amp,low,high",
    [(1.0, np.sqrt(2.0), -2.0, 2.0), (0.3, 3.0, -2.0, 2.0), (1.0, 1.0 + 1e-3, -2.0, 2.0), (2.5, 1.0, -2.0, 2.0), (0.0, 5.0, -1.0, 3.0)],
)
def test_sine_closed_form_matches_average_over_a_period(mu, amp, low, high):
    """Both kinds against the average of clip/keep over 2·10⁶ phases of one period (midpoint rule).

    Censored: the clipped sine is continuous, the midpoint rule is O(h²) accurate. Truncated: the
    kept set's edges are resolved to one phase step, so each of up to 4 edges may count one
    sample wrongly: tolerance 4·2A/N_kept.
    """
    n = 2_000_000
    theta = (np.arange(n) + 0.5) * (2 * np.pi / n)
    x = mu + amp * np.cos(theta)
    cens = np.clip(x, low, high).mean() - mu
    keep = (x >= low) & (x <= high)
    trunc = x[keep].mean() - mu
    assert sine_clip_mean_shift(mu, amp, low, high) == pytest.approx(cens, rel=1e-8, abs=1e-12)
    edge_tol = 4 * 2 * amp / keep.sum()
    assert sine_clip_mean_shift(mu, amp, low, high, kind="truncated") == pytest.approx(trunc, abs=edge_tol)


@pytest.mark.parametrize("mu,amp", [(0.01, 3.0), (1e-9, 2.5), (-0.3, 2.1)])
def test_sine_balanced_rails_match_mpmath(mu, amp):
    """Mean near mid-rail, sine past both ±2 g rails: the two rail terms nearly cancel.

    Reference: the SPEC 1.1 rail terms (A·sin θ - d·θ)/π at 100 digits in mpmath.
    """

    def term(d):  # what one rail at distance d from μ removes
        d, a = mp.mpf(d), mp.mpf(amp)
        if d >= a:
            return mp.mpf(0)
        th = mp.acos(d / a)
        return (a * mp.sin(th) - d * th) / mp.pi

    ref = term(mp.mpf(2) + mp.mpf(mu)) - term(mp.mpf(2) - mp.mpf(mu))
    assert sine_clip_mean_shift(mu, amp, -2.0, 2.0) == pytest.approx(float(ref), rel=1e-12)


def test_sine_first_contact_keeps_relative_precision():
    """Peak 1e-9 g past the rail: loss = A·θ³/(3π) with θ = √(2e/A) to leading order."""
    amp, e = 1.0, 1e-9
    theta = np.sqrt(2 * e / amp)
    got = sine_clip_mean_shift(0.0, amp, -5.0, amp - e)
    assert got == pytest.approx(-amp * theta**3 / (3 * np.pi), rel=1e-6)


def test_zero_spread_is_the_deterministic_clip():
    """σ = 0 (and A = 0): the output is clip(μ), so VRE = clip(μ) - μ."""
    mu = np.array([-3.0, 0.5, 4.0])
    for f in (censored_mean_shift, truncated_mean_shift, sine_clip_mean_shift):
        np.testing.assert_array_equal(f(mu, 0.0, -2.0, 2.0), [1.0, 0.0, -2.0])


def test_broadcasting_and_open_rails():
    """Arrays broadcast; ±inf rails mean no rail (one-sided truncation = inverse Mills ratio)."""
    out = censored_mean_shift(np.array([[0.0], [1.0]]), np.array([0.5, 1.0, 2.0]), -2.0, 2.0)
    assert out.shape == (2, 3)
    assert truncated_mean_shift(0.0, 1.0, -np.inf, np.inf) == 0.0
    assert truncated_mean_shift(0.0, 1.0, 1.0, np.inf) == pytest.approx(stats.norm.pdf(1.0) / stats.norm.sf(1.0), rel=1e-14)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(mean_g=0.0, sigma_g=-1.0, rail_low_g=-2.0, rail_high_g=2.0), "sigma_g"),
        (dict(mean_g=np.nan, sigma_g=1.0, rail_low_g=-2.0, rail_high_g=2.0), "mean_g"),
        (dict(mean_g=0.0, sigma_g=1.0, rail_low_g=2.0, rail_high_g=2.0), "rail_low_g"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        censored_mean_shift(**kwargs)


# --- properties over the whole input space -----------------------------------------------------

_sigmas = st.floats(1e-6, 1e6)
_reals = st.floats(-1e6, 1e6)


@settings(max_examples=300, deadline=None)
@given(mu=_reals, s=_sigmas, r1=_reals, r2=_reals)
def test_finite_everywhere(mu, s, r1, r2):
    """Finite output for σ in 1e-6..1e6 g and rails anywhere (the answers are all finite)."""
    low, high = min(r1, r2), max(r1, r2)
    if low == high:
        high = low + 1.0
    for f in (censored_mean_shift, truncated_mean_shift, sine_clip_mean_shift):
        v = f(mu, s, low, high)
        assert np.isfinite(v)
        # the output lies between the rails, so the shift lies in [L-μ, U-μ]
        slack = 1e-12 * max(abs(mu), abs(low), abs(high))  # rounding of L - μ, U - μ
        assert low - mu - slack <= v <= high - mu + slack


@settings(max_examples=200, deadline=None)
@given(
    r=st.floats(1e-3, 1e3),
    frac=st.floats(0.0, 1.0),
    s1=_sigmas,
    s2=_sigmas,
)
def test_censored_magnitude_grows_with_sigma_and_sign(r, frac, s1, s2):
    """Symmetric rails ±R, 0 <= μ <= R: VRE = -∫_{R-μ}^{R+μ} Φ(-s/σ) ds, so VRE <= 0 and |VRE|
    is non-decreasing in σ (Φ(-s/σ) grows with σ for s >= 0); checked to rounding (1e-12)."""
    mu = frac * r
    lo_s, hi_s = min(s1, s2), max(s1, s2)
    v_lo = censored_mean_shift(mu, lo_s, -r, r)
    v_hi = censored_mean_shift(mu, hi_s, -r, r)
    assert v_lo <= 0.0 and v_hi <= 0.0
    assert abs(v_hi) >= abs(v_lo) * (1 - 1e-12)
    # and it never exceeds the σ -> inf limit, |(L+U)/2 - μ| = μ
    assert abs(v_hi) <= mu * (1 + 1e-12)


@settings(max_examples=200, deadline=None)
@given(r=st.floats(1e-3, 1e3), frac=st.floats(0.0, 1.0), s=_sigmas)
def test_truncated_sign_for_positive_mean_in_symmetric_rails(r, frac, s):
    """μ in [0, R] with rails ±R: |α| >= |β| so φ(α) <= φ(β) and the truncated shift is <= 0."""
    assert truncated_mean_shift(frac * r, s, -r, r) <= 0.0


@settings(max_examples=150, deadline=None)
@given(
    mu=st.floats(-1e3, 1e3),
    log_s=st.floats(-6.0, 6.0),
    r1=st.floats(-1e3, 1e3),
    log_w=st.floats(-6.0, 3.0),
)
def test_both_gaussian_models_match_mpmath_across_the_space(mu, log_s, r1, log_w):
    """Anywhere in σ 1e-6..1e6 g, rail width 1e-6..1e3 g: 1e-9 relative to 100-digit mpmath.

    Results below 1e-290 g are compared absolutely (float64 cannot hold them relatively), and so
    are results below the reference's own resolution: 100 digits of the problem's scale
    (|μ| + σ + |L| + |U|), where its terms of that size cancel (μ = 7e-120 g between ±0.5 g
    rails: mpmath returns 0, the shift is of order μ).
    """
    s, low = 10.0**log_s, r1
    high = low + 10.0**log_w
    floor = max(1e-290, 1e-95 * (abs(mu) + s + abs(low) + abs(high)))
    for ours, ref in ((censored_mean_shift, _mp_censored), (truncated_mean_shift, _mp_truncated)):
        expect = ref(mu, s, low, high)
        assert ours(mu, s, low, high) == pytest.approx(expect, rel=1e-9, abs=floor)


def test_clip_vre_is_the_mean_shift_referred_to_the_vibration_off_reading():
    """SPEC 1.5: VRE = E[out] - clip(μ). Within the rails the mean shift itself (exactly: the added
    μ - clip(μ) is 0); beyond one it leaves out the static level's own clipping, here against an
    independent scipy quadrature of E[clip(μ + X)] less clip(μ)."""
    from scipy import integrate, stats

    from vrelab.models.clipping import mean_shift
    from vrelab.models.design import clip_vre

    mu = np.array([-0.7, 0.0, 1.0, 1.9])
    rms = np.array([0.3, 1.0, 2.0])[:, None]
    np.testing.assert_array_equal(clip_vre(mu, rms, -2.0, 2.0), mean_shift(mu, rms, -2.0, 2.0))
    for m, lo, hi in ((2.5, -2.0, 2.0), (-3.0, -2.0, 2.0), (0.5, 1.0, 4.0)):
        inside, _ = integrate.quad(lambda x, d=stats.norm(m, 0.8): x * d.pdf(x), lo, hi, epsabs=1e-13, epsrel=1e-13)
        out = lo * stats.norm.cdf((lo - m) / 0.8) + inside + hi * stats.norm.sf((hi - m) / 0.8)
        assert clip_vre(m, 0.8, lo, hi) == pytest.approx(out - min(max(m, lo), hi), abs=1e-10)
        assert clip_vre(m, 0.0, lo, hi) == 0.0  # no vibration, no VRE, wherever the static level is
