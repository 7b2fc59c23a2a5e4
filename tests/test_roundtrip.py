"""Round trips: simulated records with offset, drift, noise and ramps, reduced as lab files.

Issue "Analysis of recorded shaker tests", What must hold: "the simulator's records (random
and sine methods, with offset, drift, noise and ramps added) are reduced to the per-level VRE
the simulator knows, within the reported uncertainty, and the fits recover the VRC and the rail
within their standard errors." SPEC 4 (the test station): automatic segmentation from the rms
envelope, settling trimmed at each edge, baseline drift removed by bracketing, a standard
uncertainty on every VRE, fits with standard errors.

Each record is written with ``record_path`` and read back by ``vrelab analyze`` (through
:func:`vrelab.cli.main`) with ``--schedule auto``: the record's embedded schedule is ignored
and the segments come from the reference's envelope, ramps included. Seeds are fixed.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from vrelab import shaker
from vrelab.cli import main
from vrelab.profiles import RandomProfile
from vrelab.sensor import load_sensor

PROFILE = RandomProfile.flat(50.0, 2000.0)  # the article's random profile (SPEC 3)
# ADXL355 data sheet (Rev. D; SPEC 2): 0 g offset ±25 mg typical.
OFFSET_G = 0.025
# Bias drift: an assumption (warm-up, temperature), 0.2 mg/s: 8 mg over a 40 s record.
DRIFT_G_PER_S = 0.2e-3
RAMP_S = 0.5


def test_drift_stage_is_a_ramp_in_time_whatever_the_block_size():
    """The sensor's drift (issue round trips: "with offset, drift, ..."): y[n] = x[n] + r·n/fs,
    the same for any block size (blocks of 1000 and of 777 samples against the closed form),
    and added by Sensor.chain only when drift_g_per_s is set (default 0: the chain unchanged),
    after the offset and before the output rails."""
    from vrelab.sensor import Drift, SensorChain

    fs, rate = 1000.0, 2e-4
    x = np.random.default_rng(3).standard_normal(5000)
    expected = x + rate * np.arange(x.size) / fs
    chain = SensorChain((Drift(rate),))
    for block in (1000, 777):
        y, _ = chain.apply(x, fs, block_size=block)
        np.testing.assert_allclose(y, expected, rtol=0, atol=1e-15)
    ideal = load_sensor("ideal")
    assert ideal.drift_g_per_s == 0.0 and not any(isinstance(st, Drift) for st in ideal.chain(fs).stages)
    # offset and drift sit before the output rails, as a bias of the part does
    assert [type(st).__name__ for st in _disturbed(ideal).chain(fs).stages] == ["Offset", "Drift", "Clip"]
    with pytest.raises(ValueError, match="Drift rate_g_per_s must be finite"):
        Drift(float("nan"))


def _analyze(capsys, path, *extra: str) -> dict:
    rc = main(["analyze", str(path), "--dut", "dut", "--reference", "reference", "--schedule", "auto",
               "--json", *extra])
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out)


def _disturbed(sensor, offset_g: float = OFFSET_G, drift_g_per_s: float = DRIFT_G_PER_S):
    return dataclasses.replace(sensor, offset_g=offset_g, drift_g_per_s=drift_g_per_s)


# ADXL355 Z axis at 1 g: levels up to 0.25 g rms keep their 4σ peaks inside the ±2.048 g rails
# (vrelab.fits.vrc_level_limit_g at the nominal ±2.048 g: 0.262 g); 1 and 1.5 g rms clip.
CLEAR_LEVELS = [0.1, 0.25]
CLIPPING_LEVELS = [1.0, 1.5]
RANDOM_KW = dict(static_g=1.0, seconds=3.0, baseline_s=2.0, seed=21, ramp_s=RAMP_S)


@pytest.fixture(scope="module")
def adxl355_random(tmp_path_factory):
    """(record path, known-schedule result of that record, clean result: same seed, no offset/drift)."""
    levels = CLEAR_LEVELS + CLIPPING_LEVELS
    sensor = load_sensor("adxl355", range_g=2, axis="z")
    path = tmp_path_factory.mktemp("roundtrip") / "record.h5"
    known = shaker.run_random_test(_disturbed(sensor), PROFILE, levels, record_path=path, **RANDOM_KW)
    clean = shaker.run_random_test(sensor, PROFILE, levels, **RANDOM_KW)
    return path, known, clean


def test_random_adxl355_with_offset_drift_noise_ramps_auto_segmented_gives_the_known_vre(adxl355_random, capsys):
    """Issue "Analysis of recorded shaker tests" (round trips), SPEC 4: ADXL355 ±2 g, Z axis
    (its data-sheet noise in the chain), 1 g field, random 50 Hz-2 kHz at 0.1, 0.25, 1 and
    1.5 g rms, 0.5 s raised-cosine ramps, 25 mg offset (data-sheet typical) and 0.2 mg/s drift.
    `vrelab analyze --schedule auto` on the written record finds the four levels; each level's
    rms is within 1 % of the simulator's and its VRE within 3 combined standard uncertainties of

    * the simulator's own VRE for the same seed without offset and drift, at the levels clear of
      the rails (at the clipping levels the offset, which sits before the output rails as in the
      part, moves the rail margin by 25 mg and so the VRE itself: physics, not a reduction error);
    * the simulator's reduction of the same record with its known schedule, at every level."""
    path, known, clean = adxl355_random
    got = _analyze(capsys, path, "--band", "25:4000")
    assert not any("embedded in the record" in w for w in got["warnings"])
    levels = got["levels"]
    assert len(levels) == len(CLEAR_LEVELS) + len(CLIPPING_LEVELS)
    for i, (a, k, c) in enumerate(zip(levels, known.levels, clean.levels)):
        assert a["rms_g"] == pytest.approx(c.rms_g, rel=0.01)
        u_known = math.hypot(a["u_vre_g"], k.vre.u)
        assert abs(a["vre_g"] - k.vre.value) < 3 * u_known, (a, k.vre)
        if i < len(CLEAR_LEVELS):
            u_clean = math.hypot(a["u_vre_g"], c.vre.u)
            assert abs(a["vre_g"] - c.vre.value) < 3 * u_clean, (a, c.vre)
            # the check has teeth: the drift between the bracketing baselines' centres (5 s
            # apart) is 1 mg, far beyond the tolerance
            assert 3 * u_clean < 0.1 * DRIFT_G_PER_S * 5.0


