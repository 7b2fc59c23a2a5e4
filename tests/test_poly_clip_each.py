"""``poly_clip_each`` (several pairs of rails in one call, what every prediction asks at each level)
against ``poly_clip_vre`` called pair by pair: the same model, so the same numbers.

The prediction's speed-up (one array pass over a level's rail pairs, a shared sum for sines that
stay clear of the rails) must not change what it predicts. On the machine that wrote them the two
agree bit for bit (bench/check_model_exact.py); here they are held to 1e-12 relative, so that a
CPU whose vectorised exp/erfc rounds an array differently from a scalar (numpy's SIMD loops) cannot
fail the test while any real difference (a wrong piece, a dropped term: 1e-3 or more) does.
"""

import math

import numpy as np
import pytest

from vrelab.models.memoryless import poly_clip_each, poly_clip_vre

INF = math.inf


def _cases(rng: np.random.Generator, n: int):
    for _ in range(n):
        g0 = float(rng.uniform(-1.5, 1.5))
        rms = float(rng.choice([0.0, rng.uniform(0.05, 4.0)]))
        k = (float(rng.normal(0, 3e-3)), float(rng.normal(0, 1e-3)), float(rng.normal(0, 3e-4)))
        lo, hi = float(rng.uniform(-6.0, -0.5)), float(rng.uniform(0.5, 6.0))
        lo, hi = min(lo, g0 - 0.1), max(hi, g0 + 0.1)  # the field inside the rails
        rails = [(lo, hi), (lo, INF), (-INF, hi), (-INF, INF)]
        yield g0, rms, k, rails, float(rng.normal(0, 0.01))


# tones ride on Gaussian vibration only, and need a random part (both functions refuse otherwise)
@pytest.mark.parametrize(("shape", "tones"), [("gaussian", ()), ("sine", ()), ("gaussian", (0.3,))])
@pytest.mark.parametrize("kind", ["censored", "truncated"])
def test_each_pair_is_what_poly_clip_vre_gives_for_it(shape, kind, tones):
    rng = np.random.default_rng(20261129)
    for g0, rms, k, rails, offset in _cases(rng, 60):
        if tones and rms == 0:
            continue
        each = poly_clip_each(g0, rms, k, rails, offset_g=offset, shape=shape, kind=kind, tone_peaks_g=tones)
        one = [poly_clip_vre(g0, rms, *k, offset_g=offset, rail_low_g=a, rail_high_g=b, shape=shape, kind=kind,
                             tone_peaks_g=tones) for a, b in rails]
        assert len(each) == len(rails)
        for got, want, pair in zip(each, one, rails):
            assert got == pytest.approx(want, rel=1e-12, abs=1e-18), (g0, rms, k, pair, offset, shape, kind, tones)


def test_tones_without_a_random_part_are_refused_alike():
    with pytest.raises(ValueError, match="tones alone"):
        poly_clip_each(0.0, 0.0, (0.0, 0.0, 0.0), [(-2.0, 2.0)], tone_peaks_g=(0.3,))


def test_bad_rails_are_refused_in_one_line():
    with pytest.raises(ValueError, match="rail_low_g must be < rail_high_g"):
        poly_clip_each(0.0, 1.0, (0.0, 0.0, 0.0), [(-2.0, 2.0), (2.0, -2.0)])
