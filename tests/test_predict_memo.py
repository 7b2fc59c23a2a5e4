"""predict remembers its spectral integrals by their exact inputs (the profile's table, the
stages' responses): a sensor whose resonance, filters or hold change must never be given another
sensor's integrals.

Reference: the same integrals, σ² = ∫S·|H|²df (SPEC 1.3), computed directly by
:func:`vrelab.models.dynamics.effective_rms` on the profile's own PSD function and the sensor's
own response (:meth:`vrelab.sensor.loader.Sensor.response`), neither of which is remembered.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from vrelab.models.dynamics import effective_rms
from vrelab.prediction import predict
from vrelab.profiles import parse_profile
from vrelab.sensor import load_sensor


def _direct_sigma(sensor, profile, rms_g: float, where: str) -> float:
    """rms [g] at ``where`` for a drive of ``rms_g``: the profile's PSD through the sensor's response."""
    lo, hi = profile.band
    m0 = effective_rms(profile.psd, [lambda f: sensor.response(f, where)], lo, hi, points_hz=[sensor.fn_hz]) ** 2
    return rms_g * math.sqrt(m0 / profile.mean_square_g2)


def test_spectral_integrals_follow_every_response_parameter():
    """ADXL355 ±2 g Z (resonance, anti-alias, low-pass, over-range hold) and four variants, each
    differing from it in one parameter, predicted in turn and the first one again: the rms at the
    proof mass and at the output are each sensor's own (1e-7, the quadrature's tolerance is
    1e-10), so no variant was handed the integrals of another."""
    profile = parse_profile("navmat-p9492")
    base = load_sensor("adxl355", range_g=2, axis="z")
    variants = [base, dataclasses.replace(base, fn_hz=base.fn_hz * 0.8), dataclasses.replace(base, q=base.q * 3),
                dataclasses.replace(base, anti_alias_hz=base.anti_alias_hz * 0.5),
                dataclasses.replace(base, overrange_hold_s=base.overrange_hold_s * 4), base]
    seen = []
    for sensor in variants:
        (lv,) = predict(sensor, profile, [1.5], static_g=1.0).levels
        assert lv.sigma_proof_mass_g == pytest.approx(_direct_sigma(sensor, profile, 1.5, "proof-mass"), rel=1e-7)
        assert lv.sigma_output_g == pytest.approx(_direct_sigma(sensor, profile, 1.5, "output"), rel=1e-7)
        seen.append((lv.sigma_proof_mass_g, lv.sigma_output_g, lv.overrange_rate_hz, lv.vre_g))
    assert seen[-1] == seen[0]  # the same sensor again: the same numbers
    assert len(set(seen[:-1])) == len(variants) - 1  # every variant its own (the hold moves the over-range share)
