"""Each stage owns its mean shift (vrelab.sensor.meanshift); predict sums what the stages say.

The refactor from string tags to stage-owned closed forms must not change the physics: the
first test holds predict against its own results recorded on commit b3d26ac (the tag-dispatch
predict) over a grid of sensors, profiles, levels, static fields and clipping kinds
(tests/data/predict_stages_reference.py wrote tests/data/predict_stages_reference.json there).
That is a regression reference against the previous implementation; the independent truths
(Monte Carlo, quadrature, the simulated chain) are in tests/test_predict_exact.py.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"
sys.path.insert(0, str(DATA))
import predict_stages_reference as ref  # noqa: E402

REL = 1e-12


def _same(got, want, where):
    if want is None:
        assert got is None, where
    elif want == "nan":
        assert got == "nan", (where, got)
    else:
        # recorded to 15 significant digits: 1e-12 relative, or 1e-24 g where the value is 0
        assert got == pytest.approx(want, rel=REL, abs=1e-24), (where, got, want)


RECORDED = json.loads((DATA / "predict_stages_reference.json").read_text())


def test_the_reference_covers_the_grid_and_every_branch():
    assert RECORDED["commit"] == "b3d26ac"
    assert [{k: c[k] for k in ("sensor", "excitation", "kind", "static_g")} for c in RECORDED["cases"]] == ref.cases()
    assert len(ref.cases()) >= 100
    # the grid reaches every branch it is meant to: the rails' bound, the over-range share, invalid levels
    levels = [lv for c in RECORDED["cases"] for lv in c["result"]["levels"]]
    assert any(lv["model_error_g"] > 0 for lv in levels)
    assert any(lv["shares"]["overrange_g"] != 0 for lv in levels)
    assert any(not lv["valid"] for lv in levels) and any(lv["valid"] for lv in levels)
    assert any(lv["u_vre_g"] is not None for lv in levels)


@pytest.mark.parametrize("sensor", [
    pytest.param(s[0], marks=pytest.mark.slow) if s[4] else s[0] for s in ref.SENSORS])
def test_predict_reproduces_the_tag_dispatch_results_of_b3d26ac(sensor):
    notes = RECORDED["notes"]
    for case in (c for c in RECORDED["cases"] if c["sensor"] == sensor):
        spec = {k: case[k] for k in ("sensor", "excitation", "kind", "static_g")}
        if "error" in case:
            with pytest.raises(ValueError, match=case["error"]):
                ref.run(spec, {})
            continue
        table: dict[str, int] = {n: i for i, n in enumerate(notes)}
        got = ref.run(spec, table)
        want = case["result"]
        _same(got["vibration_off_g"], want["vibration_off_g"], (spec, "vibration_off_g"))
        assert [notes[i] if i < len(notes) else "(new) " + sorted(table, key=table.get)[i]
                for i in got["notes"]] == [notes[i] for i in want["notes"]], spec
        assert len(got["levels"]) == len(want["levels"]), spec
        for lg, lw in zip(got["levels"], want["levels"]):
            where = (spec, lw["rms_g"], lw["freq_hz"])
            assert (lg["rms_g"], lg["freq_hz"], lg["valid"], lg["valid_otherwise"]) == \
                   (lw["rms_g"], lw["freq_hz"], lw["valid"], lw["valid_otherwise"]), where
            assert [notes[i] if i < len(notes) else sorted(table, key=table.get)[i] for i in lg["notes"]] == \
                   [notes[i] for i in lw["notes"]], where
            for key in ("vre_g", "tilt_error_deg", "sigma_proof_mass_g", "sigma_output_g", "sigma_at_clip_g",
                        "overrange_rate_hz", "model_error_g", "u_vre_g"):
                _same(lg[key], lw[key], (where, key))
            assert list(lg["shares"]) == list(lw["shares"]), where
            for key, v in lw["shares"].items():
                _same(lg["shares"][key], v, (where, key))
            assert (lg["u_sources_g"] is None) == (lw["u_sources_g"] is None), where
            if lw["u_sources_g"] is not None:
                assert list(lg["u_sources_g"]) == list(lw["u_sources_g"]), where
                for key, v in lw["u_sources_g"].items():
                    _same(lg["u_sources_g"][key], v, (where, key))
