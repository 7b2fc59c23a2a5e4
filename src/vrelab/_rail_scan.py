"""The rail fit's departure scan without a full fit per candidate (:func:`vrelab.fits.fit_rail`).

The scan fits the clipping model to the levels below each candidate i and asks whether every
level from i up lies more than ``sigma`` combined standard uncertainties from that fit (a lone top
level: ``sigma_lone``). One full fit per candidate (a 200-rail grid search, then
``scipy.optimize.least_squares``) made the scan most of a rail fit's time. Here all candidates are
taken at once, for the default model (censored, one symmetric rail, no VRC term, every level with
its uncertainty), and :func:`cleared_candidates` returns those that are **no departure** on one of
two grounds; every other candidate gets the full fit, and the decision of the full fit, as before.
The reported fit is always the full one: this only decides which candidates need one.

Notation: levels sorted by rms σ_j, VRE y_j, u_j, w_j = 1/u_j²; f_j(r) the censored mean shift
at rail r (:func:`vrelab.models.clipping.censored_mean_shift`, static field g0),
G_j(r) = ∂f_j/∂r = P(X_j > r) − P(X_j < −r) (:func:`~vrelab.models.clipping.censored_rail_derivatives`).
The full fit of the levels below i returns p* and computes, at every level,
``z_j = |y_j − f_j(p*)| / sqrt(u_j² + u_model_j²)`` with
``u_model_j = |G_j(p*)|·sqrt(scale/Σ_{k<i} w_k G_k(p*)²)``, scale = max(1, χ²/dof) (or +inf when
the fit does not determine the rail). A candidate is a departure iff every tail z exceeds sigma.

**Ground B (proved).** Three facts:

1. f_j is monotone in r and tends to 0 as r → ∞ (its derivative G_j has the sign of g0 for every
   r >= |g0|; ``fits._monotone_grid_argmin`` relies on the same), so for p >= a,
   ``|y_j − f_j(p)| <= max(|y_j − f_j(a)|, |y_j|)``.
2. For σ_j >= σ_k the ratio G_k(r)/G_j(r) does not increase with r >= |g0|: G_σ(r) is the mass
   of N(0, σ²) in [r − |g0|, r + |g0|] ⊂ [0, ∞), the integral of the Gaussian density φ_σ(t)
   (totally positive of order 2 in (σ, t) for t >= 0: ∂²log φ_σ/∂σ∂t = 2t/σ³ >= 0) against the
   indicator of a window sliding with r (TP2 in (t, r)), hence TP2 in (σ, r) by Karlin's
   composition formula (S. Karlin, *Total Positivity*, Stanford 1968, ch. 3). The levels are
   sorted, so every tail level j >= i has σ_j >= σ_k for every fitted k < i, and
   ``R_j(r) = |G_j(r)| / sqrt(Σ_{k<i} w_k G_k(r)²)`` does not decrease with r: for p >= a,
   ``u_model_j(p) >= R_j(a)`` (scale >= 1).
3. p* lies in {p : χ²_i(p) <= χ²_i(r0)}, r0 the best rail of the full fit's grid (the
   trust-region solver only accepts steps that lower the cost, scipy's ``trf``), and
   χ²_i(r0) <= the χ² of every rail of that grid. Over a block [R_k, R_k+1] of a common grid of
   rails, f_j lies between its two ends (fact 1), which bounds χ²_i on the block from above
   (Σ w·max of the two squared residuals) and from below (Σ w·dist(y, [f(R_k), f(R_k+1)])²).
   So c_i = the least upper bound over blocks holding a rail of the full fit's grid bounds
   χ²_i(p*), and p* >= a_i, the start of the first block whose lower bound is <= c_i.

Hence ``z_j(p*) <= max(|y_j − f_j(a_i)|, |y_j|) / sqrt(u_j² + R_j(a_i)²)``: when that bound is
below the threshold for some tail level, candidate i is no departure, whatever p* is. This
clears the candidates whose levels below do not determine the rail (every fitted level far
inside it, a flat χ²: there u_model of the clipping tail is astronomically large), where no
cheap fit could say where the solver stops.

**Ground A (the solver's own accuracy).** Where the levels below i determine the rail (σ̂, the
rail's standard error as the full fit scales it, within a quarter of the rail) and χ²_i has one
basin on the common grid within the full fit's range (it falls to its best rail and rises
after), Newton's method (closed-form first and second derivatives of χ²_i) from the grid's best
rail converges to the minimum p̂ the full fit converges to: one basin, and the solver starts in
it, at its own grid's best rail. Newton is iterated until its step is below 1e-6·σ̂, and z is
computed there as the full fit computes it. The full fit itself stops at least_squares'
tolerances (ftol = xtol = gtol = 1e-8): the last step lowered χ² by less than 1e-8 of it, so
χ²(p*) − χ²(p̂) <~ 1e-8·χ², i.e. |p* − p̂| <~ 1e-4·sqrt(dof)·σ̂ (χ² = dof·scale about the
minimum); and z moves by about |Δp|/σ̂ (the residual by |G_j|·Δp against u_model_j = |G_j|·σ̂,
u_model itself by its relative change). :data:`GUARD` = 0.1 in z is that, 10 times over, for
up to 10⁴ levels below a candidate. A candidate is cleared on ground A when some tail z is
below the threshold minus :data:`GUARD`. Unlike ground B this leans on the solver converging
where its tolerances say; ``bench/check_analysis_exact.py`` (its ``rail`` group: 160 seeded
level sets, departures of 2.5-4 σ among them) and ``tests/test_rail_scan.py`` hold the fast
scan's decisions to the full fits' on both sides of the thresholds.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

# the full fit's starting grid: log-spaced rails over the range the levels below i reach
GRID_POINTS = 200
# z within this of a threshold is left to the full fit (ground A; the module's docstring)
GUARD = 0.1
# ground A: the rail determined to this fraction of itself (σ̂ / rail), Newton converged to this fraction of σ̂
_DETERMINED = 0.25
_CONVERGED = 1e-6
_NEWTON_STEPS = 12
# the common grid of ground B and of Newton's starting rails
_COMMON_POINTS = 160
# candidates × levels per chunk of the scan's arrays
_CHUNK = 1 << 16
# rounding of ground B's bounds (relative): far above a few ulps of a sum, far below any decision
_SLACK = 1e-6


def rail_grid(rms: NDArray[np.float64], static_g: float) -> NDArray[np.float64]:
    """The rail fit's starting grid for levels of rms ``rms`` [g] in the static field ``static_g``
    [g]: log-spaced from just above the field to 12 times the largest rms beyond it."""
    lo = abs(static_g) + 0.05 * float(np.min(rms))
    hi = abs(static_g) + 12.0 * float(np.max(rms))
    return np.geomspace(max(lo, 1e-6), hi, GRID_POINTS)


@dataclasses.dataclass(frozen=True)
class _Scan:
    """The levels (sorted by rms), the candidates, and the rails every bound is taken at."""

    rms: NDArray[np.float64]
    y: NDArray[np.float64]
    u: NDArray[np.float64]
    static_g: float
    cand: NDArray[np.intp]  # candidate i: the levels below i are fitted
    limits: NDArray[np.float64]  # each candidate's threshold: sigma, or sigma_lone for the top level alone
    rails: NDArray[np.float64]  # the common grid, from the full fit's lower bound up

    @property
    def w(self) -> NDArray[np.float64]:
        return 1.0 / self.u**2

    @property
    def lo(self) -> float:
        """Bottom of every candidate's own grid (the lowest level is in every fit)."""
        return max(abs(self.static_g) + 0.05 * float(self.rms[0]), 1e-6)

    @property
    def hi(self) -> NDArray[np.float64]:
        """Top of each candidate's own grid."""
        return abs(self.static_g) + 12.0 * self.rms[self.cand - 1]

    def below(self, rows: NDArray[np.intp]) -> NDArray[np.bool_]:
        """(candidate, level): the level is fitted for that candidate."""
        return np.arange(len(self.rms))[None, :] < self.cand[rows, None]

    def model(self, rails: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """f, G = ∂f/∂r and ∂G/∂r; rows = rails, columns = levels."""
        from vrelab.models.clipping import censored_mean_shift, censored_rail_derivatives

        g0, s, r = self.static_g, self.rms[None, :], rails[:, None]
        f = np.asarray(censored_mean_shift(g0, s, -r, r), dtype=np.float64)
        d_low, d_high = censored_rail_derivatives(g0, s, -r, r)
        # ∂G/∂r = (φ((r + g0)/σ) − φ((r − g0)/σ))/σ: the densities at the two rails
        with np.errstate(under="ignore"):
            dG = (np.exp(-0.5 * ((r + g0) / s) ** 2) - np.exp(-0.5 * ((r - g0) / s) ** 2)) / (s * np.sqrt(2.0 * np.pi))
        return f, np.asarray(d_high - d_low, dtype=np.float64), dG

    def clear(self, z: NDArray[np.float64], rows: NDArray[np.intp], margin: NDArray[np.float64] | float
              ) -> NDArray[np.bool_]:
        """Per row: some tail z (level >= the candidate) below the candidate's threshold minus ``margin``."""
        tail = ~self.below(rows)
        zt = np.where(tail & ~np.isnan(z), z, np.inf)
        return np.asarray(np.min(zt, axis=1) < self.limits[rows] - margin)


def cleared_candidates(
    rms: NDArray[np.float64], y: NDArray[np.float64], u: NDArray[np.float64], static_g: float,
    first: int, sigma: float, sigma_lone: float,
) -> NDArray[np.bool_]:
    """For each level i of the sorted ``rms`` [g] (VRE ``y`` [g] and its ``u`` [g], finite and
    > 0): True where the candidate i >= ``first`` of the rail fit's departure scan is provably no
    departure (the module's docstring), False where it needs the full fit."""
    n = len(rms)
    out = np.zeros(n, dtype=bool)
    if static_g == 0.0 or first >= n or not (np.all(np.isfinite(u)) and np.all(u > 0)):
        return out  # no field: no clipping shift to bound; no u: the fit is unweighted
    cand = np.arange(first, n)
    lb = max(abs(static_g), 1e-9) * (1 + 1e-9)  # the full fit's lower bound on the rail
    lo = max(abs(static_g) + 0.05 * float(rms[0]), 1e-6)
    rails = np.unique(np.r_[lb, np.geomspace(lo, abs(static_g) + 12.0 * float(rms[-1]), _COMMON_POINTS)])
    limits = np.where(cand == n - 1, sigma_lone, sigma)
    f, G, _ = _Scan(rms, y, u, float(static_g), cand, limits, rails).model(rails)
    cum = np.cumsum((f - y) ** 2 / u**2, axis=1)
    # (candidate × level) arrays in chunks of candidates: a few MB whatever the number of levels
    for part in np.array_split(np.arange(len(cand)), -(-len(cand) * n // _CHUNK)):
        S = _Scan(rms, y, u, float(static_g), cand[part], limits[part], rails)
        ok = _ground_a(S, cum[:, S.cand - 1].T)  # (candidate, rail): χ² of the levels below
        rest = np.flatnonzero(~ok)
        if rest.size:
            ok[rest] = _ground_b(S, f, G, rest)
        out[S.cand] = ok
    return out


def _ground_a(S: _Scan, chi2: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Candidates cleared on ground A: Newton on each χ² from its best rail of the common grid."""
    m = len(S.cand)
    ok = np.zeros(m, dtype=bool)
    inside = (S.rails[None, :] >= S.lo) & (S.rails[None, :] <= S.hi[:, None])
    c = np.where(inside, chi2, np.inf)
    k0 = np.argmin(c, axis=1)
    best = c[np.arange(m), k0]
    with np.errstate(invalid="ignore"):
        d = np.diff(c, axis=1)  # inf - inf outside the range: nan, left out below
    k = np.arange(d.shape[1])[None, :]
    tol = 1e-12 * np.abs(best)[:, None]
    # one basin on the grid: χ² falls to the best rail and rises after it (within rounding)
    bad = np.where(k < k0[:, None], d > tol, d < -tol) & inside[:, 1:] & inside[:, :-1]
    active = np.flatnonzero(np.isfinite(best) & ~bad.any(axis=1))
    r = S.rails[k0]
    lb = S.rails[0]
    for _ in range(_NEWTON_STEPS):
        if not active.size:
            break
        f, G, dG = S.model(r[active])
        res = f - S.y
        wm = S.w * S.below(active)
        jj = np.sum(wm * G * G, axis=1)
        g = np.sum(wm * res * G, axis=1)
        h = jj + np.sum(wm * res * dG, axis=1)
        h = np.where(h > 0, h, jj)  # not convex here: a Gauss-Newton step
        dof = S.cand[active] - 1
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            sig = np.sqrt(np.maximum(1.0, np.sum(wm * res * res, axis=1) / dof) / jj)  # σ̂ of the rail
            step = np.clip(-g / h, -0.25 * r[active], 0.25 * r[active])
        r_new = np.maximum(r[active] + step, lb)
        determined = np.isfinite(sig) & (sig <= _DETERMINED * r[active]) & np.isfinite(step)
        done = determined & (np.abs(r_new - r[active]) <= _CONVERGED * sig) & (r[active] > lb * (1 + 1e-6))
        if done.any():
            with np.errstate(invalid="ignore", over="ignore"):
                z = np.abs(res[done]) / np.sqrt(S.u**2 + (G[done] * sig[done, None]) ** 2)
            ok[active[done]] = S.clear(z, active[done], GUARD)
        r[active] = r_new
        active = active[determined & ~done]
    return ok


def _ground_b(S: _Scan, f: NDArray[np.float64], G: NDArray[np.float64], rows: NDArray[np.intp]) -> NDArray[np.bool_]:
    """Candidates ``rows`` cleared on ground B: the bound on every tail z over p* >= a_i."""
    y, w, K = S.y, S.w, len(S.rails)
    f_ext = np.vstack([f, np.zeros_like(y)])  # block k is [R_k, R_k+1]; the last one [R_top, inf): f -> 0
    f_lo, f_hi = np.minimum(f_ext[:-1], f_ext[1:]), np.maximum(f_ext[:-1], f_ext[1:])
    low = np.cumsum(w * np.maximum(np.maximum(f_lo - y, y - f_hi), 0.0) ** 2, axis=1)  # χ² from below, per block
    high = np.cumsum(w * np.maximum((f[:-1] - y) ** 2, (f[1:] - y) ** 2), axis=1)  # ... from above (finite blocks)
    cand = S.cand[rows]
    # every rail of each candidate's own grid, and the block that holds it
    grids = np.geomspace(S.lo, S.hi[rows], GRID_POINTS, axis=1)
    blocks = np.clip(np.searchsorted(S.rails, grids, side="right") - 1, 0, K - 2)
    c = np.min(high[blocks, (cand - 1)[:, None]], axis=1) * (1 + _SLACK)  # >= χ²(p*)
    feasible = low[:, cand - 1].T <= c[:, None]
    any_feasible = feasible.any(axis=1)
    ka = np.minimum(np.argmax(feasible, axis=1), K - 1)  # the first block p* can lie in: p* >= rails[ka]
    fa, Ga = f[ka], G[ka]
    den = np.sum(w * Ga * Ga * S.below(rows), axis=1)
    # scale = max(1, χ²(p*)/dof) >= max(1, the least lower bound of χ² over every block / dof)
    scale = np.maximum(1.0, np.min(low[:, cand - 1], axis=0) / (cand - 1))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.where(Ga == 0, 0.0, np.abs(Ga) * np.sqrt(scale / den)[:, None])  # <= u_model_j(p*)
        z = np.maximum(np.abs(y - fa), np.abs(y)) / np.sqrt(S.u**2 + ratio**2)
    return S.clear(z, rows, _SLACK * S.limits[rows]) & any_feasible
