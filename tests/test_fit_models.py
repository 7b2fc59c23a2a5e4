"""Issue 31 (results): a FitResult carries its model (a class per fitted model, with its name,
its parameters and ``eval(rms_g)``, the fitted VRE at a level), its parameters nested in
``to_dict``, and a results file in the flat form of earlier versions still reads.

``eval`` is held against each model's equation written here from its source, independently of
vrelab: SPEC 1.2 (``VRE = VRC·rms²``, ``VRC = k2 + 3·k3·g0``, the quartic term c4·rms⁴) and
SPEC 1.1's closed form of the censored Gaussian mean (the Analog Devices article), with
scipy.stats' truncated normal for the truncated model.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from vrelab.fits import fit_k2_k3, fit_rail, fit_vrc
from vrelab.results import (
    ClipModel,
    Estimate,
    FitResult,
    K2K3Model,
    K2Model,
    LevelResult,
    VrcK4Model,
    VrcModel,
    VreResult,
    fit_model,
)

DATA = Path(__file__).parent / "data"
SRC = Path(__file__).resolve().parents[1] / "src" / "vrelab"
RMS = np.array([0.0, 0.25, 0.5, 1.0, 1.7])
# the closed forms below and vrelab's evaluate the same normal CDF in a different order of
# operations: they agree to rounding of a few ulps of the rail (2 g), far below 1e-12 g
ATOL = 1e-12


def censored_vre(g0: float, sigma: np.ndarray, low: float, high: float) -> np.ndarray:
    """SPEC 1.1: E[clip(X)] = L·Φ(α) + U·(1-Φ(β)) + μ·(Φ(β)-Φ(α)) + σ·(φ(α)-φ(β)), VRE = E - μ."""
    s = np.where(sigma > 0, sigma, 1.0)  # σ = 0: no vibration, VRE 0 (set below)
    a, b = (low - g0) / s, (high - g0) / s
    e = (low * stats.norm.cdf(a) + high * stats.norm.sf(b) + g0 * (stats.norm.cdf(b) - stats.norm.cdf(a))
         + s * (stats.norm.pdf(a) - stats.norm.pdf(b)))
    return np.where(sigma > 0, e - g0, 0.0)


def test_vrc_models_eval_spec_1_2():
    vrc = VrcModel({"vrc_ug_per_g2": Estimate(150.0, 2.0, "ug/g^2")})
    assert np.allclose(vrc.eval(RMS), 150e-6 * RMS**2, rtol=1e-15, atol=0)
    assert vrc.eval(2.0) == pytest.approx(600e-6, rel=1e-15) and isinstance(vrc.eval(2.0), float)
    k4 = VrcK4Model({"vrc_ug_per_g2": Estimate(200.0, 1.0, "ug/g^2"), "c4_ug_per_g4": Estimate(30.0, 1.0, "ug/g^4")})
    assert np.allclose(k4.eval(RMS), 200e-6 * RMS**2 + 30e-6 * RMS**4, rtol=1e-15, atol=0)
    k23 = K2K3Model({"k2_ug_per_g2": Estimate(100.0, 3.0, "ug/g^2"), "k3_ug_per_g3": Estimate(10.0, 1.0, "ug/g^3")})
    for g0 in (1.0, -1.0, 0.3):
        assert np.allclose(k23.eval(RMS, static_g=g0), (100e-6 + 3 * 10e-6 * g0) * RMS**2, rtol=1e-15, atol=0)
    assert K2Model({"k2_ug_per_g2": Estimate(80.0, 3.0, "ug/g^2")}).eval(0.5) == pytest.approx(80e-6 * 0.25, rel=1e-15)


@pytest.mark.parametrize("params", [{"rail_g": Estimate(2.0, 0.01, "g")},
                                    {"rail_low_g": Estimate(-1.5, 0.01, "g"), "rail_high_g": Estimate(2.5, 0.01, "g")},
                                    {"rail_g": Estimate(2.0, 0.01, "g"), "vrc_ug_per_g2": Estimate(500.0, 5.0, "ug/g^2")}])
def test_clip_model_eval_against_spec_1_1_closed_form(params):
    low, high = (-2.0, 2.0) if "rail_g" in params else (-1.5, 2.5)
    vrc = params["vrc_ug_per_g2"].value * 1e-6 if "vrc_ug_per_g2" in params else 0.0
    m = ClipModel(params, "censored", static_g=1.0)
    assert m.name == "clip-censored"
    assert np.allclose(m.eval(RMS), censored_vre(1.0, RMS, low, high) + vrc * RMS**2, rtol=0, atol=ATOL)
    t = ClipModel(params, "truncated", static_g=1.0)
    # the truncated model: the mean of the doubly truncated normal (scipy.stats.truncnorm) minus μ
    s = RMS[1:]
    want = stats.truncnorm.mean((low - 1.0) / s, (high - 1.0) / s, loc=1.0, scale=s) - 1.0 + vrc * s**2
    assert np.allclose(t.eval(s), want, rtol=0, atol=1e-10)  # truncnorm's own moments: ~1e-12 at these tails


def test_fitted_rail_eval_returns_the_levels_it_was_fitted_to():
    """A rail fit over exact censored levels (rails ±2 g at 1 g): the FitResult's eval gives the
    levels back (the fitted rail is 2 g to its solver's tolerance, so within 1e-9 g of the data)."""
    rms = [0.3, 0.4, 0.5, 0.6, 0.7, 0.8]
    levels = [LevelResult(r, Estimate(float(censored_vre(1.0, np.array(r), -2.0, 2.0)), 1e-4, "g")) for r in rms]
    fit = fit_rail(levels, 1.0)
    assert isinstance(fit.model, ClipModel) and fit.model.static_g == 1.0 and fit.model.rail is fit.params["rail_g"]
    assert np.allclose(fit.eval(rms), [lv.vre.value for lv in levels], rtol=0, atol=1e-9)


def test_eval_refuses_what_the_model_cannot_give():
    k23 = K2K3Model({"k2_ug_per_g2": Estimate(100.0, 3.0, "ug/g^2"), "k3_ug_per_g3": Estimate(10.0, 1.0, "ug/g^3")})
    with pytest.raises(ValueError, match="static field"):
        k23.eval(1.0)
    vrc = VrcModel({"vrc_ug_per_g2": Estimate(150.0, 2.0, "ug/g^2")})
    with pytest.raises(ValueError, match="static_g"):
        vrc.eval(1.0, static_g=1.0)
    with pytest.raises(ValueError, match="rms_g"):
        vrc.eval([-1.0])
    with pytest.raises(ValueError, match="fitted at 1 g"):
        ClipModel({"rail_g": Estimate(2.0, 0.01, "g")}, static_g=1.0).eval(0.5, static_g=-1.0)
    with pytest.raises(ValueError, match="static field it was fitted at is unknown"):
        ClipModel({"rail_g": Estimate(2.0, 0.01, "g")}).eval(0.5)
    with pytest.raises(ValueError, match="parameters"):
        VrcModel({"rail_g": Estimate(2.0, 0.01, "g")})
    with pytest.raises(ValueError, match="unknown fit model 'spline'"):
        fit_model("spline", {})


def test_model_attributes_replace_the_name_dispatch():
    one = FitResult(VrcModel({"vrc_ug_per_g2": Estimate(150.0, 2.0, "ug/g^2")}), n_points=1)
    assert one.no_fit_reason is not None and "two levels" in one.no_fit_reason
    assert FitResult(one.model, n_points=2).no_fit_reason is None
    assert one.model.vrc is one.params["vrc_ug_per_g2"] and one.model.rail is None
    k4 = VrcK4Model({"vrc_ug_per_g2": Estimate(200.0, 1.0, "ug/g^2"), "c4_ug_per_g4": Estimate(30.0, 1.0, "ug/g^4")})
    assert k4.vrc is None  # with c4 the rms² coefficient is not the VRC of VRE = VRC·rms²
    asym = ClipModel({"rail_low_g": Estimate(-1.5, 0.01, "g"), "rail_high_g": Estimate(2.5, 0.01, "g")}, static_g=0.0)
    assert asym.rail is None and asym.static_coefficients([0.5], 0.0) is not None
    assert one.model.static_coefficients([0.5], 0.0) is None


def test_no_string_dispatch_on_a_fit_model_in_src():
    """The name is for files and people: code asks the model (issue 31)."""
    pat = re.compile(r"""\.model(\.name)?\s*(==|!=)\s*["']|\.model(\.name)?\.startswith\(|\.model\s+in\s""")
    hits = [f"{p.relative_to(SRC)}:{i}" for p in SRC.rglob("*.py")
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if pat.search(line)]
    assert hits == []


def test_to_dict_nests_parameters_and_round_trips():
    levels = [LevelResult(r, Estimate(150e-6 * r**2, 2e-6, "g"), freq_hz=100.0) for r in (0.5, 1.0, 1.5)]
    fits = [fit_vrc(levels, freq_hz=100.0),
            fit_k2_k3([(1.0, Estimate(130.0, 3.0, "ug/g^2")), (-1.0, Estimate(70.0, 5.0, "ug/g^2"))]),
            fit_rail([LevelResult(r, Estimate(float(censored_vre(1.0, np.array(r), -2.0, 2.0)), 1e-4, "g"))
                      for r in (0.3, 0.5, 0.7, 0.8)], 1.0)]
    for fit in fits:
        d = json.loads(json.dumps(fit.to_dict()))
        assert d["model"] == fit.model.name
        assert d["parameters"] == {k: {"value": e.value, "u": e.u, "unit": e.unit} for k, e in fit.params.items()}
        assert not set(fit.params) & set(d)  # no parameter beside the fit's own keys any more
        back = FitResult.from_dict(d)
        assert back == fit
    assert json.loads(json.dumps(fits[2].to_dict()))["static_g"] == 1.0


def test_a_results_file_written_by_67a2c6f_still_reads():
    """tests/data/results_67a2c6f.json, written by tests/data/results_67a2c6f.py on commit
    67a2c6f (parameters beside ``model``): every fit reads back as its model with the file's
    numbers; the rail fit's static field was not recorded then, so its eval refuses."""
    d = json.loads((DATA / "results_67a2c6f.json").read_text(encoding="utf-8"))
    res = VreResult.from_dict(d)
    assert [type(f.model) for f in res.fits] == [ClipModel, VrcK4Model, VrcModel, K2K3Model]
    for f, raw in zip(res.fits, d["fits"]):
        assert f.model.name == raw["model"]
        assert {k: (e.value, e.u, e.unit) for k, e in f.params.items()} == {
            k: (raw[k]["value"], raw[k]["u"], raw[k]["unit"]) for k in raw["covariance"]["params"]}
    assert res.fits[0].params["rail_g"].value == pytest.approx(2.0, abs=1e-9)  # the script's rails, ±2 g
    with pytest.raises(ValueError, match="unknown"):
        res.fits[0].eval(0.5)
    assert res.fits[2].eval(1.0) == pytest.approx(d["fits"][2]["vrc_ug_per_g2"]["value"] * 1e-6, rel=1e-15)
    again = res.to_dict()
    assert again["fits"][1]["parameters"]["c4_ug_per_g4"] == d["fits"][1]["c4_ug_per_g4"]
    assert again["fit"] == d["fit"]  # the summary stays flat (SPEC 5's fit.vrc_ug_per_g2, fit.rail_g)
    assert math.isfinite(again["fits"][0]["parameters"]["rail_g"]["u"])
