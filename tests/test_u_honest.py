"""An uncertainty is a claim: noiseless sine levels and random-level rms against independent truths.

* Sine, noiseless sensor: the VRE against closed forms written here (SPEC 1.1: a sine clipped at
  the rails; SPEC 1.2: ``VRE = (k2 + 3·k3·g0)·rms²`` for a sine, E[x²] = rms², E[x³] = 0; a
  linear axis: 0). Before the fix the frequency estimate's last 1e-10 (its residual is flat at
  the minimum) left 1e-10 of the drive's amplitude in the DC with a u of 1e-16: a linear ideal
  axis gave -1.2e-10 g ± 4e-15 g. Now |error| <= 2u, and u is not absurdly larger than the
  error (the arithmetic's floor for a linear axis; within 100× for a clipped one).
* Random, the level's rms: over replicated seeds against the drive's own rms, the profile's
  grms (the simulated reference is the drive; ``vrelab.synthesis.random_blocks``' Gaussian
  drive has expected PSD and rms those of the profile). Coverage of ±1u and ±2u within the 99 %
  binomial limits of 0.6827 and 0.9545 over independent levels (each level's drive is an
  independent realisation). Before the fix (u from the scatter of 4-10 window powers) it covered
  ±2u 0.85 of the time on a 20-2000 Hz profile.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

# SPEC 1.1's clipped-sine closed form, written in test_coverage (held there to SPEC 1.1's -68.3 mg)
from test_coverage import _sine_clip_closed_form
from vrelab import shaker
from vrelab.profiles import parse_profile
from vrelab.sensor import load_sensor

# (freq Hz, level g rms, static g, k2 /g, k3 /g²); range ±2 g unless the level stays inside ±8 g
SINE_CASES = [
    (80.0, 1.0, 1.0, 0.0, 0.0),  # clipped at +2 g: SPEC 1.1's -68.3 mg
    (1000.0, 1.0, 1.0, 0.0, 0.0),
    (2500.0, 1.2, -1.0, 0.0, 0.0),  # clipped at -2 g
    (80.0, 0.3, 1.0, 0.0, 0.0),  # linear: truth 0
    (1003.0, 0.3, 1.0, 0.0, 0.0),
    (2500.0, 0.5, -1.0, 0.0, 0.0),
    (80.0, 2.0, 1.0, 100e-6, 0.0),  # SPEC 1.2, on a ±8 g ideal axis
    (1003.0, 0.5, 1.0, -300e-6, 20e-6),
    (2500.0, 2.0, -1.0, 0.0, 50e-6),
]


@pytest.mark.parametrize("freq,level,g0,k2,k3", SINE_CASES)
def test_noiseless_sine_vre_within_2u_and_u_not_absurd(freq, level, g0, k2, k3):
    clipped = k2 == 0 and k3 == 0 and abs(g0) + math.sqrt(2) * level > 2.0
    assert not (k2 or k3) or abs(g0) + math.sqrt(2) * level < 8.0  # SPEC 1.2 holds unclipped only
    rng = 2.0 if (k2 == 0 and k3 == 0) else 8.0
    sensor = dataclasses.replace(load_sensor("ideal", range_g=rng), k2_per_g=k2, k3_per_g2=k3)
    res = shaker.run_sine_test(sensor, [freq], [level], static_g=g0, seconds=2.0, seed=0)
    (lv,) = res.levels
    if clipped:
        truth = _sine_clip_closed_form(g0, math.sqrt(2) * level, -rng, rng)
    else:
        truth = (k2 + 3 * k3 * g0) * level**2
    err = lv.vre.value - truth
    print(f"{freq} Hz {level} g rms g0={g0} k2={k2} k3={k3}: error {err:+.3e} g, u {lv.vre.u:.3e} g, "
          f"u/|error| {lv.vre.u / abs(err) if err else math.inf:.3g}")
    assert abs(err) <= 2 * lv.vre.u, (err, lv.vre.u)
    # not absurdly larger: within 100× of the error, or at the arithmetic's floor (ε·log₂(n)·
    # |output|, ~1e-14 g) where the fit is exact and the error is rounding. The bounds behind u
    # (the lattice rule of a clipped output, vrelab.shaker.with_lattice_u; the leakage of a
    # harmonic beyond the fit over a batch that is not quite whole periods) are within 100× of
    # the error they bound.
    assert lv.vre.u <= max(100 * abs(err), 1e-13), (err, lv.vre.u)
    # the level itself: the drive's rms, exactly up to the arithmetic, and within its u
    assert abs(lv.rms_g - level) <= 2 * lv.u_rms_g + 1e-15 * level, (lv.rms_g - level, lv.u_rms_g)
    assert lv.u_rms_g < 1e-13


def test_linear_axis_noiseless_the_finding():
    """The finding: a linear ideal axis (no nonlinearity, no clipping: truth exactly 0) gave
    -1.2e-10 g ± 4e-15 g. The value is now 0 to the arithmetic's precision."""
    res = shaker.run_sine_test(load_sensor("ideal", range_g=2.0), [1000.0], [0.3], static_g=1.0, seconds=2.0, seed=0)
    (lv,) = res.levels
    assert abs(lv.vre.value) < 1e-14
    assert abs(lv.vre.value) <= 2 * lv.vre.u