def test_drift_is_removed_by_bracketing_not_by_the_nearest_baseline(adxl355_random):
    """SPEC 4 (baseline drift removed by bracketing each level between off-segments): the same
    record reduced against its first baseline only (the nearest-baseline fall-back) is biased by
    the drift accumulated since that baseline, drift·Δt, at 0.2 mg/s: 1.5 mg and more, while the
    bracketed VRE of the levels clear of the rails matches the clean run (previous test)."""
    from vrelab.analysis import ReductionOptions, open_record, reduce_record
    from vrelab.record import Schedule

    path, known, _ = adxl355_random
    with open_record(path, dut="dut", reference="reference") as rec:
        segs = rec.schedule.segments
        first_only = Schedule((segs[0],) + tuple(s for s in segs if not s.is_baseline))
        t_base = (segs[0].start_s + segs[0].end_s) / 2
        t_levels = [(s.start_s + s.end_s) / 2 for s in segs if not s.is_baseline]
        levels, warnings = reduce_record(rec, schedule=first_only, options=ReductionOptions(band_hz=(25.0, 4000.0)))
    assert any("nearest baseline used" in w for w in warnings)
    for lv, k, t in zip(levels[: len(CLEAR_LEVELS)], known.levels, t_levels):
        bias = lv.vre.value - k.vre.value
        expected = DRIFT_G_PER_S * (t - t_base)
        assert bias == pytest.approx(expected, rel=0.05)
        assert abs(bias) > 10 * k.vre.u  # the bias a single baseline leaves is far beyond u


def test_rail_recovered_from_auto_segmented_record_with_offset_drift_ramps(tmp_path, capsys):
    """Issue "Analysis of recorded shaker tests" (fits recover the rail), SPEC 1.1 and 4: the
    `ideal` sensor with rails at ±2 g at its output, 1 g field, random levels in the clipping
    regime (0.4-1.2 g rms), 25 mg offset and 0.2 mg/s drift before the rails, 0.5 s ramps.
    The censored-model rail fit of `vrelab analyze --schedule auto` (static field from the
    baselines) recovers 2.0 g within 3 standard errors."""
    sensor = _disturbed(load_sensor("ideal", range_g=2))
    path = tmp_path / "record.h5"
    shaker.run_random_test(sensor, PROFILE, [0.4, 0.6, 0.8, 1.0, 1.2], static_g=1.0, seconds=3.0,
                           baseline_s=2.0, seed=22, ramp_s=RAMP_S, record_path=path)
    got = _analyze(capsys, path, "--band", "25:4000")
    assert len(got["levels"]) == 5
    rail = next(f for f in got["fits"] if f["model"] == "clip-censored")
    value, se = rail["parameters"]["rail_g"]["value"], rail["parameters"]["rail_g"]["u"]
    assert abs(value - 2.0) < 3 * se, rail
    assert se < 0.02  # the check has teeth


