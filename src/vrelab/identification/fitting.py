"""Identification's least squares: the starting values, the fit, its covariance."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.identification.model import model_runs, resonance_grid, vrc_chi2, vrc_chi2_grid, vrc_data
from vrelab.identification.observation import Observation
from vrelab.models.clipping import Kind as ClipKind
from vrelab.sensor.parameters import parameter, with_parameters

if TYPE_CHECKING:
    from vrelab.prediction import Prediction
    from vrelab.sensor.loader import Sensor


@dataclass
class LeastSquaresFit:
    """What :func:`least_squares_fit` finds: the free parameters' values ``x`` (in the order given),
    their covariance ``cov`` ((JᵀJ)⁻¹ of the weighted residuals, :func:`covariance_of`), the χ²
    at ``x``, the model's prediction of each run there (``preds``), the Jacobian's rank and notes.

    Examples
    --------
    What :func:`least_squares_fit` returns: the values, their covariance, χ² and the model runs.

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.fitting import least_squares_fit, starting_values
    >>> free = ["k2_ug_per_g2", "k3_ug_per_g3"]
    >>> fit = least_squares_fit(base, obs, free, starting_values(obs, base, free), "censored")
    >>> print(f"u(k2) {fit.cov[0, 0] ** 0.5:.2f}, chi2 {fit.chi2:.6f}, runs {len(fit.preds)}")
    u(k2) 3.57, chi2 0.000000, runs 2
    """

    x: NDArray[np.float64]
    cov: NDArray[np.float64]
    chi2: float
    preds: list[Prediction]
    jac_rank: int
    notes: list[str] = field(default_factory=list)


def _bounds(name: str, obs: Sequence[Observation]) -> tuple[float, float]:
    g_lo = min(ob.static_g for ob in obs)
    g_hi = max(ob.static_g for ob in obs)
    if name == "fn_hz":
        return 1e-3, 1e6
    if name == "q":
        return 0.05, 1e4
    if name == "rail_low_g":
        return -1e3, g_lo - 1e-3
    if name == "rail_high_g":
        return g_hi + 1e-3, 1e3
    if name == "overrange_threshold_g":
        return max(abs(g_lo), abs(g_hi)) + 1e-3, 1e3
    return -math.inf, math.inf


# grid points whose closed-form χ² lies within this fraction of the χ² scale of the least are
# tied: the exact least squares decides among them
_GRID_TIE_REL = 1e-6


def _grid_best(data: tuple[NDArray[np.float64], ...], k3_free: bool, k3_fixed: float, fns: NDArray[np.float64],
               qs: NDArray[np.float64]) -> tuple[float, float]:
    """The grid point (fn, Q) where :func:`vrc_chi2` is least, the first such with fn the outer
    loop: what ``min`` over every point's lstsq picks, found for the cost of a few lstsq. The
    closed form over the whole grid (:func:`vrc_chi2_grid`, the same χ² to rounding) keeps the
    points within a millionth of the χ² scale of its least, and :func:`vrc_chi2` itself, in
    the grid's order, settles among them (where the closed form is not finite: every point)."""
    chi = vrc_chi2_grid(data, k3_free, k3_fixed, fns[:, None], qs[None, :]).ravel()
    vrc, u = data[0], data[1]
    tol = _GRID_TIE_REL * (float(np.sum((vrc / u) ** 2)) + float(np.nanmax(np.abs(chi), initial=0.0)))
    every = [(fn, q) for fn in fns for q in qs]
    if np.isfinite(chi).all():
        every = [every[i] for i in np.flatnonzero(chi <= chi.min() + tol).tolist()]
    fn0, q0 = min(every, key=lambda g: vrc_chi2(data, k3_free, k3_fixed, *g)[1])
    return fn0, q0


