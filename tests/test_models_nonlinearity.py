"""Polynomial nonlinearity model (SPEC 1.2): moments, VRE, VRC units, k2/k3 separation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from vrelab.models.nonlinearity import (
    gaussian_moments,
    per_g_to_ug_per_g2,
    polynomial_vre,
    ppm_per_g_to_ug_per_g2,
    sample_moments,
    separate_k2_k3,
    sine_moments,
    ug_per_g2_from_ppm_fs,
    ug_per_g2_to_per_g,
    vrc_ug_per_g2_from_vre,
    vre_poly,
)
from vrelab.results import Estimate


def test_cos2_cos4_period_averages_are_half_and_three_eighths():
    """SPEC 1.2: E[x²] = G0²/2, E[x⁴] = 3G0⁴/8 for x = G0·cos θ; checked by quad over a period."""
    amp = 1.7
    m = sine_moments(amp / np.sqrt(2.0), 6)
    for j, frac in ((2, 1 / 2), (4, 3 / 8), (6, 5 / 16)):
        quad = integrate.quad(lambda t: np.cos(t) ** j, 0, 2 * np.pi)[0] / (2 * np.pi)
        assert frac == pytest.approx(quad, rel=1e-12)
        assert m[j] == pytest.approx(frac * amp**j, rel=1e-14)
    assert m[1] == 0 and m[3] == 0 and m[0] == 1


def test_gaussian_moments_match_quadrature():
    """E[x^j] = (j-1)!!·σ^j (even), 0 (odd): against quad over the normal pdf."""
    s = 0.8
    m = gaussian_moments(s, 6)
    for j in range(7):
        ref = integrate.quad(lambda x: x**j * np.exp(-x * x / (2 * s * s)) / (s * np.sqrt(2 * np.pi)), -np.inf, np.inf)[0]
        assert m[j] == pytest.approx(ref, rel=1e-10, abs=1e-14)


def test_polynomial_vre_equals_direct_expectation():
    """Σ k_n (E[(g0+x)^n] - g0^n) computed directly by quad against the binomial form."""
    g0, s = 1.0, 1.3
    k = {2: 120e-6, 3: -40e-6, 4: 7e-6, 5: 1e-6}
    pdf = lambda x: np.exp(-x * x / (2 * s * s)) / (s * np.sqrt(2 * np.pi))  # noqa: E731
    ref = sum(kn * (integrate.quad(lambda x: (g0 + x) ** n * pdf(x), -np.inf, np.inf)[0] - g0**n) for n, kn in k.items())
    assert polynomial_vre(k, g0, gaussian_moments(s, 5)) == pytest.approx(ref, rel=1e-10)


def test_leading_terms_of_spec_1_2():
    """SPEC 1.2: VRE = (k2 + 3·k3·g0)·σ² + k4·(6·g0²·σ² + E[x⁴]), exact up to k4."""
    k2, k3, k4, g0, s = 100e-6, 20e-6, 5e-6, 1.0, 2.0
    expect = (k2 + 3 * k3 * g0) * s**2 + k4 * (6 * g0**2 * s**2 + 3 * s**4)
    assert vre_poly(s, k2, k3, k4, static_g=g0) == pytest.approx(expect, rel=1e-14)
    expect_sine = (k2 + 3 * k3 * g0) * s**2 + k4 * (6 * g0**2 * s**2 + 1.5 * s**4)
    assert vre_poly(s, k2, k3, k4, static_g=g0, shape="sine") == pytest.approx(expect_sine, rel=1e-14)


def test_cubic_rectifies_in_a_1g_field_only():
    """Seed erratum (SPEC 1.2): k3 alone gives 3·k3·g0·σ² in 1 g and nothing at g0 = 0."""
    assert vre_poly(1.5, 0.0, 10e-6, static_g=1.0) == pytest.approx(3 * 10e-6 * 1.5**2, rel=1e-14)
    assert vre_poly(1.5, 0.0, 10e-6, static_g=0.0) == 0.0


def test_sample_moments_drive_the_model_like_the_closed_form():
    """Seeded Gaussian samples: model VRE from sample moments within 1 % of the closed form."""
    rng = np.random.default_rng(3)
    x = rng.normal(0.0, 1.2, 400_000)
    m = sample_moments(x, 4)
    assert m[1] == 0.0
    got = polynomial_vre((100e-6, 0.0, 10e-6), 1.0, m)
    assert got == pytest.approx(vre_poly(1.2, 100e-6, 0.0, 10e-6, static_g=1.0), rel=1e-2)


def test_vrc_unit_conversions():
    """µg/g² = ppm/g = 1e-6 /g (SPEC 1.2); 'X mg at Y g rms' → VRC = X/Y² mg/g²."""
    assert ug_per_g2_to_per_g(50.0) == pytest.approx(50e-6)
    assert per_g_to_ug_per_g2(50e-6) == pytest.approx(50.0)
    assert ppm_per_g_to_ug_per_g2(50.0) == 50.0
    # 0.4 mg at 2 g rms -> 100 µg/g²
    assert vrc_ug_per_g2_from_vre(0.4e-3, 2.0) == pytest.approx(100.0)
    # 0.1 % FS on ±2 g: k2·FS² = 1000e-6·FS -> k2 = 500e-6/g = 500 µg/g²
    assert ug_per_g2_from_ppm_fs(1000.0, 2.0) == pytest.approx(500.0)


def test_two_orientation_round_trip():
    """VRC(±1 g) = k2 ± 3·k3 from the model, then separate_k2_k3 recovers k2, k3 (SPEC 1.2)."""
    k2, k3, s = 80e-6, 4e-6, 1.0
    vrc_plus = vre_poly(s, k2, k3, static_g=1.0) / s**2
    vrc_minus = vre_poly(s, k2, k3, static_g=-1.0) / s**2
    got2, got3 = separate_k2_k3(vrc_plus, vrc_minus)
    assert got2 == pytest.approx(k2, rel=1e-12)
    assert got3 == pytest.approx(k3, rel=1e-12)


def test_separation_propagates_uncertainty():
    """u(k2) = √(u₊²+u₋²)/2, u(k3) = √(u₊²+u₋²)/6 for independent Estimates."""
    k2, k3 = separate_k2_k3(Estimate(130.0, 3.0, "ug/g^2"), Estimate(70.0, 4.0, "ug/g^2"))
    assert (k2.value, k2.u) == pytest.approx((100.0, 2.5))
    assert (k3.value, k3.u) == pytest.approx((10.0, 5.0 / 6.0))
    assert k3.unit == "ug/g^2/g"


def test_polynomial_bad_input():
    with pytest.raises(ValueError, match="moments"):
        polynomial_vre((1e-4, 1e-5, 1e-6), 1.0, gaussian_moments(1.0, 2))
    with pytest.raises(ValueError, match="rms_g"):
        vre_poly(-1.0, 1e-4)
    with pytest.raises(ValueError, match="order"):
        gaussian_moments(1.0, -1)
    assert math.isclose(vre_poly(0.0, 1e-4), 0.0)
