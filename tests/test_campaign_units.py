"""A campaign's units check is judged per DUT channel over all its runs (issue 19, SPEC 4.2).

A DUT with a proof-mass resonance at fn = 200 Hz, Q = 6, driven by sines at 50, 100 and 200 Hz:
its response to the reference is |H(f)| = 1/sqrt((1 - r²)² + (r/Q)²), r = f/fn (SPEC 1.3; the
second-order accelerometer response, e.g. Harris' Shock and Vibration Handbook ch. 12), so the
DUT/reference ratio is 1.07, 1.33 and exactly Q = 6 at resonance. A single-file check refuses the
200 Hz run (a ratio beyond 3); the campaign must not, since the 50 Hz run shows the channel flat.
A unit slip (the DUT in m/s² read as g) is a factor 9.81 on every run: refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vrelab.analysis.readers import open_record
from vrelab.analysis.reduction import analyze_channels
from vrelab.campaigns import read_manifest, run_campaign
from vrelab.record import Schedule, Segment, write_record_hdf5

FS = 4000.0
FN, Q = 200.0, 6.0
FREQS = (50.0, 100.0, 200.0)


def _h(f: float) -> complex:
    r = f / FN
    return 1.0 / (1 - r * r + 1j * r / Q)


def _run_file(path: Path, f: float, seed: int, factor: float = 1.0) -> None:
    """Baseline 1 s, a 0.5 g sine 2 s, baseline 1 s; DUT = 1 g static + H(f)·reference, in units
    ``factor`` times g."""
    rng = np.random.default_rng(seed)
    n = int(4 * FS)
    t = np.arange(n) / FS
    on = (t >= 1.0) & (t < 3.0)
    h = _h(f)
    ref = np.where(on, 0.5 * np.sin(2 * np.pi * f * t), 0.0) + 1e-4 * rng.standard_normal(n)
    dut = 1.0 + np.where(on, 0.5 * abs(h) * np.sin(2 * np.pi * f * t + np.angle(h)), 0.0) + 1e-4 * rng.standard_normal(n)
    sched = Schedule((Segment(0, 1, 0, None), Segment(1, 3, 0.5 / np.sqrt(2), f), Segment(3, 4, 0, None)))
    write_record_hdf5(path, FS, [{"reference": ref, "dut": dut * factor}], sched)


def _manifest(d: Path, factor: float) -> Path:
    runs = []
    for i, f in enumerate(FREQS):
        _run_file(d / f"run{i}.h5", f, seed=i, factor=factor)
        runs.append(f'[[run]]\nfile = "run{i}.h5"\ndut = ["dut"]\nreference = "reference"\nstatic_g = 1\n'
                    f'label = "{f:g} Hz"\nmethod = "sine"\n')
    m = d / "campaign.toml"
    m.write_text('name = "sweep through a resonance"\n' + "\n".join(runs))
    return m


def test_a_sine_sweep_through_a_q6_resonance_is_accepted(tmp_path: Path) -> None:
    m = _manifest(tmp_path, 1.0)
    # the single-file check stays: alone, the run at resonance is refused as a factor of Q
    with open_record(tmp_path / "run2.h5", ["dut"], "reference") as rec:
        with pytest.raises(ValueError, match=r"differ by a factor of 6 \("):
            analyze_channels(rec, None, "sine", static_g=1.0)
    results = run_campaign(read_manifest(m))
    assert [r.error for r in results] == [None, None, None]
    ratios = {r.run.label: r.unit_probes["dut"][0][2] for r in results}
    for f in FREQS:  # the probes saw |H(f)|: the check judged what the record holds
        assert ratios[f"{f:g} Hz"] == pytest.approx(abs(_h(f)), rel=0.02)


def test_a_9_81_slip_on_every_run_is_refused(tmp_path: Path) -> None:
    m = _manifest(tmp_path, 9.80665)
    out = tmp_path / "out"
    results = run_campaign(read_manifest(m), out=out)
    for r in results:
        # 9.81 times |H(50 Hz)| = 1.07: the factor the flat end of the sweep shows
        assert r.error is not None and "DUT channel 'dut' and the reference differ by a factor of 10.5" in r.error
        assert "lowest drive frequency 50 Hz" in r.error and r.folder is None and not r.results
    assert not (out / "runs").exists() or not any((out / "runs").iterdir())  # nothing half-written
