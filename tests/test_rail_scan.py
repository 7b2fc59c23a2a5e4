"""The rail fit's departure scan without a full fit per candidate (vrelab._rail_scan, issue 29).

The fast scan must decide every departure exactly as the full fit of every candidate does (the
reported fit is the full fit's either way): here both run on the same seeded level sets near
the thresholds, the fast one as ``fit_rail`` runs it, the full one with no candidate cleared.
The facts the proof rests on are checked against scipy.stats, independently of vrelab.models.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from vrelab import Estimate, LevelResult
from vrelab import _rail_scan as rail_scan
from vrelab.fits import DEPARTURE_SIGMA, DEPARTURE_SIGMA_LONE, fit_rail
from vrelab.models.clipping import censored_mean_shift


def _levels(rms: np.ndarray, y: np.ndarray, u: np.ndarray) -> list[LevelResult]:
    return [LevelResult(rms_g=float(r), vre=Estimate(float(v), float(e))) for r, v, e in zip(rms, y, u)]


def _both(monkeypatch: pytest.MonkeyPatch, levels: list[LevelResult], g0: float
          ) -> tuple[dict, dict, np.ndarray]:
    """(fit_rail with the fast scan, with the full fit of every candidate, the cleared candidates)."""
    seen: list[np.ndarray] = []
    fast_clear = rail_scan.cleared_candidates

    def spy(*args: object) -> np.ndarray:
        seen.append(fast_clear(*args))  # type: ignore[arg-type]
        return seen[-1]

    monkeypatch.setattr(rail_scan, "cleared_candidates", spy)
    fast = fit_rail(levels, g0).to_dict()
    monkeypatch.setattr(rail_scan, "cleared_candidates", lambda rms, *a: np.zeros(len(rms), dtype=bool))
    full = fit_rail(levels, g0).to_dict()
    monkeypatch.setattr(rail_scan, "cleared_candidates", fast_clear)
    return fast, full, seen[0]


def test_the_fast_scan_decides_as_the_full_fits_near_the_thresholds(monkeypatch: pytest.MonkeyPatch) -> None:
    """Levels on ±2 g rails (1 g field) whose top levels step off the model by about 3 combined
    u (c·1.5·u, the combined u there being 1.2-1.5 u), and a lone top level moved by about 5:
    the same fit, the same departure (or none), bit for bit, on both sides of each threshold;
    and a candidate near a threshold, no departure, left to its full fit (the guard)."""
    rms = np.linspace(0.5, 1.6, 10)
    base = np.asarray(censored_mean_shift(1.0, rms, -2.0, 2.0))
    u = 2e-4 + 0.01 * np.abs(base)
    y0 = base + np.random.default_rng(0).standard_normal(len(rms)) * u
    cases = [y0 + np.where(rms >= 1.2, -c * 1.5 * u, 0.0) for c in (1.4, 2.0, 2.9, 3.3)]
    cases += [y0 + np.where(rms == rms[-1], -(c + 1.2) * 1.2 * u, 0.0) for c in (1.4, 2.0)]
    outcomes, fell_back = [], 0
    for y in cases:
        fast, full, cleared = _both(monkeypatch, _levels(rms, y, u), 1.0)
        assert fast == full
        outcomes.append(full["departure_rms_g"])
        first_fitted = len(rms) if full["departure_rms_g"] is None else full["n_points"]
        fell_back += int(np.count_nonzero(~cleared[2:first_fitted]))  # no departure, yet fitted
    # both decisions on each side: the step from 2 c on, the lone level from its 2nd case
    assert [d is not None for d in outcomes] == [False, True, True, True, False, True]
    assert fell_back > 0


def test_candidates_whose_levels_do_not_determine_the_rail_are_cleared(monkeypatch: pytest.MonkeyPatch) -> None:
    """The low levels far inside the rails (their VRE a k2 the clipping model lacks) determine no
    rail: ground B clears them without a fit (the clipping top levels' model u is huge there),
    and the scan still decides as the full fits do."""
    rng = np.random.default_rng(7)
    rms = np.r_[np.full(6, 0.1), np.full(6, 0.2), np.linspace(0.6, 2.0, 8)]
    u = 1e-7 + 2e-3 * np.abs(np.asarray(censored_mean_shift(1.0, rms, -2.5, 2.5)))
    y = np.asarray(censored_mean_shift(1.0, rms, -2.5, 2.5)) + 3e-4 * rms**2 + rng.standard_normal(len(rms)) * u
    fast, full, cleared = _both(monkeypatch, _levels(rms, y, u), 1.0)
    assert fast == full
    assert full["departure_rms_g"] is None
    # the fits of the 0.1 and 0.2 g levels alone: 2.5 g rails are 7.5 sigma and more beyond them
    assert cleared[2:12].all()


@pytest.mark.parametrize("g0", [1.0, -0.4])
def test_the_facts_the_proof_rests_on(g0: float) -> None:
    """Against scipy.stats: the shift's rail derivative G is the N(0, σ²) mass in [r-|g0|, r+|g0|]
    (signed as g0), the scan's ∂G/∂r is G's derivative (a central difference), and G_k/G_j does
    not increase with the rail when σ_j >= σ_k (the ratio bound of ground B)."""
    sig = np.array([0.05, 0.2, 0.5, 1.0, 3.0])
    rails = np.linspace(abs(g0) * (1 + 1e-9), abs(g0) + 6.0, 400)
    S = rail_scan._Scan(sig, np.zeros(5), np.ones(5), g0, np.array([1]), np.array([3.0]), rails)
    _, G, dG = S.model(rails)
    mass = stats.norm.cdf((rails[:, None] + abs(g0)) / sig) - stats.norm.cdf((rails[:, None] - abs(g0)) / sig)
    # scipy's cdf difference loses the tail where both cdfs are near 1: compare where it has digits
    ok = mass > 1e-8
    assert np.allclose(np.sign(g0) * mass[ok], G[ok], rtol=1e-7, atol=0)
    h = 1e-6
    _, G_up, _ = S.model(rails + h)
    _, G_dn, _ = S.model(rails - h)
    fd = (G_up - G_dn) / (2 * h)
    # central difference: error O(h²·G''') plus rounding O(1e-16/h) = 1e-10
    assert np.allclose(dG, fd, rtol=1e-5, atol=1e-8)
    for j in range(1, 5):
        for k in range(j):
            both = (np.abs(G[:, j]) > 1e-290) & (np.abs(G[:, k]) > 1e-290)
            ratio = G[both, k] / G[both, j]
            assert np.all(np.diff(ratio) <= 1e-12 * ratio[:-1])


def test_no_field_or_no_uncertainty_clears_nothing() -> None:
    """Without a static field the symmetric rails shift nothing, and without every u the fit is
    unweighted (its z from the scatter): every candidate gets its full fit."""
    rms = np.linspace(0.5, 2.0, 8)
    y = np.asarray(censored_mean_shift(1.0, rms, -2.0, 2.0))
    u = np.full(8, 1e-4)
    assert not rail_scan.cleared_candidates(rms, y, u, 0.0, 2, DEPARTURE_SIGMA, DEPARTURE_SIGMA_LONE).any()
    u[3] = 0.0
    assert not rail_scan.cleared_candidates(rms, y, u, 1.0, 2, DEPARTURE_SIGMA, DEPARTURE_SIGMA_LONE).any()
