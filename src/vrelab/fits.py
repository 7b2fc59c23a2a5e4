"""Fits of measured (or simulated) VRE levels: VRC, effective rail, k2/k3 separation.

Pure functions (no I/O): they take :class:`~vrelab.results.LevelResult` sequences and return a
:class:`~vrelab.results.FitResult` whose parameters carry standard errors.

Standard errors. Every fit is weighted by ``1/u²`` with the levels' standard uncertainties taken
as absolute (``absolute_sigma=True`` in scipy's words), so the covariance is ``(JᵀWJ)⁻¹``. When
the reduced chi² exceeds 1 the data scatter more than their uncertainties say (model error,
under-estimated ``u``), and the covariance is scaled by chi²_red (Birge ratio); it is never
scaled down. The fit's ``notes`` say which was done.

References
----------
.. [1] IEEE Std 1293-1998, IEEE Standard Specification Format Guide and Test Procedure for
   Linear, Single-Axis, Nongyroscopic Accelerometers (vibration rectification test).
.. [2] Analog Devices, "Vibration rectification error in MEMS accelerometers" (ADXL355 case
   study), the article this project starts from; see docs/physics.md §1.1, §1.2 and §4.
.. [3] R. T. Birge, "The calculation of errors by the method of least squares",
   Phys. Rev. 40, 207 (1932): scaling by the reduced chi².
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _rail_scan as rail_scan
from vrelab import _validate as V
from vrelab.models.clipping import KINDS
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.results import (
    ClipModel,
    Estimate,
    FitModel,
    FitResult,
    K2K3Model,
    LevelResult,
    Method,
    Notice,
    VrcK4Model,
    VrcModel,
    group_by_frequency,
    same_frequency,
)
from vrelab.units import UG_PER_G

# Residual (in combined standard uncertainties) beyond which a level has left the model.
DEPARTURE_SIGMA = 3.0
# ... and when only the highest level is out, it must be this far out.
DEPARTURE_SIGMA_LONE = 5.0


def _arrays(levels: Sequence[LevelResult]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    rms = np.array([lv.rms_g for lv in levels], dtype=np.float64)
    vre = np.array([lv.vre.value for lv in levels], dtype=np.float64)
    u = np.array([lv.vre.u for lv in levels], dtype=np.float64)
    return rms, vre, u


def _weights(u: NDArray[np.float64], notes: list[str]) -> NDArray[np.float64]:
    """1/u², or equal weights (with a note) when any uncertainty is missing or zero."""
    if np.all(np.isfinite(u)) and np.all(u > 0):
        return 1.0 / u**2
    notes.append("some levels have no uncertainty: unweighted fit, errors from the scatter")
    return np.ones_like(u)


# A reduced chi2 beyond this is not noise: the model misses the levels by far more than their
# uncertainties (or those are tiny, as in a noise-free simulation).
_CHI2_FAR = 100.0


def _chi2_note(chi2_red: float) -> str:
    """What a reduced chi2 above 1 did to the standard errors, in words."""
    if chi2_red > _CHI2_FAR:
        return ("the levels scatter about the model far beyond their uncertainties (tiny uncertainties of a "
                f"noise-free record do this): standard errors scaled by reduced chi2 = {chi2_red:.3g}, i.e. taken "
                "from the residual scatter")
    return f"errors scaled by reduced chi2 = {chi2_red:.3g} (scatter larger than the level uncertainties)"


def _scale_cov(
    cov: NDArray[np.float64], chi2: float, dof: int, weighted_abs: bool, notes: list[str]
) -> tuple[NDArray[np.float64], float | None]:
    if dof <= 0:
        notes.append("as many parameters as points: chi2 undefined, errors from the level uncertainties alone")
        return cov, None
    chi2_red = chi2 / dof
    if not weighted_abs:
        return cov * chi2_red, chi2_red
    if chi2_red > 1.0:
        notes.append(_chi2_note(chi2_red))
        return cov * chi2_red, chi2_red
    notes.append(f"errors from the level uncertainties (reduced chi2 = {chi2_red:.3g} <= 1, not scaled)")
    return cov, chi2_red


def fit_vrc(
    levels: Sequence[LevelResult],
    max_rms_g: float | None = None,
    with_k4: bool = False,
    freq_hz: float | None = None,
) -> FitResult:
    r"""Vibration rectification coefficient: weighted least squares through the origin.

    Parameters
    ----------
    levels : sequence of LevelResult
        Measured VRE [g] with standard uncertainty at vibration level ``rms_g`` [g rms].
    max_rms_g : float, optional
        Only levels at or below this rms enter the fit (the nonlinearity regime, below clipping).
    with_k4 : bool
        Add a quartic term: ``VRE = k2_eff·rms² + c4·rms⁴``.
    freq_hz : float, optional
        Sine method: fit only the levels measured at this frequency (within 1 %); recorded in
        the result.

    Returns
    -------
    FitResult
        ``model`` "vrc" (or "vrc+k4"); params ``vrc_ug_per_g2`` [µg/g²] (and ``c4_ug_per_g4``
        [µg/g⁴]). Levels flagged ``saturated`` are left out (they are clipping, not
        nonlinearity).

    Notes
    -----
    IEEE Std 1293-1998 and physics §1.2: ``VRE = VRC·rms²`` with ``VRC = k2 + 3·k3·g0 + 6·k4·g0²``
    at static field g0. Minimise :math:`\sum_i (y_i - X_i β)^2/u_i^2` with
    :math:`X_i = [r_i^2]` (or :math:`[r_i^2, r_i^4]`): :math:`β = (X^TWX)^{-1}X^TWy`,
    :math:`\mathrm{cov}\,β = (X^TWX)^{-1}`, scaled by χ²_red when it exceeds 1 (Birge 1932, module references).
    ``c4 = k4·E[x⁴]/rms⁴``: 3·k4 for Gaussian vibration, 1.5·k4 for a sine.

    Examples
    --------
    Three levels of a k2 = 100 µg/g² sensor (VRE = VRC·rms²), each to 0.03 mg:

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import fit_vrc
    >>> levels = [LevelResult(rms_g=r, vre=Estimate(1e-4 * r**2, 3e-5)) for r in (1.0, 2.0, 3.0)]
    >>> vrc = fit_vrc(levels).params["vrc_ug_per_g2"]
    >>> print(f"VRC {vrc.value:.1f} ± {vrc.u:.1f} {vrc.unit}")
    VRC 100.0 ± 3.0 ug/g^2
    """
    notes: list[str] = []
    if max_rms_g is not None:
        max_rms_g = V.positive_scalar("max_rms_g", max_rms_g)
    sel = [
        lv
        for lv in levels
        if "saturated" not in lv.flags
        and np.isfinite(lv.rms_g)
        and np.isfinite(lv.vre.value)
        and lv.rms_g > 0
        and (max_rms_g is None or lv.rms_g <= max_rms_g)
        and (freq_hz is None or same_frequency(lv.freq_hz, freq_hz))
    ]
    n_sat = sum("saturated" in lv.flags for lv in levels)
    if n_sat:
        notes.append(f"{n_sat} saturated level(s) left out")
    n_par = 2 if with_k4 else 1
    if len(sel) < n_par:
        raise ValueError(
            f"levels: need at least {n_par} unsaturated level(s) with rms_g > 0 for the VRC fit, got {len(sel)}"
        )
    rms, y, u = _arrays(sel)
    w = _weights(u, notes)
    x2, x3 = drive_moments(sel)
    X = np.column_stack([x2, x2**2]) if with_k4 else x2[:, None]
    A = X.T @ (w[:, None] * X)
    beta = np.linalg.solve(A, X.T @ (w * y))
    # VRE_i = VRC·E[x²]_i + k3·E[x³]_i: the fitted VRC is k2 + 3·k3·(g0 + shift), shift =
    # Σw·E[x²]·E[x³] / (3·Σw·E[x²]²) (the normal equation of the one-column fit, exact). The
    # moments' own u is left out of the VRC's, as the rms's always was: E[x²] is known to 1e-5
    # of itself and the shift to about 2e-6 g (tests/test_distorted_drive.py's records), i.e.
    # 3·k3·u(shift) ≈ 6e-4 µg/g² for k3 = 100 µg/g³, against a VRC's u of several µg/g².
    shift = None
    if any(lv.drive is not None for lv in sel):
        shift = float(np.sum(w * x2 * x3) / (3.0 * np.sum(w * x2 * x2)))
        if any(lv.drive is not None and lv.drive.distorted for lv in sel):
            notes.append(f"a distorted drive (physics §4.4): VRE fitted against each level's measured E[x²]; its E[x³] "
                         f"makes the cubic term rectify as at g0 {shift:+.3g} g: VRC = k2 + 3*k3*(g0 {shift:+.3g} g)")
    cov = np.linalg.inv(A).astype(np.float64, copy=False)
    resid = y - X @ beta
    chi2 = float(np.sum(w * resid**2))
    cov, chi2_red = _scale_cov(cov, chi2, len(sel) - n_par, bool(np.all(u > 0)), notes)
    se = np.sqrt(np.diag(cov))
    params = {"vrc_ug_per_g2": Estimate(float(beta[0] * UG_PER_G), float(se[0] * UG_PER_G), "ug/g^2")}
    if with_k4:
        params["c4_ug_per_g4"] = Estimate(float(beta[1] * UG_PER_G), float(se[1] * UG_PER_G), "ug/g^4")
        notes.append("c4 = k4*E[x^4]/rms^4: 3*k4 for Gaussian vibration, 1.5*k4 for sine")
    return FitResult(
        model=VrcK4Model(params) if with_k4 else VrcModel(params),
        n_points=len(sel),
        chi2_reduced=chi2_red,
        freq_hz=freq_hz,
        levels_used=tuple(float(r) for r in rms),
        notes=tuple(notes),
        covariance=_cov_tuple(cov * UG_PER_G**2),  # both parameters in µg units
        static_shift_g=shift,
    )


def drive_moments(levels: Sequence[LevelResult]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(E[x²], E[x³]) per level [g², g³]: a sine level's measured from its reference waveform
    (:class:`~vrelab.results.DriveWaveform`, physics §4.4), else those of the level's rms: rms² and 0
    (a pure sine, or a symmetric random drive).

    Examples
    --------
    Random levels (no reference waveform): the Gaussian moments, rms² and 0:

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import drive_moments
    >>> m2, m3 = drive_moments([LevelResult(rms_g=2.0, vre=Estimate(0.0, 1e-5))])
    >>> print(m2, m3)
    [4.] [0.]
    """
    x2 = np.array([lv.drive.mean_square_g2.value if lv.drive is not None else lv.rms_g**2 for lv in levels],
                  dtype=np.float64)
    x3 = np.array([lv.drive.mean_cube_g3.value if lv.drive is not None else 0.0 for lv in levels], dtype=np.float64)
    return x2, x3


