"""The sensor is an ordered tuple of stage configurations, each declaring its own fields (issue 31).

A new parameter is one field on its stage, a new stage one frozen class and one entry in the
ordered tuple (``fields.register_stage``): the test below defines a fixture stage (a housing
resonance; the real ``Mount`` stage began as this fixture) here, registers it, and follows its fields through
the loader, the sensor's stages, the writer, the sweep and the presets' README block with no
other edit to ``src/``. The others hold every preset to its file (the writer's round trip) and
the stage order to the chain the module docstring draws.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vrelab.sensor import Sensor, fields, list_presets, load_sensor, parameters
from vrelab.sensor.configs import Field, Mechanics, Mount, Sense, StageConfig, row
from vrelab.sensor.stages import Resonator
from vrelab.sensor.writer import sensor_document, write_sensor_file
from vrelab.sweep import spec as sweep_spec
from vrelab.sweep.points import sensor_for


@dataclasses.dataclass(frozen=True)
class Housing(StageConfig):
    """A housing's resonance between the shaker and the part: a second-order resonator
    (``H = 1 / (1 - r² + j·r/Q)``, r = f/fn, as the proof mass's) at ``housing_fn_hz`` with ``housing_q``."""

    housing_fn_hz: float | None = row(Field(
        "housing_fn_hz", "housing_fn_hz", "positive", None, "housing resonance [Hz] (with housing_q; omit both for a rigid housing)",
        lower=1.0, why_lower="below 1 Hz a housing is a suspension", upper=1e6, why_upper="beyond any housing's",
        sweepable=True, assumable=True))
    housing_q: float | None = row(Field(
        "housing_q", "housing_q", "positive", None, "quality factor of the housing resonance",
        upper=1e3, why_upper="no bolted mount rings that long", sweepable=True))

    def validate(self, sensor: Sensor) -> None:
        if (self.housing_fn_hz is None) != (self.housing_q is None):
            raise ValueError(f"sensor {sensor.name}: housing_fn_hz and housing_q must be given together")

    def build(self, sensor, factor):
        return () if self.housing_fn_hz is None else (Resonator(self.housing_fn_hz, self.housing_q),)


PART = """schema = 1
name = "mounted"
fn_hz = 2400.0
q = 7.4
k2_ug_per_g2 = 20.0
housing_fn_hz = 800.0
housing_q = 5.0
[uncertainty]
housing_fn_hz = 40.0
[facts]
fn_hz = "datasheet: 2.4 kHz"
q = "datasheet"
k2_ug_per_g2 = "assumption: one sample"
housing_fn_hz = "measured: tap test of the fixture"
housing_q = "measured: tap test of the fixture"
"""


def test_a_stage_defined_here_is_loaded_built_written_swept_and_documented(tmp_path):
    part = tmp_path / "mounted.toml"
    part.write_text(PART, encoding="utf-8")
    with fields.stage_registered(Housing, after=Mechanics):  # the one registration: an entry in the tuple
        assert fields.STAGES[:4] == (Mount, Mechanics, Housing, Sense)
        # loaded: the file's keys parse into the Sensor, with their facts and assumed u
        s = load_sensor(str(part))
        assert (s.housing_fn_hz, s.housing_q) == (800.0, 5.0)
        assert s.facts["housing_fn_hz"] == "measured: tap test of the fixture" and s.uncertainty == {"housing_fn_hz": 40.0}
        assert load_sensor("ideal").housing_fn_hz is None  # a file that leaves it out: the row's default
        with pytest.raises(ValueError, match="housing_fn_hz and housing_q must be given together"):
            load_sensor("ideal", overrides={"housing_fn_hz": 500.0})
        with pytest.raises(ValueError, match="housing_q must be at most 1000"):
            load_sensor(str(part), overrides={"housing_q": 5e3})
        # built: its stage sits where the tuple puts it (after the proof mass, before the polynomial)
        st = s.stages()
        assert st[:2] == (Resonator(2400.0, 7.4), Resonator(800.0, 5.0)) and type(st[2]).__name__ == "Polynomial"
        # the sensor's response is the product of the two resonances, H = 1/(1 - r² + j·r/Q) each
        # (SPEC 1.3's resonator, written out here); 1e-12: a few roundings of a complex division
        f = np.array([10.0, 800.0, 2400.0, 5000.0])
        h = 1.0 / (1.0 - (f / 2400.0) ** 2 + 1j * f / 2400.0 / 7.4) / (1.0 - (f / 800.0) ** 2 + 1j * f / 800.0 / 5.0)
        np.testing.assert_allclose(s.response(f), h, rtol=1e-12)
        # written: the writer's document holds the fields, and the written file loads to the same sensor
        doc = sensor_document(s)
        assert (doc["housing_fn_hz"], doc["housing_q"]) == (800.0, 5.0)
        back = load_sensor(str(write_sensor_file(tmp_path / "back.toml", doc)))
        assert back.stage_values() == s.stage_values() and back.facts == s.facts and back.uncertainty == s.uncertainty
        # swept: the sweep's lists know the fields, a grid may set them, a point's sensor has them
        assert {"housing_fn_hz", "housing_q"} <= set(sweep_spec.params_for("predict"))
        sp = sweep_spec.parse_spec({"kind": "predict", "fixed": {"sensor": str(part), "freq_hz": 100.0},
                                    "grid": {"rms_g": [1.0], "housing_fn_hz": [600.0, 900.0]}})
        assert sp.shape == (1, 2)
        point = sensor_for({"sensor": str(part), "housing_fn_hz": 600.0})
        assert point.housing_fn_hz == 600.0 and Resonator(600.0, 5.0) in point.stages()
        assert point.facts["housing_fn_hz"] == "set by the user: 600 Hz" and point.uncertainty == {}
        # the parameter lists
        assert parameters.parameter(s, "housing_fn_hz") == 800.0 and "housing_fn_hz" in parameters.assumable()
        assert parameters.with_parameters(s, {"housing_fn_hz": 700.0}).housing_fn_hz == 700.0
        # documented: the presets README block lists the rows, in stage order
        text = fields.schema_text()
        assert "housing_fn_hz" in text and "housing_q" in text and "Mechanics -> Housing -> Sense" in text
        assert text.index("    housing_fn_hz") < text.index("    input_axis")
    # gone with its registration
    assert Housing not in fields.STAGES and "housing_fn_hz" not in fields.schema_text()
    assert not hasattr(load_sensor("ideal"), "housing_fn_hz")
    with pytest.raises(ValueError, match="unknown key 'housing_fn_hz'"):
        load_sensor(str(part))


def test_a_stage_declares_each_field_by_its_row_and_a_key_once():
    @dataclasses.dataclass(frozen=True)
    class Bare(StageConfig):
        housing_fn_hz: float | None = None  # no row: not a field the loader or the writer could know

    with pytest.raises(TypeError, match="must be declared with row"):
        fields.register_stage(Bare)

    @dataclasses.dataclass(frozen=True)
    class Twice(StageConfig):
        fn_hz: float | None = row(Field("fn_hz", "fn_hz", "positive", None, "another resonance"))

    with pytest.raises(ValueError, match="field key fn_hz twice"):
        fields.register_stage(Twice)
    assert Twice not in fields.STAGES and Bare not in fields.STAGES


def test_the_stage_order_is_the_chain_the_loader_draws():
    """Every stage, present in one sensor, in the order the loader's docstring draws (SPEC 1.3)."""
    s = dataclasses.replace(load_sensor("adxl355", odr_hz=4000.0), clip_position="proof-mass", highpass_hz=0.1,
                            offset_g=0.01, drift_g_per_s=1e-6)
    assert [type(x).__name__ for x in s.stages(16000.0)] == [
        "Resonator", "Polynomial", "OverRange", "Clip", "Noise", "AntiAlias", "LowPass", "HighPass", "Offset",
        "Drift", "Decimate", "Quantize"]
    assert [type(x).__name__ for x in load_sensor("adxl355").stages(16000.0)][-3:] == ["Decimate", "Clip", "Quantize"]


@pytest.mark.parametrize("name", list_presets())
def test_every_preset_range_survives_the_writer(tmp_path, name):
    """Each preset at each of its ranges and axes: the sensor written (by file key, in the file's
    units) loads back to the same to_dict() and the same stages: the loader and the writer read
    the stages' rows the same way (rel 1e-12: a value times a unit scale and back)."""
    first = load_sensor(name)
    for range_g in first.ranges_g or (first.range_g,):
        for axis in first.axes:
            s = load_sensor(name, range_g=range_g, axis=axis)
            back = load_sensor(str(write_sensor_file(tmp_path / "s.toml", sensor_document(s))))
            a, b = s.to_dict(), back.to_dict()
            assert b.pop("source") and a.pop("source")
            for key in ("ranges_g", "axes", "odrs_hz"):  # the written file is one configuration
                a.pop(key), b.pop(key)
            assert a.keys() == b.keys()
            for key, v in a.items():
                w = b[key]
                if isinstance(v, float):
                    assert math.isclose(v, w, rel_tol=1e-12), (name, range_g, axis, key)
                else:
                    assert v == w, (name, range_g, axis, key)
            assert len(s.stages()) == len(back.stages())
