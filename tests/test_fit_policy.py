"""One fit policy (vrelab.fits.fit_levels): the simulated test and the analysis of its record.

Issue 13: `vrelab simulate ... --record --out S` reported fit.model "clip-censored" while
`vrelab analyze S/record.h5` reported "vrc" — the shaker and the reduction each decided which
fits to run, in which order. Both now call the one policy, so one record gives the same `fit`
and `fits` (models identical, values within 1 %) whichever command reduced it.
"""

from __future__ import annotations

import json

import pytest

from vrelab.cli import main


def _run(capsys, argv):
    assert main(argv) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def _params(fit):
    return {k: v["value"] for k, v in fit["parameters"].items()}


def _same_fits(sim, ana):
    assert [f["model"] for f in sim["fits"]] == [f["model"] for f in ana["fits"]]
    assert sim["fit"]["model"] == ana["fit"]["model"]
    for fs, fa in zip(sim["fits"], ana["fits"]):
        assert fs.get("freq_hz") == pytest.approx(fa.get("freq_hz"), rel=1e-9) if fs.get("freq_hz") else True
        ps, pa = _params(fs), _params(fa)
        assert ps.keys() == pa.keys()
        for k in ps:
            assert pa[k] == pytest.approx(ps[k], rel=0.01, abs=1e-9), (fs["model"], k)


def test_random_record_gives_the_same_fits_to_simulate_and_analyze(tmp_path, capsys):
    """ADXL355 Z, 1 g, flat 50-2000 Hz up to 2.5 g rms: a rail fit and a VRC fit on both sides."""
    out = tmp_path / "S"
    sim = _run(capsys, ["simulate", "--sensor", "adxl355", "--axis", "z", "--profile", "flat:50-2000",
                        "--levels", "0.25,0.5,1,1.5,2,2.5", "--seconds", "4", "--record", "--out", str(out), "--json"])
    ana = _run(capsys, ["analyze", str(out / "record.h5"), "--dut", "dut", "--reference", "reference", "--json"])
    assert [f["model"] for f in sim["fits"]] == ["clip-censored", "vrc"]
    _same_fits(sim, ana)


def test_sine_record_gives_the_same_fits_to_simulate_and_analyze(tmp_path, capsys):
    """ADXL355 X with k2 = 300 µg/g² at 100 Hz and 1.5 kHz: one VRC fit per frequency, at the
    schedule's nominal frequency, on both sides."""
    out = tmp_path / "S"
    sim = _run(capsys, ["simulate", "--sensor", "adxl355", "--axis", "x", "--k2", "300", "--freq", "100,1500",
                        "--levels", "0.2,0.4,0.6", "--seconds", "2", "--record", "--out", str(out), "--json"])
    ana = _run(capsys, ["analyze", str(out / "record.h5"), "--dut", "dut", "--reference", "reference",
                        "--method", "sine", "--json"])
    assert [f["freq_hz"] for f in sim["fits"]] == [100.0, 1500.0]
    _same_fits(sim, ana)
