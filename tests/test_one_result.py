"""Issue 31's one result type: ``vrelab.simulate`` and ``vrelab.analyze`` return a ``VreResult``
for one axis and three, read alike (``axes``, ``levels``, ``fits``, ``to_dataframe()``); a
triaxial result adds its ``triaxial`` part; the former ``TriaxialTest`` / ``TriaxialAnalysis``
warn for one release; ``analysis.pipeline``'s three functions take a ``Given`` and their former
keywords alike.

The simulations are short (one level of 2 s): what is checked is the type, the reading and the
documents' shape, not the physics (tests/test_triaxial_sim_test.py and
tests/test_triaxial_analyze_coverage.py hold those)."""

from __future__ import annotations

import warnings

import pytest

import vrelab
from vrelab import Conditions, Estimate, LevelResult, VreResult
from vrelab.triaxial.profile import TriaxialProfile

SENSOR = dict(range_g=2, odr_hz=4000)
EXAMPLE = "examples/campaign/runs/01_z_up_80hz.tdms"
EXAMPLE_UNITS = dict(dut="shaker/sn1_z", reference="shaker/ref", dut_units="lsb", dut_sensitivity=256000,
                     reference_units="mv", reference_sensitivity=10)
# the documents TriaxialTest.to_dict() and TriaxialAnalysis.to_dict() wrote at cd72ec7 (their
# source, src/vrelab/triaxial/simulate.py and analyze.py there): the keys, in order
SIMULATION_KEYS = ["kind", "method", "channels", "triaxial", "provenance"]
SIMULATION_TRIAXIAL_KEYS = ["excitation", "level", "levels_g", "static_vector_g", "conditions", "record"]
ANALYSIS_KEYS = ["kind", "method", "channels", "provenance", "triaxial"]
ANALYSIS_TRIAXIAL_KEYS = ["reference_channels", "segmenting_axis", "level", "levels"]


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> dict[str, VreResult]:
    """Simulated and analysed, one axis and three (one DUT axis, z, and two, x and z)."""
    tmp = tmp_path_factory.mktemp("one-result")
    z = vrelab.load_sensor("adxl355", axis="z", **SENSOR)
    x = vrelab.load_sensor("adxl355", axis="x", **SENSOR)
    tri = TriaxialProfile.along(vrelab.parse_profile("flat:50-1000"), (1, 0, 1))
    one = vrelab.simulate(z, "flat:50-1000", [1.0], 1.0, seconds=2, seed=1)
    three = vrelab.simulate(z, tri, [1.0], (0, 0, 1), seconds=2, seed=1, record_path=tmp / "tri.h5")
    two = vrelab.simulate([x, z], tri, [1.0], (0, 0, 1), seconds=2, seed=1, record_path=tmp / "xz.h5")
    refs = ("reference_x", "reference_y", "reference_z")
    return {
        "simulate one axis": one,
        "simulate triaxial": three,
        "simulate triaxial x, z": two,
        "analyze one axis": vrelab.analyze(EXAMPLE, **EXAMPLE_UNITS),
        "analyze triaxial": vrelab.analyze(tmp / "tri.h5", dut={"z": "dut_z"}, reference=refs),
        "analyze triaxial x, z": vrelab.analyze(tmp / "xz.h5", dut={"x": "dut_x", "z": "dut_z"}, reference=refs),
    }


def test_simulate_and_analyze_return_one_type_read_alike(results):
    core = {"rms_g", "vre_g", "u_vre_g", "vrc_ug_per_g2", "u_vrc_ug_per_g2"}
    for name, result in results.items():
        assert type(result) is VreResult, name
        assert all(type(r) is VreResult and not r.axis_results for r in result.axes.values()), name
        assert result.method in ("random", "sine") and result.kind in ("simulation", "measurement"), name
        if len(result.axes) == 1:  # the one axis's attributes read through: the same objects
            [(axis, own)] = result.axes.items()
            assert result.levels == own.levels and result.fits == own.fits, name
            assert result.conditions == own.conditions and result.warnings == own.warnings, name
            assert result.levels[0].vre.u > 0, name
        columns = set(result.to_dataframe().columns)
        assert columns >= core and ("axis" in columns) == (result.triaxial is not None), name
        per_axis = set().union(*(r.to_dataframe().columns for r in result.axes.values()))
        assert columns - {"axis"} == per_axis, name
    assert list(results["simulate triaxial x, z"].axes) == ["x", "z"]
    assert results["simulate one axis"].axes["z"] is results["simulate one axis"]


def test_several_axes_refuse_one_axis_reading(results):
    both = results["analyze triaxial x, z"]
    for name in ("levels", "fits", "warnings", "conditions", "noise"):
        with pytest.raises(AttributeError, match=r"2 DUT axes \(x, z\): read result.axes\[axis\]"):
            getattr(both, name)
    with pytest.raises(AttributeError, match="reference_levels"):
        both.levels  # noqa: B018
    assert len(both.reference_levels) == 1 and both.triaxial.segmenting_axis in "xz"


