"""Identification (SPEC 6.1): recovery on a simulated campaign (over 24 drawn parts:
tests/test_identify_recovery.py), honest nulls, the sensor file,
the covariance carried into predict, the command line (the 2f
cross-check on the example: tests/test_identify_2f.py).

Truth comes from the simulator (vrelab.simulation): parts drawn with a seeded generator, their
campaigns simulated in the time domain and reduced as lab files (vrelab.shaker.run_test), so
the identification meets the same noise, batch-means uncertainties and discretised dynamics a
real campaign would.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vrelab.cli import main
from vrelab.example_campaign import ExampleRun, campaign_document, example_truth
from vrelab.identification import IdentifyOptions, identify, observations, write_sensor_file
from vrelab.prediction import predict, propagated_u
from vrelab.profiles import RandomProfile
from vrelab.sensor import load_sensor

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "campaign" / "campaign.toml"

PART = """schema = 1
name = "drawn-part"
default_range_g = 2
default_axis = "z"
full_scale_g = {rail}
clip_position = "output"
fn_hz = {fn}
q = {q}
noise_ug_per_rthz = 25.0
k2_ug_per_g2 = {k2}
k3_ug_per_g3 = {k3}
"""
def _h2(f: float, fn: float, q: float) -> float:
    r = f / fn
    return 1.0 / ((1 - r * r) ** 2 + (r / q) ** 2)


def _draw(seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    return dict(k2=rng.uniform(-3000, 3000), k3=rng.uniform(-400, 400), fn=rng.uniform(900, 1500),
                q=rng.uniform(2.5, 6.0), rail=rng.uniform(1.9, 2.3))


def _design(t: dict[str, float]) -> list[ExampleRun]:
    """A campaign a lab would run on a part whose resonance it knows roughly: sine at 80 Hz,
    0.5, 0.8 and 1.25·fn at +1 g and -1 g (peaks kept 40 % clear of the rails), and random
    50-500 Hz at both orientations reaching into the rails."""
    room = t["rail"] - 1.0
    runs = []
    for g0 in (1.0, -1.0):
        for f in (80.0, 0.5 * t["fn"], 0.8 * t["fn"], 1.25 * t["fn"]):
            top = 0.6 * room / (math.sqrt(2) * math.sqrt(_h2(f, t["fn"], t["q"])))
            runs.append(ExampleRun("memory", g0, f, (top / 3, 2 * top / 3, top)))
        runs.append(ExampleRun("memory", g0, None, tuple(room * x for x in (0.3, 0.45, 0.6))))
    return runs


def _part(t: dict[str, float], folder: Path) -> Path:
    path = folder / f"part-{t['fn']:.6f}.toml"
    path.write_text(PART.format(**t))
    return path


@pytest.fixture(scope="module")
def drawn(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """One drawn part (seed 3), its campaign and identification, its sensor file."""
    d = tmp_path_factory.mktemp("identify")
    t = _draw(3)
    part = _part(t, d)
    doc = campaign_document(load_sensor(str(part)), _design(t), seed=3, seconds=2.0, settle_s=0.2)
    ident = identify(doc, "ideal")
    sensor_file = write_sensor_file(d / "sensor.toml", ident)
    return {"truth": t, "part": part, "doc": doc, "ident": ident, "file": sensor_file, "dir": d}


def test_identified_model_is_the_predict_model(drawn: dict) -> None:
    """One owner: every level's model value in the identification equals `predict` run on the
    written sensor file at that level's conditions (identify and predict cannot drift apart)."""
    sensor = load_sensor(str(drawn["file"]), axis="dut")
    ch = drawn["ident"].channels[0]
    profile = RandomProfile.flat(50.0, 500.0)
    for run in ch.runs:
        rms = [r["rms_g"] for r in run["residuals"]]
        exc = profile if run["method"] == "random" else [run["freq_hz"]]
        pred = predict(sensor, exc, rms, static_g=run["static_g"])
        got = [lv.vre_g for lv in pred.levels]
        want = [r["model_g"] for r in run["residuals"]]
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12), run["label"]


def test_prediction_in_an_environment_the_campaign_did_not_use(drawn: dict) -> None:
    """The identified part predicts VRE under a vibration the campaign never ran (random
    20-1000 Hz sloping -3 dB/oct, at +1 g and at 0 g, a level reaching the rails): the
    prediction with its u_vre_g (the identified covariance) agrees with the simulated truth
    within 3·sqrt(u_pred² + u_sim²)."""
    from vrelab.shaker import run_test
    from vrelab.simulation.plan import TestPlan

    env = RandomProfile.from_breakpoints([20.0, 200.0, 1000.0], [0.02, 0.02, 0.004])
    truth_sensor = load_sensor(str(drawn["part"]))
    ident_sensor = load_sensor(str(drawn["file"]), axis="dut")
    room = drawn["truth"]["rail"]
    for g0 in (1.0, 0.0):
        levels = (0.35 * room, 0.55 * room)
        sim = run_test(TestPlan.random(truth_sensor, env, levels, static_g=g0, seconds=4.0, baseline_s=2.0, seed=77))
        pred = predict(ident_sensor, env, [lv.rms_g for lv in sim.levels], static_g=g0)
        for s, p in zip(sim.levels, pred.levels):
            assert p.u_vre_g is not None and p.u_vre_g > 0
            tol = 3 * math.hypot(p.u_vre_g, s.vre.u)
            assert abs(p.vre_g - s.vre.value) <= tol, (g0, s.rms_g, p.vre_g, s.vre.value, tol)


