"""One channel identified: the fit iterated with the levels the model covers, its Type B terms,
the cross-coupling and 2f checks beside it (:func:`identify_channel`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.gum import MAX_REL_U
from vrelab.identification.check2f import cross_check_2f
from vrelab.identification.cross_coupling import CROSS, CrossCoupling, fit_cross_coupling
from vrelab.identification.fitting import (
    LeastSquaresFit,
    least_squares_fit,
    level_key,
    starting_values,
    subset_levels,
    unsaturated,
)
from vrelab.identification.model import NUISANCE, Findings, model_runs, plan_parameters, post_checks
from vrelab.identification.observation import ChannelModel, Observation, RunFit, TypeBTerm, apparent_vrc, value_u
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.results import Estimate
from vrelab.sensor.parameters import PARAMETERS, TABLE, parameter, with_parameters

if TYPE_CHECKING:
    from vrelab.gum import TypeB
    from vrelab.prediction import LevelPrediction, Prediction
    from vrelab.sensor.loader import Sensor


@dataclass(frozen=True)
class IdentifyOptions:
    """How a campaign is identified, beyond its base sensor (:func:`vrelab.identification.identify`).

    Examples
    --------
    >>> from vrelab import TypeB
    >>> from vrelab.identification.channel import IdentifyOptions
    >>> options = IdentifyOptions(typeb=TypeB(u_reference_pct=1.0))
    >>> options.kind, options.workers, options.prefer_base
    ('censored', 1, False)
    """

    kind: ClipKind = DEFAULT_CLIP_KIND  # the clipping model
    # the Type B budget; identify's None: the largest value each run declared (one reference, one DUT)
    typeb: TypeB | None = None
    workers: int = 1  # > 1: channels identified in parallel processes
    # fn and Q that the runs see but determine poorly (relative u above MAX_REL_U): the base sensor's
    # instead (by default they are kept with their u)
    prefer_base: bool = False


def identify_channel(channel: str, obs: Sequence[Observation], base: Sensor, options: IdentifyOptions | None = None,
                     campaign: str = "the campaign", notes: Sequence[str] = ()) -> ChannelModel:
    """Identify one channel's model from its observations (see :mod:`vrelab.identification`).

    Which levels the fit uses is decided with the fitted model and iterated: a sine level the
    analysis flagged saturated (against its own rail) comes back when the identified rails clear
    its peak, and a level the fitted model does not cover goes (:func:`_modelled`).

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg: both come back with their u.

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> model = identify_channel("sn1", obs, base)
    >>> for name in ("k2_ug_per_g2", "k3_ug_per_g3"):
    ...     print(f"{name} {model.parameters[name].value:.1f} ± {model.parameters[name].u:.2f}")
    k2_ug_per_g2 100.0 ± 3.57
    k3_ug_per_g3 10.0 ± 1.19
    """
    opts = options or IdentifyOptions()
    notes = list(notes)
    tilted = [ob for ob in obs if ob.tilted]
    full = [ob for ob in obs if not ob.tilted]
    if not full:
        raise ValueError(f"identify: channel {channel!r} has no usable level in any run"
                         + (" with its input axis along the vibration (every run is mounted at an angle: the model "
                            "needs a 0° run)" if tilted else ""))
    it = _iterate(full, base, opts.kind, opts.prefer_base)
    fit, obs, free, why = it.fit, it.obs, it.free, it.why
    notes += it.level_notes
    notes += [t for n, t in it.found.loose.items() if n not in why]
    readmitted = [f"{ob.freq_hz:.4g} Hz {r:.4g} g rms" for ob in obs for r, sat in zip(ob.rms_g, ob.saturated or ()) if sat]
    if readmitted:
        notes.append("sine level(s) flagged saturated by the analysis kept: their peaks stay inside the identified rails ("
                     + ", ".join(readmitted) + ")")
    cov, dof = _scaled_covariance(it, notes)
    values = dict(zip(free, (float(v) for v in fit.x)))
    budget: list[TypeBTerm] = []
    if opts.typeb is not None and opts.typeb.declared and free:
        cov, budget = _type_b(cov, values, base, obs, free, opts.kind, opts.typeb)
    if "k2_ug_per_g2" in why and "k3_ug_per_g3" in why and "k2_ug_per_g2" in values:
        g0 = obs[0].static_g
        k3b = parameter(base, "k3_ug_per_g3") or 0.0
        i = free.index("k2_ug_per_g2")
        notes.append(f"one orientation: k2 + 3·k3·g0 = {values['k2_ug_per_g2'] + 3 * k3b * g0:.6g} ± "
                     f"{math.sqrt(cov[i, i]):.2g} µg/g² at g0 = {g0:+g} g (valid at that orientation only)")
    # the cross-coupling coefficients from the runs mounted at an angle, on the model just identified
    cross = fit_cross_coupling(tilted, [ob for ob in obs if ob.method == "sine"],
                               with_parameters(base, values), opts.typeb, opts.kind)
    why.update(cross.reasons)
    notes += cross.notes
    table = _parameters(it, values, cov, cross, base, opts.prefer_base, notes)
    _assumption_notes(it, values, cov, table, bool(tilted), opts.prefer_base, notes)
    return ChannelModel(channel, table.params, {n: why[n] for n in PARAMETERS if table.params[n] is None}, table.used,
                        _joint_covariance(free, table.params, cov, cross), fit.chi2, dof,
                        tuple(_run_table(fit.preds, obs)), tuple(notes), tuple(budget),
                        tuple(cross_check_2f(obs, base)), table.assumed, cross if tilted else None)


@dataclass
class _Iterated:
    """The fit :func:`_iterate` settled on: the levels it used, the parameters left free, why the
    others are not, and what :func:`post_checks` found about fn and Q."""

    fit: LeastSquaresFit
    obs: list[Observation]
    free: list[str]
    why: dict[str, str]
    found: Findings
    level_notes: list[str]


def _iterate(full: list[Observation], base: Sensor, kind: ClipKind, prefer_base: bool) -> _Iterated:
    """Fit, then choose the levels the fitted model covers and the parameters the data determine,
    and refit until neither changes (at most 8 fits)."""
    obs = unsaturated(full) or full
    free, why = plan_parameters(obs, base)
    fit: LeastSquaresFit | None = None
    start = starting_values(obs, base, free)
    found = Findings()
    level_notes: list[str] = []
    for attempt in range(8):
        fit = least_squares_fit(base, obs, free, start, kind)
        fitted = with_parameters(base, dict(zip(free, fit.x)))
        # the candidates: every level, the flagged sine ones only where the rails were identified
        rails_known = "rail_low_g" in free and "rail_high_g" in free
        cand = full if rails_known else (unsaturated(full) or full)
        level_notes = []
        kept = _modelled(cand, model_runs(fitted, cand, kind), level_notes, fitted)
        kept = cand if kept is None else kept
        start = {n: float(v) for n, v in zip(free, fit.x)}  # go on from here
        if level_key(kept) != level_key(obs) and attempt < 7:  # the fitted model covers other levels: refit on them
            obs = kept
            continue
        dof = sum(ob.n for ob in obs) - len(free)
        scale = max(1.0, fit.chi2 / dof) if dof > 0 else 1.0
        values = dict(zip(free, fit.x))
        var = {n: fit.cov[i, i] * scale for i, n in enumerate(free)}
        found.widen.clear()
        found.loose.clear()
        later = post_checks(values, var, free, fit.preds, obs, base, prefer_base, found)
        why.update(later)
        fixed = [n for n in later if n not in NUISANCE]
        if not fixed:
            break
        free = [n for n in free if n not in fixed]
        start = {n: v for n, v in start.items() if n in free}
    if fit is None:  # range(8) runs at least once
        raise RuntimeError("identify: no fit was made")
    return _Iterated(fit, list(obs), free, why, found, level_notes)


def _scaled_covariance(it: _Iterated, notes: list[str]) -> tuple[NDArray[np.float64], int]:
    """The fit's covariance scaled by the Birge ratio where it exceeds 1, fn and Q widened where
    their likelihood is not quadratic; and the degrees of freedom."""
    fit, free, why = it.fit, it.free, it.why
    n_levels = sum(ob.n for ob in it.obs)
    dof = n_levels - len(free)
    chi2_red = fit.chi2 / dof if dof > 0 else math.nan
    cov = fit.cov.copy()
    if dof > 0 and chi2_red > 1.0:
        cov *= chi2_red
        notes.append(f"the levels scatter about the model more than their uncertainties (chi2/dof = {chi2_red:.3g}): "
                     "the covariance is scaled by it")
    if dof <= 0:
        notes.append("as many parameters as levels (or more): chi2 undefined, the covariance from the levels' "
                     "uncertainties alone")
    if fit.jac_rank < len(free):
        notes.append(f"the Jacobian has rank {fit.jac_rank} for {len(free)} parameters: some combination is not "
                     "determined (its direction dropped from the covariance)")
    for n, factor in it.found.widen.items():
        if n in free and n not in why and math.isfinite(factor):
            i = free.index(n)
            before = math.sqrt(max(cov[i, i], 0.0))
            cov[i, :] *= factor
            cov[:, i] *= factor
            notes.append(f"{n}: the likelihood is not quadratic over its u (the sine runs' profile Δχ² <= 1 half-width is "
                         f"{factor:.2g}× what its curvature says): its u {before:.2g} widened by that, correlations kept")
    return cov, dof


@dataclass(frozen=True)
class _Table:
    """Per parameter: its estimate (None: not identified), the value used, and the assumed ones' u and source."""

    params: dict[str, Estimate | None]
    used: dict[str, float | None]
    assumed: dict[str, tuple[float | None, str]]


