"""One ``predict`` for one axis and three (issue 31): the single-axis call is the triaxial model
along the input axis, a vibration along any direction, a static field as a scalar or a vector,
one result type; ``predict_triaxial`` a deprecated alias of the same numbers.

Tolerance: 1e-12 g absolute, as tests/test_triaxial_predict.py holds the triaxial model along
the input axis against the single-axis one (the projected profile is the single-axis profile on
its own breakpoints, so the two differ only by the rounding of ``w·d`` and of a few sums).
"""

from __future__ import annotations

import json

import pytest

from vrelab.prediction import Prediction, predict
from vrelab.profiles import parse_profile
from vrelab.sensor import load_sensor
from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

TOL_G = 1e-12


def _same_levels(a: Prediction, b: Prediction) -> None:
    assert len(a.levels) == len(b.levels)
    for x, y in zip(a.levels, b.levels):
        assert abs(x.vre_g - y.vre_g) <= TOL_G
        assert abs(x.model_error_g - y.model_error_g) <= TOL_G
        assert (x.u_vre_g is None) == (y.u_vre_g is None)
        assert x.u_vre_g is None or y.u_vre_g is None or abs(x.u_vre_g - y.u_vre_g) <= TOL_G
        assert x.valid == y.valid
        for k, v in x.shares.items():
            assert abs(v - y.shares[k]) <= TOL_G, k
    assert abs(a.vibration_off_g - b.vibration_off_g) <= TOL_G


@pytest.mark.parametrize("preset,axis,static", [("adxl355", "z", 1.0), ("ideal", "x", -0.5)])
def test_the_single_axis_call_is_the_triaxial_call_along_the_input_axis(preset: str, axis: str, static: float) -> None:
    """ADXL355 ±2 g (filtered rails, an assumed u carried by the propagation) and the ideal ±2 g
    sensor on x in -0.5 g: a plain profile, the same along the input axis given as
    ``direction=``, as a TriaxialProfile with the static field as a vector, and a sine the same
    three ways."""
    sensor = load_sensor(preset, range_g=2, axis=axis)
    e = tuple(1.0 if a == axis else 0.0 for a in "xyz")
    g = tuple(static if a == axis else 0.0 for a in "xyz")  # the vector of the scalar, as predict makes it
    profile = parse_profile("flat:50-2000")
    levels = [0.5, 1.0, 2.5]
    one = predict(sensor, profile, levels, static_g=static)
    assert one.excitation is None and one.levels[0].sensed_rms_g is None  # the single-axis result
    along = predict(sensor, profile, levels, static_g=static, direction=e)
    tri = predict(sensor, TriaxialProfile.along(profile, e), levels, static_g=g)
    for other in (along, tri):
        assert other.excitation is not None and other.levels[0].shares["cross_g"] == 0.0
        _same_levels(one, other)
    assert along.to_dict() == tri.to_dict()  # the same call, spelled twice
    sine = predict(sensor, [400.0], [1.0, 2.0], static_g=static)
    for other in (predict(sensor, 400.0, [1.0, 2.0], static_g=static, direction=e),
                  predict(sensor, TriaxialSine(400.0, e, 1.0), [1.0, 2.0], static_g=g)):
        _same_levels(sine, other)
        assert all(lv.freq_hz == 400.0 for lv in other.levels)


def test_predict_triaxial_is_a_deprecated_alias_of_the_same_numbers() -> None:
    from vrelab.prediction.triaxial import predict_triaxial

    sensor = load_sensor("ideal", range_g=2, axis="z", overrides={"kip_ug_per_g2": 3000.0})
    tri = TriaxialProfile.along(parse_profile("flat:20-500"), (1.0, 0.0, 1.0))
    with pytest.warns(DeprecationWarning, match=r"predict_triaxial\(\) is deprecated .* vrelab\.predict\("):
        old = predict_triaxial(sensor, tri, [0.5, 1.0], static_g=(0, 0, 1))
    new = predict(sensor, tri, [0.5, 1.0], static_g=(0, 0, 1))
    assert json.dumps(old.to_dict()) == json.dumps(new.to_dict())  # same code path: bit for bit
    assert new.to_dict()["kind"] == "triaxial-prediction" and new.levels[0].shares["cross_kip_g"] != 0.0


@pytest.mark.parametrize("vibration,kw,words", [
    (TriaxialProfile.along(parse_profile("flat:20-500"), (0, 0, 1)), {"direction": (1, 0, 0)},
     "direction applies to a single-axis vibration"),
    (parse_profile("flat:50-2000+sine:80:0.4"), {"direction": (1, 0, 1)}, r"random profile \(no \+sine tones"),
    ([100.0, 200.0], {"direction": (1, 0, 1)}, r"random profile \(no \+sine tones.* or one sine frequency"),
    (parse_profile("flat:50-2000"), {"static_g": (0, 1)}, "static_g must be three finite numbers"),
    (parse_profile("flat:50-2000"), {"direction": (0, 0, 0)}, "direction"),
])
def test_what_has_no_triaxial_model_is_refused_in_one_line(vibration: object, kw: dict[str, object], words: str) -> None:
    sensor = load_sensor("ideal", range_g=2, axis="z")
    with pytest.raises(ValueError, match=words):
        predict(sensor, vibration, [1.0], **kw)  # type: ignore[arg-type]
