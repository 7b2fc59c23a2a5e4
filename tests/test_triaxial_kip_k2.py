"""The polynomial sees the axis's own input, the cross terms are added after it (issue: k2 with a
static vector across the cross terms).

IEEE Std 1293-2018's model equation for one axis (SPEC §1.6, as vrelab's triaxial contract writes
it): ``y = P(w·b) + Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``, ``b = g + x``
at the proof mass, then the rails. With a static vector ``g`` the cross terms have a part linear in
the vibration, ``2gᵀK·x``; the equation adds it after the polynomial, so ``k2`` never squares it.
An earlier predict fed ``(w + 2Kg)·x`` to the polynomial: a sine at 45° in the IP plane with
k2 = Kip = 0.01/g at 2 g rms gave a nonlinearity share of 20.402 mg against the equation's
20.0 mg, covered by a model error built for something else.

Held here against computations written out from the equation alone (numpy, no vrelab model):
a sine's whole-period phase average (a trigonometric polynomial: exact to rounding on a uniform
phase grid), and a seeded Monte Carlo of correlated Gaussian samples (antithetic pairs and the
zero-mean linear part subtracted as a control variate), its standard error from the pairs' scatter.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vrelab.prediction import predict
from vrelab.profiles import RandomProfile
from vrelab.sensor import load_sensor
from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine, direction

G_X, G_TILT = (0.0, 0.0, 1.0), (0.3, -0.2, 0.9)


def _ideal(range_g: float = 8.0, **kw: float | str) -> object:
    """The ideal z axis (triad (z, x, y)): the polynomial, rails at ±range, nothing else."""
    return dataclasses.replace(load_sensor("ideal", range_g=range_g, axis="z"), **kw)


def _equation(s: object, b: np.ndarray, rails: bool = True) -> np.ndarray:
    """The model equation on samples of b (3, n) [g], then the censored rails (written out)."""
    w = np.asarray(s.sensitivity_row)  # type: ignore[attr-defined]
    i, p, o = s.triad  # type: ignore[attr-defined]
    u = w @ b
    y = u + s.k2_per_g * u**2 + s.k3_per_g2 * u**3 + s.k4_per_g3 * u**4  # type: ignore[attr-defined]
    y = y + (s.kip_per_g * b[i] * b[p] + s.kio_per_g * b[i] * b[o] + s.kpp_per_g * b[p] ** 2  # type: ignore[attr-defined]
             + s.koo_per_g * b[o] ** 2 + s.kpo_per_g * b[p] * b[o])  # type: ignore[attr-defined]
    return np.clip(y, *s.rails_g) if rails else y  # type: ignore[attr-defined]


def _phase_average(s: object, g: np.ndarray, d: np.ndarray, peak: float, n: int = 4096) -> float:
    """VRE of a sine of ``peak`` along ``d``: the equation averaged over n uniform phases, less
    the vibration-off reading. Without rails the output is a trigonometric polynomial of degree
    4, which the grid averages exactly; with rails the kinks leave O(n⁻²)."""
    theta = (np.arange(n) + 0.5) * 2.0 * math.pi / n
    b = g[:, None] + np.outer(d, peak * np.cos(theta))
    return float(_equation(s, b).mean() - _equation(s, g[:, None])[0])


def _monte_carlo(s: object, g: np.ndarray, cov: np.ndarray, n: int, seed: int) -> tuple[float, float]:
    """VRE and its standard error over n antithetic pairs of Gaussian x (covariance ``cov``): the
    pair's mean output less the vibration-off reading. Control variate: the quadratic form
    ``q = xᵀAx``, ``A = k2·w wᵀ + K``, whose mean ``tr(AΣ)`` is exact (every part of the output
    odd in x cancels in the pair): the estimate is ``tr(AΣ) + mean(pair - q)``."""
    rng = np.random.default_rng(seed)
    lam, vec = np.linalg.eigh(cov)
    x = (vec * np.sqrt(np.maximum(lam, 0.0))) @ rng.standard_normal((3, n))
    w = np.asarray(s.sensitivity_row)  # type: ignore[attr-defined]
    a = s.k2_per_g * np.outer(w, w) + _k(s)  # type: ignore[attr-defined]
    off = float(_equation(s, g[:, None])[0])
    pair = 0.5 * (_equation(s, g[:, None] + x) + _equation(s, g[:, None] - x)) - off
    pair -= np.einsum("jn,jk,kn->n", x, a, x)
    return float(np.trace(a @ cov)) + float(pair.mean()), float(pair.std(ddof=1) / math.sqrt(n))


def _closed_sine(s: object, g: np.ndarray, d: np.ndarray, peak: float) -> float:
    """SPEC §1.2 and §1.6 with no rails reached: E[P(u0 + a·cos θ)] - P(u0), a = peak·(w·d), plus
    Σ K_jk·d_j·d_k·peak²/2 (the static vector's products with the zero-mean sine average out)."""
    w = np.asarray(s.sensitivity_row)  # type: ignore[attr-defined]
    i, p, o = s.triad  # type: ignore[attr-defined]
    u0, a = float(w @ g), peak * float(w @ d)
    k2, k3, k4 = s.k2_per_g, s.k3_per_g2, s.k4_per_g3  # type: ignore[attr-defined]
    poly = k2 * a**2 / 2 + 3 * k3 * u0 * a**2 / 2 + k4 * (3 * u0**2 * a**2 + 3 * a**4 / 8)
    ms = peak**2 / 2
    cross = ms * (s.kip_per_g * d[i] * d[p] + s.kio_per_g * d[i] * d[o] + s.kpp_per_g * d[p] ** 2  # type: ignore[attr-defined]
                  + s.koo_per_g * d[o] ** 2 + s.kpo_per_g * d[p] * d[o])  # type: ignore[attr-defined]
    return poly + cross


CASES = {
    # the reported case: 45° in the IP plane, 1 g up the input axis, k2 = Kip = 0.01/g at 2 g rms
    "reported": (dict(k2_per_g=0.01, kip_per_g=0.01), G_X, direction("z", "x", 45.0), 2.0),
    "k3 k4 kio": (dict(k2_per_g=4e-3, k3_per_g2=2e-3, k4_per_g3=-5e-4, kip_per_g=-6e-3, kio_per_g=8e-3,
                       kpp_per_g=2e-3), G_TILT, direction("z", "y", -30.0), 1.5),
    "oblique": (dict(k2_per_g=-8e-3, kip_per_g=5e-3, kio_per_g=-4e-3, kpp_per_g=1e-3, koo_per_g=3e-3,
                     kpo_per_g=-2e-3, cross_axis_x=0.02, cross_axis_y=-0.01), (0.0, 0.6, 0.8),
                np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0), 1.8),
}


