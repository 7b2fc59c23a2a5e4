"""Designer's inverse questions and planning checks (SPEC 1.3, 4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vrelab.models.clipping import censored_mean_shift
from vrelab.models.design import (
    fixture_resonance_ok,
    grms_at_peak_threshold,
    max_rms_for_budget,
    max_sine_level_clear_of_rails,
    overrange_vre,
    tilt_error_deg,
    total_vre,
)


def test_budget_inverse_of_pure_vrc():
    """k2 only: |VRE| = k2·rms² = budget → rms = √(budget/k2); 1 mg at 100 µg/g² is √10 g rms."""
    assert max_rms_for_budget(1e-3, 0.0, -np.inf, np.inf, k2_per_g=100e-6) == pytest.approx(math.sqrt(10.0), rel=1e-10)


def test_budget_inverse_of_clipping_round_trips():
    """Clipping only: the returned rms gives exactly the budget back (SPEC 1.1 model)."""
    rms = max_rms_for_budget(0.4, 1.0, -2.5, 2.5)
    assert abs(censored_mean_shift(1.0, rms, -2.5, 2.5)) == pytest.approx(0.4, rel=1e-10)
    # ADXL355 datasheet: < 0.4 g at 2.5 g rms; the fitted 2.5 g rail gives -0.33 g there (SPEC 1.1)
    assert rms > 2.5


def test_budget_finds_the_first_crossing_when_mechanisms_oppose():
    """Positive k2 (2000 µg/g²) against the negative clipping shift (1 g field, ±2 g): VRE rises
    to +0.15 mg near 0.3 g rms, falls through 0 near 0.37 g rms and then dives negative. With a
    0.1 mg budget the answer is the first crossing, on the rising k2 side (≈ √(budget/k2) =
    0.224 g rms plus a small clipping correction), not the later one past the zero.
    """
    k2, budget = 2000e-6, 0.1e-3
    rms = max_rms_for_budget(budget, 1.0, -2.0, 2.0, k2_per_g=k2)
    assert abs(total_vre(rms, 1.0, -2.0, 2.0, k2_per_g=k2)) == pytest.approx(budget, rel=1e-9)
    assert math.sqrt(budget / k2) <= rms < 0.3
    grid = np.linspace(0, rms, 200)
    assert np.all(np.abs(total_vre(grid, 1.0, -2.0, 2.0, k2_per_g=k2)) <= budget * (1 + 1e-9))


def test_budget_errors_are_clear():
    with pytest.raises(ValueError, match="already exceeded"):
        max_rms_for_budget(0.1, 3.0, -2.0, 2.0)
    with pytest.raises(ValueError, match="never reached"):
        max_rms_for_budget(5.0, 0.0, -2.0, 2.0)


def test_sine_clear_of_rails():
    """1 g field, ±2 g: peak room 1 g; at resonance (|H| = Q = 7.4) the input may be 7.4× less."""
    assert max_sine_level_clear_of_rails(1.0, -2.0, 2.0) == pytest.approx(1 / math.sqrt(2))
    assert max_sine_level_clear_of_rails(1.0, -2.0, 2.0, gain=7.4) == pytest.approx(1 / (7.4 * math.sqrt(2)))
    with pytest.raises(ValueError, match="static_g"):
        max_sine_level_clear_of_rails(3.0, -2.0, 2.0)


def test_grms_at_peak_threshold_adxl355():
    """SPEC 1.3: ±8 g protection, crest factor 3, 1 g field: (8-1)/3 = 2.33 g rms ("about 2.5")."""
    assert grms_at_peak_threshold(8.0, 1.0) == pytest.approx(7.0 / 3.0)
    assert grms_at_peak_threshold(8.0) == pytest.approx(8.0 / 3.0)


def test_overrange_vre_formula_and_limits():
    """p = 1 - exp(-ν·hold), ν = Rice rates at ±T; VRE = p·(value - μ) (SPEC 1.3)."""
    mu, s, t, hold, nu0 = 1.0, 2.5, 8.0, 0.5e-3, 1200.0
    nu = nu0 * (math.exp(-((t - mu) ** 2) / (2 * s * s)) + math.exp(-((t + mu) ** 2) / (2 * s * s)))
    expect = -math.expm1(-nu * hold) * (0.0 - mu)
    assert overrange_vre(mu, s, t, hold, nu0) == pytest.approx(expect, rel=1e-14)
    # far below threshold: nothing; far above: always held, VRE -> value - μ
    assert abs(overrange_vre(mu, 0.5, t, hold, nu0)) < 1e-30
    assert overrange_vre(mu, 1e3, t, 1.0, nu0) == pytest.approx(-mu, rel=1e-9)
    assert overrange_vre(mu, s, t, hold, nu0, value_g=mu) == 0.0


def test_tilt_error():
    """SPEC 4: δ/cos θ rad → degrees; 1 mg is 0.0573° level and twice that at 60°."""
    assert tilt_error_deg(1e-3) == pytest.approx(math.degrees(1e-3))
    assert tilt_error_deg(1e-3, 60.0) == pytest.approx(2 * math.degrees(1e-3))
    with pytest.raises(ValueError, match="tilt_deg"):
        tilt_error_deg(1e-3, 90.0)


def test_fixture_rule():
    """Article: fixture's lowest resonance >= 1.5 × highest test frequency."""
    assert fixture_resonance_ok(3000.0, 2000.0)
    assert not fixture_resonance_ok(2999.0, 2000.0)