def test_propagated_u_agrees_with_monte_carlo_over_the_covariance(drawn: dict) -> None:
    """GUM Supplement 1 check: draw the parameters from N(θ, Σ) of the sensor file (seeded),
    predict each draw; the spread of the predictions agrees with the linear propagation within
    10 % (u in the tens of per cent of VRE: the propagation is linear on that scale)."""
    from vrelab.sensor.parameters import parameter, with_parameters

    sensor = load_sensor(str(drawn["file"]), axis="dut")
    cov = sensor.covariance
    names, sigma = cov["params"], np.array(cov["matrix"])
    theta = np.array([parameter(sensor, n) for n in names])
    env = RandomProfile.flat(20.0, 1000.0)
    levels = [0.3, 0.6]
    u = propagated_u(sensor, env, levels, 1.0)
    rng = np.random.default_rng(20261125)
    draws = rng.multivariate_normal(theta, sigma, size=400)
    vre = np.array([[lv.vre_g for lv in predict(with_parameters(sensor, dict(zip(names, x))), env, levels, 1.0).levels]
                    for x in draws])
    mc = vre.std(axis=0, ddof=1)
    assert np.all(np.abs(mc / u - 1) < 0.1), (mc, u)


def test_sensor_file_works_in_predict_simulate_and_sweep(drawn: dict, capsys: pytest.CaptureFixture[str]) -> None:
    """The written file is a sensor file: every number marked, usable as --sensor with
    --axis <channel> in predict (with u_vre_g), simulate and sweep."""
    f = str(drawn["file"])
    s = load_sensor(f, axis="dut")
    ch = drawn["ident"].channels[0]
    for n in ("k2_per_g", "k3_per_g2", "fn_hz", "q", "rails_g"):
        assert s.facts[n].startswith("identified from") or "identified from" in s.facts[n], (n, s.facts[n])
    assert s.overrange_threshold_g is None and "from base sensor ideal" in s.facts["overrange_threshold_g"]
    assert s.k2_per_g * 1e6 == pytest.approx(ch.parameters["k2_ug_per_g2"].value, rel=1e-12)
    assert main(["predict", "--sensor", f, "--axis", "dut", "--profile", "flat:20-1000", "--levels", "0.5", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["levels"][0]["u_vre_g"] > 0
    assert main(["simulate", "--sensor", f, "--axis", "dut", "--freq", "300", "--levels", "0.3", "--seconds", "2",
                 "--json"]) == 0
    sim = json.loads(capsys.readouterr().out)
    assert sim["conditions"]["axis"] == "dut" and sim["levels"][0]["vre_g"] is not None
    sweep = drawn["dir"] / "sweep.toml"
    sweep.write_text(f'kind = "predict"\nseed = 1\n[fixed]\nsensor = "{f}"\naxis = "dut"\nprofile = "flat:20-1000"\n'
                     '[grid]\nrms_g = "0.3,0.6"\n')
    assert main(["sweep", str(sweep), "--out", str(drawn["dir"] / "sweep-out"), "--json"]) == 0


def _campaign_of(runs: list[ExampleRun], seed: int = 5) -> dict:
    """An ideal part (no resonance, rails ±2 g) with k2 = 2000 µg/g², k3 = 300 µg/g³ and
    25 µg/√Hz of noise (a noise-free record has no uncertainty to test against)."""
    import dataclasses

    sensor = dataclasses.replace(load_sensor("ideal", k2_ug_per_g2=2000.0, k3_ug_per_g3=300.0), noise_ug_per_rthz=25.0)
    return campaign_document(sensor, runs, seed=seed, seconds=2.0, settle_s=0.2)


def test_one_orientation_gives_null_k3_and_k2_with_reasons() -> None:
    """Honest nulls: sine runs at +1 g only determine k2 + 3·k3·g0, never k2 and k3 apart:
    both null with the reason, the combination in the notes (truth 2000 + 900 µg/g²)."""
    doc = _campaign_of([ExampleRun("m", 1.0, 80.0, (0.3, 0.6, 0.9)), ExampleRun("m", 1.0, 200.0, (0.3, 0.6, 0.9))])
    ch = identify(doc, "ideal").channels[0]
    assert ch.parameters["k3_ug_per_g3"] is None and ch.parameters["k2_ug_per_g2"] is None
    assert "one orientation only" in ch.reasons["k3_ug_per_g3"]
    assert "not separable" in ch.reasons["k2_ug_per_g2"]
    note = next(n for n in ch.notes if n.startswith("one orientation: k2 + 3·k3·g0 ="))
    value = float(note.split("=")[1].split("±")[0])
    u = float(note.split("±")[1].split("µg")[0])
    assert abs(value - 2900.0) <= 3 * u
    for n in ("fn_hz", "q"):  # the ideal part has no resonance; two frequencies show none
        assert ch.parameters[n] is None


def test_zero_g_orientation_determines_k2_not_k3() -> None:
    """At 0 g VRC = k2: k2 identified (truth 2000 µg/g² within 3u), k3 null (one orientation)."""
    doc = _campaign_of([ExampleRun("m", 0.0, 80.0, (0.3, 0.6, 0.9))])
    ch = identify(doc, "ideal").channels[0]
    k2 = ch.parameters["k2_ug_per_g2"]
    assert k2 is not None and abs(k2.value - 2000.0) <= 3 * k2.u
    assert ch.parameters["k3_ug_per_g3"] is None and "one orientation only" in ch.reasons["k3_ug_per_g3"]
    assert "one frequency only" in ch.reasons["fn_hz"] and "no random run" in ch.reasons["rail_high_g"]


def test_type_b_terms_enter_the_covariance(drawn: dict) -> None:
    """A reference-sensitivity error r scales every level's rms by 1 + r, so k2 and k3 move by
    about -2r (SPEC 4.3); declared at 1 %, the refit's shifts say so and u grows accordingly."""
    from vrelab.gum import TypeB

    plain = drawn["ident"].channels[0]
    with_b = identify(drawn["doc"], "ideal", options=IdentifyOptions(typeb=TypeB(u_reference_pct=1.0))).channels[0]
    (term,) = with_b.budget
    assert term["source"] == "reference sensitivity"
    for n in ("k2_ug_per_g2", "k3_ug_per_g3"):
        shift = term["shifts"][n]
        assert shift == pytest.approx(-2 * 0.01 * plain.parameters[n].value, rel=0.1)
        assert with_b.parameters[n].u == pytest.approx(math.hypot(plain.parameters[n].u, shift), rel=1e-6)


def test_cli_identify_contract(example_campaign_out: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """SPEC 5.1: --json prints sensor_file and channels with parameters {value, u} or null,
    chi2_reduced and notes; the sensor file loads for every channel; the example's truth is
    recovered where determined (k2, k3, the upper rail within 3u)."""
    camp = example_campaign_out / "camp"  # `vrelab campaign` of EXAMPLE, once per run (tests/conftest.py): read only
    out = tmp_path / "ident"
    assert main(["identify", str(camp), "--out", str(out), "--workers", "2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert Path(doc["sensor_file"]).is_file()
    truth = example_truth()
    for ch, part in zip(doc["channels"], truth.parts):
        p = ch["parameters"]
        assert set(p) == {"k2_ug_per_g2", "k3_ug_per_g3", "fn_hz", "q", "rail_low_g", "rail_high_g",
                          "overrange_threshold_g", "kip_ug_per_g2", "kpp_ug_per_g2", "kio_ug_per_g2", "koo_ug_per_g2"}
        # no run mounted at an angle: IEEE 1293's cross-coupling coefficients are null with the reason (SPEC 1.6)
        assert p["kip_ug_per_g2"] is None and "no run mounted at an angle" in ch["null_reasons"]["kip_ug_per_g2"]
        assert all(v is None or {"value", "u"} <= set(v) for v in p.values())
        assert isinstance(ch["chi2_reduced"], float) and isinstance(ch["notes"], list)
        for name, want in (("k2_ug_per_g2", part.k2_ug_per_g2), ("k3_ug_per_g3", part.k3_ug_per_g3),
                           ("rail_high_g", truth.rail_g)):
            assert abs(p[name]["value"] - want) <= 3 * p[name]["u"], (ch["channel"], name, p[name], want)
        assert p["overrange_threshold_g"] is None and "over-range" in ch["null_reasons"]["overrange_threshold_g"]
        load_sensor(doc["sensor_file"], axis=ch["channel"])
    obs, _ = observations(json.loads((camp / "results.json").read_text()))
    assert set(obs) == {"sn1", "sn2"}
    # the folder's report: a section per channel with its parameters, the nulls with their reasons;
    # with the shipped metadata, whose [items.sn1] and [items.sn2] are this campaign's channels
    # (issue 30: the identify report knew no channel and refused it: "channels: none named")
    metadata = EXAMPLE.parent.parent / "report-metadata.toml"
    assert main(["report", str(out), "--metadata", str(metadata)]) == 0
    html = (out / "report.html").read_text()
    assert "SN 0001" in html and "SN 0002" in html
    assert "Channel sn1" in html and "Channel sn2" in html and "2f cross-check" in html
    assert "do not reach the lower rail" in html and html.count("<img") >= 4


def test_identify_names_options_of_the_wrong_type() -> None:
    # a dict in place of IdentifyOptions used to fail deep inside with an AttributeError
    with pytest.raises(TypeError, match="options must be an IdentifyOptions, not dict"):
        identify({"runs": []}, "ideal", options={"kind": "clip"})  # type: ignore[arg-type]
