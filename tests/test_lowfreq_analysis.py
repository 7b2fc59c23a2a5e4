"""Lab records of low-frequency environments analyse (issue 32): 2 s vibration-off baselines
between random levels from 5, 8 and 10 Hz and of the MIL-STD-810H common-carrier vertical
shape, read from a CSV file (no plan: the schedule found from the record), each VRE within its
U of the known truth; a baseline too short to average is refused in one line.

Before the fix these records were refused ("no vibration-off baseline in the record"): a band
from f1 below 20 Hz gives the first pass windows of 2/f1 (vrelab.record.window_seconds: 0.4 s
from 5 Hz), and a 2 s baseline trimmed by 0.5 s at each edge held one or two whole windows,
fewer than the 3 a baseline is averaged over. A baseline has no vibration to resolve; it is now
averaged over 0.1 s windows of its own samples (vrelab.analysis.baseline_windows).

The truth is made with numpy alone: the reference is Gaussian noise shaped in the frequency
domain to the environment's PSD (flat from f1 to 500 Hz, or MIL-STD-810H Method 514.8 Annex C
common carrier vertical: 0.015 g²/Hz from 5 to 40 Hz, then log-log to 0.00015 g²/Hz at
500 Hz), scaled to each level's rms; the DUT reads the reference, a static 1 g with an offset
and a slow drift, white noise, and during each plateau (not its ramps) a known offset shift
(the VRE). Records are short (22 s) and every seed fixed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vrelab.analysis import open_record, reduce
from vrelab.analysis.options import ReductionOptions
from vrelab.cli import main
from vrelab.record import ArrayRecord, Schedule, Segment

FS = 2000.0
LEVELS_G = (0.6, 1.2)
VRE_G = (-0.4e-3, 1.1e-3)  # the known offset shift of each level (a VRE of either sign)
NOISE_G = 2e-4  # the DUT's white noise per sample
DRIFT_G_PER_S = 2e-5
REF_NOISE_G = 1e-3  # the reference accelerometer's own noise (the DUT does not read it)


def psd_shape(kind: str, f: np.ndarray) -> np.ndarray:
    """The environment's PSD shape (any scale): "mil" or a flat band from ``kind`` Hz to 500 Hz."""
    if kind == "mil":
        slope = np.log(0.00015 / 0.015) / np.log(500.0 / 40.0)  # -5.5 dB/octave
        p = np.where(f <= 40.0, 0.015, 0.015 * (np.maximum(f, 1e-9) / 40.0) ** slope)
        return np.where((f >= 5.0) & (f <= 500.0), p, 0.0)
    return np.where((f >= float(kind)) & (f <= 500.0), 1.0, 0.0)


def lab_record(path: Path, kind: str, seed: int, t_off_s: float = 2.0, t_on_s: float = 6.0) -> None:
    """Write a lab record (time, ref, adxl columns; see the module docstring) to ``path``."""
    rng = np.random.default_rng(seed)

    def vib(n: int, rms: float) -> np.ndarray:
        m = n + 4096  # a longer draw cut to n: no wrap-around of the circular shaping
        x = np.fft.irfft(np.fft.rfft(rng.standard_normal(m)) * np.sqrt(psd_shape(kind, np.fft.rfftfreq(m, 1 / FS))), m)
        return x[:n] / x[:n].std() * rms

    ref, shift = [np.zeros(int(t_off_s * FS))], [np.zeros(int(t_off_s * FS))]
    n_ramp, n_on = int(0.5 * FS), int(t_on_s * FS)
    for rms, vre in zip(LEVELS_G, VRE_G):
        ref += [vib(n_ramp, rms) * np.linspace(0, 1, n_ramp), vib(n_on, rms), vib(n_ramp, rms) * np.linspace(1, 0, n_ramp),
                np.zeros(int(t_off_s * FS))]
        shift += [np.zeros(n_ramp), np.full(n_on, vre), np.zeros(n_ramp), np.zeros(int(t_off_s * FS))]
    r, s = np.concatenate(ref), np.concatenate(shift)
    t = np.arange(len(r)) / FS
    dut = 1.012 + DRIFT_G_PER_S * t + NOISE_G * rng.standard_normal(len(r)) + s + r
    r = r + REF_NOISE_G * rng.standard_normal(len(r))
    np.savetxt(path, np.column_stack([t, r, dut]), delimiter=",", header="time,ref,adxl", comments="", fmt="%.12g")


PROFILES = {"5": "flat:5-500", "8": "flat:8-500", "10": "flat:10-500", "mil": "mil-std-810h-common-carrier-vertical"}