def test_options_given_by_position_as_before_still_work_with_a_deprecation_warning():
    """Issue 31's limit of 8 parameters made the trailing options of the model functions
    keywords; a call that gives them by position, as before, returns the same number for one
    release and warns (the suite's filterwarnings turns that warning into an error, so vrelab's
    own code cannot rely on it). Equality is exact: both calls run the same arithmetic."""
    from vrelab.models.memoryless import poly_clip_vre

    by_name = poly_clip_vre(1.0, 0.8, 0.01, 0.002, 0.0, offset_g=0.05, rail_low_g=-2.0, rail_high_g=2.0,
                            kind="truncated")
    with pytest.warns(DeprecationWarning, match=r"poly_clip_vre\(\): the keywords offset_g, rail_low_g, rail_high_g, "
                      r"shape, kind given by position are deprecated"):
        assert poly_clip_vre(1.0, 0.8, 0.01, 0.002, 0.0, 0.05, -2.0, 2.0, "gaussian", "truncated") == by_name
    with pytest.warns(DeprecationWarning, match="total_vre"):
        assert total_vre(1.5, 1.0, -2.0, 2.0, 0.01, 0.0, "sine") == total_vre(1.5, 1.0, -2.0, 2.0, 0.01, shape="sine")
    with pytest.warns(DeprecationWarning, match="max_rms_for_budget"):
        assert max_rms_for_budget(0.05, 1.0, -2.0, 2.0, 0.01, 0.0, "gaussian", "truncated") == max_rms_for_budget(
            0.05, 1.0, -2.0, 2.0, 0.01, kind="truncated")
    with pytest.warns(DeprecationWarning, match="overrange_vre"):
        assert overrange_vre(1.0, 4.0, 8.0, 5e-4, 800.0, 0.0, (), (), 1.5) == overrange_vre(
            1.0, 4.0, 8.0, 5e-4, 800.0, held_mean_g=1.5)
    # a call Python itself would refuse is still refused, in Python's words
    with pytest.raises(TypeError, match="unexpected keyword argument 'rail_low'"):
        poly_clip_vre(1.0, 0.8, rail_low=-2.0)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="multiple values for argument 'offset_g'"):
        poly_clip_vre(1.0, 0.8, 0.0, 0.0, 0.0, 0.1, offset_g=0.1)
    with pytest.raises(TypeError, match="at most 6 optional positional"):
        poly_clip_vre(1.0, 0.8, 0.0, 0.0, 0.0, 0.1, -2.0, 2.0, "gaussian", "censored", (), 7)
