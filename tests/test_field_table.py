"""One sensor-parameter table (issue 21): vrelab.sensor.fields.FIELDS and its views.

Every list of sensor parameters elsewhere (the loader's keys and facts, the identifiable and
assumable parameters, what identify fits, what a sweep point may set, the README block, the
sensor-file writer) is a view of the table: the first test holds each view to its column, the
second adds a row and follows it through every view.
"""

from __future__ import annotations

import math
from importlib import resources

import pytest

from vrelab.sensor import fields, load_sensor, parameters
from vrelab.sensor.fields import FIELDS, Field
from vrelab.sensor.loader import NUMERIC_FIELDS
from vrelab.sensor.writer import file_values, sensor_document, write_sensor_file
from vrelab.sweep import spec as sweep_spec
from vrelab.sweep.points import sensor_for

# What vrelab identify fits today, and the units its JSON gives them: the hand-written table
# vrelab.sensor.parameters held before it became a view of FIELDS (commit 8aa9c98).
# the old hand-written table (sensor/parameters.py at b3d26ac), and the IEEE 1293 terms the
# mount-angle fit adds (identify.fit_cross_coupling: the IP and IO planes; Kpo needs a p-o mount)
FITTED_TODAY = {"k2_ug_per_g2": "ug/g^2", "k3_ug_per_g3": "ug/g^3", "fn_hz": "Hz", "q": "1", "rail_low_g": "g",
                "rail_high_g": "g", "overrange_threshold_g": "g", "kip_ug_per_g2": "ug/g^2",
                "kio_ug_per_g2": "ug/g^2", "kpp_ug_per_g2": "ug/g^2", "koo_ug_per_g2": "ug/g^2"}
TRIAXIAL_K = ("kip_ug_per_g2", "kio_ug_per_g2", "kpp_ug_per_g2", "koo_ug_per_g2", "kpo_ug_per_g2")
CROSS_AXIS = ("cross_axis_x", "cross_axis_y", "cross_axis_z")


def _column(which: str) -> list[str]:
    return [n for f in FIELDS if getattr(f, which) for n in f.parameters]


def test_each_derived_list_is_its_table_column():
    assert list(parameters.TABLE) == _column("identifiable")
    assert list(parameters.PARAMETERS) == _column("fitted")
    assert list(parameters.ASSUMABLE) == _column("assumable")
    assert NUMERIC_FIELDS == ("range_g", "odr_hz") + tuple(
        f.name for f in FIELDS if f.kind in ("positive", "finite", "non_negative", "order", "rails"))
    for kind in ("predict", "simulate"):
        sensor_keys = [k for k in sweep_spec.PARAMS[kind] if k in fields.by_key()]
        assert sensor_keys == [f.key for f in FIELDS if f.sweepable], kind
    # the model kind's closed forms read a subset of the sweepable rows, no row of its own
    assert set(sweep_spec.MODEL_SENSOR_PARAMS) <= {f.key for f in FIELDS if f.sweepable}
    assert set(sweep_spec.PARAMS["model"]) & set(fields.by_key()) == set(sweep_spec.MODEL_SENSOR_PARAMS)
    for name, p in parameters.ASSUMABLE.items():  # each parameter reads its own row
        row = fields.by_key()[p.file_key]
        assert (p.attribute, p.scale, p.rail) == (row.name, row.scale, row.elements.index(name) if row.elements else None)


def test_identify_fits_what_it_fitted_and_the_triaxial_rows_are_marked():
    """identify's list is the fitted column: what it fitted, and the four mount-angle terms."""
    assert {n: parameters.TABLE[n].unit for n in parameters.PARAMETERS} == FITTED_TODAY
    assert parameters.TABLE["k2_ug_per_g2"].text_unit == "µg/g²" and parameters.TABLE["q"].text_unit == ""
    sweepable = {f.key for f in FIELDS if f.sweepable}
    for key in TRIAXIAL_K:
        assert key in parameters.TABLE and (key in parameters.PARAMETERS) == (key != "kpo_ug_per_g2")
        assert key in sweepable
    for key in CROSS_AXIS:
        assert key in parameters.ASSUMABLE and key in sweepable and key not in parameters.TABLE
    assert {"bandwidth_hz", "anti_alias_hz"} <= set(parameters.ASSUMABLE)


