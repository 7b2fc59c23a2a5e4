"""Issue 28: an assumption is a number with a u, never silently exact.

u covered what was measured, not what was assumed. The presets now give every parameter the
data sheet leaves open a sourced u ([uncertainty], its source in [facts]); predict carries them
into u_vre_g, checked here against a Monte Carlo over the assumptions (numpy draws, predict per
draw); where the VRE is curved in an assumption (a rail at the edge of clipping) the linearised
propagation understates the spread and predict's own Monte Carlo says so and widens u; and an
assumption a file gives no u (identify's rails from the ideal base sensor) makes the levels that
depend on it not valid, naming it.
"""

from __future__ import annotations

import functools
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from vrelab import load_sensor
from vrelab.cli import main
from vrelab.prediction import CURVED_SOURCE, predict
from vrelab.profiles import RandomProfile, parse_profile
from vrelab.sensor.parameters import ASSUMABLE, parameter, with_parameters

# Nonlinearity 0.1 % FS (ADXL354/355 data sheet Rev. D, on ±2 g; the presets take it on every range)
NL = 0.001


@functools.lru_cache(maxsize=8)
def _bow_bounds(r: float) -> tuple[float, float]:
    """|k2| and |k3| [µg/g², µg/g³] whose bow alone deviates from its best straight line by NL·R on
    ±R, found numerically (scipy's bounded scalar minimiser over the line, max over a grid of a):
    the minimax deviation of a² (its best line a constant, by symmetry) and of a³ (a line through 0)."""
    from scipy.optimize import minimize_scalar

    a = np.linspace(-r, r, 20001)
    dev2 = minimize_scalar(lambda c: float(np.max(np.abs(a**2 - c))), bounds=(0.0, r * r), method="bounded",
                           options={"xatol": 1e-10 * r * r}).fun
    dev3 = minimize_scalar(lambda m: float(np.max(np.abs(a**3 - m * a))), bounds=(0.0, 1.5 * r * r),
                           method="bounded", options={"xatol": 1e-10 * r * r}).fun
    return NL * r / dev2 * 1e6, NL * r / dev3 * 1e6


@pytest.mark.parametrize("name", ["adxl354", "adxl355", "adxl357"])
def test_presets_give_every_open_parameter_a_sourced_u(name):
    """Every parameter the data sheet leaves open carries a u, each with its source in the facts;
    k2 and k3 from the nonlinearity %FS (bounds computed here with numpy), read as rectangular
    (u = bound/√3); no preset leaves an assumption without a u (``unstated``) but the IEEE 1293
    coupling terms (0, no data sheet bounds them)."""
    probe = load_sensor(name)
    for rng in probe.ranges_g:
        for axis in probe.axes:
            s = load_sensor(name, range_g=rng, axis=axis)
            # the IEEE 1293 coupling terms stay 0 with no u: no data sheet bounds them (identify them from a
            # mount-angle campaign); a single-axis vibration does not reach them, the triaxial prediction names them
            assert set(s.unstated) <= {"kip_ug_per_g2", "kio_ug_per_g2", "kpp_ug_per_g2", "koo_ug_per_g2",
                                       "kpo_ug_per_g2"}, (name, rng, axis, s.unstated)
            want = {"fn_hz", "q", "k2_ug_per_g2", "k3_ug_per_g3"}
            want |= {f"cross_axis_{a}" for a in "xyz" if a != axis}
            if s.anti_alias_hz is not None:
                want |= {"anti_alias_hz", "anti_alias_order"}
            if s.bandwidth_hz is not None:  # a digital low-pass (with an ODR) or an analog output filter
                want |= {"bandwidth_hz", "lowpass_order"}
            assert want <= set(s.uncertainty), (name, rng, axis, want - set(s.uncertainty))
            if name == "adxl354":  # an analog output stage's swing: not pinned by the data sheet
                want |= {"rail_low_g", "rail_high_g"}
            for n in want:  # each u has its source, said in the parameter's fact
                assert re.search(r"\bu\b", s.facts[ASSUMABLE[n].fact_key]), (name, n, s.facts[ASSUMABLE[n].fact_key])
            b2, b3 = _bow_bounds(s.range_g)
            # the preset writes 4 significant digits: 0.1 %
            assert s.uncertainty["k2_ug_per_g2"] * math.sqrt(3) == pytest.approx(b2, rel=2e-3), (name, rng)
            assert s.uncertainty["k3_ug_per_g3"] * math.sqrt(3) == pytest.approx(b3, rel=2e-3), (name, rng)
            # cross-axis ±1 % typical, rectangular
            assert s.uncertainty[f"cross_axis_{'y' if axis != 'y' else 'x'}"] == pytest.approx(0.01 / math.sqrt(3), rel=1e-3)
    if probe.odr_hz is not None:  # the corner's u follows the ODR: ODR/4 ± 10 % rectangular
        for odr in (4000.0, 500.0):
            s = load_sensor(name, odr_hz=odr)
            assert s.uncertainty["bandwidth_hz"] == pytest.approx(odr * 0.25 * 0.1 / math.sqrt(3), rel=1e-3)
    assert load_sensor("ideal").unstated == ()  # a definition, no part: exact


