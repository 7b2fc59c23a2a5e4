"""The GUM budget (SPEC 4.3): coverage factors, Welch-Satterthwaite, decisions, and the law of
propagation held against a Monte Carlo propagation (JCGM 101:2008, GUM Supplement 1) for a VRE,
a VRC and a rail."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from vrelab import gum
from vrelab.analysis.options import BudgetOptions, FitOptions
from vrelab.analysis.pipeline import with_budget
from vrelab.fits import fit_levels
from vrelab.models.clipping import censored_mean_shift
from vrelab.results import Estimate, LevelResult


def test_coverage_factor_matches_gum_table_g2() -> None:
    # JCGM 100:2008 Table G.2, p = 95.45 %: ν = 10 -> 2.28, ν = 20 -> 2.13, ν = ∞ -> 2.00
    assert gum.coverage_factor(10) == pytest.approx(2.28, abs=0.005)
    assert gum.coverage_factor(20) == pytest.approx(2.13, abs=0.005)
    assert gum.coverage_factor(math.inf) == pytest.approx(2.00, abs=0.001)


def test_welch_satterthwaite() -> None:
    # one Type A term with ν = 9 and a Type B of the same size: ν_eff = (2u²)²/(u⁴/9) = 36
    assert gum.welch_satterthwaite(math.sqrt(2.0), [(1.0, 9), (1.0, None)]) == pytest.approx(36.0)
    assert gum.welch_satterthwaite(1.0, [(1.0, None)]) == math.inf


@pytest.mark.parametrize("vre, U, limit, expected", [
    (0.30, 0.05, 0.40, "pass"), (-0.35, 0.05, 0.40, "pass"), (0.38, 0.05, 0.40, "indeterminate"),
    (0.44, 0.05, 0.40, "indeterminate"), (0.46, 0.05, 0.40, "fail"), (-0.50, 0.05, 0.40, "fail"),
    (math.nan, 0.05, 0.40, None),
])
def test_guarded_acceptance(vre: float, U: float, limit: float, expected: str | None) -> None:
    assert gum.decide(vre, U, limit) == expected


# ----------------------------------------------------------------------------- Monte Carlo


def _sine_levels(rng: np.random.Generator) -> list[LevelResult]:
    vrc = 2500e-6  # g/g²
    rms = np.array([0.2, 0.4, 0.6, 0.8])
    u = np.full(4, 2e-5)
    return [LevelResult(float(r), Estimate(float(vrc * r * r), float(ui), "g"), 80.0, dof=30.0) for r, ui in zip(rms, u)]


def _random_levels() -> list[LevelResult]:
    rms = np.array([0.6, 0.8, 1.0, 1.2, 1.4])
    vre = censored_mean_shift(1.0, rms, -2.0, 2.0)
    return [LevelResult(float(r), Estimate(float(v), 2e-4, "g"), dof=40.0) for r, v in zip(rms, vre)]


def _mc_param(levels: list[LevelResult], method: str, g0: float, typeb: gum.TypeB, name: str, n: int,
              rng: np.random.Generator) -> np.ndarray:
    out = []
    for _ in range(n):
        dr = rng.normal(0, typeb.u_reference_pct / 100)
        dp = rng.normal(0, typeb.u_dut_pct / 100)
        dg = rng.normal(0, typeb.u_static_g)
        do = rng.normal(0, typeb.u_thermal_g)
        noisy = [replace(lv, vre=Estimate(lv.vre.value + rng.normal(0, lv.vre.u), lv.vre.u, "g")) for lv in levels]
        lv = gum.perturb_levels(noisy, dr, dp, do)
        fits, _ = fit_levels(lv, method, g0 + dg, nominal_freqs_hz=[lv0.freq_hz for lv0 in levels])
        f = next(f for f in fits if name in f.params)
        out.append(f.params[name].value)
    return np.array(out)


def test_vrc_budget_agrees_with_monte_carlo() -> None:
    rng = np.random.default_rng(2026)
    levels = _sine_levels(rng)
    typeb = gum.TypeB(u_reference_pct=1.0, u_dut_pct=0.5, u_static_g=0.02, u_thermal_g=1e-5)
    fits, _ = fit_levels(levels, "sine", 1.0, nominal_freqs_hz=[80.0] * 4)
    _, budgeted = with_budget(levels, fits, "sine", 1.0, [80.0] * 4, FitOptions(clip_kind="censored"), BudgetOptions(typeb, None))
    u = budgeted[0].params["vrc_ug_per_g2"].u
    mc = _mc_param(levels, "sine", 1.0, typeb, "vrc_ug_per_g2", 3000, rng)
    # 3000 draws: the MC standard deviation is good to about 1.3 % (1/√(2·3000))
    assert np.std(mc, ddof=1) == pytest.approx(u, rel=0.06)
    # closed form of SPEC 4.3: a reference-sensitivity error r changes a VRC by -2r
    only_r = gum.TypeB(u_reference_pct=1.0)
    _, b = with_budget(levels, fits, "sine", 1.0, [80.0] * 4, FitOptions(clip_kind="censored"), BudgetOptions(only_r, None))
    u_a = fits[0].params["vrc_ug_per_g2"].u
    vrc = fits[0].params["vrc_ug_per_g2"].value
    assert math.sqrt(b[0].params["vrc_ug_per_g2"].u ** 2 - u_a**2) == pytest.approx(2 * 0.01 * abs(vrc), rel=0.02)


def test_rail_budget_agrees_with_monte_carlo() -> None:
    rng = np.random.default_rng(7)
    levels = _random_levels()
    typeb = gum.TypeB(u_reference_pct=1.0, u_dut_pct=1.0, u_static_g=0.01, u_thermal_g=2e-4)
    fits, _ = fit_levels(levels, "random", 1.0)
    rail = next(f for f in fits if "rail_g" in f.params)
    assert rail.params["rail_g"].value == pytest.approx(2.0, rel=1e-3)
    _, budgeted = with_budget(levels, fits, "random", 1.0, [None] * 5, FitOptions(clip_kind="censored"), BudgetOptions(typeb, None))
    u = next(f for f in budgeted if "rail_g" in f.params).params["rail_g"].u
    # 500 draws (each a nonlinear rail fit): the MC standard deviation is good to about 3 %
    mc = _mc_param(levels, "random", 1.0, typeb, "rail_g", 500, rng)
    assert np.std(mc, ddof=1) == pytest.approx(u, rel=0.10)


def test_vre_budget_agrees_with_monte_carlo() -> None:
    rng = np.random.default_rng(11)
    levels = _random_levels()
    typeb = gum.TypeB(u_reference_pct=1.0, u_dut_pct=2.0, u_static_g=0.02, u_thermal_g=3e-4)
    fits, _ = fit_levels(levels, "random", 1.0)
    out, _ = with_budget(levels, fits, "random", 1.0, [None] * 5, FitOptions(clip_kind="censored"), BudgetOptions(typeb, 0.2))
    rail = next(f for f in fits if "rail_g" in f.params).params["rail_g"].value
    lv, b = levels[-1], out[-1]
    n = 20000
    # the VRE read at the stated field g0 while the fixture holds g0 + δg: its physics moves by
    # the clipping model's change (independent of the budget's finite difference)
    dg = rng.normal(0, typeb.u_static_g, n)
    physics = censored_mean_shift(1.0 + dg, lv.rms_g, -rail, rail) - censored_mean_shift(1.0, lv.rms_g, -rail, rail)
    mc = ((lv.vre.value + physics + rng.normal(0, lv.vre.u, n)) * (1 + rng.normal(0, 0.02, n))
          + rng.normal(0, typeb.u_thermal_g, n))
    assert np.std(mc) == pytest.approx(b.vre.u, rel=0.03)
    assert b.U_vre_g == pytest.approx(b.k * b.vre.u)
    assert b.decision == gum.decide(b.vre.value, b.U_vre_g, 0.2)
    sources = {t["source"] for t in b.budget}
    assert sources == {"record (batch means, low-frequency noise)", "DUT sensitivity", "reference sensitivity",
                       "static field (alignment)", "thermal offset"}


# ----------------------------------------------------------------------------- the CLI


def test_analyze_budget_and_limit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from vrelab.cli import main
    from vrelab.example_campaign import write_campaign

    m = write_campaign(tmp_path / "c")
    f = str(m.parent / "runs" / "01_z_up_80hz.tdms")
    base = [f, "--dut", "shaker/sn1_z", "--reference", "shaker/ref", "--reference-units", "mv",
            "--reference-sensitivity", "10", "--dut-units", "lsb", "--dut-sensitivity", "256000"]
    assert main(["analyze", *base, "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main(["analyze", *base, "--u-reference-pct", "1", "--u-dut-pct", "0.5", "--u-thermal-g", "1e-5",
                 "--limit", "0.0008", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    for a, b in zip(plain["levels"], doc["levels"]):
        assert b["vre_g"] == a["vre_g"]
        assert b["u_vre_g"] > a["u_vre_g"]
        assert b["U_vre_g"] == pytest.approx(b["k"] * b["u_vre_g"])
        assert b["decision"] == gum.decide(b["vre_g"], b["U_vre_g"], 0.0008)
        assert [t["source"] for t in b["budget"]][0] == "record (batch means, low-frequency noise)"
    assert {lv["decision"] for lv in doc["levels"]} == {"pass", "fail"}  # 0.1 and 0.47 mg pass, 1.0 mg fails
    assert doc["fit"]["vrc_ug_per_g2"]["u"] > plain["fit"]["vrc_ug_per_g2"]["u"]
    assert doc["conditions"]["extra"]["decision_rule"].startswith("guarded acceptance")
    assert main(["analyze", *base, "--u-dut-pct", "-1"]) == 2
    err = capsys.readouterr().err
    assert "u_dut_pct" in err and len(err.strip().splitlines()) == 1