@pytest.mark.parametrize("case", list(CASES))
def test_sine_without_rails_is_the_equations_phase_average(case: str) -> None:
    kw, g_t, d_t, rms = CASES[case]
    s = _ideal(**kw)  # type: ignore[arg-type]
    g, d = np.asarray(g_t, dtype=float), np.asarray(d_t, dtype=float)
    lv = predict(s, TriaxialSine(100.0, tuple(d), rms), [rms], static_g=g).levels[0]  # type: ignore[arg-type]
    truth = _phase_average(s, g, d, math.sqrt(2.0) * rms)
    # no rail is reached: the equation is a trig polynomial of degree 4, its grid average exact
    # to the rounding of 4096 terms of O(1 g) (a few 1e-13 g)
    theta = np.linspace(0.0, 2.0 * math.pi, 721)
    assert np.all(np.abs(_equation(s, g[:, None] + np.outer(d, math.sqrt(2.0) * rms * np.cos(theta)), False)) < 7.9)
    assert truth == pytest.approx(_closed_sine(s, g, d, math.sqrt(2.0) * rms), abs=1e-12)
    assert lv.vre_g == pytest.approx(truth, abs=1e-12), (lv.vre_g, truth)
    # the polynomial's share is the polynomial of the axis's own input, the cross terms apart
    w = np.asarray(s.sensitivity_row)  # type: ignore[attr-defined]
    plain = dataclasses.replace(s, kip_per_g=0.0, kio_per_g=0.0, kpp_per_g=0.0, koo_per_g=0.0, kpo_per_g=0.0)
    assert lv.shares["nonlinearity_g"] == pytest.approx(
        _closed_sine(plain, g, d, math.sqrt(2.0) * rms), abs=1e-12)
    assert lv.valid and lv.model_error_g < 1e-9, (lv.model_error_g, lv.notes)
    assert float(w @ d) != 0.0


