"""Each stage owns its mean shift (vrelab.sensor.meanshift); predict sums what the stages say.

The refactor from string tags to stage-owned closed forms must not change the physics: the
first test holds predict against its own results recorded on commit b3d26ac (the tag-dispatch
predict) over a grid of sensors, profiles, levels, static fields and clipping kinds
(tests/data/predict_stages_reference.py wrote tests/data/predict_stages_reference.json there).
That is a regression reference against the previous implementation; the independent truths
(Monte Carlo, quadrature, the simulated chain) are in tests/test_predict_exact.py.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from vrelab.prediction import predict
from vrelab.profiles import RandomProfile
from vrelab.sensor import StageBase, load_sensor

DATA = Path(__file__).parent / "data"
sys.path.insert(0, str(DATA))
import predict_stages_reference as ref  # noqa: E402

# The recorded values are spectral integrals (scipy quad, epsrel 1e-10 in models.dynamics) and
# closed forms built on numpy's exp/erf, whose last bits depend on the SIMD path the CPU takes
# (AVX-512 vs AVX2 kernels differ by an ulp or two); an adaptive quadrature can then split an
# interval differently and move its result anywhere within its own tolerance, and a bound that is
# a difference of such numbers (model_error_g of 4.8e-11 g) loses more relative digits still.
# A share that is a far rail's rounding residue (1e-17 g on one CPU, 2e-17 g on another) has no
# relative digits at all: 1e-14 g absolute is a few ulps of the 1 g quantities it is a
# difference of, and a hundred-millionth of a µg, far below anything printed. 1e-9 relative is ten
# times the quadrature's tolerance.
REL = 1e-9
ABS = 1e-14


def _same(got, want, where):
    if want is None:
        assert got is None, where
    elif want == "nan":
        assert got == "nan", (where, got)
    else:
        # recorded to 15 significant digits; compared within what the computation holds (REL, ABS)
        assert got == pytest.approx(want, rel=REL, abs=ABS), (where, got, want)


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
    # a sensor that keeps its assumed u: that u's propagation changed on purpose with issue 28 (the
    # secant over ± u, a Monte Carlo where the VRE is curved in the assumption), and the notes and
    # validity with it; its physics (VRE, shares, rms) is still held here, its u by
    # tests/test_assumptions_u.py and tests/test_identify_honest.py
    keeps_u = next(s for s in ref.SENSORS if s[0] == sensor)[4]
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
        assert keeps_u or [notes[i] if i < len(notes) else "(new) " + sorted(table, key=table.get)[i]
                           for i in got["notes"]] == [notes[i] for i in want["notes"]], spec
        assert len(got["levels"]) == len(want["levels"]), spec
        for lg, lw in zip(got["levels"], want["levels"]):
            where = (spec, lw["rms_g"], lw["freq_hz"])
            assert (lg["rms_g"], lg["freq_hz"], lg["valid_otherwise"]) == \
                   (lw["rms_g"], lw["freq_hz"], lw["valid_otherwise"]), where
            assert keeps_u or lg["valid"] == lw["valid"], where
            assert keeps_u or [notes[i] if i < len(notes) else sorted(table, key=table.get)[i] for i in lg["notes"]] == \
                   [notes[i] for i in lw["notes"]], where
            for key in ("vre_g", "tilt_error_deg", "sigma_proof_mass_g", "sigma_output_g", "sigma_at_clip_g",
                        "overrange_rate_hz", "model_error_g") + (() if keeps_u else ("u_vre_g",)):
                _same(lg[key], lw[key], (where, key))
            assert list(lg["shares"]) == list(lw["shares"]), where
            for key, v in lw["shares"].items():
                _same(lg["shares"][key], v, (where, key))
            assert (lg["u_sources_g"] is None) == (lw["u_sources_g"] is None), where
            if lw["u_sources_g"] is not None and not keeps_u:
                assert list(lg["u_sources_g"]) == list(lw["u_sources_g"]), where
                for key, v in lw["u_sources_g"].items():
                    _same(lg["u_sources_g"][key], v, (where, key))


# --- the numerical fallback: a memoryless stage with no closed form --------------------------


@dataclasses.dataclass(frozen=True)
class _PolyRails(StageBase):
    """A user's memoryless stage with no mean_shift: rails after a polynomial, through process()
    only; its truth is the closed form poly_clip_vre (truncated normal moments on the pieces)."""

    k2: float
    k3: float
    low: float
    high: float

    def process(self, x, state, fs_hz):
        return np.clip(x + self.k2 * x * x + self.k3 * x**3, self.low, self.high), state


_MAPS = [
    (1.0, 1.0, 0.0, 0.0, -2.0, 2.0),  # SPEC 1.1: -83 mg censored Gaussian, -68.3 mg sine
    (1.0, 0.7, 0.02, -0.01, -2.0, 2.0),
    (0.0, 2.5, 0.05, 0.0, -1.5, 3.0),
    (-1.0, 0.3, 1e-3, 2e-4, -2.0, 2.0),  # clear of the rails: a smooth map, Gauss-Hermite exact
    (1.9, 0.05, 0.0, 0.0, -2.0, 2.0),  # close to a rail, small vibration
]


@pytest.mark.parametrize("shape,tones,g0,rms,k2,k3,low,high",
                         [("gaussian", (), *m) for m in _MAPS] + [("sine", (), *m) for m in _MAPS]
                         + [("gaussian", (0.6, 0.3), *m) for m in _MAPS[:2]])  # the tones' phase grid: slower
def test_the_quadrature_fallback_meets_the_closed_forms_within_its_error(shape, tones, g0, rms, k2, k3, low, high):
    from vrelab.models.memoryless import map_vre, poly_clip_vre
    from vrelab.sensor.meanshift import memoryless_map

    f = memoryless_map(_PolyRails(k2, k3, low, high))
    value, err = map_vre(f, g0, rms, shape=shape, tone_peaks_g=tones)
    truth = poly_clip_vre(g0, rms, k2, k3, rail_low_g=low, rail_high_g=high, shape=shape, tone_peaks_g=tones)
    # the error a number, not a shrug: well below predict's 1 µg floor (looser with the tones' many kinks)
    assert err < (1e-6 if tones else 1e-9)
    # the stated error holds (with a floor for the closed form's own rounding)
    assert abs(value - truth) <= err + 1e-14 + 1e-12 * abs(truth), (value, truth, err)
    if (g0, rms, shape, tones) == (1.0, 1.0, "gaussian", ()):
        assert value == pytest.approx(-0.0829, abs=1e-4)  # SPEC 1.1's -83 mg


def test_the_fallback_takes_over_only_where_the_map_is_not_smooth():
    from vrelab.models.memoryless import map_vre

    # a polynomial: Gauss-Hermite is exact (its two node counts agree), E[k2·x²] = k2·σ² (SPEC 1.2)
    value, err = map_vre(lambda y: y + 3e-3 * y * y, 0.0, 2.0)
    assert value == pytest.approx(3e-3 * 4.0, rel=1e-13) and err < 1e-15
    # tanh: E[tanh(g0 + σZ)] against scipy's adaptive quadrature of the integral written out
    from scipy import integrate

    truth = integrate.quad(lambda z: np.tanh(0.4 + 1.3 * z) * np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi),
                           -40, 40, epsabs=1e-14, limit=400)[0] - np.tanh(0.4)
    value, err = map_vre(np.tanh, 0.4, 1.3)
    assert abs(value - truth) <= err + 1e-13


def test_predict_takes_a_user_memoryless_stage_by_quadrature_at_its_site():
    """A user stage with only process(): predict gives its mean at the vibration that reaches it
    through the resonance before it, valid, with the quadrature's error as model_error_g."""
    from vrelab.models.memoryless import poly_clip_vre
    from vrelab.sensor.stages import Resonator

    base = load_sensor("ideal")

    class Custom(type(base)):
        def stages(self, fs_hz=None):
            return (Resonator(1500.0, 20.0), _PolyRails(0.01, 0.0, -2.0, 2.0))

    s = Custom(**{f.name: getattr(base, f.name) for f in dataclasses.fields(base)})
    p = predict(s, RandomProfile.flat(50.0, 2000.0), [1.0, 1.5], static_g=1.0)
    for lv in p.levels:
        # the closed form on the proof-mass rms predict reports (σ_m² = ∫S|H|²df)
        truth = poly_clip_vre(1.0, lv.sigma_proof_mass_g, 0.01, rail_low_g=-2.0, rail_high_g=2.0)
        assert lv.valid, lv.notes
        assert lv.vre_g == pytest.approx(truth, rel=1e-9)
        assert lv.shares["numerical_g"] == lv.vre_g and 0 <= lv.model_error_g < 1e-9
    assert p.vibration_off_g == pytest.approx(1.01, rel=1e-15)  # P(1 g) = 1 + 0.01
    assert any("_PolyRails" in n and "quadrature" in n for n in p.notes)
    # with another nonlinearity in the chain, neither sees the other's output: not valid, named
    class Two(type(base)):
        def stages(self, fs_hz=None):
            return (_PolyRails(0.01, 0.0, -2.0, 2.0), *super().stages(fs_hz))

    lv = predict(Two(**{f.name: getattr(base, f.name) for f in dataclasses.fields(base)}),
                 RandomProfile.flat(50.0, 2000.0), [1.0], static_g=1.0).levels[0]
    assert not lv.valid and any("_PolyRails" in n and "Clip" in n for n in lv.notes)


def test_a_stage_with_memory_and_no_closed_form_is_named_not_guessed():
    base = load_sensor("ideal")

    @dataclasses.dataclass(frozen=True)
    class Smear(StageBase):
        is_static = False

        def process(self, x, state, fs_hz):
            return x, state

    class Odd(type(base)):
        def stages(self, fs_hz=None):
            return (Smear(), *super().stages(fs_hz))

    lv = predict(Odd(**{f.name: getattr(base, f.name) for f in dataclasses.fields(base)}),
                 RandomProfile.flat(50.0, 2000.0), [1.0], static_g=1.0).levels[0]
    assert not lv.valid and any("Smear" in n and "no closed form" in n for n in lv.notes)
