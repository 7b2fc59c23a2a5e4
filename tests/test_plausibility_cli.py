"""SPEC 4.2 end to end on records with a known truth: the slips labs make are refused with what
was found, and the same records reduce normally when given right (issue 9's table)."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from vrelab.cli import main


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """A random and a sine test of the ADXL355 (Z, ±2 g, 1 g field), simulated and written as lab
    files (HDF5), plus the random one with its reference in mV at 10 mV/g."""
    from vrelab.profiles import RandomProfile
    from vrelab.sensor import load_sensor
    from vrelab.shaker import run_random_test, run_sine_test

    d = tmp_path_factory.mktemp("plaus")
    sensor = load_sensor("adxl355", axis="z")
    run_random_test(sensor, RandomProfile.flat(50.0, 2000.0), [0.5, 1.0, 1.5], seconds=3.0, seed=3,
                    record_path=d / "random.h5")
    run_sine_test(sensor, [160.0], [0.3, 0.6], seconds=3.0, seed=4, record_path=d / "sine.h5")
    with h5py.File(d / "random.h5") as f, h5py.File(d / "random_mv.h5", "w") as g:
        g["dut"] = f["dut"][:]
        g["reference"] = f["reference"][:] * 10.0  # 10 mV/g, written in mV
        g.attrs["fs_hz"] = f.attrs.get("fs_hz", f["dut"].attrs.get("fs_hz"))
    return d


def _run(capsys, argv):
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


def test_reference_in_mv_without_its_units_is_refused_naming_the_ratio(records, capsys):
    """Issue 9: levels came out 10× too large with a 23.7 g "rail", exit 0."""
    rc, out, err = _run(capsys, ["analyze", str(records / "random_mv.h5"), "--dut", "dut", "--reference", "reference"])
    assert rc == 2 and len(err.strip().splitlines()) == 1
    import re

    factor = float(re.search(r"factor of ([0-9.]+)", err).group(1))
    assert factor == pytest.approx(0.1, rel=0.15)  # 1/10 (mV at 10 mV/g), times the DUT's response
    assert "--reference-units" in err and "--accept-unit-ratio" in err
    rc, out, _ = _run(capsys, ["analyze", str(records / "random_mv.h5"), "--dut", "dut", "--reference", "reference",
                               "--reference-units", "mv", "--reference-sensitivity", "10", "--json"])
    assert rc == 0
    assert [lv["rms_g"] for lv in json.loads(out)["levels"]] == pytest.approx([0.5, 1.0, 1.5], rel=0.03)


def test_swapped_channels_are_refused(records, capsys):
    """Issue 9: --dut ref --reference dut gave VRE ≈ 0 and rail_g = 17.73 ± inf, exit 0."""
    rc, out, err = _run(capsys, ["analyze", str(records / "random.h5"), "--dut", "reference", "--reference", "dut"])
    assert rc == 2 and "swapped" in err and "--accept-channels" in err


def test_sine_method_on_a_random_record_is_refused_with_what_was_found(records, capsys):
    """Issue 9: --method sine on a random record invented tones (952/289/906 Hz), exit 0."""
    rc, out, err = _run(capsys, ["analyze", str(records / "random.h5"), "--dut", "dut", "--reference", "reference",
                                 "--method", "sine"])
    assert rc == 2 and "--method sine does not fit the record" in err and "broadband" in err


def test_sine_record_with_the_default_method_is_reduced_as_sine(records, capsys):
    """Issue 9: the default method (random) once gave 2400 Hz levels at 3e-13 g rms; auto finds
    the 160 Hz sine and reduces it as the explicit sine method does."""
    rc, out, _ = _run(capsys, ["analyze", str(records / "sine.h5"), "--dut", "dut", "--reference", "reference",
                               "--json"])
    assert rc == 0
    auto = json.loads(out)
    rc, out, _ = _run(capsys, ["analyze", str(records / "sine.h5"), "--dut", "dut", "--reference", "reference",
                               "--method", "sine", "--json"])
    explicit = json.loads(out)
    assert auto["method"] == "sine" and [lv["freq_hz"] for lv in auto["levels"]] == pytest.approx([160.0] * 2, rel=1e-6)
    assert [lv["rms_g"] for lv in auto["levels"]] == pytest.approx([0.3, 0.6], rel=0.01)
    assert [lv["vre_g"] for lv in auto["levels"]] == [lv["vre_g"] for lv in explicit["levels"]]


def test_right_records_pass_every_check(records, capsys):
    """The checks must not trip on a correct record: random and sine, auto and explicit."""
    for name, method in (("random.h5", "random"), ("random.h5", "auto"), ("sine.h5", "auto")):
        rc, out, err = _run(capsys, ["analyze", str(records / name), "--dut", "dut", "--reference", "reference",
                                     "--method", method, "--json"])
        assert rc == 0, err
        assert np.isfinite([lv["vre_g"] for lv in json.loads(out)["levels"]]).all()


def test_a_static_field_beyond_the_range_gives_no_plain_number(capsys):
    """Issue 9: `simulate --static 5` on the ±2 g range printed "VRE -40.5 ± 3.1 mg". The DUT sits
    on its +2.048 g rail with the vibration off, so VRE is undefined: each level is flagged
    baseline-off-scale and its VRE is null, with a notice saying why."""
    rc, out, _ = _run(capsys, ["simulate", "--sensor", "adxl355", "--profile", "flat:50-2000", "--levels", "0.5,1",
                               "--static", "5", "--json"])
    assert rc == 0
    d = json.loads(out)
    assert all(lv["vre_g"] is None and "baseline-off-scale" in lv["flags"] for lv in d["levels"])
    assert any(n["code"] == "baseline-off-scale" for n in d["notices"])
    # the same sensor at +1 g gives plain numbers
    rc, out, _ = _run(capsys, ["simulate", "--sensor", "adxl355", "--profile", "flat:50-2000", "--levels", "0.5,1",
                               "--json"])
    assert all(lv["vre_g"] is not None and "baseline-off-scale" not in lv["flags"] for lv in json.loads(out)["levels"])
