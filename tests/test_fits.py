"""Fits: VRC, effective rail with departure detection, k2/k3 separation.

Truths are built from the formulas directly, independently of vrelab.models: the censored
mean by numerical quadrature of E[clip(g0 + x)] (scipy.integrate.quad), the truncated mean
by scipy.stats.truncnorm.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import integrate, stats

from vrelab.fits import fit_rail, fit_vrc, separate_k2_k3
from vrelab.results import ClipModel, Estimate, FitResult, LevelResult, VrcModel


def _levels(rms, vre, u, flags=None):
    flags = flags or [()] * len(rms)
    return [LevelResult(float(r), Estimate(float(v), float(s))) for r, v, s in zip(rms, vre, u)] if not any(
        flags
    ) else [LevelResult(float(r), Estimate(float(v), float(s)), flags=f) for r, v, s, f in zip(rms, vre, u, flags)]


def censored_vre_quad(g0: float, sigma: float, low: float, high: float) -> float:
    """E[clip(g0 + x)] - g0 for x ~ N(0, σ²), by quadrature (SPEC 1.1, censored)."""
    f = lambda x: (min(max(g0 + x, low), high) - g0) * stats.norm.pdf(x, scale=sigma)  # noqa: E731
    pts = [low - g0, high - g0]
    val, _ = integrate.quad(f, -12 * sigma, 12 * sigma, points=pts, limit=200)
    return val


def truncated_vre_scipy(g0: float, sigma: float, low: float, high: float) -> float:
    """Mean of a doubly truncated normal minus g0 (scipy.stats.truncnorm)."""
    a, b = (low - g0) / sigma, (high - g0) / sigma
    return float(stats.truncnorm.mean(a, b, loc=g0, scale=sigma)) - g0


def test_fit_vrc_recovers_k2_within_standard_error_and_se_matches_closed_form():
    rng = np.random.default_rng(0)
    rms = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    u = 20e-6 * np.ones_like(rms)
    k2 = 120e-6
    z = []
    for _ in range(300):
        y = k2 * rms**2 + rng.standard_normal(len(rms)) * u
        fit = fit_vrc(_levels(rms, y, u))
        est = fit.params["vrc_ug_per_g2"]
        z.append((est.value - 120.0) / est.u)
    z = np.array(z)
    # se = 1/sqrt(Σ r⁴/u²) when chi2_red <= 1; scaled up by sqrt(chi2_red) otherwise
    se0 = 1e6 / math.sqrt(np.sum(rms**4 / u**2))
    fit = fit_vrc(_levels(rms, k2 * rms**2, u))
    assert fit.params["vrc_ug_per_g2"].value == pytest.approx(120.0, rel=1e-9)
    assert fit.params["vrc_ug_per_g2"].u == pytest.approx(se0, rel=1e-9)
    assert fit.params["vrc_ug_per_g2"].unit == "ug/g^2"
    assert fit.model.name == "vrc" and fit.n_points == 5
    assert 0.60 <= np.mean(np.abs(z) <= 1) <= 0.85  # >= 68 %: errors are never scaled down
    assert any("not scaled" in n for n in fit.notes)


def test_fit_vrc_scales_errors_by_chi2_when_scatter_exceeds_u():
    rms = np.array([0.5, 1.0, 1.5, 2.0])
    y = 100e-6 * rms**2 + np.array([5e-5, -5e-5, 5e-5, -5e-5])
    u = np.full(4, 1e-6)
    fit = fit_vrc(_levels(rms, y, u))
    assert fit.chi2_reduced > 100
    se0 = 1e6 / math.sqrt(np.sum(rms**4 / u**2))
    assert fit.params["vrc_ug_per_g2"].u == pytest.approx(se0 * math.sqrt(fit.chi2_reduced), rel=1e-9)
    assert any("scaled by reduced chi2" in n for n in fit.notes)


def test_fit_vrc_excludes_saturated_and_above_max_rms():
    rms = [0.5, 1.0, 2.0, 3.0]
    y = [50e-6 * 0.25, 50e-6, 50e-6 * 4, -0.1]
    u = [1e-6] * 4
    lv = _levels(rms, y, u, [(), (), (), ("saturated",)])
    fit = fit_vrc(lv)
    assert fit.levels_used == (0.5, 1.0, 2.0)
    assert fit.params["vrc_ug_per_g2"].value == pytest.approx(50.0, rel=1e-9)
    assert fit_vrc(lv, max_rms_g=1.5).levels_used == (0.5, 1.0)


def test_fit_vrc_with_k4_recovers_quartic_term():
    """Gaussian vibration: VRE = k2·σ² + 3·k4·σ⁴ (SPEC 1.2, g0 = 0)."""
    rms = np.array([0.5, 1.0, 1.5, 2.0, 3.0, 4.0])
    k2, k4 = 80e-6, 5e-6
    y = k2 * rms**2 + 3 * k4 * rms**4
    fit = fit_vrc(_levels(rms, y, np.full(6, 1e-7)), with_k4=True)
    assert fit.model.name == "vrc+k4"
    assert fit.params["vrc_ug_per_g2"].value == pytest.approx(80.0, rel=1e-6)
    assert fit.params["c4_ug_per_g4"].value == pytest.approx(15.0, rel=1e-6)


def test_fit_vrc_selects_frequency():
    lv = [
        LevelResult(1.0, Estimate(100e-6, 1e-6), freq_hz=100.0),
        LevelResult(2.0, Estimate(400e-6, 1e-6), freq_hz=100.0),
        LevelResult(1.0, Estimate(900e-6, 1e-6), freq_hz=1000.0),
    ]
    fit = fit_vrc(lv, freq_hz=100.0)
    assert fit.params["vrc_ug_per_g2"].value == pytest.approx(100.0)
    assert fit.freq_hz == 100.0 and fit.n_points == 2


def test_fit_vrc_too_few_levels_is_value_error():
    with pytest.raises(ValueError, match="levels"):
        fit_vrc([LevelResult(1.0, Estimate(1e-4, 1e-6), flags=("saturated",))])


def test_quadrature_truth_matches_spec_reference_value():
    """SPEC 1.1: μ = 1 g, ±2 g rails, σ = 1 g: censored -83 mg, truncated -283 mg."""
    assert censored_vre_quad(1.0, 1.0, -2.0, 2.0) == pytest.approx(-0.083, abs=0.0006)
    assert truncated_vre_scipy(1.0, 1.0, -2.0, 2.0) == pytest.approx(-0.283, abs=0.0006)


@pytest.mark.parametrize("kind,truth", [("censored", censored_vre_quad), ("truncated", truncated_vre_scipy)])
def test_fit_rail_recovers_known_rail_from_noisy_data(kind, truth):
    rng = np.random.default_rng(1)
    rail, g0 = 2.5, 1.0
    rms = np.array([0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0])
    u = np.full(len(rms), 2e-3)
    y = np.array([truth(g0, s, -rail, rail) for s in rms]) + rng.standard_normal(len(rms)) * u
    fit = fit_rail(_levels(rms, y, u), g0, kind=kind)
    est = fit.params["rail_g"]
    assert fit.model.name == f"clip-{kind}"
    assert abs(est.value - rail) < 3 * est.u
    assert est.u < 0.05  # precise enough that the check means something
    assert fit.departure_rms_g is None


def test_fit_rail_detects_departure_where_extra_offset_was_injected():
    """Over-range protection adds a negative offset from 2.0 g rms up: the departure is there."""
    rng = np.random.default_rng(2)
    rail, g0 = 2.5, 1.0
    rms = np.arange(0.25, 3.01, 0.25)
    u = np.full(len(rms), 2e-3)
    y = np.array([censored_vre_quad(g0, s, -rail, rail) for s in rms]) + rng.standard_normal(len(rms)) * u
    extra = np.where(rms >= 2.0, -0.05 - 0.1 * (rms - 2.0), 0.0)
    fit = fit_rail(_levels(rms, y + extra, u), g0)
    assert fit.departure_rms_g == pytest.approx(2.0)
    assert max(fit.levels_used) == pytest.approx(1.75)
    assert abs(fit.params["rail_g"].value - rail) < 3 * fit.params["rail_g"].u


def test_fit_rail_single_outlier_is_not_a_departure():
    rail, g0 = 2.5, 1.0
    rms = np.arange(0.5, 2.51, 0.25)
    u = np.full(len(rms), 2e-3)
    y = np.array([censored_vre_quad(g0, s, -rail, rail) for s in rms])
    y[4] -= 0.05  # one bad level in the middle, the rest back on the model
    fit = fit_rail(_levels(rms, y, u), g0)
    assert fit.departure_rms_g is None


def test_fit_rail_asymmetric_rails():
    g0 = 0.5
    rms = np.arange(0.25, 2.01, 0.25)
    u = np.full(len(rms), 1e-4)
    y = np.array([censored_vre_quad(g0, s, -2.2, 2.6) for s in rms])
    fit = fit_rail(_levels(rms, y, u), g0, symmetric=False)
    assert fit.params["rail_low_g"].value == pytest.approx(-2.2, abs=0.01)
    assert fit.params["rail_high_g"].value == pytest.approx(2.6, abs=0.01)


def test_separate_k2_k3_spec_formula_and_uncertainty():
    """SPEC 1.2: VRC(±1 g) = k2 ± 3·k3: k2 = (V+ + V-)/2, k3 = (V+ - V-)/6."""
    k2, k3 = 40.0, 5.0
    fp = FitResult(VrcModel({"vrc_ug_per_g2": Estimate(k2 + 3 * k3, 3.0, "ug/g^2")}), 5)
    fm = FitResult(VrcModel({"vrc_ug_per_g2": Estimate(k2 - 3 * k3, 4.0, "ug/g^2")}), 5)
    out = separate_k2_k3(fp, fm)
    assert out.model.name == "k2-k3"
    assert out.params["k2_ug_per_g2"].value == pytest.approx(40.0)
    assert out.params["k3_ug_per_g3"].value == pytest.approx(5.0)
    assert out.params["k2_ug_per_g2"].u == pytest.approx(2.5)  # hypot(3, 4)/2
    assert out.params["k3_ug_per_g3"].u == pytest.approx(5.0 / 6)
    with pytest.raises(ValueError, match="vrc_ug_per_g2"):
        separate_k2_k3(fp, FitResult(ClipModel({"rail_g": Estimate(2.5, 0.1)}), 5))


def test_fit_rail_with_vrc_term_recovers_rail_and_k2():
    """Clipping plus a quadratic term (VRE = censored shift + k2·σ²): the joint fit recovers
    both; the clip-only fit of the same data has a large reduced χ²."""
    rng = np.random.default_rng(3)
    rail, g0, k2 = 2.5, 1.0, 2000e-6
    rms = np.array([0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0])
    u = np.full(len(rms), 2e-5) + 0.01 * np.abs([censored_vre_quad(g0, s, -rail, rail) for s in rms])
    y = np.array([censored_vre_quad(g0, s, -rail, rail) for s in rms]) + k2 * rms**2
    y = y + rng.standard_normal(len(rms)) * u
    fit = fit_rail(_levels(rms, y, u), g0, with_vrc=True)
    r, v = fit.params["rail_g"], fit.params["vrc_ug_per_g2"]
    assert abs(r.value - rail) < 3 * r.u and r.u < 0.05
    assert abs(v.value - 2000.0) < 3 * v.u and v.u < 200
    assert fit.departure_rms_g is None
    clip_only = fit_rail(_levels(rms, y, u), g0)
    assert clip_only.chi2_reduced > 5 * max(fit.chi2_reduced, 1.0)


def test_fit_rail_top_level_alone_needs_5_sigma_to_be_a_departure():
    rail, g0 = 2.5, 1.0
    rms = np.arange(0.5, 2.51, 0.25)
    u = np.full(len(rms), 2e-3)
    y = np.array([censored_vre_quad(g0, s, -rail, rail) for s in rms])
    y4 = y.copy()
    y4[-1] -= 4 * 2e-3  # 4 sigma: chance is possible, not reported
    assert fit_rail(_levels(rms, y4, u), g0).departure_rms_g is None
    y10 = y.copy()
    y10[-1] -= 10 * 2e-3  # far out: over-range at the top level
    assert fit_rail(_levels(rms, y10, u), g0).departure_rms_g == pytest.approx(2.5)


def test_fits_keep_their_covariance_in_the_units_of_their_parameters(rng):
    """FitResult.covariance: the diagonal is each parameter's u² (identification needs the
    off-diagonal too); it survives to_dict/from_dict."""
    from vrelab.results import Estimate, FitResult, LevelResult

    rms = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    levels = [LevelResult(float(r), Estimate(300e-6 * r * r + 20e-6 * r**4 + 1e-6 * rng.standard_normal(), 1e-6))
              for r in rms]
    fit = fit_vrc(levels, with_k4=True)
    cov = np.array(fit.covariance)
    u = [fit.params["vrc_ug_per_g2"].u, fit.params["c4_ug_per_g4"].u]
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), u, rtol=1e-12)
    assert cov[0, 1] < 0  # rms² and rms⁴ columns trade off: anti-correlated estimates
    back = FitResult.from_dict(json.loads(json.dumps(fit.to_dict())))
    np.testing.assert_allclose(back.covariance, cov, rtol=1e-15)


def test_k2_k3_covariance_is_the_linear_map_of_independent_vrcs():
    """k2 = (1-c)·VRC+ + c·VRC-, k3 = (VRC+ - VRC-)/d: cov = J·diag(u+², u-²)·Jᵀ (GUM 5.1)."""
    from vrelab.results import Estimate, FitResult

    fp = FitResult(VrcModel({"vrc_ug_per_g2": Estimate(130.0, 3.0, "ug/g^2")}), 4)
    fm = FitResult(VrcModel({"vrc_ug_per_g2": Estimate(70.0, 5.0, "ug/g^2")}), 4)
    out = separate_k2_k3(fp, fm, 1.0, -0.5)
    c, d = 1.0 / 1.5, 3.0 * 1.5
    J = np.array([[1 - c, c], [1 / d, -1 / d]])
    expect = J @ np.diag([9.0, 25.0]) @ J.T
    np.testing.assert_allclose(np.array(out.covariance), expect, rtol=1e-12)
    assert out.params["k2_ug_per_g2"].value == pytest.approx(130 * (1 - c) + 70 * c)
    assert out.params["k3_ug_per_g3"].value == pytest.approx(60.0 / d)


def test_notices_are_strings_with_a_code_that_survive_json_and_pickle():
    import pickle

    from vrelab.results import Conditions, Notice, VreResult

    n = Notice("rail-found", "DUT upper rail found at 2.048 g (40 samples on it)")
    assert n == "DUT upper rail found at 2.048 g (40 samples on it)" and n.code == "rail-found"
    assert pickle.loads(pickle.dumps(n)).code == "rail-found"
    res = VreResult("random", Conditions(), (), (), (n, "a plain note"))
    d = json.loads(json.dumps(res.to_dict()))
    assert d["warnings"] == [str(n), "a plain note"]
    assert d["notices"] == [{"code": "rail-found", "text": str(n)}, {"code": "note", "text": "a plain note"}]
    assert [w.code for w in VreResult.from_dict(d).warnings] == ["rail-found", "note"]


@pytest.mark.parametrize("g0,sigma,low,high", [(1.0, 0.5, -2.5, 2.5), (1.0, 2.0, -2.5, 2.5), (-0.3, 1.2, -2.0, 1.0),
                                               (2.2, 0.7, -2.0, 2.0), (0.0, 3.0, -1.5, 4.0)])
def test_censored_rail_derivatives_are_the_quadrature_models_slopes(g0, sigma, low, high):
    """The rail fit's Jacobian (∂VRE/∂L = P(X < L), ∂VRE/∂U = P(X > U), Leibniz's rule on SPEC
    1.1's integral) against central differences of the independent quadrature model."""
    from vrelab.models.clipping import censored_rail_derivatives

    d_low, d_high = censored_rail_derivatives(g0, sigma, low, high)
    h = 1e-4
    num_low = (censored_vre_quad(g0, sigma, low + h, high) - censored_vre_quad(g0, sigma, low - h, high)) / (2 * h)
    num_high = (censored_vre_quad(g0, sigma, low, high + h) - censored_vre_quad(g0, sigma, low, high - h)) / (2 * h)
    np.testing.assert_allclose([d_low, d_high], [num_low, num_high], rtol=2e-5, atol=1e-9)
    # vibration off: a step where the static field crosses the rail
    assert censored_rail_derivatives(3.0, 0.0, -1.0, 2.0) == (0.0, 1.0)
    assert censored_rail_derivatives(-3.0, 0.0, -1.0, 2.0) == (1.0, 0.0)