def test_linear_adxl355_noiseless_lattice_u_is_not_absurd():
    """The ADXL355 Z chain (resonance, filters, decimation) made linear and noiseless, at 1 kHz:
    its 4 kHz output meets 4 phases of the drive, so the drive runs on a lattice
    (vrelab.simulation.plan.sine_drive); a linear chain's VRE is 0 (filters pass DC at unit gain
    and make none). The lattice bound of a clipped output (2e-6 g) was claimed here over an
    error of 1e-15 g; a level the chain neither clipped nor tripped is averaged exactly."""
    base = load_sensor("adxl355", axis="z")
    sensor = dataclasses.replace(base, noise_ug_per_rthz=0.0, lsb_g=None, k2_per_g=0.0, k3_per_g2=0.0, k4_per_g3=0.0)
    (lv,) = shaker.run_sine_test(sensor, [1000.0], [0.8], static_g=1.0, seconds=2.0, seed=0).levels
    assert "saturated" not in lv.flags
    assert abs(lv.vre.value) <= 2 * lv.vre.u
    assert lv.vre.u < 1e-13, lv.vre.u


# --- random: the level's rms over replicated seeds ----------------------------------------------


def _limits(p: float, n: int) -> tuple[float, float]:
    lo, hi = stats.binom.interval(0.99, n, p)
    return lo / n, hi / n


def _rms_z(profile: str, seeds: int, levels: int = 4, seconds: float = 2.0) -> np.ndarray:
    sensor = load_sensor("ideal", range_g=50.0)
    prof = parse_profile(profile)
    z = []
    for seed in range(seeds):
        res = shaker.run_random_test(sensor, prof, [1.0] * levels, static_g=1.0, seconds=seconds, baseline_s=2.0,
                                     seed=seed)
        for lv in res.levels:
            z.append((lv.rms_g - 1.0) / lv.u_rms_g)
    return np.array(z)


def _coverage(z: np.ndarray) -> tuple[float, float]:
    return float(np.mean(np.abs(z) <= 1)), float(np.mean(np.abs(z) <= 2))


@pytest.mark.parametrize("profile", ["flat:50-500", "flat:20-2000"])
def test_random_level_rms_u_covers_the_drive_rms(profile):
    z = _rms_z(profile, 30)
    n = len(z)
    c1, c2 = _coverage(z)
    print(f"{profile}: n={n} levels, coverage ±1u {c1:.3f}, ±2u {c2:.3f}, mean z² {np.mean(z**2):.2f}")
    lo1, hi1 = _limits(0.6827, n)
    lo2, hi2 = _limits(0.9545, n)
    assert lo1 <= c1 <= hi1, (c1, (lo1, hi1))
    assert lo2 <= c2 <= hi2, (c2, (lo2, hi2))


def test_random_level_rms_u_from_window_scatter_alone_undercovers(monkeypatch):
    """The failure fixed, on the same levels: with u from the scatter of a level's window powers
    alone (4 windows of 0.2 s in a 20-2000 Hz level: 3 degrees of freedom), ±2u covers well
    below 0.9545."""
    import vrelab.analysis.levels as LV

    monkeypatch.setattr(LV, "random_level_u_ms", lambda pm, stats, k0, k1: pm.u)
    z = _rms_z("flat:20-2000", 30)
    c1, c2 = _coverage(z)
    print(f"window scatter alone: coverage ±1u {c1:.3f}, ±2u {c2:.3f}, mean z² {np.mean(z**2):.2f}")
    assert c2 < _limits(0.9545, len(z))[0]