def _parameters(it: _Iterated, values: Mapping[str, float], cov: NDArray[np.float64], cross: CrossCoupling,
                base: Sensor, prefer_base: bool, notes: list[str]) -> _Table:
    """Every parameter of PARAMETERS: identified (the fit's or the cross-coupling fit's), bounded
    (a resonance on one flank: an assumption with its profile's u) or the base sensor's."""
    free, why = it.free, it.why
    out = _Table({}, {}, {})
    params, used, assumed = out.params, out.used, out.assumed
    for n in PARAMETERS:
        if n in cross.estimates:
            params[n] = cross.estimates[n]
            used[n] = cross.estimates[n].value
        elif n in values and n not in why:
            i = free.index(n)
            est = params[n] = Estimate(values[n], math.sqrt(max(cov[i, i], 0.0)), TABLE[n].unit)
            used[n] = values[n]
            rel = est.u / abs(est.value) if est.value else math.inf
            if n in NUISANCE and not rel <= MAX_REL_U:
                notes.append(f"{n} poorly determined ({100 * rel:.0f} % relative u): kept with its value, u and "
                             "correlations (predict carries them; --prefer-base takes the base sensor's instead)")
        elif n in it.found.bounds and n in values and not prefer_base:
            # a resonance the runs show on one flank: kept at the fitted value as an assumption with the u its
            # profile allows (never the base's "no resonance", never the fit's local, overconfident u)
            params[n] = None
            u, text, middle = it.found.bounds[n]
            used[n] = values[n] if middle is None else middle
            assumed[n] = (u, f"fitted as a nuisance parameter, only bounded: {text}"
                          + ("" if middle is None else f"; written at the bound's middle {middle:.4g} ± {u:.3g}"))
        else:
            params[n] = None
            used[n] = parameter(base, n)
            why.setdefault(n, "not fitted")
            if used[n] is not None:
                u_stated = base.uncertainty.get(n)
                assumed[n] = (u_stated, f"from base sensor ({why[n]}); "
                              + (f"its stated u {u_stated:.3g}" if u_stated is not None else "the base states no u for it"))
    return out


