"""``vrelab model clip|poly``: the SPEC section 5 contract (keys, list syntax, exit status 2)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import integrate, stats

from vrelab._lists import parse_list
from vrelab.cli import main


def _json(capsys, argv):
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert err == ""
    return json.loads(out)


def test_clip_json_keys_and_article_value(capsys):
    """SPEC 5 keys; SPEC 1.1: 1 g field, ±2 g, 1 g rms → -83 mg censored, -283 mg truncated."""
    d = _json(capsys, ["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1", "--json"])
    for key in ("rms_g", "vre_g", "mean_g", "rail_g", "rail_low_g", "shape", "kind"):
        assert key in d
    assert d["rail_low_g"] == -2.0 and d["kind"] == "censored" and d["shape"] == "gaussian"
    assert d["vre_g"][0] == pytest.approx(-0.083, abs=0.5e-3)
    d = _json(capsys, ["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1", "--kind", "truncated", "--json"])
    assert d["vre_g"][0] == pytest.approx(-0.283, abs=0.5e-3)


def test_clip_sine_and_range_syntax(capsys):
    """Range a:b:step inclusive; sine check value -68.3 mg at 1 g rms (SPEC 1.1)."""
    d = _json(capsys, ["model", "clip", "--mean", "1", "--rail", "2", "--rms", "0.5:1.5:0.5", "--shape", "sine", "--json"])
    assert d["rms_g"] == [0.5, 1.0, 1.5]
    assert len(d["vre_g"]) == 3
    assert d["vre_g"][1] == pytest.approx(-0.0683, abs=0.05e-3)
    assert d["vre_g"][0] == 0.0  # 0.71 g peak + 1 g stays inside ±2 g


def test_clip_rail_low(capsys):
    d = _json(capsys, ["model", "clip", "--mean", "0", "--rail", "2", "--rail-low", "-1", "--rms", "1", "--json"])
    assert d["rail_low_g"] == -1.0 and d["vre_g"][0] > 0  # the nearer lower rail pushes the mean up


def test_poly_json(capsys):
    """SPEC 1.2: VRE = (k2 + 3·k3·g0)·σ² + k4·(6g0²σ² + 3σ⁴); 100 µg/g², 5 µg/g³, 1 g, 2 g rms."""
    d = _json(capsys, ["model", "poly", "--k2", "100", "--k3", "5", "--static", "1", "--rms", "1,2", "--json"])
    assert d["rms_g"] == [1.0, 2.0]
    assert d["vre_g"] == pytest.approx([115e-6, 460e-6], rel=1e-12)


def test_human_output_is_a_table_in_mg(capsys):
    assert main(["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1,2"]) == 0
    out = capsys.readouterr().out
    assert "VRE (mg)" in out and "-82.9333" in out
    # title, the reference point (SPEC 1.5), header, two levels; no note: 1 g is within the rails
    assert "VRE referred to the vibration-off reading (1 g)" in out and "note:" not in out
    assert len(out.strip().splitlines()) == 5


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["model", "clip", "--mean", "nan", "--rail", "2", "--rms", "1"], "--mean"),
        (["model", "clip", "--mean", "1", "--rail", "2", "--rms", "-1"], "--rms"),
        (["model", "clip", "--mean", "1", "--rail", "2", "--rail-low", "2", "--rms", "1"], "--rail-low"),
        (["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1,abc"], "abc"),
        (["model", "clip", "--mean", "1", "--rail", "2", "--rms", "3:1:1"], "3:1:1"),
        (["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1", "--kind", "clipped"], "--kind"),
        (["model", "clip", "--mean", "1", "--rail", "2"], "--rms"),
        (["model", "poly", "--k2", "inf", "--rms", "1"], "--k2"),
        (["model", "poly", "--k2", "100", "--rms", "1:2:0"], "step"),
    ],
)
def test_bad_input_one_line_exit_2(capsys, argv, needle):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and needle in err


def test_parse_list_ranges_and_errors():
    """SPEC 5: ranges inclusive of both ends on the grid; decimal steps land on the end."""
    assert parse_list("0:1:0.1", "--rms")[-1] == 1.0
    assert parse_list("0:1:0.1", "--rms")[3] == 0.3
    assert parse_list("0:1:0.3", "--rms") == [0.0, 0.3, 0.6, 0.9]
    assert parse_list("2, 1:0:-0.5", "--x") == [2.0, 1.0, 0.5, 0.0]
    for bad in ("", "1,,2", "1:2", "a", "inf"):
        with pytest.raises(ValueError, match="--rms"):
            parse_list(bad, "--rms")


def _clipped_vre_by_quad(mu: float, sigma: float, lo: float, hi: float) -> float:
    """E[clip(μ + X)] - clip(μ) for X ~ N(0, σ²), by scipy quadrature of the clipped value
    (independent of vrelab: SPEC 1.5's reference point is the reading with no vibration)."""
    pdf = stats.norm(mu, sigma).pdf
    inside, _ = integrate.quad(lambda x: x * pdf(x), lo, hi, epsabs=1e-13, epsrel=1e-13)
    mean_out = lo * stats.norm.cdf((lo - mu) / sigma) + inside + hi * stats.norm.sf((hi - mu) / sigma)
    return mean_out - min(max(mu, lo), hi)


def test_clip_beyond_a_rail_is_referred_to_the_clipped_reading_as_predict(capsys):
    """Issue 21 / SPEC 1.5: ±2 g rails, 2.5 g static, 1 g rms. Measured from μ the mean moves
    -698 mg; from the vibration-off reading (2 g, itself clipped) -198 mg. `model clip` and
    `predict` on the ideal ±2 g sensor both state the latter, equal to 1e-9 and to scipy quad."""
    want = _clipped_vre_by_quad(2.5, 1.0, -2.0, 2.0)
    assert want == pytest.approx(-0.198, abs=0.5e-3)  # the figure
    d = _json(capsys, ["model", "clip", "--mean", "2.5", "--rail", "2", "--rms", "1", "--json"])
    p = _json(capsys, ["predict", "--sensor", "ideal", "--range", "2", "--static", "2.5",
                       "--profile", "flat:20-2000", "--levels", "1", "--json"])
    assert d["vre_g"][0] == pytest.approx(want, abs=1e-9)
    assert p["levels"][0]["vre_g"] == pytest.approx(want, abs=1e-9)
    assert d["vre_g"][0] == pytest.approx(p["levels"][0]["vre_g"], abs=1e-9)
    # both state the reference point, and that it is clipped here
    for out in (d, p):
        assert out["reference"] == "vibration-off reading" and out["vibration_off_g"] == 2.0
        assert any("vibration-off reading is itself clipped" in n for n in out["notes"])
    assert d["vibration_off_clipped"] is True
    assert main(["model", "clip", "--mean", "2.5", "--rail", "2", "--rms", "1"]) == 0
    table = capsys.readouterr().out
    assert "VRE referred to the vibration-off reading (2 g)" in table and "itself clipped" in table


@pytest.mark.parametrize("shape,kind", [("gaussian", "truncated"), ("sine", "censored"), ("sine", "truncated")])
def test_clip_other_models_referred_to_the_clipped_reading(capsys, shape, kind):
    """The same reference point for the truncated model and a sine, against direct computations:
    truncated, scipy.stats.truncnorm's mean; a sine, a dense phase grid; less clip(μ) = 2 g."""
    d = _json(capsys, ["model", "clip", "--mean", "2.5", "--rail", "2", "--rms", "1", "--shape", shape,
                       "--kind", kind, "--json"])
    if shape == "gaussian":
        want = stats.truncnorm(-4.5, -0.5, loc=2.5, scale=1.0).mean() - 2.0
    else:
        x = 2.5 + math.sqrt(2.0) * np.cos(np.linspace(0.0, 2 * np.pi, 400_001)[:-1])
        want = (np.clip(x, -2.0, 2.0).mean() if kind == "censored" else x[(x > -2.0) & (x < 2.0)].mean()) - 2.0
    assert d["vre_g"][0] == pytest.approx(want, abs=1e-5 if shape == "sine" else 1e-9)


def test_poly_states_its_reference(capsys):
    """`model poly` is referred to P(g0) (SPEC 1.2, 1.5): 1 g + 100 µg/g²·(1 g)² = 1.0001 g."""
    d = _json(capsys, ["model", "poly", "--k2", "100", "--static", "1", "--rms", "1", "--json"])
    assert d["reference"] == "vibration-off reading"
    assert d["vibration_off_g"] == pytest.approx(1.0001, abs=1e-15)
    assert main(["model", "poly", "--k2", "100", "--static", "1", "--rms", "1"]) == 0
    assert "VRE referred to the vibration-off reading (1.0001 g)" in capsys.readouterr().out