def _cov_tuple(cov: ArrayLike) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(c) for c in row) for row in np.atleast_2d(cov))


# a clipping model's mean shift: (mean_g, sigma_g, rail_low_g, rail_high_g) -> shift [g]
_Shift = Callable[[ArrayLike, ArrayLike, ArrayLike, ArrayLike], NDArray[np.float64] | float]


def _clip_model(kind: ClipKind) -> _Shift:
    # Imported here: the clipping models live in vrelab.models (one place for each formula).
    from vrelab.models import clipping

    return clipping.censored_mean_shift if kind == "censored" else clipping.truncated_mean_shift


def _clip_predict(
    p: NDArray[np.float64], rms: NDArray[np.float64], static_g: float, shift: _Shift, symmetric: bool, with_vrc: bool
) -> NDArray[np.float64]:
    low, high = (-p[0], p[0]) if symmetric else (p[0], p[1])
    out = np.asarray(shift(static_g, rms, low, high), dtype=np.float64)
    return out + p[-1] * rms**2 if with_vrc else out


# the clipping models whose derivatives with respect to the rails are in closed form
_CLOSED_FORM_JACOBIAN: tuple[ClipKind, ...] = ("censored",)


def _clip_jacobian(
    p: NDArray[np.float64], rms: NDArray[np.float64], static_g: float, kind: ClipKind, symmetric: bool, with_vrc: bool
) -> NDArray[np.float64] | None:
    """∂(model)/∂(params) at every level, one column per parameter; None where the model has no
    closed-form derivative (the truncated model: the fit then differentiates numerically)."""
    if kind not in _CLOSED_FORM_JACOBIAN:
        return None
    from vrelab.models.clipping import censored_rail_derivatives

    low, high = (-p[0], p[0]) if symmetric else (p[0], p[1])
    d_low, d_high = censored_rail_derivatives(static_g, rms, low, high)
    cols = [d_high - d_low] if symmetric else [d_low, d_high]  # symmetric: L = -r, U = r
    if with_vrc:
        cols.append(rms**2)
    return np.column_stack(np.broadcast_arrays(*cols)).astype(np.float64)