def _assumption_notes(it: _Iterated, values: Mapping[str, float], cov: NDArray[np.float64], table: _Table,
                      tilted: bool, prefer_base: bool, notes: list[str]) -> None:
    """What the sensor file will carry as assumptions without a u, and the nuisance parameters only bounded."""
    free = it.free
    # (the cross-coupling terms act only off the input axis: without a mount-angle run they are not news)
    no_u = [n for n, (u, _w) in table.assumed.items() if u is None and (tilted or n not in CROSS)]
    if no_u:
        notes.append("taken from the base sensor without a stated u (its file has no [uncertainty] for them): "
                     + ", ".join(f"{n} = {table.used[n]:.6g}" for n in no_u) + "; the sensor file marks them as "
                     "assumptions without u: predict names them and is not valid where the VRE moves with them (±10 %) "
                     "beyond its u")
    nuisance = [n for n in free if n in NUISANCE and table.params[n] is None]
    if nuisance:
        notes.append("fitted as nuisance parameters, only bounded (null): "
                     + ", ".join(f"{n} = {values[n]:.4g} (local ± {math.sqrt(max(cov[free.index(n), free.index(n)], 0)):.2g}"
                                 f" not a claim)" for n in nuisance)
                     + "; the other parameters are estimated with them free; the sensor file carries them as "
                     "assumptions with the profile's u" + (" (--prefer-base: the base's instead)" if prefer_base else ""))


def _joint_covariance(free: Sequence[str], params: Mapping[str, Estimate | None], cov: NDArray[np.float64],
                      cross: CrossCoupling) -> tuple[tuple[str, ...], NDArray[np.float64]] | None:
    """The identified parameters' covariance, the cross-coupling fit's block beside it."""
    ident = [n for n in free if params[n] is not None]
    idx = [free.index(n) for n in ident]
    covariance = (tuple(ident), cov[np.ix_(idx, idx)]) if ident else None
    if cross.covariance is not None:  # its own fit: uncorrelated with the model's parameters (block diagonal)
        names, block = cross.covariance
        if covariance is None:
            covariance = (names, block)
        else:
            m = np.zeros((len(covariance[0]) + len(names),) * 2)
            k = len(covariance[0])
            m[:k, :k], m[k:, k:] = covariance[1], block
            covariance = (covariance[0] + names, m)
    return covariance