def test_vrc_recovered_from_sine_record_with_offset_drift_ramps_ieee1293(tmp_path, capsys):
    """Issue "Analysis of recorded shaker tests" (fits recover the VRC), SPEC 1.2 and 4, IEEE
    Std 1293-1998 sine method: the `ideal` sensor (no resonance, |H| = 1) with k2 = 1000 µg/g²
    at g0 = 0 (VRC = k2), 20 µg/√Hz white noise, 25 mg offset, 0.2 mg/s drift, 0.5 s ramps;
    sine at 200 Hz, 0.2-0.8 g rms, well inside the ±2 g rails. `vrelab analyze --method sine
    --schedule auto` recovers VRC = 1000 µg/g² within 3 standard errors."""
    k2 = 1000.0
    sensor = _disturbed(dataclasses.replace(load_sensor("ideal", range_g=2, k2_ug_per_g2=k2), noise_ug_per_rthz=20.0))
    path = tmp_path / "record.h5"
    shaker.run_sine_test(sensor, [200.0], [0.2, 0.4, 0.6, 0.8], static_g=0.0, seconds=3.0, baseline_s=2.0,
                         seed=23, ramp_s=RAMP_S, record_path=path)
    got = _analyze(capsys, path, "--method", "sine")
    assert len(got["levels"]) == 4
    vrc = next(f for f in got["fits"] if f["model"] == "vrc")
    value, se = vrc["parameters"]["vrc_ug_per_g2"]["value"], vrc["parameters"]["vrc_ug_per_g2"]["u"]
    assert abs(value - k2) < 3 * se, vrc
    assert se < 0.05 * k2  # the check has teeth


def test_simulate_ramp_and_drift_options_round_trip_through_analyze(tmp_path, capsys):
    """Issue "Analysis of recorded shaker tests" (round trips), SPEC 4 and 5: `vrelab simulate
    --ramp 0.5 --drift 0.0002 --record` writes a record whose schedule leaves the ramps out
    (each level segment 0.5 s after the previous baseline ends), and `vrelab analyze
    --schedule auto` on it finds the same levels: rms within 1 % and VRE within 3 combined
    standard uncertainties of the simulation's. A negative ramp exits 2 with one line."""
    from vrelab.analysis import open_record

    out_dir = tmp_path / "sim"
    rc = main(["simulate", "--sensor", "ideal", "--k2", "1000", "--static", "0", "--profile", "flat:50-2000",
               "--levels", "0.3,0.6", "--seconds", "2", "--ramp", "0.5", "--drift", "0.0002", "--seed", "5",
               "--out", str(out_dir), "--record", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    sim = json.loads(out)
    assert sim["conditions"]["extra"]["ramp_s"] == pytest.approx(0.5)
    with open_record(out_dir / "record.h5", dut="dut", reference="reference") as rec:
        segs = rec.schedule.segments
    assert [s.nominal_rms_g for s in segs] == [0.0, 0.3, 0.0, 0.6, 0.0]
    for before, level, after in zip(segs[0::2], segs[1::2], segs[2::2]):
        assert level.start_s - before.end_s == pytest.approx(RAMP_S)
        assert after.start_s - level.end_s == pytest.approx(RAMP_S)
    got = _analyze(capsys, out_dir / "record.h5", "--band", "25:4000")
    assert len(got["levels"]) == 2
    for a, s in zip(got["levels"], sim["levels"]):
        assert a["rms_g"] == pytest.approx(s["rms_g"], rel=0.01)
        assert abs(a["vre_g"] - s["vre_g"]) < 3 * math.hypot(a["u_vre_g"], s["u_vre_g"])
    rc = main(["simulate", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1", "--ramp", "-1"])
    out, err = capsys.readouterr()
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--ramp" in err, err