def test_every_row_with_a_numeric_default_has_a_default_fact():
    """A preset need not repeat the fact of a value it leaves at its default, so the row gives it."""
    for f in FIELDS:
        if f.kind in fields.NUMERIC_KINDS and f.default is not None:
            assert f.default_fact.startswith("assumption"), f.key


def _patched_row() -> tuple[Field, ...]:
    """The table with a new row: the drift in µg/s under a new file key (the same attribute)."""
    new = Field("drift_ug_per_s", "drift_g_per_s", "finite", 0.0, "slow output drift [µg/s]", scale=1e6,
                identifiable=True, sweepable=True, assumable=True, default_fact="assumption: no drift (new row)")
    return tuple(new if f.key == "drift_g_per_s" else f for f in FIELDS)


def test_a_new_row_reaches_the_loader_readme_sweep_parameters_and_writer(monkeypatch, tmp_path):
    monkeypatch.setattr(fields, "FIELDS", _patched_row())
    part = tmp_path / "part.toml"
    part.write_text('schema = 1\nname = "part"\ndrift_ug_per_s = 5.0\n[uncertainty]\ndrift_ug_per_s = 0.5\n'
                    '[facts]\ndrift_ug_per_s = "datasheet: 5 µg/s"\n', encoding="utf-8")
    s = load_sensor(str(part))  # the loader: the key parses into the Sensor, with its facts and u
    assert s.drift_g_per_s == pytest.approx(5e-6, rel=1e-12)
    assert s.facts["drift_g_per_s"] == "datasheet: 5 µg/s" and s.uncertainty == {"drift_ug_per_s": 0.5}
    assert load_sensor("ideal").facts["drift_g_per_s"] != "assumption: no drift (new row)"  # the preset marks it
    bare = tmp_path / "bare.toml"
    bare.write_text('schema = 1\nname = "bare"\n', encoding="utf-8")
    assert load_sensor(str(bare)).facts["drift_g_per_s"] == "assumption: no drift (new row)"
    with pytest.raises(ValueError, match="unknown key 'drift_g_per_s'"):  # the old key is gone with its row
        part.write_text('schema = 1\nname = "part"\ndrift_g_per_s = 5.0\n', encoding="utf-8")
        load_sensor(str(part))
    # the README block
    assert "drift_ug_per_s" in fields.schema_text() and "drift_g_per_s " not in fields.schema_text()
    # the parameters
    assert parameters.parameter(s, "drift_ug_per_s") == pytest.approx(5.0)
    assert parameters.with_parameters(s, {"drift_ug_per_s": 2.0}).drift_g_per_s == pytest.approx(2e-6)
    assert "drift_ug_per_s" in parameters.identifiable()
    # the sweep: its list, its check, and the point's sensor
    assert "drift_ug_per_s" in sweep_spec.params_for("predict")
    sp = sweep_spec.parse_spec({"kind": "predict", "fixed": {"sensor": "ideal", "freq_hz": 100.0},
                                "grid": {"rms_g": [1.0], "drift_ug_per_s": [1.0, 3.0]}})
    assert sp.shape == (1, 2)
    assert sensor_for({"sensor": "ideal", "drift_ug_per_s": 3.0}).drift_g_per_s == pytest.approx(3e-6)
    # the writer
    assert file_values({"drift_ug_per_s": 1.5}) == {"drift_ug_per_s": 1.5}
    assert sensor_document(s)["drift_ug_per_s"] == pytest.approx(5.0)


def test_readme_block_is_the_table_and_names_no_parameter_list_of_its_own():
    text = (resources.files("vrelab.sensor") / "presets" / "README").read_text("utf-8")
    assert fields.schema_text() in text
    # the [uncertainty] prose refers to the table's u flag instead of a copy of the names
    assert "anti_alias_hz (e.g." not in text and "flagged u below" in text