def test_levels_far_inside_the_rails_determine_no_rail_and_make_no_departure():
    """The departure scan fits the lowest levels alone. At 0.1 g rms and 1 g static the ±2.5 g
    rails are 15σ and 35σ away: the model's derivatives (1e-51, 1e-268) determine nothing, and
    (JᵀJ)⁻¹ of them is rounding noise, which once gave a zero model uncertainty and a departure
    "from 0.2 g rms on" on exact data. Such a fit has an infinite covariance, and no departure."""
    g0, rail = 1.0, 2.5
    rms = np.array([0.1, 0.1005, 0.101, 0.2, 0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    u = np.full(len(rms), 2e-4)
    y = np.array([censored_vre_quad(g0, s, -rail, rail) for s in rms])
    for symmetric in (True, False):
        f = fit_rail(_levels(rms, y, u), g0, "censored", symmetric=symmetric)
        assert f.departure_rms_g is None, f.notes
        assert f.n_points == len(rms)
        for name, est in f.params.items():
            assert abs(est.value) == pytest.approx(rail, abs=3 * est.u + 1e-6), (name, est)


def test_rail_grid_search_picks_the_full_grid_best_rail():
    """The rail fit's start (the best of 200 log-spaced rails) is found by a bounded search that
    evaluates a fraction of the grid (fits._monotone_grid_argmin); it must pick the very rail the
    full evaluation picks (then the fit's numbers are the same bits), or decline (None). Checked
    against numpy's argmin over the whole grid on seeded random prefixes of clipped levels."""
    from vrelab.fits import _monotone_grid_argmin
    from vrelab.models.clipping import censored_mean_shift

    rng = np.random.default_rng(7)
    decided = 0
    for _ in range(12):
        g0 = float(rng.choice([1.0, -1.0, 0.3]))
        rail = abs(g0) + rng.uniform(0.5, 3.0)
        rms = np.sort(rng.uniform(0.05, 3.0, 12))
        u = np.exp(rng.uniform(np.log(1e-6), np.log(1e-3), len(rms)))
        y = np.asarray(censored_mean_shift(g0, rms, -rail, rail)) + u * rng.standard_normal(len(rms))
        sw = 1.0 / u
        for m in range(3, len(rms) + 1):
            r = rms[:m]
            grid = np.geomspace(abs(g0) + 0.05 * r[0], abs(g0) + 12.0 * r[-1], 200)
            got = _monotone_grid_argmin(grid, r, y[:m], sw[:m], g0)
            if got is None:
                continue
            pred = np.asarray(censored_mean_shift(g0, r[None, :], -grid[:, None], grid[:, None]))
            assert got == int(np.argmin(np.sum(((pred - y[:m]) * sw[:m]) ** 2, axis=1)))
            decided += 1
    assert decided > 60  # the search decides most prefixes of clipped levels (else it saves nothing)
