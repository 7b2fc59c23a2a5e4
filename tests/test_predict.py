"""The analytic prediction: against the closed forms, against the simulation, and its flags.

Reference values: SPEC 1.1 (censored mean shift; -68.3 mg for a 1 g rms sine on ±2 g in a 1 g
field), SPEC 1.2 (k2 + 3·k3·g0)·σ², SPEC 1.3 (|H(f)|² at the resonance; output clip after the
low-pass), and the simulated shaker (vrelab.shaker) where the approximations hold.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vrelab import shaker
from vrelab.models.clipping import censored_mean_shift
from vrelab.prediction import predict
from vrelab.profiles import RandomProfile
from vrelab.sensor import load_sensor

FLAT = RandomProfile.flat(50.0, 2000.0)


def test_ideal_random_is_the_censored_model_spec_1_1():
    """Ideal ±2 g sensor, 1 g field: VRE = censored Gaussian mean shift (SPEC 1.1): -83 mg at
    1 g rms; the two rails' shares add up to the total (the censored shift is additive)."""
    pred = predict(load_sensor("ideal", range_g=2), FLAT, [0.5, 1.0, 2.5], static_g=1.0)
    for lv in pred.levels:
        assert lv.vre_g == pytest.approx(float(censored_mean_shift(1.0, lv.rms_g, -2.0, 2.0)), rel=1e-9)
        sh = lv.shares
        assert sh["clip_low_g"] + sh["clip_high_g"] == pytest.approx(sh["clip_g"], rel=1e-9, abs=1e-15)
        assert sh["nonlinearity_g"] == 0 and sh["overrange_g"] == 0
        assert lv.sigma_proof_mass_g == pytest.approx(lv.rms_g) and lv.valid
    assert pred.levels[1].vre_g == pytest.approx(-0.0833, abs=0.0005)


def test_ideal_sine_clip_spec_value_minus_68_3_mg():
    """SPEC 1.1: 1 g field, ±2 g, 1 g rms sine: -68.3 mg."""
    (lv,) = predict(load_sensor("ideal", range_g=2), 100.0, [1.0], static_g=1.0).levels
    assert lv.vre_g == pytest.approx(-0.0683, abs=0.00005)
    assert lv.freq_hz == 100.0


def test_nonlinearity_share_is_k2_plus_3k3g0_sigma2_spec_1_2():
    """SPEC 1.2: VRE = (k2 + 3·k3·g0)·σ² for a cubic polynomial, Gaussian or sine."""
    k2, k3 = 200.0, 50.0  # µg/g², µg/g³
    sensor = load_sensor("ideal", range_g=40, k2_ug_per_g2=k2, k3_ug_per_g3=k3)
    for exc in (FLAT, 300.0):
        for g0 in (1.0, -1.0, 0.0):
            (lv,) = predict(sensor, exc, [2.0], static_g=g0).levels
            assert lv.shares["nonlinearity_g"] == pytest.approx((k2 + 3 * k3 * g0) * 1e-6 * 4.0, rel=1e-9)


def test_resonance_lifts_nonlinearity_by_h2_spec_1_3():
    """SPEC 1.3: a sine at f sees VRC·|H(f)|², |H(fn)| = Q."""
    sensor = dataclasses.replace(load_sensor("ideal", range_g=40, k2_ug_per_g2=1000.0), fn_hz=2400.0, q=7.4)
    (at_fn,) = predict(sensor, 2400.0, [0.1], static_g=0.0).levels
    assert at_fn.sigma_proof_mass_g == pytest.approx(0.1 * 7.4, rel=1e-9)
    assert at_fn.shares["nonlinearity_g"] == pytest.approx(1000e-6 * (0.1 * 7.4) ** 2, rel=1e-9)


def test_narrow_bandwidth_shrinks_output_clip_article_figure4():
    """Seed article Fig. 4 / SPEC 1.3: the output clip sees σ_out after the ODR/4 low-pass, so
    ODR 500 (125 Hz) predicts far less VRE than ODR 4000 (1 kHz) at the same 1.5 g rms.

    The claim is on the central values: the preset's assumed u are set aside (their propagation,
    a Monte Carlo over the assumptions, was ~95 % of this test's CPU and adds u_vre_g only:
    ``Propagation.applied`` leaves vre_g, σ_out and the shares as they are)."""
    def central(odr_hz: float):
        part = load_sensor("adxl355", range_g=2, axis="y", odr_hz=odr_hz)
        return predict(dataclasses.replace(part, uncertainty={}), FLAT, [1.5]).levels[0]

    p500, p4k = central(500), central(4000)
    assert p500.sigma_output_g < 0.5 * p4k.sigma_output_g
    assert abs(p500.shares["clip_g"]) < 0.05 * abs(p4k.shares["clip_g"])