@pytest.mark.parametrize("kind", ["5", "8", "10", "mil"])
@pytest.mark.parametrize("seed", [1, 2])
def test_low_frequency_lab_record_analyses_each_vre_within_its_U(kind: str, seed: int, tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "rec.csv"
    lab_record(path, kind, seed)
    # over the band the simulator reduces its own records over (the environment's widened by an
    # octave each side, vrelab.simulation.plan.measurement_band: windows of 0.4 to 0.8 s)
    # and over the environment's own band (--profile)
    f1 = 5.0 if kind == "mil" else float(kind)
    for extra in (["--band", f"{f1 / 2:g}:1000"], ["--profile", PROFILES[kind]]):
        rc = main(["analyze", str(path), "--dut", "adxl", "--reference", "ref", "--dut-units", "g",
                   "--reference-units", "g", "--method", "random", "--json", *extra])
        out = capsys.readouterr()
        assert rc == 0, (extra, out.err)
        levels = json.loads(out.out)["levels"]
        assert len(levels) == len(LEVELS_G), extra
        for lv, rms, vre in zip(levels, LEVELS_G, VRE_G):
            # the level measured is the one made: 6 s of noise from f1 (a few thousand degrees of
            # freedom) and the reference's noise (1 mg against 0.6 g) move it well under 10 %
            assert lv["rms_g"] == pytest.approx(rms, rel=0.1), extra
            # U: the reduction's expanded uncertainty at 95 % (k from the level's own degrees of
            # freedom); two seeds × four shapes × two bands × two levels: 32 claims at 95 %,
            # each seed fixed (measured: none outside)
            assert abs(lv["vre_g"] - vre) <= lv["U_vre_g"], (extra, lv["vre_g"], vre, lv["U_vre_g"])


def test_a_baseline_too_short_to_average_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "rec.csv"
    lab_record(path, "5", 3)
    # the user's schedule: the record's true plateaus, its baselines cut to 0.5 s; trimmed by
    # a quarter (0.125 s) at each edge they hold 0.25 s, under the three 0.1 s windows a
    # baseline needs even over the short windows (the band's own windows are 0.4 s)
    t_lv = [(2.5, 8.5), (11.5, 17.5)]
    segs = [Segment(0.75, 1.25, 0.0), Segment(*t_lv[0], LEVELS_G[0]), Segment(9.75, 10.25, 0.0),
            Segment(*t_lv[1], LEVELS_G[1]), Segment(18.75, 19.25, 0.0)]
    rec = open_record(path, dut="adxl", reference="ref")
    with rec, pytest.raises(ValueError, match=r"^no vibration-off baseline long enough to average: the longest "
                                              r"holds 0\.25 s after the settling trims, under the 0\.3 s"):
        reduce(rec, Schedule(tuple(segs)), "random", options=ReductionOptions(band_hz=(5.0, 500.0)))


def test_a_short_window_baseline_at_a_rail_is_off_scale_and_one_below_it_is_not(tmp_path: Path) -> None:
    path = tmp_path / "rec.csv"
    lab_record(path, "5", 4)
    t, ref, dut = np.loadtxt(path, delimiter=",", skiprows=1).T
    # the DUT clipped at ±2 g: the vibration reaches the rail, the baselines (1.01 g) do not;
    # clipped at ±1 g: the baselines sit on it (physics §4.2: VRE undefined, null)
    for rail, off_scale in ((2.0, False), (1.0, True)):
        rec = ArrayRecord({"reference": ref, "dut": np.clip(dut, -rail, rail)}, FS)
        red = reduce(rec, method="random", options=ReductionOptions(band_hz=(5.0, 500.0)))
        assert len(red.baselines) == 3
        assert all((b.n_saturated > 0) == off_scale for b in red.baselines), rail
        for lv in red.levels:
            assert ("baseline-off-scale" in lv.flags) == off_scale
            assert np.isnan(lv.vre.value) == off_scale


def test_swapped_channels_are_refused_when_every_baseline_is_shorter_than_a_window(tmp_path: Path,
                                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "rec.csv"
    lab_record(path, "5", 5)
    # from 2.5 Hz the windows are 0.8 s: the 2 s baselines found, trimmed, hold none whole, so the
    # reference's static reading over them comes from their samples (physics §4.2: a reference
    # reading a static field with vibration off while the DUT reads none is a swap)
    rc = main(["analyze", str(path), "--dut", "ref", "--reference", "adxl", "--dut-units", "g",
               "--reference-units", "g", "--band", "2.5:1000"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "the channels look swapped" in err and len(err.strip().splitlines()) == 1


def test_a_baseline_at_the_records_end_is_found_whatever_the_bands_windows(tmp_path: Path,
                                                                           capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "rec.csv"
    # 6.3 s levels: the last baseline (18.6-20.6 s) holds one whole 0.8 s window of a band from
    # 2.5 Hz after the ramp's tail, and the record ends 0.6 s into the next; found over those
    # windows it was lost, and the last level took the baseline before it alone, its drift
    # (20 µg/s over 5 s) not removed: 6 U off. The off test runs over 0.1 s windows now.
    lab_record(path, "5", 1, t_on_s=6.3)
    rc = main(["analyze", str(path), "--dut", "adxl", "--reference", "ref", "--dut-units", "g",
               "--reference-units", "g", "--method", "random", "--band", "2.5:1000", "--json"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    doc = json.loads(out.out)
    assert not [w for w in doc["warnings"] if "no baseline after" in w]
    for lv, vre in zip(doc["levels"], VRE_G):
        assert abs(lv["vre_g"] - vre) <= lv["U_vre_g"], (lv["vre_g"], vre, lv["U_vre_g"])