def test_user_values_replace_the_files_estimates(tmp_path):
    """load_sensor's overrides (--k2/--k3, a sweep point): the value wins, its facts say so, and the
    file's covariance and assumed u of that parameter go (they were about another value)."""
    f = tmp_path / "ident.toml"
    f.write_text(
        'schema = 1\nname = "ident"\nfn_hz = 2400.0\nq = 7.4\nk2_ug_per_g2 = 20.0\nanti_alias_hz = 1500.0\n'
        "[uncertainty]\nanti_alias_hz = 100.0\n"
        "[axes.sn1]\n[axes.sn1.uncertainty]\ncross_axis_y = 0.005\n"
        '[axes.sn1.covariance]\nparams = ["fn_hz", "q", "k2_ug_per_g2"]\n'
        "matrix = [[100.0, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 4.0]]\n", encoding="utf-8")
    base = load_sensor(str(f), axis="sn1")
    assert base.covariance is not None and base.covariance["params"] == ["fn_hz", "q", "k2_ug_per_g2"]
    s = sensor_for({"sensor": str(f), "axis": "sn1", "fn_hz": 2000.0, "cross_axis_y": 0.01, "kip_ug_per_g2": 30.0})
    assert (s.fn_hz, s.q, s.cross_axis_y) == (2000.0, 7.4, 0.01) and s.kip_per_g == pytest.approx(30e-6)
    assert s.covariance == {"params": ["q", "k2_ug_per_g2"], "matrix": [[0.04, 0.0], [0.0, 4.0]]}
    assert s.uncertainty == {"anti_alias_hz": 100.0}
    assert s.facts["fn_hz"] == "set by the user: 2000 Hz" and s.facts["kip_per_g"] == "set by the user: 30 µg/g²"
    with pytest.raises(ValueError, match="unknown key 'kip_per_g'"):
        load_sensor("ideal", overrides={"kip_per_g": 1.0})
    with pytest.raises(ValueError, match="cross_axis_x must be at most 0.5"):
        load_sensor("ideal", axis="y", overrides={"cross_axis_x": 0.7})


@pytest.mark.parametrize("name, axis", [("ideal", None), ("adxl355", "z"), ("adxl354", "y"), ("adxl357", None)])
def test_sensor_document_writes_a_sensor_that_loads_back(tmp_path, name, axis):
    s = load_sensor(name, axis=axis)
    back = load_sensor(str(write_sensor_file(tmp_path / "s.toml", sensor_document(s))))
    for f in FIELDS:
        a, b = getattr(s, f.name), getattr(back, f.name)
        if isinstance(a, float):
            assert math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300), f.name
        else:
            assert a == b, f.name
    assert (back.range_g, back.axis, back.odr_hz, back.uncertainty) == (s.range_g, s.axis, s.odr_hz, s.uncertainty)
    assert dict(back.facts) == dict(s.facts)


def test_the_writer_leaves_nothing_when_the_document_does_not_load(tmp_path):
    doc = sensor_document(load_sensor("ideal"))
    bad = {**doc, "q": 2.0}  # a Q without its resonance
    with pytest.raises(ValueError, match="fn_hz and q must be given together"):
        write_sensor_file(tmp_path / "s.toml", bad)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="both rails"):
        file_values({"rail_low_g": -2.0})


def test_the_views_follow_the_table_back_after_a_patch():
    """The views are of the table in place at the call (run after the patched test: its row is gone)."""
    assert "drift_ug_per_s" not in parameters.identifiable() and "drift_g_per_s" in fields.by_key()
    assert load_sensor("ideal").drift_g_per_s == 0.0


def test_a_covariance_may_name_every_identifiable_parameter_and_no_other(tmp_path):
    """Kip is identifiable (a mount-angle campaign's covariance may carry it) though identify does
    not fit it yet; a cross-axis sensitivity is only assumable: no covariance names it."""
    f = tmp_path / "ident.toml"
    body = ('schema = 1\nname = "ident"\n[axes.x.covariance]\nparams = ["{p}"]\nmatrix = [[4.0]]\n')
    f.write_text(body.replace("{p}", "kip_ug_per_g2"), encoding="utf-8")
    assert load_sensor(str(f)).covariance == {"params": ["kip_ug_per_g2"], "matrix": [[4.0]]}
    f.write_text(body.replace("{p}", "cross_axis_y"), encoding="utf-8")
    with pytest.raises(ValueError, match="params must be distinct names of"):
        load_sensor(str(f))