def _draw(sensor, rng):
    """One draw of every assumed parameter: uniform over the bound ±√3·u its u stands for (the
    presets' u = a/√3 of a bound ±a, GUM 4.3.7), a filter order uniform over the whole orders of its span."""
    out = {}
    for n, u in sensor.uncertainty.items():
        x = parameter(sensor, n)
        if ASSUMABLE[n].integer:
            out[n] = float(max(1, rng.integers(round(x) - round(u), round(x) + round(u) + 1)))
        else:
            out[n] = float(rng.uniform(x - math.sqrt(3) * u, x + math.sqrt(3) * u))
    return out


def test_row2_adxl357_u_spans_a_monte_carlo_over_its_assumptions(capsys):
    """Issue 28 row 2: ``predict --sensor adxl357 --range 10 --odr 4000 --axis z --static 1
    --profile flat:50-2000 --levels 7.5`` printed -49.2 mg with no u. Now u_vre_g carries the
    preset's assumptions; a numpy Monte Carlo over them (40 joint draws, predict per draw) has a
    spread the propagated u covers and does not exceed twice (40 draws know a standard deviation
    to ±11 %: 1.3 is 2.5 of those; the filter orders' share is the larger move to an end of their
    span, conservative against uniform draws). The result names the dominant assumptions, in its
    JSON (the CLI's --json prints ``to_dict``) and in the text the CLI prints."""
    from vrelab.cli.predict import print_prediction

    s = load_sensor("adxl357", range_g=10, odr_hz=4000, axis="z")
    prof = parse_profile("flat:50-2000")
    pred = predict(s, prof, [7.5], static_g=1.0)
    (lv,) = pred.levels
    assert lv.u_vre_g is not None and lv.valid
    on_axis = {n for n in s.uncertainty if not n.startswith("cross_axis_")}
    assert on_axis <= set(lv.u_sources_g)
    rng = np.random.default_rng(28)
    vre = [predict(with_parameters(s, _draw(s, rng)), prof, [7.5], static_g=1.0).levels[0].vre_g for _ in range(40)]
    spread = float(np.std(vre, ddof=1))
    assert spread > 0.005  # the assumptions move this VRE by mg: u is no formality
    assert spread <= 1.3 * lv.u_vre_g, (spread, lv.u_vre_g)
    assert lv.u_vre_g <= 2.0 * spread, (spread, lv.u_vre_g)
    d = json.loads(json.dumps(pred.to_dict()))
    assert d["levels"][0]["u_vre_g"] == pytest.approx(lv.u_vre_g, rel=1e-12)
    assert any(n.startswith("u_vre_g dominated by assumed") for n in d["notes"])
    print_prediction(pred)
    out = capsys.readouterr().out
    assert " ± " in out.splitlines()[3] and "note: u_vre_g dominated by assumed" in out