@pytest.mark.parametrize("rms", [1.0, 1.5, 2.0])
def test_predict_agrees_with_simulate_adxl355_z(rms):
    """Where the approximations hold (valid): the prediction agrees with the simulated test
    within 3 standard uncertainties of the simulation plus 10 % of the prediction (the output
    rails see the polynomial's output through the filters as Gaussian; the Rice×hold over-range
    estimate is rough)."""
    sensor = load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    (lv,) = predict(sensor, FLAT, [rms]).levels
    assert lv.valid
    (sim,) = shaker.run_random_test(sensor, FLAT, [rms], seconds=2.0, baseline_s=2.0, seed=21).levels
    assert abs(sim.vre.value - lv.vre_g) < 3 * sim.vre.u + 0.10 * abs(lv.vre_g), (sim.vre, lv.vre_g)


def test_predict_agrees_with_simulate_sine_through_the_chain():
    """Sine at 1 kHz on ADXL355 X (Q = 7.4) with k2 = 1000 µg/g²: nonlinearity on the proof-mass
    motion, k2·(rms·|H(f)|)² (SPEC 1.3), agrees with the simulation within 3u + 1 %."""
    sensor = load_sensor("adxl355", range_g=8, axis="x", k2_ug_per_g2=1000.0)
    pred = predict(sensor, 1000.0, [1.0, 2.0], static_g=1.0)
    sim = shaker.run_sine_test(sensor, [1000.0], [1.0, 2.0], static_g=1.0, seconds=2.0, baseline_s=2.0, seed=2)
    for p, s in zip(pred.levels, sim.levels):
        assert p.valid
        assert abs(s.vre.value - p.vre_g) < 3 * s.vre.u + 0.01 * abs(p.vre_g), (s.vre, p.vre_g)


def test_flags_where_the_approximations_stop_holding():
    """Over-range holds filling the time (ADXL355 X on ±2 g at 4 g rms) and a sine whose
    proof-mass peak reaches the ±8 g threshold are flagged invalid, with a note saying to
    simulate; at small levels the prediction is valid."""
    x = load_sensor("adxl355", range_g=2, axis="x")
    small, big = predict(x, FLAT, [0.5, 4.0]).levels
    assert small.valid and not small.notes
    assert not big.valid and any("simulate" in n for n in big.notes)
    assert abs(big.shares["overrange_g"]) > 0.1 * abs(big.vre_g)
    (sine,) = predict(x, 2400.0, [1.0]).levels  # 1 g rms at fn, Q 7.4: 10.5 g peak at the mass
    assert not sine.valid and any("over-range" in n for n in sine.notes)
    pred = predict(x, FLAT, [0.5, 4.0])
    assert not pred.valid
    assert any("Gaussian" in n for n in pred.notes)


def test_to_dict_carries_the_cli_contract_keys():
    pred = predict(load_sensor("adxl355", range_g=2, axis="z"), FLAT, [1.0, 2.0])
    d = pred.to_dict()
    assert d["conditions"]["sensor"] == "adxl355" and d["conditions"]["axis"] == "z"
    for lv in d["levels"]:
        assert {"rms_g", "vre_g", "tilt_error_deg", "shares", "valid", "notes"} <= set(lv)
        assert {"clip_g", "clip_low_g", "clip_high_g", "nonlinearity_g", "overrange_g"} <= set(lv["shares"])
        # SPEC 1.5: an axis at +1 g is vertical, where a reading has no tilt: null, said once
        assert lv["tilt_error_deg"] is None
    assert any("tilt error undefined" in n for n in d["notes"])
    # on a horizontal axis an offset δ [g] reads as asin(δ) of tilt (≈ δ radians)
    for lv in predict(load_sensor("adxl355", range_g=2, axis="z"), FLAT, [2.0], static_g=0.0).levels:
        assert lv.tilt_error_deg == pytest.approx(math.degrees(math.asin(lv.vre_g)), rel=1e-12)
    assert isinstance(d["notes"], list)


@pytest.mark.parametrize(
    "levels, kwargs, match",
    [
        ([1.0, -0.5], {}, "levels"),
        ([], {}, "levels"),
        ([1.0], {"static_g": np.inf}, "static_g"),
        ([1.0], {"kind": "clamped"}, "kind"),
    ],
)
def test_bad_input(levels, kwargs, match):
    with pytest.raises(ValueError, match=match):
        predict(load_sensor("ideal"), FLAT, levels, **kwargs)


def test_bad_frequency():
    with pytest.raises(ValueError, match="freq_hz"):
        predict(load_sensor("ideal"), -100.0, [1.0])