def test_triaxial_documents_keep_their_former_shape(results):
    sim = results["simulate triaxial"].to_dict()
    assert list(sim) == SIMULATION_KEYS and list(sim["triaxial"]) == SIMULATION_TRIAXIAL_KEYS
    assert sim["triaxial"]["static_vector_g"] == [0.0, 0.0, 1.0] and sim["triaxial"]["levels_g"] == [1.0]
    assert [c["channel"] for c in sim["channels"]] == ["z"]
    assert sim["channels"][0]["levels"] == results["simulate triaxial"].axes["z"].to_dict()["levels"]
    ana = results["analyze triaxial x, z"].to_dict()
    assert list(ana) == ANALYSIS_KEYS and list(ana["triaxial"]) == ANALYSIS_TRIAXIAL_KEYS
    assert [c["channel"] for c in ana["channels"]] == ["x", "z"] and ana["provenance"] == {}
    assert all("axis_rms_g" in lv for c in ana["channels"] for lv in c["levels"])
    # the single-axis document is the single-axis result's own (no channels, no triaxial part)
    one = results["analyze one axis"].to_dict()
    assert "channels" not in one and "triaxial" not in one and one["levels"]


def test_the_former_classes_and_attributes_warn():
    level = LevelResult(rms_g=1.0, vre=Estimate(1e-4, 3e-5))
    z = VreResult("random", Conditions(axis="z"), (level,))
    with pytest.warns(DeprecationWarning, match="TriaxialTest is deprecated"):
        from vrelab.triaxial.simulate import TriaxialTest
    with pytest.warns(DeprecationWarning, match="TriaxialAnalysis is deprecated"):
        from vrelab.triaxial.analyze import TriaxialAnalysis
    with pytest.warns(DeprecationWarning, match="TriaxialTest is deprecated"):
        test = TriaxialTest("random", TriaxialProfile.along(vrelab.parse_profile("flat:50-1000"), (0, 0, 1)),
                            (1.0,), (0.0, 0.0, 1.0), {"z": z}, {"level": "total"})
    assert isinstance(test, VreResult) and test.levels == (level,) and test.triaxial.conditions == {"level": "total"}
    with pytest.warns(DeprecationWarning, match=r"result.static_g is deprecated .* result.triaxial.static_g"):
        assert test.static_g == (0.0, 0.0, 1.0)
    with pytest.warns(DeprecationWarning, match="TriaxialAnalysis is deprecated"):
        analysis = TriaxialAnalysis((("z", z, None),), (), {"x": "a", "y": "b", "z": "c"}, "z", {"z": "z"})
    with pytest.warns(DeprecationWarning, match="TriaxialAnalysis.levels is deprecated .*: read reference_levels"):
        assert analysis.levels == ()
    with pytest.warns(DeprecationWarning, match="result.channels is deprecated"):
        assert analysis.channels == (("z", z, None),)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert VreResult.of_axes({"z": z}).levels == (level,)  # the one result: no warning


def test_pipeline_takes_given_and_its_former_keywords_alike():
    from vrelab.analysis import open_record
    from vrelab.analysis.pipeline import Given, analyze, analyze_channels, analyze_full
    from vrelab.analysis.readers import Scale

    conditions, provenance = Conditions(sensor="sn1", axis="z"), {"operator": "test"}
    with open_record(EXAMPLE, dut="shaker/sn1_z", reference="shaker/ref", dut_scale=Scale("lsb", 256000),
                     reference_scale=Scale("mv", 10)) as record:
        old = analyze(record, conditions=conditions, provenance=provenance).to_dict()
        new = analyze(record, given=Given(conditions, provenance)).to_dict()
        full = analyze_full(record, given=Given(conditions, provenance))[0].to_dict()
        with pytest.raises(TypeError, match="provenance given twice"):
            analyze(record, given=Given(provenance=provenance), provenance=provenance)
        with pytest.raises(ValueError, match="analyze_channels's"):
            analyze_full(record, given=Given(static_g=1.0))
    for doc in (new, full):
        doc["provenance"].pop("vrelab_version"), old["provenance"].pop("vrelab_version", None)
        assert doc == old
    assert old["conditions"]["sensor"] == "sn1" and old["provenance"]["operator"] == "test"
    with open_record(EXAMPLE, dut={"sn1": "shaker/sn1_z"}, reference="shaker/ref", dut_scale=Scale("lsb", 256000),
                     reference_scale=Scale("mv", 10)) as record:
        [(_, by_keyword, _)] = analyze_channels(record, static_g=1.0, provenance=provenance)
        [(_, by_given, _)] = analyze_channels(record, given=Given(provenance=provenance, static_g=1.0))
    assert by_keyword.to_dict() == by_given.to_dict() and by_given.conditions.static_g == 1.0