def test_a_curved_assumption_gets_the_monte_carlo_spread_not_the_tangent(tmp_path):
    """A rail at the edge of clipping: an upper rail at 2 g, u 0.25 g (the bound ±0.43 g; 1 g static
    field, 0.2 g rms random: the rail 5 σ away). The VRE is near 0 at the rail's value and grows
    steeply as it comes in: the tangent (and the move at ± u) say 4 µg, a Monte Carlo over the
    rail (numpy, 400 uniform draws, predict per draw) spreads by about 26 µg. predict's own Monte
    Carlo finds it: u_vre_g within 30 % of the independent spread (60 draws against 400, of a
    skewed distribution) and a note says the linearised propagation understates it."""
    part = tmp_path / "edge.toml"
    part.write_text('schema = 1\nname = "edge"\ndefault_range_g = 2\nrails_g = [-2.0, 2.0]\n'
                    '[uncertainty]\nrail_high_g = 0.25\n[facts]\nrails_g = "assumption: 2 g, the upper ± 0.25 g"\n',
                    encoding="utf-8")
    s = load_sensor(str(part))
    prof = RandomProfile.flat(50.0, 500.0)
    p = predict(s, prof, [0.2], static_g=1.0)
    (lv,) = p.levels
    rng = np.random.default_rng(5)
    half = math.sqrt(3) * 0.25  # the bound the u stands for
    vre = [predict(with_parameters(s, {"rail_high_g": r}), prof, [0.2], static_g=1.0).levels[0].vre_g
           for r in rng.uniform(2.0 - half, 2.0 + half, 400)]
    spread = float(np.std(vre, ddof=1))
    assert lv.u_sources_g["rail_high_g"] < 0.25 * spread  # the tangent alone: far too small
    assert lv.u_vre_g == pytest.approx(spread, rel=0.3), (lv.u_vre_g, spread)
    assert CURVED_SOURCE in lv.u_sources_g
    assert any("linearised propagation understates" in n for n in p.notes)


def _identified_like(tmp_path: Path) -> Path:
    """A sensor file as ``vrelab identify --base-sensor ideal`` writes it for a campaign with no
    random run: k2, k3, fn and Q identified (their u stated; the shipped example campaign's part,
    SPEC 6.1, without its random run), the rails taken from the base sensor with no
    stated u (its facts' words)."""
    part = tmp_path / "identified.toml"
    src = ("assumption, from base sensor ideal (no random run (with its profile): the rails are identified from "
           "random levels), no stated u: definition: exactly ±range, at the output")
    part.write_text(
        'schema = 1\nname = "ideal-identified"\ndefault_range_g = 2\ndefault_axis = "sn1"\n'
        '[axes.sn1]\nk2_ug_per_g2 = 2000.0\nk3_ug_per_g3 = 300.0\nfn_hz = 1200.0\nq = 4.0\nrails_g = [-2.0, 2.0]\n'
        '[axes.sn1.uncertainty]\nk2_ug_per_g2 = 40.0\nk3_ug_per_g3 = 9.0\nfn_hz = 13.0\nq = 0.3\n'
        f'[axes.sn1.facts]\nk2_ug_per_g2 = "identified from c, 2000 ± 40 µg/g²"\n'
        f'k3_ug_per_g3 = "identified from c, 300 ± 9 µg/g³"\nrails_g = "lower: {src}; upper: {src}"\n',
        encoding="utf-8")
    return part


def test_row1_an_assumed_rail_without_u_is_never_exact(tmp_path, capsys):
    """Issue 28 row 1: the rails an identified file took from the ideal base sensor ("no stated u")
    were exact: 0.237 ± 0.005 mg valid where the part (rails ±2.048 g) gave 0.345 mg. Now the
    loader lists them as assumptions without u, and predict names them; at 1 g rms (the rails 2 σ
    away) a ±10 % change of either rail moves the VRE by far more than its u: not valid, naming the
    rail; at 0.1 g rms (20 σ away) the rails do not matter and the level stays valid. The part's
    own rails (±2.048 g, here the truth) give a VRE outside the stated u at 1 g rms."""
    part = _identified_like(tmp_path)
    s = load_sensor(str(part), axis="sn1")
    # the rails; the other assumptions left at the field table's default are 0 (named, not probed)
    assert {n for n in s.unstated if parameter(s, n)} == {"rail_low_g", "rail_high_g"}
    prof = parse_profile("flat:100-1000")
    p = predict(s, prof, [0.1, 1.0], static_g=0.0)
    quiet, loud = p.levels
    assert quiet.valid
    assert not loud.valid and {"rail_low_g", "rail_high_g"} <= {n.split(" ")[0] for n in loud.notes}
    assert any(n.startswith("assumed with no stated u") and "rail_high_g = 2" in n for n in p.notes)
    truth = predict(with_parameters(s, {"rail_low_g": -2.048, "rail_high_g": 2.048}), prof, [1.0], static_g=0.0)
    assert abs(truth.levels[0].vre_g - loud.vre_g) > 2 * loud.u_vre_g  # what the rails' assumption hid
    # the CLI says it too
    assert main(["predict", "--sensor", str(part), "--axis", "sn1", "--static", "0", "--profile", "flat:100-1000",
                 "--levels", "1"]) == 0
    out = capsys.readouterr().out
    assert "rail_low_g = -2 is an assumption with no stated u" in out and out.splitlines()[3].endswith("no")