def test_sine_reaching_a_rail_is_within_its_stated_bound() -> None:
    # ±4 g, 0.8 g up the input axis and 0.6 g along p, Kip = 0.02/g: the sine's top reaches the
    # upper rail; the polynomial's move passes it to first order, the rest inside model_error_g
    s = _ideal(4.0, k2_per_g=0.01, kip_per_g=0.02)
    g, d, rms = np.array([0.6, 0.0, 0.8]), np.asarray(direction("z", "x", 20.0)), 2.4
    lv = predict(s, TriaxialSine(100.0, tuple(d), rms), [rms], static_g=g).levels[0]  # type: ignore[arg-type]
    # 2^16 phases: the kinks at the rail leave O(n⁻²) of the 64 mg (1e-9 g)
    truth = _phase_average(s, g, d, math.sqrt(2.0) * rms, n=2**16)
    assert abs(lv.vre_g - truth) <= lv.model_error_g + 1e-9, (lv.vre_g, truth, lv.model_error_g)
    assert lv.shares["clip_g"] < -1e-3 and not lv.valid  # a sine across a rail: the first order is rough


def test_the_reported_case_reads_20_mg() -> None:
    """The numbers of the report: k2·(w·d)²·rms² = 0.01·½·4 = 20 mg, and Kip·d_i·d_p·rms² = 20 mg."""
    kw, g, d, rms = CASES["reported"]
    lv = predict(_ideal(**kw), TriaxialSine(100.0, tuple(d), rms), [rms], static_g=g).levels[0]  # type: ignore[arg-type]
    assert lv.shares["nonlinearity_g"] == pytest.approx(0.020, abs=1e-12)
    assert lv.shares["cross_kip_g"] == pytest.approx(0.020, abs=1e-12)
    assert lv.vre_g == pytest.approx(0.040, abs=1e-12)


def test_an_axis_whose_w_eff_is_across_the_sine_keeps_its_own_nonlinearity() -> None:
    # z axis, Kip = 0.05/g, 1 g along z: w_eff = (0.05, 0, 1); the sine along d ⟂ w_eff is
    # sensed as w·d ≠ 0 by the polynomial (the rails see w_eff·d = 0 of it, linear part)
    s = _ideal(k2_per_g=0.02, kip_per_g=0.05)
    g = np.array([0.0, 0.0, 1.0])
    d = np.array([1.0, 0.0, -0.05]) / math.hypot(1.0, 0.05)
    lv = predict(s, TriaxialSine(100.0, tuple(d), 2.0), [2.0], static_g=g).levels[0]
    truth = _phase_average(s, g, d, math.sqrt(2.0) * 2.0)
    assert lv.vre_g == pytest.approx(truth, abs=1e-12) and lv.sensed_rms_g == pytest.approx(0.0, abs=1e-12)
    assert lv.shares["nonlinearity_g"] == pytest.approx(0.02 * (2.0 * d[2]) ** 2, rel=1e-9)


# Gaussian cases: (sensor coefficients, range, static vector, direction (along it) or per-axis
# rms (incoherent axes), level [g rms], MC pairs)
RANDOM = {
    # rails far (±8 g, 2 g rms sensed along 45°: 4.9 σ): the closed form is exact, the MC agrees
    "far": (dict(k2_per_g=0.01, kip_per_g=0.01), 8.0, G_X, direction("z", "x", 45.0), 2.0, 400_000),
    # rails reached (±4 g, 2.2 g rms, 2.5 % of the time outside): Kip with 0.6 g along p, x and z
    # incoherent, so the cross terms' mean is 0 and their linear part 2gᵀK·x = Kip·g_p·x_i is
    # what the polynomial must not square
    "clipped": (dict(k2_per_g=0.01, kip_per_g=0.02), 4.0, (0.6, 0.0, 0.8), np.array([1.0, 0.0, 1.0]), 2.2,
                1_000_000),
    # every term, k3, a tilted static vector, rails reached: the stated bound covers the MC
    "every term": (dict(k2_per_g=0.01, k3_per_g2=2e-3, kip_per_g=0.012, kio_per_g=-6e-3, kpp_per_g=3e-3,
                        koo_per_g=2e-3, kpo_per_g=4e-3), 4.0, (0.6, -0.3, 0.742), np.array([0.8, 0.5, 1.0]), 1.8,
                   400_000),
}