def starting_values(obs: Sequence[Observation], base: Sensor, free: Sequence[str]) -> dict[str, float]:
    """Starting values: the base sensor's, with k2, k3, fn and Q from the closed form of each
    sine run's apparent VRC, ``VRC(f, g0) = (k2 + 3·k3·g0)·|H(f)|²``: k2 and k3 solved linearly
    at every (fn, Q) of a log grid (fn from a third of the lowest to ten times the highest sine
    frequency, Q from 0.5 to 50), the best grid point polished by least squares. A grid, not a
    few starts: VRC(f) has valleys (a large Q fits three frequencies nearly as well) that a
    local search from a poor start does not leave.

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg: the closed form's k2 and k3 start the fit.

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.fitting import starting_values
    >>> start = starting_values(obs, base, ["k2_ug_per_g2", "k3_ug_per_g3"])
    >>> print(f"{start['k2_ug_per_g2']:.1f} {start['k3_ug_per_g3']:.1f}")
    100.0 10.0
    """
    from scipy.optimize import least_squares

    from vrelab.models.dynamics import vrc_at_frequency

    start = {n: v for n in free if (v := parameter(base, n)) is not None}
    start.setdefault("k2_ug_per_g2", parameter(base, "k2_ug_per_g2") or 0.0)
    start.setdefault("k3_ug_per_g3", parameter(base, "k3_ug_per_g3") or 0.0)
    sines = [ob for ob in obs if ob.method == "sine"]
    if sines:
        data = vrc_data(sines)
        vrc, u, f, g0 = data
        k3_free = "k3_ug_per_g3" in free
        k3_fixed = start["k3_ug_per_g3"]
        if "fn_hz" in free:
            fns, qs = resonance_grid(sines)
            fn0, q0 = _grid_best(data, k3_free, k3_fixed, fns, qs)

            def resid(p: NDArray[np.float64]) -> NDArray[np.float64]:
                k = p[:-2]
                h: NDArray[np.float64] = np.asarray(vrc_at_frequency(1.0, f, p[-2], p[-1]))
                k2: float = k[0]
                k3: float = k[1] if k3_free else k3_fixed
                return ((k2 + 3 * k3 * g0) * h - vrc) / u

            k0, _ = vrc_chi2(data, k3_free, k3_fixed, fn0, q0)
            r = least_squares(resid, np.r_[k0, fn0, q0], x_scale="jac",
                              bounds=([-np.inf] * len(k0) + [1e-3, 0.05], [np.inf] * len(k0) + [1e6, 1e4]))
            k, (start["fn_hz"], start["q"]) = r.x[:-2], (float(r.x[-2]), float(r.x[-1]))
        else:
            k, _ = vrc_chi2(data, k3_free, k3_fixed, base.fn_hz, base.q)
        start["k2_ug_per_g2"] = float(k[0])
        if k3_free:
            start["k3_ug_per_g3"] = float(k[1])
    for n in ("rail_low_g", "rail_high_g", "overrange_threshold_g"):
        if n in free:
            lo, hi = _bounds(n, obs)
            start[n] = min(max(start[n], lo + 1e-3), hi - 1e-3)
    return start


def _residuals(sensor: Sensor, obs: Sequence[Observation], kind: ClipKind) -> tuple[NDArray[np.float64], list[Prediction]]:
    preds = model_runs(sensor, obs, kind)
    r = np.concatenate([(np.array([lv.vre_g for lv in p.levels]) - ob.vre_g) / ob.u_g for p, ob in zip(preds, obs)])
    return r, preds


