"""A unit slip on one run of a campaign is refused, run by run (issue 34, SPEC 4.1 and 4.2).

The shipped example's runs 1 and 2 (examples/campaign: the parts sn1, sn2 at +1 g and -1 g, 80 Hz;
reference in mV at 10 mV/g, DUTs in LSB at 256 000 LSB/g). Run 2 declares one channel's units
wrong by a known factor; the truth of every ratio is that factor times the part's response at
80 Hz, |H| = 1/|1 - r² + j r/Q| with r = 80/1200, Q = 4 (examples/campaign/sensor.toml): 1.0045,
so DUT/reference reads the slip factor within 1 %. Before the fix both runs were `ok` and k2/k3
came out wrong (k2 1426 µg/g² for a part that has 2000; 1.6e8 with the DUT read in g).

A sweep through a resonance is no slip: a DUT with fn = 200 Hz, Q = 20 driven at its resonance
reads |H(fn)| = Q/sqrt(1 - 1/(4Q²)) = 20.01 times the reference (the second-order accelerometer
response, SPEC 1.3), and is kept, with or without a sensor file.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from vrelab.campaigns import combine, read_manifest, run_campaign
from vrelab.cli import main
from vrelab.record import Schedule, Segment, write_record_hdf5

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "campaign"
RUNS = EXAMPLE / "runs"
H_80 = 1.0 / abs(1 - (80 / 1200) ** 2 + 1j * (80 / 1200) / 4)  # the example part at 80 Hz

RUN1 = f'''[[run]]
file = "{RUNS / "01_z_up_80hz.tdms"}"
label = "Z up, 80 Hz"
reference = "shaker/ref"
dut = {{sn1 = "shaker/sn1_z", sn2 = "shaker/sn2_z"}}
static_g = 1
reference_units = "mv"
reference_sensitivity = 10
dut_units = "lsb"
dut_sensitivity = 256000
'''
RUN2 = f'''[[run]]
file = "{RUNS / "02_z_down_80hz.csv"}"
label = "Z down, 80 Hz"
reference = "ref_mV"
dut = ["sn1", "sn2"]
static_g = -1
'''
RIGHT_REF = 'reference_units = "mv"\nreference_sensitivity = 10\n'
RIGHT_DUT = 'dut_units = "lsb"\ndut_sensitivity = 256000\n'

# (what run 2 declares, the DUT/reference ratio that makes: the slip factor)
SLIPS = {
    "reference in mV declared in V": ('reference_units = "v"\nreference_sensitivity = 0.01\n' + RIGHT_DUT, 1e-3),
    "reference sensitivity in uV/g": ('reference_units = "mv"\nreference_sensitivity = 10000\n' + RIGHT_DUT, 1e3),
    "DUT sensitivity in LSB/mg": (RIGHT_REF + 'dut_units = "lsb"\ndut_sensitivity = 256\n', 1e3),
    "DUT sensitivity x1000": (RIGHT_REF + 'dut_units = "lsb"\ndut_sensitivity = 256000000\n', 1e-3),
    "DUT in LSB declared in g": (RIGHT_REF + 'dut_units = "g"\n', 256000.0),
    # a calibration sheet's 1.0197 mV/(m/s²) typed as mV/g: the reference 9.81 times too large,
    # within what a resonance may give, so refused by run 1 at the same frequency
    "reference sensitivity per m/s2": ('reference_units = "mv"\nreference_sensitivity = 1.0197\n' + RIGHT_DUT,
                                       1.0197 / 10),
}


def _manifest(tmp: Path, run2: str, head: str = "") -> Path:
    m = tmp / "campaign.toml"
    m.write_text(f'name = "runs 1 and 2 of the example"\n{head}\n{RUN1}\n{RUN2}{run2}')
    return m


@pytest.mark.parametrize("case", list(SLIPS))
def test_a_slip_on_run_2_is_refused_and_run_1_kept(tmp_path: Path, case: str) -> None:
    run2, factor = SLIPS[case]
    results = run_campaign(read_manifest(_manifest(tmp_path, run2)))
    assert results[0].ok and [n for n, _ in results[0].results] == ["sn1", "sn2"]
    err = results[1].error
    assert err is not None and "units check" in err and "'sn1'" in err, err
    if case == "DUT in LSB declared in g":
        # the vibration-off reading, -256 000 g (the -1 g field in LSB), is 1280 times the
        # default range bound of ±200 g: refused whatever the static field declared
        m = re.search(r"reads ([-+0-9.e]+) g with vibration off", err)
        assert m is not None, err
        assert float(m.group(1)) == pytest.approx(-factor, rel=0.01)
        return
    m = re.search(r"reads ([0-9.e+-]+) times the reference at 80 Hz", err)
    assert m is not None, err
    if case == "reference sensitivity per m/s2":
        assert "the median of the channel's other run(s) at that frequency (run(s) 1)" in err, err
    # the probe reads the ratio at the drive line: the slip times |H(80 Hz)|, within 1 %
    # (the noise on a 1 s probe of a 0.5 g sine is 1e-4 of it)
    assert float(m.group(1)) == pytest.approx(factor * H_80, rel=0.01)
    # run 1 keeps its numbers: the VRC at +1 g alone, no k2/k3 from a wrong -1 g
    ch = combine(results, ["sn1"])[0]
    assert [v["run"] for v in ch.vrc_by_freq] == [1] and ch.k2 is None and ch.k3 is None


def test_the_cli_names_the_run_the_channel_and_the_ratio_exit_1(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    m = _manifest(tmp_path, SLIPS["reference in mV declared in V"][0])
    out = tmp_path / "out"
    assert main(["campaign", str(m), "--out", str(out), "--json"]) == 1
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert [r["status"] for r in doc["runs"]] == ["ok", "failed"]
    line = [ln for ln in cap.err.splitlines() if "failed" in ln]
    assert len(line) == 1 and line[0].startswith("vrelab: run 2 (Z down, 80 Hz) failed: units check"), cap.err
    assert "DUT channel 'sn1' reads 0.001" in line[0], line[0]
    # run 1's folder kept, run 2's (written before the campaign's check refused it) gone
    assert [p.name[:3] for p in (out / "runs").iterdir()] == ["01-"]


def test_with_the_sensor_file_the_response_is_the_bound(tmp_path: Path) -> None:
    """The manifest's `sensor` key: each run held to that sensor's |H(f)|, within x/÷ 3."""
    run2 = SLIPS["reference sensitivity in uV/g"][0]
    results = run_campaign(read_manifest(_manifest(tmp_path, run2, f'sensor = "{EXAMPLE / "sensor.toml"}"')))
    assert results[0].ok
    assert results[1].error is not None and "sensor file's response gives 1" in results[1].error, results[1].error
    ok = run_campaign(read_manifest(_manifest(tmp_path, RIGHT_REF + RIGHT_DUT, f'sensor = "{EXAMPLE / "sensor.toml"}"')))
    assert [r.error for r in ok] == [None, None]


# ----------------------------------------------------------------------------- a resonance is no slip

FS = 4000.0
FN, Q = 200.0, 20.0


def _h(f: float) -> complex:
    r = f / FN
    return 1.0 / (1 - r * r + 1j * r / Q)


def _run_file(path: Path, f: float, seed: int, factor: float) -> None:
    """Baseline 1 s, a 0.05 g sine 2 s, baseline 1 s; DUT = 1 g static + H(f)·reference (numpy
    alone), in units ``factor`` times g."""
    rng = np.random.default_rng(seed)
    n = int(4 * FS)
    t = np.arange(n) / FS
    on = (t >= 1.0) & (t < 3.0)
    h = _h(f)
    a = 0.05
    ref = np.where(on, a * np.sin(2 * np.pi * f * t), 0.0) + 1e-5 * rng.standard_normal(n)
    dut = 1.0 + np.where(on, a * abs(h) * np.sin(2 * np.pi * f * t + np.angle(h)), 0.0) + 1e-5 * rng.standard_normal(n)
    sched = Schedule((Segment(0, 1, 0, None), Segment(1, 3, a / np.sqrt(2), f), Segment(3, 4, 0, None)))
    write_record_hdf5(path, FS, [{"reference": ref, "dut": dut * factor}], sched)


def _sweep(tmp: Path, factors: dict[int, float], sensor: bool) -> Path:
    freqs = (50.0, 100.0, 200.0, 200.0)  # the resonance run twice (+1 g, a repeat)
    runs = []
    for i, f in enumerate(freqs):
        _run_file(tmp / f"run{i}.h5", f, seed=i, factor=factors.get(i, 1.0))
        runs.append(f'[[run]]\nfile = "run{i}.h5"\ndut = ["dut"]\nreference = "reference"\nstatic_g = 1\n'
                    f'label = "{f:g} Hz #{i}"\nmethod = "sine"\n')
    head = ""
    if sensor:
        (tmp / "dut.toml").write_text(f'schema = 1\nname = "q20"\ndefault_range_g = 2\ndefault_axis = "z"\n'
                                      f'full_scale_g = 2.048\nfn_hz = {FN}\nq = {Q}\n')
        head = 'sensor = "dut.toml"\n'
    m = tmp / "campaign.toml"
    m.write_text('name = "sweep through a Q 20 resonance"\n' + head + "\n".join(runs))
    return m


@pytest.mark.parametrize("sensor", [False, True])
def test_a_sweep_through_a_q20_resonance_is_not_refused(tmp_path: Path, sensor: bool) -> None:
    results = run_campaign(read_manifest(_sweep(tmp_path, {}, sensor)))
    assert [r.error for r in results] == [None] * 4
    # the probes saw |H(fn)| = 20.01 (a 2 s level at a 0.025 Hz-wide resonance's peak: the
    # drive line within a bin, 2 %)
    assert results[2].unit_probes["dut"][0][2] == pytest.approx(abs(_h(200.0)), rel=0.02)


@pytest.mark.parametrize("sensor", [False, True])
def test_a_slip_on_the_resonance_run_is_still_refused(tmp_path: Path, sensor: bool) -> None:
    # x1000 on the first run at the resonance: 20 000 times the reference, beyond any Q
    results = run_campaign(read_manifest(_sweep(tmp_path, {2: 1000.0}, sensor)))
    assert [r.ok for r in results] == [True, True, False, True]
    assert "units check" in (results[2].error or "")
