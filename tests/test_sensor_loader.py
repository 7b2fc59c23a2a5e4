"""Sensor descriptions: presets and user files (SPEC 2; ADXL354/ADXL355 data sheet Rev. D)."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import tomllib
from importlib import resources

import numpy as np
import pytest

from vrelab.sensor import (
    Clip,
    Decimate,
    LowPass,
    OverRange,
    Quantize,
    Resonator,
    list_presets,
    load_sensor,
)
from vrelab.sensor.loader import NUMERIC_FIELDS


def _preset_toml(name):
    return tomllib.loads((resources.files("vrelab.sensor") / "presets" / f"{name}.toml").read_text("utf-8"))


def _options(name):
    s = load_sensor(name)
    return s.ranges_g or (s.range_g,), s.axes, s.odrs_hz or (None,)


def test_presets_listed():
    assert set(list_presets()) >= {"ideal", "adxl355", "adxl354", "adxl357"}


@pytest.mark.parametrize("name", list_presets())
def test_every_preset_loads_for_every_range_axis_odr_it_declares(name):
    ranges, axes, odrs = _options(name)
    for r in ranges:
        for axis in axes:
            for odr in odrs:
                s = load_sensor(name, range_g=r, axis=axis, odr_hz=odr)
                fs = s.internal_rate_hz(2000.0)
                chain = s.chain(fs)
                assert chain.fs_out_hz(fs) == (odr if odr is not None else fs)
                assert s.rails_g[0] < 0 < s.rails_g[1]
                json.dumps(s.to_dict())  # the description is plain data
                assert s.name in s.describe()
                c = s.conditions(static_g=1.0).to_dict()
                assert (c["sensor"], c["axis"], c["odr_hz"], c["static_g"]) == (name, axis, odr, 1.0)


@pytest.mark.parametrize("name", list_presets())
def test_facts_cover_every_numeric_field(name):
    """Each preset says, for every number, whether it is a data-sheet fact or an assumption: in its
    [facts], or by the field table's default fact for a value it leaves at the row's default. The
    ideal sensor is no part: its numbers are its definition (SPEC 5), exact."""
    from vrelab.sensor.fields import FIELDS

    kinds = ("datasheet", "assumption") + (("definition",) if name == "ideal" else ())

    data = _preset_toml(name)
    rows = {f.name: f for f in FIELDS}
    aliases = {f.key: f.name for f in FIELDS}
    facts = {aliases.get(k, k): v for k, v in data["facts"].items()}
    tables = [data, *data.get("axes", {}).values(), *data.get("ranges", {}).values()]
    written = {aliases[k] for t in tables for k in t if k in aliases}
    for field in NUMERIC_FIELDS:
        if field in facts:
            assert facts[field].startswith(kinds), f"{name}.{field}: {facts[field]}"
        else:
            assert field in rows and rows[field].default_fact and field not in written, f"{name}: no fact for {field}"
    for axis in load_sensor(name).axes:
        s = load_sensor(name, axis=axis)
        assert set(NUMERIC_FIELDS) <= set(s.facts)
        assert all(s.facts[f].startswith(kinds) for f in NUMERIC_FIELDS)
    from vrelab.sensor.fields import STAGES  # a Sensor's numbers: its stages' fields

    numeric = {f.name for stage in STAGES for f in dataclasses.fields(stage) if f.type in (
        "float", "float | None", "int | None", "tuple[float, float]")}
    assert len(numeric) >= 15 and numeric <= set(NUMERIC_FIELDS)


def test_adxl355_datasheet_values():
    """ADXL354/ADXL355 data sheet Rev. D, as tabulated in SPEC 2."""
    s = load_sensor("adxl355")
    assert (s.range_g, s.full_scale_g, s.odr_hz, s.bandwidth_hz) == (2.0, 2.048, 4000.0, 1000.0)
    assert (s.fn_hz, s.q, s.axis) == (2400.0, 7.4, "x")
    assert s.lsb_g == pytest.approx(1 / 256000) and s.noise_ug_per_rthz == 22.5
    assert (s.overrange_threshold_g, s.overrange_hold_s, s.overrange_value_g) == (8.0, 0.5e-3, 0.0)
    assert s.highpass_hz is None and s.offset_g == 0.0 and s.clip_position == "output"
    assert load_sensor("adxl355", axis="z").q == 1.5
    s8 = load_sensor("adxl355", range_g=8)
    assert (s8.full_scale_g, s8.noise_ug_per_rthz, s8.overrange_threshold_g) == (8.192, 25.0, 16.0)
    assert s8.lsb_g == pytest.approx(1 / 64000)
    assert load_sensor("adxl355", range_g=4.096).range_g == 4.0  # full scale selects the range too
    assert load_sensor("adxl355", odr_hz=7.813).odr_hz == 7.8125  # data sheet rounding accepted
    s357 = load_sensor("adxl357", range_g=40)
    assert (s357.full_scale_g, s357.fn_hz, s357.noise_ug_per_rthz) == (40.96, 5500.0, 75.0)
    assert s357.lsb_g == pytest.approx(1 / 12800)
    s354 = load_sensor("adxl354")
    assert s354.odr_hz is None and s354.bandwidth_hz == 1900.0 and s354.lsb_g is None


def test_adxl355_chain_order():
    """Nonlinearity and trip on the proof mass; clip at the output after the low-pass."""
    s = load_sensor("adxl355")
    kinds = [type(st) for st in s.chain(20000.0).stages]
    assert kinds.index(Resonator) < kinds.index(OverRange) < kinds.index(LowPass) < kinds.index(Decimate)
    assert kinds.index(LowPass) < kinds.index(Clip) < kinds.index(Quantize)
    pm = dataclasses.replace(s, clip_position="proof-mass")
    kinds = [type(st) for st in pm.chain(20000.0).stages]
    assert kinds.index(Clip) < kinds.index(LowPass)


def test_ideal_is_rails_and_nonlinearity_only():
    s = load_sensor("ideal", range_g=3.0, k2_ug_per_g2=30.0)
    assert s.rails_g == (-3.0, 3.0) and s.k2_per_g == pytest.approx(30e-6)
    assert "set by the user" in s.facts["k2_per_g"]
    chain = s.chain(12345.0)  # any rate
    assert chain.rate_factor == 1
    assert [type(st).__name__ for st in chain.stages] == ["Polynomial", "Clip"]
    assert s.linear_responses("output") == []
    assert load_sensor("ideal").chain(100.0).stages == (Clip(-2.0, 2.0),)


def test_internal_rate_rule():
    """The one rate rule (vrelab.rates.simulation_rate_hz), worked by hand from its docstring:
    f_need = max(8·f_max, 5·fn, 5·f_AA, 16·BW), then the multiple k·ODR (k0 <= k <= 2·k0) that
    minimises fs + fs/m, m the largest divisor of k with fs/m >= 2·1.25·f_max."""
    s = load_sensor("adxl355")
    # f_max 2 kHz: max(16000, 12000, 7500, 16000) = 16000 = 4 × ODR; fs/m >= 5 kHz: k=4 -> m=2,
    # cost 24 k; k=5 -> m=1, 40 k; k=6 -> 32 k; k=7 -> 56 k; k=8 -> 40 k: 16 kHz
    assert s.internal_rate_hz(2000.0) == 16000.0
    # f_max 5 kHz: 40000 = 10 × ODR; fs/m >= 12.5 kHz: k=10 -> m=2, cost 60 k; no k up to 20 does better
    assert s.internal_rate_hz(5000.0) == 40000.0
    # ADXL357, f_max 100 Hz: 5 × 5.5 kHz = 27.5 kHz -> k0 = 7 (28 kHz, record 4 kHz, cost 32 k)
    assert load_sensor("adxl357").internal_rate_hz(100.0) == 28000.0
    # no ODR: 8 × 100 Hz rounded up to the 1 kHz grid
    assert load_sensor("ideal").internal_rate_hz(100.0) == 1000.0
    for odr in load_sensor("adxl355").odrs_hz:
        fs = load_sensor("adxl355", odr_hz=odr).internal_rate_hz(2000.0)
        assert fs >= 16000.0 and math.isclose(fs / odr, round(fs / odr))


def test_linear_responses_proof_mass_and_output():
    s = load_sensor("adxl355")
    f = np.array([0.0, 2400.0])
    pm = s.response(f, "proof-mass")
    assert abs(pm[0]) == pytest.approx(1.0) and abs(pm[1]) == pytest.approx(7.4)
    assert len(s.linear_responses("proof-mass")) == 1 and len(s.linear_responses("output")) == 3
    out = s.response(np.array([1000.0]), "output")[0]
    r = 1000.0 / 2400.0
    mech = 1 / abs(1 - r**2 + 1j * r / 7.4)
    aa = 1 / math.sqrt(1 + (1000 / 1500) ** 4)  # 2nd-order Butterworth
    assert abs(out) == pytest.approx(mech * aa / math.sqrt(2), rel=1e-6)  # LPF -3 dB at its corner
    with pytest.raises(ValueError, match="where must be one of proof-mass, output"):
        s.linear_responses("input")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"spec": "adxl999"}, r"sensor must be one of adxl354, adxl355, adxl356, adxl357, adxl358, adxl359, adxl380, ideal, ma352, sca3300 or a path"),
        ({"spec": "adxl355", "range_g": 3}, r"range_g must be one of 2, 4, 8 g \(full scale 2.048, 4.096, 8.192\) for adxl355; got 3"),
        ({"spec": "adxl355", "axis": "w"}, r"axis must be one of x, y, z for adxl355; got 'w'"),
        ({"spec": "adxl355", "odr_hz": 3000}, r"odr_hz must be one of 4000, 2000, .* Hz for adxl355; got 3000"),
        ({"spec": "adxl354", "odr_hz": 4000}, r"odr_hz must not be given for adxl354"),
        ({"spec": "ideal", "range_g": -1}, r"range_g must be a number > 0 for ideal; got -1"),
        ({"spec": "adxl357", "range_g": 2}, r"range_g must be one of 10, 20, 40 g"),
    ],
)
def test_loader_errors_name_field_and_allowed_values(kwargs, message):
    with pytest.raises(ValueError, match=message):
        load_sensor(**kwargs)


def _readme_example() -> str:
    text = (resources.files("vrelab.sensor") / "presets" / "README").read_text("utf-8")
    return re.search(r"```toml\n(.*?)```", text, re.S).group(1)


def test_readme_example_user_file_loads(tmp_path):
    path = tmp_path / "my_part.toml"
    path.write_text(_readme_example(), encoding="utf-8")
    s = load_sensor(str(path))
    assert (s.name, s.axis, s.q, s.range_g, s.odr_hz, s.bandwidth_hz) == ("my_part", "z", 2.0, 2.0, 1000.0, 250.0)
    assert s.k2_per_g == pytest.approx(35e-6) and s.overrange_threshold_g == 6.0
    assert s.facts["k2_per_g"].startswith("assumption") and "unmarked" in s.facts["q"]
    s4 = load_sensor(str(path), range_g=4.096, axis="x")
    assert s4.rails_g == (-4.096, 4.096) and s4.q == 5.0 and s4.noise_ug_per_rthz == 35.0
    fs = s4.internal_rate_hz(500.0)
    assert fs == 15000.0  # 5 × 3 kHz resonance, a multiple of the 1 kHz ODR (record 3 kHz, cost 18 k)
    y, _ = s4.chain(fs).apply(np.ones(3000), fs)
    assert y.size == 200


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda t: t + "\nbogus = 1\n", r"unknown key 'bogus'; allowed keys are"),
        (lambda t: t.replace("fn_hz = 3000.0", 'fn_hz = "fast"'), r"fn_hz must be a number, got 'fast'"),
        (lambda t: t.replace("q = 2.0", "q = -2.0"), r"q must be a number > 0, got -2.0"),
        (lambda t: t.replace('clip_position = "output"', 'clip_position = "middle"'),
         r"clip_position must be one of output, proof-mass; got 'middle'"),
        (lambda t: t.replace("rails_g = [-2.048, 2.048]", "rails_g = [2.0, -2.0]"), r"rails_g must be \[low, high\]"),
        (lambda t: t.replace("[axes.z]\nq = 2.0", "[axes.z]\nqq = 2.0"), r"\[axes.z\]: unknown key 'qq'"),
        (lambda t: t + "\n[[broken", r"is not valid TOML"),
        (lambda t: t.replace("lowpass_order = 4", "lowpass_order = 4.5"), r"lowpass_order must be an integer"),
    ],
)
def test_invalid_user_file_names_the_field(tmp_path, edit, message):
    path = tmp_path / "bad.toml"
    path.write_text(edit(_readme_example()), encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        load_sensor(str(path))


def test_one_field_table_drives_the_file_the_sensor_and_the_readme():
    """vrelab.sensor.fields.FIELDS: every row is a Sensor attribute and a file key, and the presets
    README lists exactly the table (a new parameter is one row, one attribute, one stage)."""
    import dataclasses

    from vrelab.sensor.fields import FIELDS, STAGES, schema_text

    attrs = {f.name for stage in STAGES for f in dataclasses.fields(stage)}  # each stage declares its fields
    assert {f.name for f in FIELDS} == attrs
    assert all(hasattr(load_sensor("ideal"), name) for name in attrs)  # and the Sensor reads them
    readme = (resources.files("vrelab.sensor") / "presets" / "README").read_text("utf-8")
    assert schema_text() in readme
    s = load_sensor("adxl355")
    for f in FIELDS:  # every preset value passes its own row's check
        f.check(getattr(s, f.name), s.name)


@pytest.mark.parametrize(
    "body, message",
    [
        ("", r"no schema key: a sensor file starts with schema = 1"),
        ("schema = 9\n", r"schema must be 1 \(the sensor schema this version reads\), got 9"),
        ("schema = 1\nodrs_hz = []\n", r"odrs_hz must be a non-empty list of rates"),
        ("schema = 1\nlowpass_order = 400\n", r"lowpass_order must be at most 12"),
        ("schema = 1\nanti_alias_order = 0\n", r"anti_alias_order must be an integer >= 1"),
        ("schema = 1\nfn_hz = 1e9\nq = 2.0\n", r"fn_hz must be at most 1e\+06 \(a resonance above 1 MHz"),
        ("schema = 1\nq = -1.0\nfn_hz = 100.0\n", r"q must be a number > 0"),
        ("schema = 1\nclip_position = 'middle'\n", r"clip_position must be one of output, proof-mass"),
        ("schema = 1\noverrange_retrigger = 1\n", r"overrange_retrigger must be true or false"),
    ],
)
def test_impossible_sensor_files_are_refused_naming_the_field(tmp_path, body, message):
    """Issue 9: an empty file once acted as an ideal ±2 g sensor, lowpass_order = 400 overflowed,
    fn_hz = 1e9 ran the simulation at a runaway rate."""
    path = tmp_path / "part.toml"
    path.write_text(body, encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        load_sensor(str(path))