def test_predict_agrees_with_simulate_proof_mass_clip():
    """A clip at the proof mass (before the filters, SPEC 1.3) sees σ_m = rms·|H_mech| over the
    band, not the filtered σ_out: prediction and simulation agree (3u + 10 %), and the clip
    rectifies more than the same rail at the output."""
    out_clip = load_sensor("adxl355", range_g=2, axis="z")
    pm_clip = dataclasses.replace(out_clip, clip_position="proof-mass")
    (p_pm,) = predict(pm_clip, FLAT, [1.0]).levels
    (p_out,) = predict(out_clip, FLAT, [1.0]).levels
    assert p_pm.sigma_at_clip_g == pytest.approx(p_pm.sigma_proof_mass_g)
    assert p_out.sigma_at_clip_g == pytest.approx(p_out.sigma_output_g) and p_out.sigma_output_g < p_pm.sigma_proof_mass_g
    assert p_pm.vre_g < 2 * p_out.vre_g < 0
    (sim,) = shaker.run_random_test(pm_clip, FLAT, [1.0], seconds=2.0, baseline_s=2.0, seed=22).levels
    assert abs(sim.vre.value - p_pm.vre_g) < 3 * sim.vre.u + 0.10 * abs(p_pm.vre_g), (sim.vre, p_pm.vre_g)


def test_static_field_beyond_a_rail_is_flagged_and_referred_to_the_clipped_baseline():
    """A 3 g static field on a ±2 g sensor reads 2 g without vibration; VRE is measured against
    that reading (SPEC definition: mean with vibration − mean without), so a small vibration
    gives ~0. The prediction says it is out of its domain; the simulated test, whose baseline
    sits on the rail, reports no number at all (SPEC 4.2: off-scale baseline, VRE undefined)."""
    sensor = load_sensor("ideal", range_g=2)
    (lv,) = predict(sensor, FLAT, [0.3], static_g=3.0).levels
    assert not lv.valid and any("rail" in n for n in lv.notes)
    # only the rare dips below 2 g (3.3σ) move the mean: -σ·G(3.33) ≈ -34 µg, not 2 - 3 = -1 g
    assert -1e-4 < lv.vre_g < 0
    (sim,) = shaker.run_random_test(sensor, FLAT, [0.3], static_g=3.0, seconds=2.0, baseline_s=2.0, seed=1).levels
    assert math.isnan(sim.vre.value) and "baseline-off-scale" in sim.flags


def test_offset_before_the_rails_is_honoured_like_the_simulation():
    """Issue 13's disagreement: ideal ±2 g rails, offset 0.3 g, 1 g field, 1 g rms flat 50-2000 Hz.
    predict once said -82.9 mg (the offset ignored). The censored closed form (SPEC 1.1) at the
    static level the rails see, 1.3 g, is -142.8 mg; predict must be within 2 mg of it, and of
    the simulated test (the same sensor's stages run on a shaker) within 3 u + 2 mg."""
    import dataclasses

    from vrelab.models.clipping import censored_mean_shift
    from vrelab.shaker import run_random_test

    sensor = dataclasses.replace(load_sensor("ideal"), offset_g=0.3)
    flat = RandomProfile.flat(50.0, 2000.0)
    closed = float(censored_mean_shift(1.3, 1.0, -2.0, 2.0))
    assert closed == pytest.approx(-0.1428, abs=5e-5)
    pred = predict(sensor, flat, [1.0], static_g=1.0).levels[0]
    assert pred.valid
    assert pred.vre_g == pytest.approx(closed, abs=2e-3)
    sim = run_random_test(sensor, flat, [1.0], static_g=1.0, seconds=8.0, seed=5).levels[0]
    assert abs(sim.vre.value - pred.vre_g) <= 3 * sim.vre.u + 2e-3, (sim.vre, pred.vre_g)


def test_a_stage_without_closed_form_makes_the_prediction_say_so():
    """predict walks the sensor's stages; one it cannot model is named and the level invalid."""
    import dataclasses

    from vrelab.sensor.stages import StageBase

    @dataclasses.dataclass(frozen=True)
    class Compressor(StageBase):
        def process(self, x, state, fs_hz):
            return np.tanh(x), state

    class Odd(type(load_sensor("ideal"))):
        def stages(self, fs_hz=None):
            return (Compressor(), *super().stages(fs_hz))

    base = load_sensor("ideal")
    odd = Odd(**{f.name: getattr(base, f.name) for f in dataclasses.fields(base)})
    lv = predict(odd, RandomProfile.flat(50.0, 2000.0), [1.0], static_g=1.0).levels[0]
    assert not lv.valid and any("Compressor" in n for n in lv.notes)