# the coarse stride of the exact search of the rail fit's starting grid (_rail_scan.rail_grid)
_GRID_STRIDE = 8
# two grid rails whose chi² agree within this (relative) are a tie the search leaves to the full
# evaluation: far above the rounding of a sum of squares (~1e-15), far below any real difference
_GRID_TIE = 1e-9


def _monotone_grid_argmin(
    grid: NDArray[np.float64], rms: NDArray[np.float64], y: NDArray[np.float64], sw: NDArray[np.float64], static_g: float
) -> int | None:
    """The best rail of ``grid`` for the symmetric censored model, found without evaluating every
    rail; None when the search cannot decide (a tie, a non-finite chi²): the caller then
    evaluates the whole grid.

    It returns what ``argmin`` over the whole grid returns. The censored shift at each level is
    monotone in the symmetric rail r (its derivative ``P(X > r) - P(X < -r)`` has the sign of the
    static field g0 for every r, :func:`vrelab.models.clipping.censored_rail_derivatives`), so
    between two evaluated rails r_a < r_b every level's prediction lies between its values at r_a
    and r_b, and ``Σ w·dist(y, [f(r_a), f(r_b)])²`` bounds the chi² of every rail in between from
    below. Every stride-th rail is evaluated; a block between two of them is skipped only when its
    bound exceeds the best chi² found by more than ``_GRID_TIE`` (relative), its rails evaluated
    otherwise. The best rail must then beat every other evaluated one by more than ``_GRID_TIE``,
    which no rounding difference can reverse; else None. The rail fit starts from this rail, so
    the fit's numbers are the full evaluation's, bit for bit (``bench/check_analysis_exact.py``).
    It is the costly part of each full rail fit (the departure scan runs one only for the
    candidates :func:`vrelab._rail_scan.cleared_candidates` does not clear).
    """
    from vrelab.models.clipping import censored_mean_shift

    n = len(grid)

    def chi2_rows(idx: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        g = grid[idx]
        pred = np.asarray(censored_mean_shift(static_g, rms[None, :], -g[:, None], g[:, None]), dtype=np.float64)
        return pred, np.sum(((pred - y) * sw) ** 2, axis=1)

    coarse = np.unique(np.r_[np.arange(0, n, _GRID_STRIDE), n - 1])
    pred, chi2 = chi2_rows(coarse)
    if not np.all(np.isfinite(chi2)) or not np.all(np.isfinite(pred)):
        return None
    best = float(np.min(chi2))
    if np.count_nonzero(chi2 <= best * (1.0 + _GRID_TIE)) > 1:
        return None  # a plateau of equal chi² (levels far inside every rail): its first rail is a tie of bits
    lo_f, hi_f = np.minimum(pred[:-1], pred[1:]), np.maximum(pred[:-1], pred[1:])
    dist = np.maximum(np.maximum(lo_f - y, y - hi_f), 0.0)
    bound = np.sum((dist * sw) ** 2, axis=1)  # one per block between consecutive coarse rails
    open_blocks = np.flatnonzero(bound <= best * (1.0 + _GRID_TIE))
    inner = [np.arange(coarse[b] + 1, coarse[b + 1]) for b in open_blocks]
    idx, vals = coarse, chi2
    if inner and sum(len(x) for x in inner):
        more = np.concatenate(inner)
        _, chi2_more = chi2_rows(more)
        if not np.all(np.isfinite(chi2_more)):
            return None
        idx, vals = np.r_[coarse, more], np.r_[chi2, chi2_more]
    k = int(np.argmin(vals))
    others = np.delete(vals, k)
    if others.size and float(np.min(others)) <= float(vals[k]) * (1.0 + _GRID_TIE):
        return None
    return int(idx[k])


def _fit_clip_once(
    rms: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    static_g: float,
    kind: ClipKind,
    symmetric: bool,
    with_vrc: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Least-squares rail(s) (and VRC in g/g²); returns (params, covariance unscaled, chi2)."""
    from scipy.optimize import least_squares

    shift = _clip_model(kind)
    sw = np.sqrt(w)

    def resid(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return (_clip_predict(p, rms, static_g, shift, symmetric, with_vrc) - y) * sw

    # The chi² surface is flat where the rail is far beyond every level (no clipping, no
    # information) and steep near the data: start from the best point of a log grid.
    grid = rail_scan.rail_grid(rms, static_g)
    found = _monotone_grid_argmin(grid, rms, y, sw, static_g) if (kind == "censored" and symmetric
                                                                    and not with_vrc) else None
    if found is None:
        # all grid rails at once (the model broadcasts): rows = rails, columns = levels
        pred = np.asarray(shift(static_g, rms[None, :], -grid[:, None], grid[:, None]), dtype=np.float64)
        if with_vrc:  # the VRC term is linear: its best value for each grid rail in closed form
            x2 = rms**2
            vrc = ((y - pred) * w * x2).sum(axis=1) / np.sum(w * x2**2)
            pred = pred + vrc[:, None] * x2
        found = int(np.argmin(np.sum(((pred - y) * sw) ** 2, axis=1)))
    i0 = found
    r0 = grid[i0]
    if symmetric:
        p0 = [r0]
        lb, ub = [max(abs(static_g), 1e-9) * (1 + 1e-9)], [np.inf]
    else:
        p0 = [-r0, r0]
        lb, ub = [-np.inf, static_g], [static_g, np.inf]
    if with_vrc:
        p0, lb, ub = p0 + [float(vrc[i0])], lb + [-np.inf], ub + [np.inf]
    def jac(p: NDArray[np.float64]) -> NDArray[np.float64]:
        J = _clip_jacobian(p, rms, static_g, kind, symmetric, with_vrc)
        assert J is not None
        return J * sw[:, None]

    exact = kind in _CLOSED_FORM_JACOBIAN
    sol = least_squares(resid, np.array(p0), jac=jac if exact else "2-point", bounds=(lb, ub), x_scale="jac")
    J = np.asarray(sol.jac)  # dense (no jac_sparsity): the array itself; typed as any Jacobian form
    # The levels determine the parameters only if J's columns are independent to within rounding:
    # levels far inside the rails give derivatives of 1e-50 or less (the probability beyond a
    # rail), and (JᵀJ)⁻¹ of such columns is rounding noise of any sign, not a covariance.
    sv = np.linalg.svd(J, compute_uv=False)
    determined = bool(np.all(np.isfinite(sv)) and sv[-1] > sv[0] * max(J.shape) * np.finfo(np.float64).eps)
    try:
        cov = np.linalg.inv(J.T @ J) if determined else np.full((len(p0), len(p0)), np.inf)
    except np.linalg.LinAlgError:
        cov = np.full((len(p0), len(p0)), np.inf)
    return sol.x, cov, float(np.sum(sol.fun**2))


def fit_rail(
    levels: Sequence[LevelResult],
    static_g: float,
    kind: ClipKind = DEFAULT_CLIP_KIND,
    symmetric: bool = True,
    with_vrc: bool = False,
) -> FitResult:
    r"""Effective rail of the clipping model fitted to VRE vs random vibration level.

    Parameters
    ----------
    levels : sequence of LevelResult
        VRE [g] with uncertainty at Gaussian vibration level ``rms_g`` [g rms].
    static_g : float
        Static acceleration along the axis during the test [g] (from the baselines or given).
    kind : {"censored", "truncated"}
        Clipping model (physics §1.1): samples beyond a rail read as the rail, or are discarded.
    symmetric : bool
        One rail parameter ``rail_g`` (rails at ±rail_g), or two (``rail_low_g``, ``rail_high_g``).
    with_vrc : bool
        Add the nonlinearity's share, ``VRC·rms²`` (param ``vrc_ug_per_g2``), to the clipping
        model: at levels where clipping is small the VRC term is what is left, and without it
        the rail fit's χ² is inflated when the sensor also has a k2.

    Returns
    -------
    FitResult
        ``model`` "clip-censored" / "clip-truncated"; params ``rail_g`` [g] (or
        ``rail_low_g``, ``rail_high_g``); ``departure_rms_g``: the first level at which the data
        leave the model, and ``levels_used``: the levels below it, the ones that were fitted.

    Notes
    -----
    Model (physics §1.1, the Analog Devices article): VRE(σ) = E[clip(g0 + x)] − g0 (+ VRC·σ² when ``with_vrc``) for
    x ~ N(0, σ²), from
    :func:`vrelab.models.clipping.censored_mean_shift` (or ``truncated_mean_shift``). Weighted
    least squares (``scipy.optimize.least_squares`` on residuals (model − y)/u), covariance
    ``(JᵀJ)⁻¹`` scaled by χ²_red when it exceeds 1.

    Departure rule (over-range protection, physics §1.3): sort the levels by rms; for each level i
    scanning upward (from the first that leaves enough levels below it to fit), fit the levels
    below i and predict the others; the departure is the first i from which every level lies
    more than 3 combined standard uncertainties (√(u² + u_model²)) from the prediction ("leaves
    and stays out"), or, when i is the highest level alone, more than 5 (a single 3σ draw is
    chance). The reported fit is the one below the departure. A lone outlier followed by levels
    back on the model is not a departure. For the censored symmetric model without VRC the scan
    fits only the candidates it cannot clear at once (``vrelab._rail_scan``: proved no departure,
    or so within the solver's own tolerance), and the reported fit is a full fit, as before.

    Examples
    --------
    Random levels against ±2 g rails on a 1 g field (the VRE of :func:`vrelab.models.clip_vre`,
    each to 0.1 mg): the fit finds the rail.

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import fit_rail
    >>> from vrelab.models.design import clip_vre
    >>> levels = [LevelResult(rms_g=r, vre=Estimate(float(clip_vre(1.0, r, -2.0, 2.0)), 1e-4)) for r in (0.8, 1.0, 1.2)]
    >>> rail = fit_rail(levels, static_g=1.0).params["rail_g"]
    >>> print(f"rail {rail.value:.4f} g, u {rail.u * 1e3:.2f} mg")
    rail 2.0000 g, u 0.37 mg
    """
    static_g = V.finite_scalar("static_g", static_g)
    V.one_of("kind", kind, KINDS)
    notes: list[str] = []
    sel = sorted(
        (lv for lv in levels if np.isfinite(lv.rms_g) and lv.rms_g > 0 and np.isfinite(lv.vre.value)),
        key=lambda lv: lv.rms_g,
    )
    n_par = (1 if symmetric else 2) + (1 if with_vrc else 0)
    if len(sel) < n_par + 1:
        raise ValueError(f"levels: need at least {n_par + 1} levels with rms_g > 0 for the rail fit, got {len(sel)}")
    rms, y, u = _arrays(sel)
    w = _weights(u, notes)
    absolute = bool(np.all(np.isfinite(u)) and np.all(u > 0))
    shift = _clip_model(kind)

    def fit_below(n_fit: int) -> tuple[NDArray[np.float64], NDArray[np.float64], float, NDArray[np.float64]]:
        """Fit the lowest n_fit levels; z = |residual| / combined u for every level."""
        p, cov, chi2 = _fit_clip_once(rms[:n_fit], y[:n_fit], w[:n_fit], static_g, kind, symmetric, with_vrc)
        dof = n_fit - n_par
        scale = chi2 / dof if (dof > 0 and (chi2 / dof > 1 or not absolute)) else 1.0
        covs = cov * scale
        pred = _clip_predict(p, rms, static_g, shift, symmetric, with_vrc)
        # Model uncertainty at each level from its derivative w.r.t. the parameters (closed form
        # for the censored model, a forward difference for the truncated one).
        G = _clip_jacobian(p, rms, static_g, kind, symmetric, with_vrc)
        if G is None:
            grads = []
            for k in range(len(p)):
                dp = np.zeros_like(p)
                dp[k] = 1e-6 * max(abs(p[k]), 1e-3)
                grads.append((_clip_predict(p + dp, rms, static_g, shift, symmetric, with_vrc) - pred) / dp[k])
            G = np.array(grads).T
        with np.errstate(invalid="ignore", over="ignore"):
            u_model = np.sqrt(np.maximum(np.nan_to_num(np.einsum("ij,jk,ik->i", G, covs, G), nan=np.inf), 0.0))
        u_res = np.sqrt(u**2 + u_model**2) if absolute else np.full_like(u, math.sqrt(scale))
        return p, covs, chi2, np.abs(y - pred) / u_res

    # Scan upward: fit the levels below i, predict the rest; the departure is the first i from
    # which every level is out (a lone top level: far out). Fitting below each candidate keeps
    # the departing levels from pulling the fit toward themselves and masking their departure.
    # The default model clears most candidates without their fit (_rail_scan: proved, or within
    # the full fit's own accuracy); the others are fitted and decided as always.
    cleared = (rail_scan.cleared_candidates(rms, y, u, static_g, n_par + 1, DEPARTURE_SIGMA, DEPARTURE_SIGMA_LONE)
               if kind == "censored" and symmetric and not with_vrc else np.zeros(len(sel), dtype=bool))
    departure: int | None = None
    for i in range(n_par + 1, len(sel)):
        if cleared[i]:
            continue
        found = fit_below(i)
        tail = found[3][i:]
        if (tail > DEPARTURE_SIGMA).all() and (len(tail) > 1 or tail[0] > DEPARTURE_SIGMA_LONE):
            departure = i
            break
    n_fit = len(sel) if departure is None else departure
    # the fit below the departure is the scan's last one (the same levels, the same numbers)
    p, covs, chi2, _ = found if departure is not None else fit_below(n_fit)
    chi2_red = chi2 / (n_fit - n_par) if n_fit > n_par else None
    if chi2_red is None:
        notes.append("as many parameters as points: chi2 undefined")
    elif not absolute:
        notes.append("unweighted: errors scaled by the residual scatter")
    elif chi2_red > 1:
        notes.append(_chi2_note(chi2_red))
    else:
        notes.append(f"errors from the level uncertainties (reduced chi2 = {chi2_red:.3g} <= 1, not scaled)")
    se = np.sqrt(np.diag(covs))
    scale = np.ones(len(p))  # units of params: g for rails, µg/g² for the joint VRC term
    if with_vrc:
        scale[-1] = UG_PER_G
    if symmetric:
        params = {"rail_g": Estimate(float(p[0]), float(se[0]), "g")}
    else:
        params = {
            "rail_low_g": Estimate(float(p[0]), float(se[0]), "g"),
            "rail_high_g": Estimate(float(p[1]), float(se[1]), "g"),
        }
    if with_vrc:
        params["vrc_ug_per_g2"] = Estimate(float(p[-1] * UG_PER_G), float(se[-1] * UG_PER_G), "ug/g^2")
    if departure is not None:
        notes.append(
            f"data leave the {kind} model from {rms[departure]:.4g} g rms on "
            f"(residuals > {DEPARTURE_SIGMA:g} sigma from there up); fitted below it"
        )
    notes.append(f"static field {static_g:.4g} g")
    return FitResult(
        model=ClipModel(params, kind, static_g),
        n_points=n_fit,
        chi2_reduced=chi2_red,
        levels_used=tuple(float(r) for r in rms[:n_fit]),
        departure_rms_g=None if departure is None else float(rms[departure]),
        notes=tuple(notes),
        covariance=_cov_tuple(covs * np.outer(scale, scale)),
    )


def separate_k2_k3(
    fit_plus: FitResult, fit_minus: FitResult, static_plus_g: float = 1.0, static_minus_g: float = -1.0
) -> FitResult:
    r"""Separate k2 and k3 from VRC fits at two orientations (physics §1.2).

    Parameters
    ----------
    fit_plus, fit_minus : FitResult
        VRC fits (param ``vrc_ug_per_g2``) of two recordings, at static fields
        ``static_plus_g`` and ``static_minus_g`` [g] (+1 g and −1 g by default).

    Returns
    -------
    FitResult
        ``model`` "k2-k3", params ``k2_ug_per_g2`` [µg/g²] and ``k3_ug_per_g3`` [µg/g³].

    Notes
    -----
    ``VRC(g0) = k2 + 3·k3·g0`` (the k4 term ``6·k4·g0²`` is the same at ±1 g and folds into
    k2). Two orientations: ``k3 = (VRC₊ − VRC₋)/(3·(g₊ − g₋))``, ``k2 = VRC₊ − 3·k3·g₊``;
    at ±1 g, k2 = (VRC₊ + VRC₋)/2 and k3 = (VRC₊ − VRC₋)/6. The two recordings are
    independent, so their uncertainties add in quadrature through these linear maps.

    Examples
    --------
    VRC fits axis up (+1 g) and axis down (-1 g) of a sensor with k2 = 100 µg/g², k3 = 10 µg/g³
    (VRC = k2 + 3·k3·g0):

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import fit_vrc, separate_k2_k3
    >>> def fit(vrc):
    ...     return fit_vrc([LevelResult(rms_g=r, vre=Estimate(vrc * 1e-6 * r**2, 3e-5)) for r in (1.0, 2.0)])
    >>> both = separate_k2_k3(fit(130.0), fit(70.0))
    >>> for name in ("k2_ug_per_g2", "k3_ug_per_g3"):
    ...     print(f"{name} {both.params[name].value:.1f} ± {both.params[name].u:.1f}")
    k2_ug_per_g2 100.0 ± 5.1
    k3_ug_per_g3 10.0 ± 1.7
    """
    from vrelab.models.nonlinearity import k2_k3_covariance
    from vrelab.models.nonlinearity import separate_k2_k3 as separate

    gp = V.finite_scalar("static_plus_g", static_plus_g)
    gm = V.finite_scalar("static_minus_g", static_minus_g)
    if gp == gm:
        raise ValueError(f"static_plus_g and static_minus_g must differ, got {gp} and {gm}")
    for name, f in (("fit_plus", fit_plus), ("fit_minus", fit_minus)):
        if "vrc_ug_per_g2" not in f.params:
            raise ValueError(f"{name} has no vrc_ug_per_g2 parameter (model {f.model.name!r})")
    a, b = fit_plus.params["vrc_ug_per_g2"], fit_minus.params["vrc_ug_per_g2"]
    if gp < gm:  # the formula takes the higher orientation first
        a, b, gp, gm = b, a, gm, gp
    k2, k3 = separate(a, b, static_g=gp, static_minus_g=gm)
    cov23 = k2_k3_covariance(a.u, b.u, gp, gm)
    return FitResult(
        model=K2K3Model({
            "k2_ug_per_g2": Estimate(k2.value, k2.u, "ug/g^2"),
            "k3_ug_per_g3": Estimate(k3.value, k3.u, "ug/g^3"),
        }),
        covariance=((k2.u**2, cov23), (cov23, k3.u**2)),
        n_points=2,
        freq_hz=fit_plus.freq_hz,
        notes=(
            f"VRC(g0) = k2 + 3*k3*g0 from fits at {gp:g} g and {gm:g} g; k4 (if any) folds into k2",
        ),
    )


def fit_k2_k3(points: Sequence[tuple[float, Estimate]], freq_hz: float | None = None) -> FitResult:
    r"""k2 and k3 from VRCs measured at several orientations (physics §1.2, §4.1).

    ``points`` are (static field g0 [g], VRC [µg/g²]) pairs. Weighted least squares of
    ``VRC(g0) = k2 + 3·k3·g0`` (weights 1/u², parameter covariance ``(AᵀWA)⁻¹``); with two
    orientations it is exactly :func:`separate_k2_k3`. Needs at least two distinct fields
    (physics §1.2: +1 g and −1 g); the k4 term ``6·k4·g0²`` is the same at ±g0 and folds into k2.

    Examples
    --------
    VRCs at three orientations (g0 = +1, 0, -1 g) of the same sensor (k2 = 100 µg/g²,
    k3 = 10 µg/g³):

    >>> from vrelab import Estimate
    >>> from vrelab.fits import fit_k2_k3
    >>> points = [(1.0, Estimate(130.0, 3.0, "µg/g²")), (0.0, Estimate(100.0, 3.0, "µg/g²")), (-1.0, Estimate(70.0, 3.0, "µg/g²"))]
    >>> fit = fit_k2_k3(points)
    >>> print(f"k2 {fit.params['k2_ug_per_g2'].value:.1f}, k3 {fit.params['k3_ug_per_g3'].value:.1f}")
    k2 100.0, k3 10.0
    """
    g = np.array([float(p[0]) for p in points])
    y = np.array([float(p[1].value) for p in points])
    u = np.array([float(p[1].u) for p in points])
    if len(points) < 2 or np.ptp(g) < 0.1:
        raise ValueError("k2 and k3 need VRCs at two orientations at least (static fields 0.1 g apart or more)")
    if not (np.isfinite(y).all() and np.isfinite(u).all() and (u > 0).all()):
        raise ValueError("k2 and k3: every VRC needs a finite value and a positive uncertainty")
    A = np.column_stack([np.ones_like(g), 3.0 * g])
    W = 1.0 / u**2
    cov = np.linalg.inv(A.T @ (A * W[:, None]))
    beta = cov @ (A.T @ (W * y))
    resid = y - A @ beta
    dof = len(y) - 2
    chi2 = float(np.sum(W * resid**2) / dof) if dof > 0 else None
    return FitResult(
        model=K2K3Model({
            "k2_ug_per_g2": Estimate(float(beta[0]), math.sqrt(cov[0, 0]), "ug/g^2"),
            "k3_ug_per_g3": Estimate(float(beta[1]), math.sqrt(cov[1, 1]), "ug/g^3"),
        }),
        covariance=tuple(tuple(float(c) for c in row) for row in cov),
        n_points=len(y),
        chi2_reduced=chi2,
        freq_hz=freq_hz,
        levels_used=tuple(float(x) for x in g),
        notes=(f"VRC(g0) = k2 + 3*k3*g0, weighted least squares over static fields {', '.join(f'{x:+g}' for x in g)} g",),
    )


def combine_fits(fits: Sequence[FitResult], names: Sequence[str],
                 model: Callable[[dict[str, Estimate]], FitModel]) -> FitResult:
    """Weighted mean of the same parameters ``names`` from independent fits, with their
    covariances (generalised least squares: ``x̄ = (Σ C_i⁻¹)⁻¹ Σ C_i⁻¹ x_i``), as ``model``
    (a :class:`~vrelab.results.FitModel` class taking those parameters: ``K2K3Model``).

    ``chi2_reduced`` = χ²/(p·(n−1)) of the fits about the mean. When it exceeds 1 the fits
    disagree by more than their uncertainties (for k2/k3 across frequencies: the resonance, or
    an effect the model lacks): the covariance is scaled by it (the Birge ratio²) and a note
    says so, so the combined ``u`` covers the spread instead of hiding it.

    Examples
    --------
    Two runs' VRC fits (100 and 110 µg/g², each to 5) combined into one:

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import combine_fits, fit_vrc
    >>> from vrelab.results import VrcModel
    >>> def fit(vrc):
    ...     return fit_vrc([LevelResult(rms_g=1.0, vre=Estimate(vrc * 1e-6, 5e-6))])
    >>> both = combine_fits([fit(100.0), fit(110.0)], ["vrc_ug_per_g2"], VrcModel)
    >>> print(f"{both.params['vrc_ug_per_g2'].value:.1f} ± {both.params['vrc_ug_per_g2'].u:.2f}")
    105.0 ± 5.00
    """
    if not fits:
        raise ValueError("combine_fits: no fit to combine")
    p = len(names)
    xs, invs = [], []
    for f in fits:
        x = np.array([f.params[n].value for n in names], dtype=float)
        if f.covariance is not None and list(f.params)[:p] == list(names):
            C = np.array(f.covariance, dtype=float)[:p, :p]
        else:
            C = np.diag([f.params[n].u ** 2 for n in names])
        xs.append(x)
        invs.append(np.linalg.inv(C))
    cov = np.linalg.inv(np.sum(invs, axis=0))
    mean = cov @ np.sum([Ci @ x for Ci, x in zip(invs, xs)], axis=0)
    notes: list[str] = [f"weighted mean of {len(fits)} fit(s)"]
    chi2 = None
    if len(fits) > 1:
        chi2 = float(sum((x - mean) @ Ci @ (x - mean) for Ci, x in zip(invs, xs)) / (p * (len(fits) - 1)))
        if chi2 > 1.0:
            cov = cov * chi2
            notes.append(f"the fits scatter more than their uncertainties (chi2/dof = {chi2:.3g}): "
                         "u scaled by its square root")
    units = {n: fits[0].params[n].unit for n in names}
    return FitResult(
        model=model({n: Estimate(float(mean[i]), math.sqrt(cov[i, i]), units[n]) for i, n in enumerate(names)}),
        covariance=tuple(tuple(float(c) for c in row) for row in cov),
        n_points=sum(f.n_points for f in fits),
        chi2_reduced=chi2,
        levels_used=tuple(f.freq_hz for f in fits if f.freq_hz is not None),
        notes=tuple(notes),
    )


# --- the fit policy -------------------------------------------------------------------------------

# A level belongs to the nonlinearity regime when its Gaussian peaks (this many σ) stay inside the
# rails: there clipping adds less than about 1e-5·σ to the VRE (the censored mean shift at 4σ).
VRC_PEAK_SIGMAS = 4.0


def vrc_level_limit_g(rails_g: tuple[float, float], static_g: float) -> float:
    """Largest rms [g] whose Gaussian peaks (4σ) stay inside ``rails_g`` at ``static_g``.

    Examples
    --------
    ±2 g rails on a 1 g field: Gaussian peaks of 4σ reach the upper rail at 0.25 g rms.

    >>> from vrelab.fits import vrc_level_limit_g
    >>> print(f"{vrc_level_limit_g((-2.0, 2.0), 1.0):.2f} g rms")
    0.25 g rms
    """
    low, high = (float(x) for x in rails_g)
    return max(0.0, min(high - static_g, static_g - low)) / VRC_PEAK_SIGMAS


def _rails_of(fit: FitResult) -> tuple[float, float] | None:
    """The fitted rails, when the fit determines them (finite, with u below the distance)."""
    p = fit.params
    if "rail_g" in p:
        r = p["rail_g"]
        ok = math.isfinite(r.value) and math.isfinite(r.u) and 0 <= r.u < abs(r.value)
        return (-abs(r.value), abs(r.value)) if ok else None
    lo, hi = p.get("rail_low_g"), p.get("rail_high_g")
    if lo is None or hi is None:
        return None
    ok = all(math.isfinite(e.value) and math.isfinite(e.u) for e in (lo, hi)) and lo.value + lo.u < hi.value - hi.u
    return (lo.value, hi.value) if ok else None


def _frequency_groups(levels: Sequence[LevelResult]) -> list[list[int]]:
    """Indices of the levels run at each sine frequency (:func:`vrelab.results.group_by_frequency`),
    in increasing frequency."""
    return group_by_frequency((i for i, lv in enumerate(levels) if lv.freq_hz is not None),
                              lambda i: float(levels[i].freq_hz))  # type: ignore[arg-type]


def fit_levels(
    levels: Sequence[LevelResult],
    method: Method,
    static_g: float | None,
    clip_kind: ClipKind = DEFAULT_CLIP_KIND,
    fit_k4: bool = False,
    rail_with_vrc: bool = False,
    nominal_freqs_hz: Sequence[float | None] | None = None,
) -> tuple[list[FitResult], list[Notice]]:
    """The fits of physics §4, decided in one place for every reducer of a record.

    The simulated test (:mod:`vrelab.shaker`) and the analysis of a recorded file
    (:func:`vrelab.analysis.reduction.analyze`) both call this, with what both know (the
    levels, the method, the static field), so one record gives the same ``fits`` whichever
    command reduced it.

    * **sine**: one VRC fit (:func:`fit_vrc`) per frequency; levels at the same frequency
      within 1 % (:func:`vrelab.results.same_frequency`) form a group, reported at the
      schedule's nominal frequency (``nominal_freqs_hz``, aligned with ``levels``) when the
      group's levels share one, else at the mean of their estimates.
    * **random**: first the clipping model's effective rail (:func:`fit_rail`, with the static
      field; skipped when it is unknown), then the VRC over the nonlinearity regime: unsaturated
      levels whose 4σ peaks stay inside the fitted rails (:func:`vrc_level_limit_g`), or every
      unsaturated level when the rail fit does not determine the rails.

    Returns the fits and :class:`~vrelab.results.Notice` s (code ``fit`` or ``departure``).

    Examples
    --------
    The fits a random test gets (the policy of every reducer): the VRC below the rails' reach and
    the rail above it. Levels of the ±2 g rails of :func:`vrelab.models.clip_vre` on a 1 g field:

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import fit_levels
    >>> from vrelab.models.design import clip_vre
    >>> levels = [LevelResult(rms_g=r, vre=Estimate(float(clip_vre(1.0, r, -2.0, 2.0)), 1e-4)) for r in (0.2, 0.8, 1.0, 1.2)]
    >>> fits, notices = fit_levels(levels, "random", static_g=1.0)
    >>> [fit.model.name for fit in fits]
    ['clip-censored', 'vrc']
    """
    V.one_of("method", method, ("random", "sine"))
    out: list[FitResult] = []
    notes: list[Notice] = []
    if method == "sine":
        groups = _frequency_groups(levels) or [list(range(len(levels)))]
        for grp in groups:
            sel = [levels[i] for i in grp]
            nominal = {nominal_freqs_hz[i] for i in grp} if nominal_freqs_hz is not None else {None}
            f: float | None
            if len(nominal) == 1 and None not in nominal:
                f = float(next(iter(nominal)))  # type: ignore[arg-type]
            else:
                known = [lv.freq_hz for lv in sel if lv.freq_hz is not None]
                f = float(np.mean(known)) if known else None
            try:
                fit = fit_vrc(sel, with_k4=fit_k4)
                out.append(dataclasses.replace(fit, freq_hz=f))
            except ValueError as exc:
                notes.append(Notice("fit", f"VRC fit at {f:g} Hz skipped: {exc}" if f else f"VRC fit skipped: {exc}"))
        return out, notes
    limit: float | None = None
    if static_g is not None:
        try:
            rail_fit = fit_rail(levels, static_g, kind=clip_kind, with_vrc=rail_with_vrc)
        except (ValueError, ImportError) as exc:
            notes.append(Notice("fit", f"rail fit skipped: {exc}"))
        else:
            out.append(rail_fit)
            if rail_fit.departure_rms_g is not None:
                notes.append(Notice("departure", f"data leave the clipping model from {rail_fit.departure_rms_g:.4g} g rms on"))
            rails = _rails_of(rail_fit)
            if rails is not None:
                limit = vrc_level_limit_g(rails, static_g)
    if limit is not None and not any(lv.rms_g <= limit for lv in levels):
        notes.append(Notice("fit", f"no level at or below {limit:.3g} g rms (4 sigma clear of the fitted rails): no VRC fit"))
        return out, notes
    try:
        out.append(fit_vrc(levels, max_rms_g=limit, with_k4=fit_k4))
    except ValueError as exc:
        notes.append(Notice("fit", f"VRC fit skipped: {exc}"))
    return out, notes
