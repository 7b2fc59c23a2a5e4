"""VRC (VRE / rms², µg/g²) with its u beside every VRE: predict and simulate (issue 28, a designer
comparing with a datasheet's VRC), in the result objects, ``--json``, the CLI text and the report.

Reference values: SPEC 1.2, the polynomial alone rectifies ``(k2 + 3·k3·g0)·σ²`` for Gaussian or
sine vibration (``k4 = 0``), so the level's VRC is ``k2 + 3·k3·g0`` exactly, whatever the level.
"""

from __future__ import annotations

import json
import math

import pytest

from vrelab.cli import main
from vrelab.prediction import predict
from vrelab.profiles import parse_profile
from vrelab.results import Estimate, LevelResult, level_vrc
from vrelab.sensor import load_sensor


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_predict_states_the_vrc_of_spec_1_2_at_every_level(capsys):
    """Ideal ±40 g part (no rail reached), k2 = 100 µg/g², k3 = 20 µg/g³, 1 g field: VRC = 160 µg/g²."""
    rc, out, err = _run(capsys, "predict", "--sensor", "ideal", "--range", "40", "--static", "1", "--k2", "100",
                        "--k3", "20", "--profile", "flat:50-2000", "--levels", "0.5,1,3", "--json")
    assert rc == 0, err
    for lv in json.loads(out)["levels"]:
        assert lv["vrc_ug_per_g2"] == pytest.approx(100 + 3 * 20 * 1.0, rel=1e-9)
    rc, out, err = _run(capsys, "predict", "--sensor", "ideal", "--range", "40", "--static", "1", "--k2", "100",
                        "--k3", "20", "--freq", "200", "--levels", "2")
    assert rc == 0, err
    assert "VRC ug/g^2" in out
    row = next(line for line in out.splitlines() if line.split()[:2] == ["200", "2"])
    assert "160.0" in row.split()  # shown beside the VRE (0.640 mg = 160 µg/g² × 4 g²)


def test_the_predicted_vrc_carries_the_parameters_u(tmp_path):
    """A file's assumed u of k2 (10 µg/g²) is the VRC's u where only the polynomial rectifies:
    ∂VRC/∂k2 = 1, so u_vrc = 10 µg/g² (GUM 5.1.2), at every level."""
    path = tmp_path / "s.toml"
    path.write_text('schema = 1\nname = "s"\ndefault_range_g = 40\nk2_ug_per_g2 = 100.0\n'
                    "[uncertainty]\nk2_ug_per_g2 = 10.0\n", encoding="utf-8")
    pred = predict(load_sensor(str(path)), parse_profile("flat:50-2000"), [0.5, 2.0], static_g=0.0)
    for lv in pred.levels:
        assert lv.vrc_ug_per_g2 == pytest.approx(100.0, rel=1e-9)
        assert lv.u_vrc_ug_per_g2 == pytest.approx(10.0, rel=1e-3)  # central differences of a linear map
        d = lv.to_dict()
        assert d["vrc_ug_per_g2"] == pytest.approx(100.0, rel=1e-9) and d["u_vrc_ug_per_g2"] == pytest.approx(10.0, rel=1e-3)


def test_simulated_vrc_recovers_the_parts_k2_within_its_u(capsys):
    """Simulate the ideal ±40 g part with k2 = 1000 µg/g² in a 0 g field (SPEC 1.2: VRC = k2): the
    VRC each level states covers 1000 µg/g² within 4u (seeded; u from the record's noise)."""
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--range", "40", "--static", "0", "--k2", "1000",
                        "--profile", "flat:50-2000", "--levels", "1,2", "--seconds", "2", "--seed", "7", "--json")
    assert rc == 0, err
    levels = json.loads(out)["levels"]
    for lv in levels:
        assert lv["u_vrc_ug_per_g2"] > 0
        assert abs(lv["vrc_ug_per_g2"] - 1000.0) < 4 * lv["u_vrc_ug_per_g2"], lv
    rc, out, err = _run(capsys, "simulate", "--sensor", "ideal", "--range", "40", "--static", "0", "--k2", "1000",
                        "--profile", "flat:50-2000", "--levels", "1", "--seconds", "2", "--seed", "7")
    assert rc == 0 and "VRC ± u (ug/g^2)" in out


def test_level_vrc_is_gum_propagation_of_vre_and_rms():
    """VRC = VRE/rms², u² = (u_vre/rms²)² + (2·VRC·u_rms/rms)² (GUM 5.1.2, uncorrelated): by hand
    for VRE = 2 ± 0.1 mg at 2 ± 0.02 g rms: 500 µg/g² ± hypot(25, 10) µg/g²."""
    v, u = level_vrc(2e-3, 2.0, 1e-4, 0.02)
    assert v == pytest.approx(500.0) and u == pytest.approx(math.hypot(25.0, 10.0))
    lv = LevelResult(2.0, Estimate(2e-3, 1e-4), u_rms_g=0.02)
    assert lv.to_dict()["vrc_ug_per_g2"] == pytest.approx(500.0)
    assert lv.to_dict()["u_vrc_ug_per_g2"] == pytest.approx(math.hypot(25.0, 10.0))
    assert math.isnan(level_vrc(1e-3, 0.0)[0]) and level_vrc(1e-3, 0.0)[1] is None


def test_the_report_shows_the_vrc_beside_the_predicted_vre():
    from vrelab.report.html import _prediction_html

    pred = predict(load_sensor("ideal", range_g=40.0, k2_ug_per_g2=100.0), parse_profile("flat:50-2000"), [1.0, 2.0],
                   static_g=0.0)
    html = _prediction_html(pred.to_dict())
    assert "VRC (µg/g²)" in html and ">100<" in html
