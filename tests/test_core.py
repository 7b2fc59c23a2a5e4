"""The shared core: result objects, the record boundary, atomic outputs, the CLI's error rule."""

import json
import math

import h5py
import numpy as np
import pytest

from vrelab import _io
from vrelab.cli import main
from vrelab.record import ArrayRecord, Schedule, Segment, write_record_hdf5
from vrelab.results import ClipModel, Conditions, Estimate, FitResult, LevelResult, VrcModel, VreResult


def _result() -> VreResult:
    lv = (
        LevelResult(rms_g=0.5, vre=Estimate(-1e-4, 2e-5), n_samples=4000),
        LevelResult(rms_g=1.0, vre=Estimate(-0.083, 0.001), n_saturated=12, flags=("saturated",)),
    )
    fits = (
        FitResult(ClipModel({"rail_g": Estimate(2.5, 0.05, "g")}), n_points=2, departure_rms_g=None),
        FitResult(VrcModel({"vrc_ug_per_g2": Estimate(-400.0, 80.0, "ug/g^2")}), n_points=1, chi2_reduced=math.nan),
    )
    return VreResult("random", Conditions(sensor="ideal", static_g=1.0, range_g=2.0), lv, fits, ("x",))


def test_result_dict_has_the_cli_contract_keys_and_round_trips():
    d = _result().to_dict()
    json.dumps(d, allow_nan=False)  # NaN must already be None: JSON has no NaN
    assert [set(x) >= {"rms_g", "vre_g", "u_vre_g"} for x in d["levels"]] == [True, True]
    assert d["fit"]["rail_g"] == {"value": 2.5, "u": 0.05, "unit": "g"}
    assert d["fit"]["vrc_ug_per_g2"]["value"] == -400.0
    assert d["fits"][1]["chi2_reduced"] is None
    back = VreResult.from_dict(json.loads(json.dumps(d)))
    assert back.to_dict() == d


def test_estimate_prints_value_and_uncertainty_in_mg():
    assert str(Estimate(-0.0831, 0.0004)) == "-83.10 ± 0.40 mg"  # GUM 7.2.6: u to two significant digits


def test_schedule_rejects_overlap_and_bad_segments(tmp_path):
    with pytest.raises(ValueError, match="overlap"):
        Schedule((Segment(0, 2, 0), Segment(1, 3, 1.0)))
    with pytest.raises(ValueError, match="start_s"):
        Segment(2, 1, 0)
    with pytest.raises(ValueError, match="nominal_rms_g"):
        Segment(0, 1, -1)
    p = tmp_path / "s.csv"
    s = Schedule((Segment(0, 2, 0), Segment(2.5, 5, 1.0, 100.0)))
    s.write_csv(p)
    assert Schedule.read_csv(p) == s
    p.write_text("start,end,level\n0,1,zero\n")
    with pytest.raises(ValueError, match="line 2"):
        Schedule.read_csv(p)


def test_hdf5_record_streams_blocks_and_is_complete_or_absent(tmp_path):
    rng = np.random.default_rng(1)
    x = rng.normal(size=10_001)
    rec = ArrayRecord({"reference": x, "dut": 2 * x}, fs_hz=1000.0)
    path = tmp_path / "r.h5"
    sched = Schedule((Segment(0, 5, 0), Segment(5, 10, 1.0)))
    n = write_record_hdf5(path, 1000.0, rec.blocks(4096, ("reference", "dut")), sched, {"sensor": "ideal"})
    assert n == x.size
    with h5py.File(path) as f:
        np.testing.assert_array_equal(f["dut"][:], 2 * x)
        assert f.attrs["fs_hz"] == 1000.0
        assert Schedule.from_array(f["schedule"][:]) == sched

    def failing():
        yield {"dut": x[:10]}
        raise RuntimeError("disk gone")

    bad = tmp_path / "bad.h5"
    with pytest.raises(RuntimeError):
        write_record_hdf5(bad, 1000.0, failing())
    assert list(tmp_path.iterdir()) == [path]


def test_array_record_rejects_mismatched_channels():
    with pytest.raises(ValueError, match="mismatched"):
        ArrayRecord({"a": np.zeros(3), "b": np.zeros(4)}, fs_hz=10.0)


def test_output_dir_writes_nothing_when_the_job_fails(tmp_path):
    dest = tmp_path / "out"
    with pytest.raises(RuntimeError):
        with _io.output_dir(dest) as stage:
            (stage / "results.json").write_text("{}")
            raise RuntimeError("boom")
    assert not dest.exists()
    assert [p.name for p in tmp_path.iterdir()] == []
    with _io.output_dir(dest) as stage:
        _io.write_json(stage / "results.json", {"a": 1})
    assert json.loads((dest / "results.json").read_text()) == {"a": 1}


def test_cli_usage_errors_are_one_line_with_status_2(capsys):
    assert main(["no-such-command"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and "invalid choice" in err
