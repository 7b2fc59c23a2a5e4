"""The built-in point kinds of vrelab.sweep, held against independent computations.

``model`` against SPEC reference values and scipy quadrature / Gauss-Hermite / a dense grid;
``predict`` and ``simulate`` against direct calls of the functions they wrap (the sweep must
only pass parameters and seeds through), and the simulated ideal sensor against the closed form.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import integrate, stats

from vrelab.sweep import parse_spec, run_sweep
from vrelab.sweep.points import model_point, sensor_for


def _censored_by_quad(mu: float, sigma: float, lo: float, hi: float) -> float:
    """E[clip(X)] - mu for X ~ N(mu, sigma²), by quadrature of the clipped value."""
    pdf = stats.norm(mu, sigma).pdf
    inside, _ = integrate.quad(lambda x: x * pdf(x), lo, hi, epsabs=1e-13)
    below = lo * stats.norm.cdf((lo - mu) / sigma)
    above = hi * stats.norm.sf((hi - mu) / sigma)
    return below + inside + above - mu


def _model_sweep(tmp_path, grid, **fixed):
    spec = parse_spec({"kind": "model", "fixed": fixed, "grid": grid})
    res = run_sweep(spec, tmp_path)
    assert res.summary["n_failed"] == 0, res.summary["failed"]
    return res.dataset


def test_model_clipping_matches_spec_values_and_scipy(tmp_path):
    """SPEC 1.1: mu = 1 g, ±2 g rails, sigma = 1 g rms: censored -83 mg, truncated -283 mg;
    1 g rms sine: -68.3 mg. Held against quadrature and scipy.stats.truncnorm."""
    ds = _model_sweep(
        tmp_path,
        {"rms_g": [0.5, 1.0, 2.5], "clip_kind": ["censored", "truncated"], "shape": ["gaussian", "sine"]},
        static_g=1.0,
        range_g=2.0,
    )
    vre = ds["vre_g"]
    assert vre.sel(rms_g=1.0, clip_kind="censored", shape="gaussian") == pytest.approx(-0.083, abs=0.5e-3)
    assert vre.sel(rms_g=1.0, clip_kind="truncated", shape="gaussian") == pytest.approx(-0.283, abs=0.5e-3)
    assert vre.sel(rms_g=1.0, clip_kind="censored", shape="sine") == pytest.approx(-0.0683, abs=0.05e-3)
    for rms in (0.5, 1.0, 2.5):
        assert vre.sel(rms_g=rms, clip_kind="censored", shape="gaussian") == pytest.approx(
            _censored_by_quad(1.0, rms, -2.0, 2.0), rel=1e-9, abs=1e-14
        )
        tn = stats.truncnorm((-2.0 - 1.0) / rms, (2.0 - 1.0) / rms, loc=1.0, scale=rms)
        assert vre.sel(rms_g=rms, clip_kind="truncated", shape="gaussian") == pytest.approx(tn.mean() - 1.0, rel=1e-8)
        theta = np.linspace(0.0, 2 * np.pi, 200_001)[:-1]
        sine = np.clip(1.0 + rms * math.sqrt(2) * np.cos(theta), -2.0, 2.0).mean() - 1.0
        assert vre.sel(rms_g=rms, clip_kind="censored", shape="sine") == pytest.approx(sine, rel=1e-6, abs=1e-12)
    # SPEC 1.5: at +1 g the axis is vertical, so no tilt corresponds to the reading: NaN
    assert np.isnan(ds["tilt_error_deg"]).all()


def test_model_tilt_is_asin_of_the_reading():
    """SPEC 1.5: an axis at θ = asin(g0) reading g0 + δ has the tilt error asin(g0 + δ) - asin(g0)
    (not δ/cos θ, its first order); NaN where g0 or g0 + δ is beyond ±1 g."""
    for static, rms in ((0.2, 2.0), (0.5, 1.5), (-0.9, 1.2)):
        pt = model_point({"rms_g": rms, "static_g": static, "range_g": 2.0}, None)
        d = pt["vre_g"]
        assert abs(d) > 1e-3  # large enough that asin and its first order differ visibly
        want = math.degrees(math.asin(static + d) - math.asin(static))
        assert pt["tilt_error_deg"] == pytest.approx(want, rel=1e-12)
        assert abs(pt["tilt_error_deg"] - math.degrees(d / math.cos(math.asin(static)))) > 1e-9
    assert math.isnan(model_point({"rms_g": 1.0, "static_g": 2.5, "range_g": 2.0}, None)["tilt_error_deg"])
    with pytest.raises(ValueError, match="tilt_deg: unknown parameter"):
        parse_spec({"kind": "model", "fixed": {"tilt_deg": 60.0}, "grid": {"rms_g": [1.0]}})


def test_model_point_matches_predict_on_the_ideal_sensor_beyond_a_rail():
    """SPEC 1.5: one reference point. At 2.5 g static on ±2 g rails the vibration-off reading is
    itself clipped (2 g); the model point, predict on the ideal sensor and an independent scipy
    quadrature of E[clip(μ + X)] - clip(μ) agree."""
    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor

    mu, rms = 2.5, 1.0
    want = _censored_by_quad(mu, rms, -2.0, 2.0) + mu - 2.0  # E[clip] - clip(μ), clip(μ) = 2 g
    pt = model_point({"rms_g": rms, "static_g": mu, "range_g": 2.0}, None)
    pred = predict(load_sensor("ideal", range_g=2.0), parse_profile("flat:20-2000"), [rms], static_g=mu)
    assert pt["vre_g"] == pytest.approx(want, abs=1e-9)
    assert pt["vre_g"] == pytest.approx(pred.levels[0].vre_g, abs=1e-9)
    assert pt["vibration_off_g"] == pred.vibration_off_g == 2.0


def test_model_nonlinearity_matches_gauss_hermite(tmp_path):
    """SPEC 1.2: VRE = sum k_n (E[(g0+x)^n] - g0^n); E by 40-point Gauss-Hermite quadrature."""
    ds = _model_sweep(
        tmp_path,
        {"rms_g": [0.3, 1.5], "static_g": [1.0, -1.0, 0.0]},
        clip_kind="none",
        k2_ug_per_g2=50.0,
        k3_ug_per_g3=20.0,
    )
    x, w = np.polynomial.hermite_e.hermegauss(40)
    w = w / w.sum()
    for rms in (0.3, 1.5):
        for g0 in (1.0, -1.0, 0.0):
            a = g0 + rms * x
            expect = 50e-6 * (w @ a**2 - g0**2) + 20e-6 * (w @ a**3 - g0**3)
            assert float(ds["vre_g"].sel(rms_g=rms, static_g=g0)) == pytest.approx(expect, rel=1e-10)
    assert (ds["vre_clip_g"] == 0).all()


def test_model_resonance_and_offset(tmp_path):
    """SPEC 1.3: a sine at fn is amplified by Q; a flat band sees sqrt(mean |H|^2) (dense grid
    trapezoid); the offset moves the mean that meets the rails (quadrature at mu = g0 + offset)."""
    sine = model_point({"rms_g": 0.2, "shape": "sine", "fn_hz": 2400.0, "q": 7.4, "freq_hz": 2400.0}, None)
    assert sine["rms_mass_g"] == pytest.approx(0.2 * 7.4, rel=1e-12)
    f = np.linspace(50.0, 2000.0, 400_001)
    r = f / 2400.0
    h2 = 1.0 / ((1 - r**2) ** 2 + (r / 7.4) ** 2)
    gain = math.sqrt(np.trapezoid(h2, f) / (2000.0 - 50.0))
    ds = _model_sweep(
        tmp_path,
        {"offset_g": [0.0, 0.1]},
        rms_g=1.0,
        fn_hz=2400.0,
        q=7.4,
        f_lo_hz=50.0,
        f_hi_hz=2000.0,
    )
    assert float(ds["rms_mass_g"].sel(offset_g=0.0)) == pytest.approx(gain, rel=1e-8)
    assert float(ds["vre_g"].sel(offset_g=0.1)) == pytest.approx(_censored_by_quad(1.1, gain, -2.0, 2.0), rel=1e-8)


def test_model_point_with_one_of_fn_q_fails_that_point_only(tmp_path):
    spec = parse_spec({"kind": "model", "grid": {"rms_g": [1.0], "q": [2.0]}})
    res = run_sweep(spec, tmp_path)
    assert res.summary["n_failed"] == 1
    assert res.dataset["error"].item() == "ValueError: fn_hz and q go together: give both or neither"
    assert res.records[0].attempts == 1  # a ValueError fails the same way again: not retried


def test_predict_point_passes_sensor_profile_and_draws_through(tmp_path):
    from vrelab.prediction import predict
    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor

    spec = parse_spec(
        {
            "kind": "predict",
            "seed": 4,
            "fixed": {"sensor": "adxl355", "profile": "flat:50-2000", "static_g": 1.0},
            "grid": {"rms_g": [1.0, 2.5], "odr_hz": [4000.0, 500.0]},
            "montecarlo": {"units": 2, "q": {"dist": "uniform", "low": 5.0, "high": 9.0}},
        }
    )
    ds = run_sweep(spec, tmp_path).dataset
    assert dict(ds.sizes) == {"unit": 2, "rms_g": 2, "odr_hz": 2}
    for u in range(2):
        q = float(ds["q"][u])
        for odr in (4000.0, 500.0):
            # (a sweep point propagates no u: neither does this prediction)
            sensor = dataclasses.replace(load_sensor("adxl355", odr_hz=odr), q=q, uncertainty={})
            p = predict(sensor, parse_profile("flat:50-2000"), [1.0, 2.5], static_g=1.0)
            for lv in p.levels:
                got = ds.sel(unit=u, odr_hz=odr, rms_g=lv.rms_g)
                assert float(got["vre_g"]) == lv.vre_g
                # at +1 g the axis is vertical: the tilt is undefined (NaN) on both sides
                np.testing.assert_equal(float(got["tilt_error_deg"]), lv.tilt_error_deg)
    # the drawn Q reached the sensor: a different Q gives a different proof-mass rms
    assert float(ds["rms_mass_g"][0, 0, 0]) != float(ds["rms_mass_g"][1, 0, 0])


def test_sensor_for_rejects_an_impossible_draw():
    with pytest.raises(ValueError, match="q"):
        sensor_for({"sensor": "adxl355", "q": -1.0})


def test_simulate_point_uses_the_point_seed_and_agrees_with_the_closed_form(tmp_path):
    """The ideal sensor (rails at exactly ±2 g) simulated at 1 g rms in a 1 g field: the measured
    VRE is the censored closed form at the measured rms, within its uncertainty (SPEC 1.1)."""
    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor
    from vrelab.shaker import run_random_test

    spec = parse_spec(
        {
            "kind": "simulate",
            "seconds": 2.0,
            "seed": 7,
            "fixed": {"sensor": "ideal", "profile": "flat:50-2000"},
            "grid": {"rms_g": [1.0, 1.5]},
        }
    )
    ds = run_sweep(spec, tmp_path).dataset
    assert (ds["status"] == "ok").all()
    seed = int(np.random.SeedSequence(7, spawn_key=(0, 1)).generate_state(1, dtype=np.uint64)[0])
    direct = run_random_test(
        load_sensor("ideal"), parse_profile("flat:50-2000"), [1.5], 1.0, seconds=2.0, seed=seed
    ).levels[0]
    assert float(ds["vre_g"].sel(rms_g=1.5)) == direct.vre.value
    assert float(ds["u_vre_g"].sel(rms_g=1.5)) == direct.vre.u
    for rms in (1.0, 1.5):
        got = ds.sel(rms_g=rms)
        measured = float(got["rms_measured_g"])
        closed = _censored_by_quad(1.0, measured, -2.0, 2.0)
        assert abs(float(got["vre_g"]) - closed) < 4 * float(got["u_vre_g"]) + 2e-3


def test_a_lot_spread_in_q_spreads_the_vre_as_q_squared_at_resonance(tmp_path):
    """A production lot (the sweep's [montecarlo], which replaced shaker.monte_carlo_lot): Q drawn
    per unit; a sine at fn gives VRE = k2·(rms·|H(fn)|)² = k2·rms²·Q² (SPEC 1.3), per unit; the
    same file gives the same lot (seeded per unit)."""
    spec = {
        "kind": "predict",
        "seed": 3,
        "fixed": {"sensor": "adxl355", "range_g": 8.0, "axis": "z", "k2_ug_per_g2": 1000.0, "freq_hz": 2400.0,
                  "static_g": 0.0, "rms_g": 0.5},
        "montecarlo": {"units": 6, "q": {"dist": "normal", "mean": 1.5, "sd": 0.2}},
    }
    ds = run_sweep(parse_spec(spec), tmp_path / "a").dataset
    again = run_sweep(parse_spec(spec), tmp_path / "b").dataset
    q = ds["q"].values
    assert q.std() > 0.05
    np.testing.assert_array_equal(ds["vre_g"].values, again["vre_g"].values)
    # the clip and over-range shares are 0 here (0.5·Q g rms stays far inside ±8 g)
    np.testing.assert_allclose(ds["vre_g"].values.ravel(), 1000e-6 * 0.25 * q**2, rtol=1e-9)