def _modelled(obs: Sequence[Observation], preds: Sequence[Prediction], notes: list[str], sensor: Sensor) -> list[Observation] | None:
    """The observations without the levels the analytic model does not cover well enough to fit
    through; None when every level is covered. Each level left out is said in ``notes``.

    :func:`vrelab.prediction.predict` evaluates the nonlinearity and the rails as one map: exactly
    where nothing sits between them; where filters do (an output clip), the rails see the
    polynomial's output as a Gaussian and ``model_error_g`` bounds the rest. Left out: a level
    whose prediction is not valid for another reason; a sine level whose peak reaches a rail
    (deterministic, u of a few µg: the rails come from the random runs); a random level whose
    ``model_error_g`` exceeds half its u."""

    def covered(lv: LevelPrediction, ob: Observation, u: float) -> bool:
        if not lv.valid_otherwise:
            return False
        if ob.method == "sine":
            return lv.shares["clip_g"] == 0.0
        # predict's bound on the rails seeing the nonlinearity's non-Gaussian output through the filters
        return lv.model_error_g <= 0.5 * u

    out: list[Observation] = []
    dropped = False
    for ob, p in zip(obs, preds):
        keep = np.array([covered(lv, ob, float(u)) for lv, u in zip(p.levels, ob.u_g)])
        if keep.all():
            out.append(ob)
            continue
        dropped = True
        where = f"run {ob.run} ({ob.label!r}{f', {ob.freq_hz:.4g} Hz' if ob.freq_hz else ''})"
        for lv, kept in zip(p.levels, keep):
            if not kept:
                why = ("; ".join(lv.notes) if not lv.valid_otherwise else "the sine's peak reaches a rail, where clipping and "
                       "the nonlinearity do not add" if ob.method == "sine" else "the rails see the nonlinearity's "
                       "output through the filters: predict's error bound (model_error_g) exceeds half the level's u")
                notes.append(f"{where}: level {lv.rms_g:.4g} g rms left out of the fit: {why}")
        if keep.any():
            out.append(subset_levels(ob, keep))
    if not dropped:
        return None
    if not out:
        raise ValueError("identify: no level of the channel is covered by the analytic model (every one clips "
                         "with the nonlinearity, or its prediction is not valid): simulate instead")
    return out


def _run_table(preds: Sequence[Prediction], obs: Sequence[Observation]) -> list[RunFit]:
    out: list[RunFit] = []
    for p, ob in zip(preds, obs):
        model = np.array([lv.vre_g for lv in p.levels])
        pulls = (ob.vre_g - model) / ob.u_g
        out.append({
            "run": ob.run, "label": ob.label, "method": ob.method, "static_g": ob.static_g,
            "freq_hz": ob.freq_hz, "profile": None if ob.profile is None else ob.profile.describe().split(",")[0],
            "n": ob.n, "chi2": float(pulls @ pulls),
            "vrc_ug_per_g2": None if ob.method != "sine" else value_u(*apparent_vrc(ob)),
            "residuals": [{"rms_g": float(r), "vre_g": float(v), "u_vre_g": float(u), "model_g": float(m),
                           "pull": float(z), "model_valid": bool(lv.valid)}
                          for r, v, u, m, z, lv in zip(ob.rms_g, ob.vre_g, ob.u_g, model, pulls, p.levels)],
        })  # fmt: skip
    return out


def _type_b(cov: NDArray[np.float64], values: Mapping[str, float], base: Sensor, obs: Sequence[Observation],
            free: Sequence[str], kind: ClipKind, typeb: TypeB) -> tuple[NDArray[np.float64], list[TypeBTerm]]:
    """The Type B terms: refit with each declared input perturbed (:func:`vrelab.gum.type_b_shifts`);
    the covariance gains ``d·dᵀ`` per source."""
    from dataclasses import replace

    from vrelab.gum import type_b_shifts

    def refit(delta: Mapping[str, float]) -> dict[str, float] | None:
        moved = [replace(ob, rms_g=ob.rms_g * (1 + delta.get("rms_rel", 0.0)),
                         vre_g=ob.vre_g * (1 + delta.get("vre_rel", 0.0)) + delta.get("offset_g", 0.0),
                         static_g=ob.static_g + delta.get("static_g", 0.0)) for ob in obs]
        try:
            f = least_squares_fit(base, moved, free, values, kind)
        except ValueError:
            return None
        return dict(zip(free, (float(v) for v in f.x)))

    out = cov.copy()
    terms: list[TypeBTerm] = []
    for source, delta, shift in type_b_shifts(values, refit, typeb):
        if shift is None:
            terms.append({"source": source, "type": "B", "shifts": None, "note": "not evaluated (the refit failed)"})
            continue
        d = np.array([shift[n] for n in free])
        out = out + np.outer(d, d)
        terms.append({"source": source, "type": "B", "perturbation": dict(delta),
                      "shifts": {n: float(shift[n]) for n in free}})
    return out, terms