@pytest.mark.parametrize("case", list(RANDOM))
def test_random_against_a_monte_carlo_of_the_equation(case: str) -> None:
    kw, range_g, g_t, shape_t, level, pairs = RANDOM[case]
    s = _ideal(range_g, **kw)  # type: ignore[arg-type]
    g, shape = np.asarray(g_t, dtype=float), np.asarray(shape_t, dtype=float)
    band = RandomProfile(np.array([20.0, 1000.0]), np.array([1e-3, 1e-3]))
    if case == "far":
        prof = TriaxialProfile.along(band, shape)
        cov = np.outer(shape, shape)
    else:  # incoherent axes of rms shape_j: the per-unit covariance is their diagonal
        prof = TriaxialProfile.from_axes({a: band.scaled_to(band.grms * r) for a, r in zip("xyz", shape) if r})
        cov = np.diag(shape**2) / float(shape @ shape)
    lv = predict(s, prof, [level], static_g=g).levels[0]
    c = cov * level**2
    mc, se = _monte_carlo(s, g, c, int(pairs), seed=11)  # type: ignore[call-overload]
    # 4 standard errors of the seeded MC (a |z| over 4 has odds 6e-5) plus the prediction's own
    # stated bound on its approximation
    assert abs(lv.vre_g - mc) <= 4.0 * se + lv.model_error_g, (lv.vre_g, mc, se, lv.model_error_g)
    # the error fixed here, k2·(2·Cov(u, L) + Var(L)) with L = 2gᵀK·x, against what resolves it
    w = np.asarray(s.sensitivity_row)  # type: ignore[attr-defined]
    lin = 2.0 * _k(s) @ g
    wrong = s.k2_per_g * (2.0 * float(w @ c @ lin) + float(lin @ c @ lin))  # type: ignore[attr-defined]
    if case == "far":
        # no rail reached: the bound is the rails' 1e-6 g, the MC resolves the error to 8 SE
        assert abs(wrong) > 8.0 * se + 2.0 * lv.model_error_g, (wrong, se, lv.model_error_g)
        # SPEC §1.2/§1.6: k2·wᵀΣw + Kip·Σ_zx; the nonlinearity share exactly, the whole within the
        # rails' share (4.5 σ of the polynomial's output above its mean: about 1e-6 g)
        assert lv.shares["nonlinearity_g"] == pytest.approx(s.k2_per_g * float(w @ c @ w), rel=1e-12)  # type: ignore[attr-defined]
        closed = s.k2_per_g * float(w @ c @ w) + 0.01 * float(c[2, 0])  # type: ignore[attr-defined]
        assert abs(lv.vre_g - closed) <= 2.0 * abs(lv.shares["clip_g"]) + 1e-12
    elif case == "clipped":
        # the polynomial's move passes the rails to first order; what that misses is bounded by
        # Cauchy-Schwarz (0.2 mg here, conservative): the MC, at SE 0.1 mg, finds the prediction
        # within its own 4 SE, where feeding 2gᵀK·x through the polynomial was 0.6 mg (6.6 SE) off
        assert abs(wrong) > 5.0 * se
        assert abs(lv.vre_g - mc) <= 4.0 * se, (lv.vre_g, mc, se)


def _k(s: object) -> np.ndarray:
    """The symmetric K over x, y, z with bᵀKb the cross terms (written out from the triad)."""
    i, p, o = s.triad  # type: ignore[attr-defined]
    k = np.zeros((3, 3))
    for (a, b), v in {(i, p): s.kip_per_g, (i, o): s.kio_per_g, (p, p): s.kpp_per_g,  # type: ignore[attr-defined]
                      (o, o): s.koo_per_g, (p, o): s.kpo_per_g}.items():  # type: ignore[attr-defined]
        k[a, b] += v / 2.0
        k[b, a] += v / 2.0
    return k


def test_the_simulated_chain_applies_the_same_equation() -> None:
    """The time-domain sensor (vrelab.triaxial.chain) against the closed form: whole periods of a
    sine at 45° with 1 g along the input axis, the ideal axis (no dynamics, no filter)."""
    from vrelab.triaxial.chain import triaxial_chain

    kw, g_t, d_t, rms = CASES["k3 k4 kio"]
    s = _ideal(**kw)  # type: ignore[arg-type]
    g, d = np.asarray(g_t, dtype=float), np.asarray(d_t, dtype=float)
    fs, f, n = 6400.0, 100.0, 6400  # 100 whole periods of 64 samples
    t = np.arange(n) / fs
    a = g[:, None] + np.outer(d, math.sqrt(2.0) * rms * np.cos(2.0 * math.pi * f * t))
    chain = triaxial_chain(s, fs)  # type: ignore[arg-type]
    y, _ = chain.apply(a, fs, seed=0)
    y0, _ = chain.apply(np.repeat(g[:, None], 64, axis=1), fs, seed=0)
    # 64 samples a period average a degree-4 trig polynomial exactly: rounding only
    assert float(y.mean() - y0.mean()) == pytest.approx(_closed_sine(s, g, d, math.sqrt(2.0) * rms), abs=1e-12)
