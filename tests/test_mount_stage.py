"""The Mount stage (issue 32): a PCB or bracket's base-excitation transmissibility between the
environment and the part, in predict and in simulate, held to the closed form.

The closed form is written out here from the textbook, independently of
``vrelab.sensor.mount``: a single-degree-of-freedom system under base excitation transmits

    |T(f)|² = (1 + (2ζr)²) / ((1 − r²)² + (2ζr)²),  r = f/fn,  ζ = 1/(2Q)

(D. S. Steinberg, Vibration Analysis for Electronic Equipment, 3rd ed., §2.9; S. S. Rao,
Mechanical Vibrations, eq. 3.68). A part with only a second-order nonlinearity k2 (the ideal
preset, rails far away) reads the mean ``k2·E[a²]`` of what reaches it: ``k2·A²|T|²/2`` for a
sine of amplitude A, ``k2·∫S|T|²df`` for a Gaussian random PSD S.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import integrate, signal

import vrelab
from vrelab.sensor import load_sensor
from vrelab.sensor.mount import MountTransmissibility

FN, Q = 400.0, 10.0
K2 = 1000.0  # µg/g²: a large k2 so that the VRE stands far above the simulation's scatter


def t2(f: float | np.ndarray, fn: float = FN, q: float = Q) -> np.ndarray:
    """|T|² of the base-excited oscillator (module docstring), from the textbook formula."""
    r = np.asarray(f, dtype=float) / fn
    two_zeta_r = r / q  # 2ζr with ζ = 1/(2Q)
    return (1 + two_zeta_r**2) / ((1 - r**2) ** 2 + two_zeta_r**2)


def mounted(**kw: float) -> vrelab.Sensor:
    # ±50 g rails: at 1 g rms through a Q of 10 the part sees under 3 g rms, so clipping is
    # beyond 16 sigma (exp(-128): no share)
    return load_sensor("ideal", range_g=50, overrides={"k2_ug_per_g2": K2, "mount_fn_hz": FN, "mount_q": Q, **kw})


def test_the_stage_response_and_its_discretisation_are_the_textbook_transmissibility():
    st = MountTransmissibility(FN, Q)
    f = np.array([0.0, 10.0, 100.0, 399.0, 400.0, 401.0, 800.0, 1000.0])
    # 1e-12: the same formula, a few roundings of a complex division apart
    np.testing.assert_allclose(np.abs(st.response(f)) ** 2, t2(f), rtol=1e-12)
    assert st.response(0.0) == 1.0  # the static field passes unchanged
    # the second-order sections the simulation runs, at the rate it picks for a 1 kHz drive
    from vrelab.rates import simulation_rate_hz

    fs = simulation_rate_hz(mounted(), 1000.0)
    assert fs >= 5 * FN
    w, h = signal.sosfreqz(st.design(fs), worN=np.linspace(1.0, fs / 8, 400), fs=fs)
    # 0.2 %: the fitted numerator's documented match (0.03 % for a resonance alone, here with its
    # zero; vrelab.sensor.filtering.discretize_zpk) with room for the zero's extra curvature
    np.testing.assert_allclose(np.abs(h) ** 2, t2(w), rtol=2e-3)


def test_predict_holds_the_closed_form_sine_and_random():
    s = mounted()
    # sine: every level at 300 Hz, A = rms·√2: VRE = k2·rms²·|T|² (rel 1e-9: a closed form both ways)
    pred = vrelab.predict(s, 300.0, [0.5, 1.0], static_g=0.0)
    for lv in pred.levels:
        assert lv.valid
        assert lv.vre_g == pytest.approx(K2 * 1e-6 * lv.rms_g**2 * t2(300.0), rel=1e-9)
    # random: flat 50-1000 Hz at 1 g rms: VRE = k2·∫S|T|²df, scipy's quad on the textbook |T|²
    # (rel 1e-6: both integrals converge to 1e-9 or better; the prediction's own quadrature is
    # split at the resonance, so is this one)
    s0 = 1.0 / 950.0
    want, _ = integrate.quad(lambda f: s0 * float(t2(f)), 50.0, 1000.0, points=[FN], limit=200, epsabs=0, epsrel=1e-11)
    lv = vrelab.predict(s, vrelab.parse_profile("flat:50-1000"), [1.0], static_g=0.0).levels[0]
    assert lv.valid and lv.vre_g == pytest.approx(K2 * 1e-6 * want, rel=1e-6)
    # without the mount, the same part reads k2·σ²: the mount's whole effect is the ∫S|T|² above
    rigid = load_sensor("ideal", range_g=50, overrides={"k2_ug_per_g2": K2})
    bare = vrelab.predict(rigid, vrelab.parse_profile("flat:50-1000"), [1.0], static_g=0.0).levels[0]
    assert bare.vre_g == pytest.approx(K2 * 1e-6, rel=1e-9) and lv.vre_g > 5 * bare.vre_g


def test_simulate_agrees_with_predict_and_the_closed_form():
    """The simulated shaker drives the part through the mount's second-order section (its state
    carried across blocks); the reduced VRE agrees with the closed form within its U (k = 3 here:
    one seeded draw, a test that must not flake)."""
    s = mounted()
    s0 = 1.0 / 950.0
    want = K2 * 1e-6 * integrate.quad(lambda f: s0 * float(t2(f)), 50.0, 1000.0, points=[FN], limit=200)[0]
    res = vrelab.simulate(s, vrelab.parse_profile("flat:50-1000"), [1.0], static_g=0.0, seconds=4, seed=7)
    lv = res.levels[0]
    assert lv.vre.u > 0 and abs(lv.vre.value - want) <= 3 * lv.vre.u, (lv.vre.value, lv.vre.u, want)
    # and the mount changed what the simulation measured: the rigid part's k2·σ² is far outside
    assert abs(lv.vre.value - K2 * 1e-6) > 10 * lv.vre.u
    # a sine through the mount's section: deterministic, so held tightly to k2·rms²·|T(f)|²
    # (rel 1e-3: the discretised section matches |T| within 0.03 % at fs/8 and below, |T|² twice
    # that, plus the reduction's rounding; without the mount's zero |T(300 Hz)|² is 0.56 % off)
    sine = vrelab.simulate(s, None, [1.0], static_g=0.0, freq_hz=[300.0, 600.0], seconds=2, seed=7)
    for lv in sine.levels:
        assert lv.vre.value == pytest.approx(K2 * 1e-6 * t2(lv.freq_hz), rel=1e-3), lv.freq_hz


def test_the_fixture_rule_warns_of_a_mount_in_the_band():
    profile = vrelab.parse_profile("flat:50-1000")
    inside = vrelab.predict(mounted(), profile, [1.0], static_g=0.0)
    assert any("mount resonance 400 Hz (Q 10) is inside the vibration's band" in n for n in inside.notes)
    # 1.5 × 1000 Hz = 1500 Hz: a 1400 Hz mount is within reach of the band, a 1600 Hz one is not
    near = vrelab.predict(mounted(mount_fn_hz=1400.0), profile, [1.0], static_g=0.0)
    assert any("within 1.5× of" in n for n in near.notes)
    far = vrelab.predict(mounted(mount_fn_hz=1600.0), profile, [1.0], static_g=0.0)
    assert not any("mount resonance" in n for n in far.notes)
    rigid = vrelab.predict(load_sensor("ideal", range_g=50), profile, [1.0], static_g=0.0)
    assert not any("mount resonance" in n for n in rigid.notes)


def _cli(capsys, *argv: str) -> tuple[int, str, str]:
    from vrelab.cli import main

    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_the_cli_options_set_the_mount_and_refuse_half_of_one(capsys):
    base = ["predict", "--sensor", "ideal", "--range", "50", "--k2", str(K2), "--static", "0",
            "--freq", "300", "--levels", "1"]
    rc, out, err = _cli(capsys, *base, "--mount-fn", str(FN), "--mount-q", str(Q), "--json")
    assert rc == 0, err
    assert json.loads(out)["levels"][0]["vre_g"] == pytest.approx(K2 * 1e-6 * t2(300.0), rel=1e-9)
    rc, _, err = _cli(capsys, *base, "--mount-fn", str(FN))
    assert rc == 2 and err.strip().count("\n") == 0 and "--mount-fn and --mount-q go together" in err
    rc, _, err = _cli(capsys, *base, "--mount-fn", "0.5", "--mount-q", "5")
    assert rc == 2 and err.strip().count("\n") == 0 and "mount_fn_hz must be at least 1" in err


def test_triaxial_simulate_warns_of_the_mount_as_one_axis_does(capsys):
    """The fixture rule in planning (fn >= 1.5 × the highest test frequency, the rule's own
    numbers): a triaxial test on a mount inside its band warns as a single-axis one does, and a
    mount far above it does not."""
    common = ["simulate", "--sensor", "ideal", "--range", "50", "--k2", str(K2), "--static-vector", "0,0,1",
              "--direction", "1,0,1", "--levels", "1", "--seconds", "2", "--mount-q", str(Q)]
    rc, _, err = _cli(capsys, *common, "--profile", "flat:50-1000", "--mount-fn", str(FN))
    assert rc == 0, err
    assert "warning: mount resonance 400 Hz (Q 10) is inside the vibration's band 50-1000 Hz" in err
    rc, _, single = _cli(capsys, "simulate", "--sensor", "ideal", "--range", "50", "--static", "0", "--levels", "1",
                         "--seconds", "2", "--profile", "flat:50-1000", "--mount-fn", str(FN), "--mount-q", str(Q))
    assert rc == 0 and [ln for ln in single.splitlines() if "mount resonance" in ln] == \
        [ln for ln in err.splitlines() if "mount resonance" in ln]
    # a triaxial sine at 300 Hz: a 1000 Hz mount is beyond 1.5 × 300 Hz, no warning
    rc, _, err = _cli(capsys, *common, "--freq", "300", "--mount-fn", "1000")
    assert rc == 0 and "mount resonance" not in err