def least_squares_fit(base: Sensor, obs: Sequence[Observation], free: Sequence[str], start: Mapping[str, float],
         kind: ClipKind) -> LeastSquaresFit:
    """Least squares over the ``free`` parameters; the others keep the base sensor's values.

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg:

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.fitting import least_squares_fit, starting_values
    >>> free = ["k2_ug_per_g2", "k3_ug_per_g3"]
    >>> fit = least_squares_fit(base, obs, free, starting_values(obs, base, free), "censored")
    >>> print([f"{x:.2f}" for x in fit.x], fit.jac_rank)
    ['100.00', '10.00'] 2
    """
    from scipy.optimize import least_squares

    def sensor_at(x: NDArray[np.float64]) -> Sensor:
        return with_parameters(base, dict(zip(free, x)))

    n_res = sum(ob.n for ob in obs)
    bad = np.full(n_res, 1e6)
    # the model at each x the optimiser tried, by x's exact bits: the solution is one of them, and
    # its residuals and predictions are read again below (one model evaluation of ~10 a fit saved)
    seen: dict[bytes, tuple[NDArray[np.float64], list[Prediction]]] = {}

    def evaluated(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], list[Prediction]]:
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key not in seen:
            seen[key] = _residuals(sensor_at(x), obs, kind)
        return seen[key]

    def resid(x: NDArray[np.float64]) -> NDArray[np.float64]:
        try:
            r, _ = evaluated(x)
        except ValueError:  # a parameter set the sensor refuses (rails crossing a static level)
            return bad
        return np.where(np.isfinite(r), r, 1e6)

    x0 = np.array([start[n] for n in free], dtype=np.float64)
    bounds = np.array([_bounds(n, obs) for n in free], dtype=np.float64).T if free else (-np.inf, np.inf)
    if free:
        # diff_step as a one-element list: scipy-stubs types it 1-D; scipy broadcasts it (the same steps)
        res = least_squares(resid, x0, bounds=(bounds[0], bounds[1]), x_scale="jac", diff_step=[1e-5], max_nfev=60,
                            ftol=1e-6, xtol=1e-6)  # χ² to 1e-6 (relative) is far below its own scatter
        x = res.x
    else:
        x = x0
    r, preds = evaluated(x)
    chi2 = float(r @ r)
    # the Jacobian at the solution by central differences (steps a small fraction of each
    # parameter's scale): the covariance rests on it, so not the optimiser's forward ones
    jac = np.empty((n_res, len(free)))
    for j, n in enumerate(free):
        h = 1e-4 * max(abs(x[j]), 1.0 if n.startswith("k") else 1e-3)
        lo, hi = _bounds(n, obs)
        xp, xm = x.copy(), x.copy()
        xp[j] = min(x[j] + h, hi)
        xm[j] = max(x[j] - h, lo)
        jac[:, j] = (resid(xp) - resid(xm)) / (xp[j] - xm[j])
    cov, rank = covariance_of(jac)
    return LeastSquaresFit(x, cov, chi2, preds, rank)


def covariance_of(jac: NDArray[np.float64]) -> tuple[NDArray[np.float64], int]:
    """(JᵀJ)⁻¹ by SVD, singular directions dropped (as scipy's curve_fit does); and J's rank.

    Examples
    --------
    A Jacobian of two independent unit-slope parameters, and one whose columns coincide (its
    singular direction dropped: rank 1):

    >>> import numpy as np
    >>> from vrelab.identification.fitting import covariance_of
    >>> cov, rank = covariance_of(np.eye(2))
    >>> print(cov, rank)
    [[1. 0.]
     [0. 1.]] 2
    >>> _, rank = covariance_of(np.array([[1.0, 1.0], [2.0, 2.0]]))
    >>> rank
    1
    """
    if jac.shape[1] == 0:
        return np.zeros((0, 0)), 0
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    keep = s > np.finfo(float).eps * max(jac.shape) * s[0]
    s, vt = s[keep], vt[keep]
    return (vt.T / s**2) @ vt, int(keep.sum())


def subset_levels(ob: Observation, keep: NDArray[np.bool_]) -> Observation:
    """``ob`` with only the levels ``keep`` marks.

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.fitting import subset_levels
    >>> print(subset_levels(obs[0], np.array([True, True, False])).rms_g)
    [0.2 0.4]
    """
    from dataclasses import replace

    def pick(t: tuple[Any, ...]) -> tuple[Any, ...]:
        return tuple(x for x, k in zip(t, keep) if k) if t else ()

    return replace(ob, rms_g=ob.rms_g[keep], vre_g=ob.vre_g[keep], u_g=ob.u_g[keep], harmonic_g=pick(ob.harmonic_g),
                   saturated=pick(ob.saturated), drive=pick(ob.drive))


def unsaturated(obs: Sequence[Observation]) -> list[Observation]:
    """The observations without the sine levels the analysis flagged saturated.

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.fitting import unsaturated
    >>> len(unsaturated(obs)), [len(ob.rms_g) for ob in unsaturated(obs)]
    (2, [3, 3])
    """
    out = []
    for ob in obs:
        keep = ~np.array(ob.saturated, dtype=bool) if ob.saturated else np.ones(ob.n, dtype=bool)
        if keep.any():
            out.append(subset_levels(ob, keep))
    return out


def level_key(obs: Sequence[Observation]) -> list[tuple[int, float | None, tuple[float, ...]]]:
    """Each observation's identity as a cache key: its run, frequency and levels' rms.

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.fitting import level_key
    >>> [(run, freq_hz) for run, freq_hz, _ in level_key(obs)]
    [(1, 80.0), (2, 80.0)]
    """
    return [(ob.run, ob.freq_hz, tuple(ob.rms_g)) for ob in obs]
