"""Identification: the sensor's VRE model from a campaign, per channel (SPEC 6.1).

A campaign measures a part under a few conditions (orientations, sine frequencies, random
levels); a designer needs its VRE under *their* vibration, range and bandwidth. This module
fits the physical model of SPEC 1 to every level of every run of a channel at once — one
weighted least-squares likelihood, each level weighted by its Type A standard uncertainty —
and writes the result as a sensor file that ``predict``, ``simulate`` and ``sweep`` take.

The model of a level is :func:`vrelab.predict.predict` on the base sensor with the parameters
set (:func:`vrelab.sensor.parameters.with_parameters`): the same analytic model, walked through
the same stages, that ``vrelab predict`` evaluates, so identification and prediction cannot
drift apart. The parameters (:data:`vrelab.sensor.parameters.PARAMETERS`):

* ``k2_ug_per_g2``, ``k3_ug_per_g3`` — from the sine runs' orientations: a sine at f in a field
  g0 gives ``VRE = (k2 + 3·k3·g0)·|H(f)|²·rms²`` (SPEC 1.2, 1.3); two static fields separate
  them (random levels carry k·σ² under the clipping's share, which the rails also shape);
* ``fn_hz``, ``q`` — from VRC(f) across the sine frequencies, ``|H(f)|² = 1/((1-r²)² + (r/Q)²)``;
* ``rail_low_g``, ``rail_high_g`` — from the random runs, through the identified dynamics and
  the base sensor's filters (the physical rail where the clip sits, not the effective rail that
  a fit against the reference's rms gives);
* ``overrange_threshold_g`` — from the random runs, where the data reach it (the base sensor
  must give the hold time).

What the campaign cannot determine is null with its reason and taken from the base sensor,
marked so: k2 and k3 without a sine run; k3 with one orientation; k2 too when that orientation
is not 0 g (then only ``k2 + 3·k3·g0`` is known, and said); fn and Q with fewer than three sine
frequencies (two fix k and one combination of fn and Q), without a sine run near fn
(``f/fn >= 0.5``) or with a relative u above 50 %; a rail or the over-range threshold whose
share of the VRE stays within 3 standard uncertainties over the levels. The last three checks
are made with the fitted values: a rail or the threshold that fails is fixed at the base
sensor's value and the rest refitted; fn and Q that fail stay free as nuisance parameters (a
resonance the runs show but do not pin down must not be absorbed by k2 and k3) and are
reported null. Levels the analytic sum does not cover (a sine peak at a rail; a random level
where clipping and the nonlinearity interact beyond half its u) are left out with a note.

Uncertainty: the covariance ``(JᵀJ)⁻¹`` of the whitened residuals at the solution (J by
central differences), scaled by the reduced χ² when that exceeds 1 (the Birge ratio, as the
campaign's combinations do). Declared Type B terms (SPEC 4.3: reference and DUT sensitivity,
static field, thermal offset) enter by refitting with each input perturbed by its standard
uncertainty (:func:`vrelab.gum.type_b_shifts`); each gives a shift vector ``d`` and the
covariance gains ``d·dᵀ`` (the shifts are fully correlated across parameters).

Data flow: campaign document (``vrelab campaign``'s results.json, or a manifest reduced here)
-> :func:`observations` -> :func:`identify_channel` per channel -> :class:`Identification`
-> :func:`write_sensor_file` (DIR/sensor.toml) and the JSON document.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab._format import finite_or_none
from vrelab.campaign import SAME_ORIENTATION_G  # static fields closer than this are one orientation
from vrelab.models.clipping import Kind as ClipKind
from vrelab.profiles import RandomProfile
from vrelab.results import Estimate, same_frequency
from vrelab.sensor.parameters import PARAMETERS, TABLE, parameter, with_parameters

# A rail or the over-range threshold is determined when its share of the VRE, summed in
# quadrature over the levels in units of their standard uncertainty, reaches this.
REACH_SIGMA = 3.0
# The highest sine frequency must reach this fraction of fn for Q (and fn) to be determined:
# below it |H|² ≈ 1 + (2 - 1/Q²)·r², and only that one combination of fn and Q shows.
NEAR_FN = 0.5
# fn or Q with a relative standard uncertainty beyond this is not determined.
MAX_REL_U = 0.5
# Parameters that stay free when not determined (see _post_checks).
NUISANCE = ("fn_hz", "q")


@dataclass(frozen=True)
class Observation:
    """One run of one channel as identification uses it: the excitation and the levels."""

    run: int
    label: str
    method: str  # "sine" | "random"
    static_g: float
    freq_hz: float | None  # sine
    profile: RandomProfile | None  # random: the drive's spectrum shape (scaled to each level)
    rms_g: NDArray[np.float64]
    vre_g: NDArray[np.float64]
    u_g: NDArray[np.float64]  # Type A standard uncertainty of each VRE
    harmonic_g: tuple[tuple[float, float] | None, ...] = ()  # per level: the 2f estimate (value, u)

    @property
    def n(self) -> int:
        return int(self.rms_g.size)


@dataclass(frozen=True)
class ChannelModel:
    """The identified model of one channel."""

    channel: str
    parameters: Mapping[str, Estimate | None]  # every name of PARAMETERS; None: not determined
    reasons: Mapping[str, str]  # why a parameter is null
    values: Mapping[str, float | None]  # the value used for each parameter (identified or base)
    covariance: tuple[tuple[str, ...], NDArray[np.float64]] | None  # over the identified ones
    chi2: float
    dof: int
    runs: tuple[dict[str, Any], ...]  # per run: chi2, n, residuals
    notes: tuple[str, ...]
    budget: tuple[dict[str, Any], ...] = ()
    cross_check_2f: tuple[dict[str, Any], ...] = ()

    @property
    def chi2_reduced(self) -> float | None:
        return self.chi2 / self.dof if self.dof > 0 else None

    def to_dict(self) -> dict[str, Any]:
        params = {n: (None if e is None else {"value": finite_or_none(e.value), "u": finite_or_none(e.u),
                                              "unit": e.unit}) for n, e in self.parameters.items()}
        return {
            "channel": self.channel,
            "parameters": params,
            "null_reasons": dict(self.reasons),
            "values_used": {n: finite_or_none(v) if v is not None else None for n, v in self.values.items()},
            "covariance": None if self.covariance is None else {
                "params": list(self.covariance[0]),
                "matrix": [[finite_or_none(float(c)) for c in row] for row in self.covariance[1]]},
            "chi2_reduced": finite_or_none(self.chi2_reduced),
            "chi2": finite_or_none(self.chi2),
            "dof": self.dof,
            "runs": list(self.runs),
            "budget": list(self.budget),
            "cross_check_2f": list(self.cross_check_2f),
            "notes": list(self.notes),
        }  # fmt: skip


# --------------------------------------------------------------------------- observations


def observations(doc: Mapping[str, Any]) -> tuple[dict[str, list[Observation]], dict[str, list[str]]]:
    """Per channel, its runs' levels from a campaign document (:func:`vrelab.campaign.campaign_doc`).

    Levels without a finite VRE and a positive uncertainty are left out; a random run without
    its profile (the manifest's ``profile``) cannot be modelled and is left out with a note.
    """
    if not isinstance(doc, Mapping) or not isinstance(doc.get("runs"), list):
        raise ValueError("identify: not a campaign document (no runs): give a manifest or a `vrelab campaign --out` folder")
    obs: dict[str, list[Observation]] = {}
    notes: dict[str, list[str]] = {}
    for run in doc["runs"]:
        if run.get("status") != "ok":
            for ch in run.get("channels") or ():
                notes.setdefault(ch["channel"], []).append(f"run {run['index']} failed ({run.get('error')}): not used")
            continue
        for ch in run.get("channels") or ():
            name = ch["channel"]
            obs.setdefault(name, [])
            notes.setdefault(name, [])
            obs[name] += _observation(run, ch, notes[name])
    return obs, notes


def _pooled(u: NDArray[np.float64], dof: NDArray[np.float64]) -> NDArray[np.float64]:
    """The levels of one sine frequency share the DUT's noise (the drive is removed exactly, so
    the VRE's scatter is the sensor's and the baselines'), and each level's batch-means u rests
    on few degrees of freedom: their variances are pooled, weighted by those dof (unknown dof:
    the plain mean), so one level whose u came out low by chance does not steer the fit."""
    w = np.where(np.isfinite(dof), dof, 1.0)
    return np.full_like(u, math.sqrt(float(np.sum(w * u**2) / np.sum(w))))


def apparent_vrc(ob: Observation) -> tuple[float, float]:
    """A sine observation's apparent VRC [µg/g²] and its u: the weighted least-squares fit
    through the origin of VRE = VRC·rms² over its levels (u from the levels' u, unscaled)."""
    w = 1.0 / ob.u_g**2
    x2 = ob.rms_g**2
    s = float(np.sum(w * x2 * x2))
    return float(np.sum(w * ob.vre_g * x2)) / s * 1e6, 1e6 / math.sqrt(s)


def _type_a(level: Mapping[str, Any]) -> float | None:
    """A level's Type A standard uncertainty (its budget's record term when a budget was declared)."""
    for term in level.get("budget") or ():
        if term.get("type") == "A":
            return term.get("u_g")
    return level.get("u_vre_g")


def _observation(run: Mapping[str, Any], ch: Mapping[str, Any], notes: list[str]) -> list[Observation]:
    """A run's levels of one channel: one observation per sine frequency (a run may step
    several), or one for a random run."""
    where = f"run {run['index']} ({run.get('label')!r})"
    method = run.get("method")
    rows = []
    saturated = []
    for lv in ch.get("levels") or ():
        v, u, rms = lv.get("vre_g"), _type_a(lv), lv.get("rms_g")
        if v is None or u is None or rms is None or not (u > 0 and math.isfinite(v) and rms > 0):
            continue
        if method == "sine" and "saturated" in (lv.get("flags") or ()):
            saturated.append(f"{rms:.4g}")  # the DUT reached a rail: see _modelled for why a sine level must not
            continue
        h = lv.get("vre_2f")
        h2f = (float(h["value"]), float(h["u"])) if isinstance(h, Mapping) and h.get("value") is not None \
            and h.get("u") else None
        dof = lv.get("dof")
        rows.append((float(rms), float(v), float(u), lv.get("freq_hz"), h2f,
                     float(dof) if dof is not None and math.isfinite(dof) and dof > 0 else math.inf))
    if saturated:
        notes.append(f"{where}: sine level(s) {', '.join(saturated)} g rms left out: the DUT reached a rail there, "
                     "where clipping and the nonlinearity do not add")
    if not rows:
        notes.append(f"{where}: no level with a VRE and its uncertainty: not used")
        return []
    g0 = float(ch["static_g"])
    index, label = int(run["index"]), str(run.get("label", ""))

    def make(sel: Sequence[tuple[Any, ...]], freq: float | None, profile: RandomProfile | None) -> Observation:
        rms, vre, u, _, h2f, dof = zip(*sel)
        return Observation(index, label, str(method), g0, freq, profile, np.array(rms), np.array(vre),
                           _pooled(np.array(u), np.array(dof)) if freq is not None else np.array(u), tuple(h2f))

    if method == "sine":
        if any(r[3] is None for r in rows):
            notes.append(f"{where}: sine levels without a drive frequency: not used")
            return []
        groups: list[list[tuple[Any, ...]]] = []
        for r in sorted(rows, key=lambda r: r[3]):
            if groups and same_frequency(groups[-1][0][3], r[3]):
                groups[-1].append(r)
            else:
                groups.append([r])
        return [make(g, float(np.median([r[3] for r in g])), None) for g in groups]
    if method == "random":
        prof = run.get("profile")
        if not prof or not prof.get("breakpoints"):
            notes.append(f"{where}: random run without its profile (the manifest's `profile`, what the controller "
                         "ran): the drive's spectrum is unknown, its levels are not used")
            return []
        bp = np.asarray(prof["breakpoints"], dtype=np.float64)
        return [make(rows, None, RandomProfile(bp[:, 0], bp[:, 1], name=prof.get("name"), source=prof.get("spec")))]
    notes.append(f"{where}: method {method!r}: not used")
    return []


# --------------------------------------------------------------------------- the model


def model_levels(sensor: Any, ob: Observation, kind: ClipKind = "censored") -> Any:
    """:func:`vrelab.predict.predict` at the observation's conditions (its levels' rms)."""
    from vrelab.predict import predict

    excitation = ob.profile if ob.method == "random" else [ob.freq_hz]
    return predict(sensor, excitation, ob.rms_g, static_g=ob.static_g, kind=kind)  # type: ignore[arg-type]


def _model(sensor: Any, obs: Sequence[Observation], kind: ClipKind) -> list[Any]:
    return [model_levels(sensor, ob, kind) for ob in obs]


# --------------------------------------------------------------------------- determinability


def _orientations(obs: Sequence[Observation]) -> list[float]:
    out: list[float] = []
    for g in sorted(ob.static_g for ob in obs):
        if not out or g - out[-1] >= SAME_ORIENTATION_G:
            out.append(g)
    return out


def _sine_frequencies(obs: Sequence[Observation]) -> list[float]:
    out: list[float] = []
    for f in sorted(ob.freq_hz for ob in obs if ob.method == "sine" and ob.freq_hz):
        if not out or not same_frequency(out[-1], f):
            out.append(f)
    return out


def _plan(obs: Sequence[Observation], base: Any) -> tuple[list[str], dict[str, str]]:
    """Which parameters the data can determine before fitting, and why the others cannot."""
    free: list[str] = []
    why: dict[str, str] = {}
    sines = [ob for ob in obs if ob.method == "sine"]
    orient = _orientations(sines)
    if not sines:
        # random levels carry k2·σ² under the clipping's share, which the rails also shape: the
        # nonlinearity is read from sine runs, where nothing else rectifies below the rails
        why["k2_ug_per_g2"] = why["k3_ug_per_g3"] = "no sine run: k2 and k3 are identified from sine runs"
    elif len(orient) >= 2:
        free += ["k2_ug_per_g2", "k3_ug_per_g3"]
    else:
        free.append("k2_ug_per_g2")
        why["k3_ug_per_g3"] = (f"one orientation only (every run at g0 = {orient[0]:+g} g): k3 needs two static "
                               "fields (+g and -g)")
        if abs(orient[0]) >= SAME_ORIENTATION_G / 2:
            why["k2_ug_per_g2"] = (f"one orientation only (g0 = {orient[0]:+g} g): k2 and k3 are not separable "
                                   "(only k2 + 3·k3·g0 is, see the notes)")
    freqs = _sine_frequencies(obs)
    if not freqs:
        why["fn_hz"] = why["q"] = "no sine run: VRC(f) not measured"
    elif len(freqs) < 2:
        why["fn_hz"] = why["q"] = f"sine runs at one frequency only ({freqs[0]:g} Hz): VRC(f) has no shape"
    elif len(freqs) < 3:
        # VRC(f) = k·|H(f)|² at two frequencies fixes k and one more number: a whole curve of
        # (fn, Q) passes through both points, and any one of them would be a confident guess
        why["fn_hz"] = why["q"] = (f"sine runs at two frequencies only ({freqs[0]:g}, {freqs[1]:g} Hz): VRC(f) "
                                   "there fixes one combination of fn and Q, not both (needs three)")
    else:
        free += ["fn_hz", "q"]
    randoms = [ob for ob in obs if ob.method == "random"]
    if not randoms:
        for n in ("rail_low_g", "rail_high_g", "overrange_threshold_g"):
            why[n] = "no random run (with its profile): the rails are identified from random levels"
    else:
        free += ["rail_low_g", "rail_high_g"]
        if base.overrange_threshold_g is None or base.overrange_hold_s is None:
            why["overrange_threshold_g"] = ("the base sensor has no over-range protection (its hold time is needed "
                                            "to model one): give --base-sensor with overrange_hold_s")
        else:
            free.append("overrange_threshold_g")
    return free, why


def _reach(preds: Sequence[Any], obs: Sequence[Observation], share: str) -> float:
    """Σ (share / u)² over every level, square-rooted: how far a mechanism's share of the VRE
    stands out of the levels' noise (a sine level whose peak stays inside a rail has none)."""
    s = 0.0
    for p, ob in zip(preds, obs):
        for lv, u in zip(p.levels, ob.u_g):
            s += (float(lv.shares.get(share, 0.0)) / u) ** 2
    return math.sqrt(s)


def _post_checks(values: Mapping[str, float], cov: Mapping[str, float], free: Sequence[str], preds: Sequence[Any],
                 obs: Sequence[Observation]) -> dict[str, str]:
    """Parameters the fit freed that the fitted model shows the data do not determine.

    fn and Q so found stay in the fit as nuisance parameters (a resonance the sine runs show
    but do not pin down still shapes VRC(f), and k2, k3 must not absorb it); a rail or the
    threshold that the levels do not reach is fixed at the base sensor's value and the rest
    refitted (it shapes nothing the data see)."""
    why: dict[str, str] = {}
    if "fn_hz" in free:
        fmax = max(_sine_frequencies(obs))
        fn = values["fn_hz"]
        if fmax / fn < NEAR_FN:
            why["fn_hz"] = why["q"] = (f"no sine run near fn (the highest, {fmax:g} Hz, is {fmax / fn:.2f}·fn of the "
                                       f"fitted {fn:.4g} Hz; Q needs f >= {NEAR_FN:g}·fn)")
        else:
            for n in ("fn_hz", "q"):
                rel = math.sqrt(cov.get(n, math.inf)) / abs(values[n])
                if not rel <= MAX_REL_U:
                    why["fn_hz"] = why["q"] = (f"not determined by the sine runs ({n} has a relative standard "
                                               f"uncertainty of {100 * rel:.0f} %)")
    for n, share, side in (("rail_low_g", "clip_low_g", "lower"), ("rail_high_g", "clip_high_g", "upper")):
        if n in free:
            z = _reach(preds, obs, share)
            if z < REACH_SIGMA:
                why[n] = (f"the random levels do not reach the {side} rail: its share of the VRE is {z:.2g} standard "
                          f"uncertainties in all (needs {REACH_SIGMA:g})")
    if "overrange_threshold_g" in free:
        z = _reach(preds, obs, "overrange_g")
        if z < REACH_SIGMA:
            why["overrange_threshold_g"] = (f"the data do not reach the over-range threshold: its share of the VRE is "
                                            f"{z:.2g} standard uncertainties in all (needs {REACH_SIGMA:g})")
    return why


# --------------------------------------------------------------------------- fitting


@dataclass
class _Fit:
    x: NDArray[np.float64]
    cov: NDArray[np.float64]
    chi2: float
    preds: list[Any]
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


def _start(obs: Sequence[Observation], base: Any, free: Sequence[str]) -> dict[str, float]:
    """Starting values: the base sensor's, with k2, k3, fn and Q from the closed form of each
    sine run's apparent VRC, ``VRC(f, g0) = (k2 + 3·k3·g0)·|H(f)|²``: k2 and k3 solved linearly
    at every (fn, Q) of a log grid (fn from a third of the lowest to ten times the highest sine
    frequency, Q from 0.5 to 50), the best grid point polished by least squares. A grid, not a
    few starts: VRC(f) has valleys (a large Q fits three frequencies nearly as well) that a
    local search from a poor start does not leave."""
    from scipy.optimize import least_squares

    from vrelab.models.dynamics import vrc_at_frequency

    start = {n: v for n in free if (v := parameter(base, n)) is not None}
    start.setdefault("k2_ug_per_g2", parameter(base, "k2_ug_per_g2") or 0.0)
    start.setdefault("k3_ug_per_g3", parameter(base, "k3_ug_per_g3") or 0.0)
    sines = [ob for ob in obs if ob.method == "sine"]
    if sines:
        vrc, u = (np.array(a) for a in zip(*(apparent_vrc(ob) for ob in sines)))
        f = np.array([ob.freq_hz for ob in sines])
        g0 = np.array([ob.static_g for ob in sines])
        k3_free = "k3_ug_per_g3" in free
        dyn_free = "fn_hz" in free
        k3_fixed = start["k3_ug_per_g3"]

        def ks(h: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
            """k2 (and k3) by weighted linear least squares at the response |H|² = h; the cost."""
            a = np.column_stack([h, 3 * g0 * h] if k3_free else [h]) / u[:, None]
            y = (vrc - (0.0 if k3_free else 3 * k3_fixed * g0 * h)) / u
            k, *_ = np.linalg.lstsq(a, y, rcond=None)
            r = a @ k - y
            return k, float(r @ r)

        def h_of(fn: float | None, q: float | None) -> NDArray[np.float64]:
            return np.asarray(vrc_at_frequency(1.0, f, fn, q)) if fn else np.ones_like(f)

        if dyn_free:
            grid = [(fn, q) for fn in np.geomspace(f.min() / 3, 10 * f.max(), 60) for q in np.geomspace(0.5, 50, 15)]
            fn0, q0 = min(grid, key=lambda g: ks(h_of(*g))[1])

            def resid(p: NDArray[np.float64]) -> NDArray[np.float64]:
                k = p[:-2]
                h = h_of(p[-2], p[-1])
                k3 = k[1] if k3_free else k3_fixed
                return ((k[0] + 3 * k3 * g0) * h - vrc) / u

            k0, _ = ks(h_of(fn0, q0))
            r = least_squares(resid, np.r_[k0, fn0, q0], x_scale="jac",
                              bounds=([-np.inf] * len(k0) + [1e-3, 0.05], [np.inf] * len(k0) + [1e6, 1e4]))
            k, (start["fn_hz"], start["q"]) = r.x[:-2], (float(r.x[-2]), float(r.x[-1]))
        else:
            k, _ = ks(h_of(base.fn_hz, base.q))
        start["k2_ug_per_g2"] = float(k[0])
        if k3_free:
            start["k3_ug_per_g3"] = float(k[1])
    for n in ("rail_low_g", "rail_high_g", "overrange_threshold_g"):
        if n in free:
            lo, hi = _bounds(n, obs)
            start[n] = min(max(start[n], lo + 1e-3), hi - 1e-3)
    return start


def _residuals(sensor: Any, obs: Sequence[Observation], kind: ClipKind) -> tuple[NDArray[np.float64], list[Any]]:
    preds = _model(sensor, obs, kind)
    r = np.concatenate([(np.array([lv.vre_g for lv in p.levels]) - ob.vre_g) / ob.u_g for p, ob in zip(preds, obs)])
    return r, preds


def _fit(base: Any, obs: Sequence[Observation], free: Sequence[str], start: Mapping[str, float],
         kind: ClipKind) -> _Fit:
    """Least squares over the ``free`` parameters; the others keep the base sensor's values."""
    from scipy.optimize import least_squares

    def sensor_at(x: NDArray[np.float64]) -> Any:
        return with_parameters(base, dict(zip(free, x)))

    n_res = sum(ob.n for ob in obs)
    bad = np.full(n_res, 1e6)

    def resid(x: NDArray[np.float64]) -> NDArray[np.float64]:
        try:
            r, _ = _residuals(sensor_at(x), obs, kind)
        except ValueError:  # a parameter set the sensor refuses (rails crossing a static level)
            return bad
        return np.where(np.isfinite(r), r, 1e6)

    x0 = np.array([start[n] for n in free], dtype=np.float64)
    bounds = np.array([_bounds(n, obs) for n in free], dtype=np.float64).T if free else (-np.inf, np.inf)
    if free:
        res = least_squares(resid, x0, bounds=(bounds[0], bounds[1]), x_scale="jac", diff_step=1e-5, max_nfev=60,
                            ftol=1e-6, xtol=1e-6)  # χ² to 1e-6 (relative) is far below its own scatter
        x = res.x
    else:
        x = x0
    r, preds = _residuals(sensor_at(x), obs, kind)
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
    cov, rank = _covariance(jac)
    return _Fit(x, cov, chi2, preds, rank)


def _covariance(jac: NDArray[np.float64]) -> tuple[NDArray[np.float64], int]:
    """(JᵀJ)⁻¹ by SVD, singular directions dropped (as scipy's curve_fit does); and J's rank."""
    if jac.shape[1] == 0:
        return np.zeros((0, 0)), 0
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    keep = s > np.finfo(float).eps * max(jac.shape) * s[0]
    s, vt = s[keep], vt[keep]
    return (vt.T / s**2) @ vt, int(keep.sum())


def identify_channel(channel: str, obs: Sequence[Observation], base: Any, kind: ClipKind = "censored",
                     campaign: str = "the campaign", typeb: Any = None, notes: Sequence[str] = ()) -> ChannelModel:
    """Identify one channel's model from its observations (see the module docstring)."""
    notes = list(notes)
    obs = list(obs)
    if not obs:
        raise ValueError(f"identify: channel {channel!r} has no usable level in any run")
    free, why = _plan(obs, base)
    base_values = {n: parameter(base, n) for n in PARAMETERS}
    fit: _Fit | None = None
    start = _start(obs, base, free)
    for _ in range(4):
        fit = _fit(base, obs, free, start, kind)
        kept = _modelled(obs, fit.preds, notes, with_parameters(base, dict(zip(free, fit.x))))
        if kept is not None:  # levels the analytic model does not cover: left out, refitted
            obs = kept
            fit = _fit(base, obs, free, dict(zip(free, (float(v) for v in fit.x))), kind)
        dof = sum(ob.n for ob in obs) - len(free)
        scale = max(1.0, fit.chi2 / dof) if dof > 0 else 1.0
        values = dict(zip(free, fit.x))
        var = {n: fit.cov[i, i] * scale for i, n in enumerate(free)}
        later = _post_checks(values, var, free, fit.preds, obs)
        why.update(later)
        fixed = [n for n in later if n not in NUISANCE]
        if not fixed:
            break
        free = [n for n in free if n not in fixed]
        start = {n: float(v) for n, v in zip(list(values), fit.x) if n in free}  # go on from here
    assert fit is not None
    n_levels = sum(ob.n for ob in obs)
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
    values = dict(zip(free, (float(v) for v in fit.x)))
    budget: list[dict[str, Any]] = []
    if typeb is not None and typeb.declared and free:
        cov, budget = _type_b(cov, values, base, obs, free, kind, typeb)
    if "k2_ug_per_g2" in why and "k3_ug_per_g3" in why and "k2_ug_per_g2" in values:
        g0 = obs[0].static_g
        k3b = base_values["k3_ug_per_g3"] or 0.0
        i = free.index("k2_ug_per_g2")
        notes.append(f"one orientation: k2 + 3·k3·g0 = {values['k2_ug_per_g2'] + 3 * k3b * g0:.6g} ± "
                     f"{math.sqrt(cov[i, i]):.2g} µg/g² at g0 = {g0:+g} g (valid at that orientation only)")
    params: dict[str, Estimate | None] = {}
    used: dict[str, float | None] = {}
    for n in PARAMETERS:
        if n in values and n not in why:
            i = free.index(n)
            params[n] = Estimate(values[n], math.sqrt(max(cov[i, i], 0.0)), TABLE[n].unit)
            used[n] = values[n]
        else:
            params[n] = None
            used[n] = base_values[n]
            why.setdefault(n, "not fitted")
    nuisance = [n for n in free if n in NUISANCE and params[n] is None]
    if nuisance:
        notes.append("fitted as nuisance parameters, not determined (null; the sensor file takes the base sensor's): "
                     + ", ".join(f"{n} = {values[n]:.4g} ± {math.sqrt(max(cov[free.index(n), free.index(n)], 0)):.2g}"
                                 for n in nuisance)
                     + "; the other parameters are estimated with them free")
    ident = [n for n in free if params[n] is not None]
    idx = [free.index(n) for n in ident]
    covariance = (tuple(ident), cov[np.ix_(idx, idx)]) if ident else None
    runs = _run_table(fit.preds, obs)
    return ChannelModel(channel, params, {n: why[n] for n in PARAMETERS if params[n] is None}, used, covariance,
                        fit.chi2, dof, tuple(runs), tuple(notes), tuple(budget), tuple(cross_check_2f(obs)))


def _modelled(obs: Sequence[Observation], preds: Sequence[Any], notes: list[str], sensor: Any) -> list[Observation] | None:
    """The observations without the levels the analytic model does not cover well enough to fit
    through; None when every level is covered. Each level left out is said in ``notes``.

    :func:`vrelab.predict.predict` evaluates the nonlinearity and the rails as one map: exactly
    where nothing sits between them; where filters do (an output clip), the rails see the
    polynomial's output as a Gaussian and ``model_error_g`` bounds the rest. Left out: a level
    whose prediction is not valid for another reason; a sine level whose peak reaches a rail
    (deterministic, u of a few µg: the rails come from the random runs); a random level whose
    ``model_error_g`` exceeds half its u."""
    from dataclasses import replace

    def covered(lv: Any, ob: Observation, u: float) -> bool:
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
            out.append(replace(ob, rms_g=ob.rms_g[keep], vre_g=ob.vre_g[keep], u_g=ob.u_g[keep],
                               harmonic_g=tuple(h for h, kept in zip(ob.harmonic_g, keep) if kept) if ob.harmonic_g else ()))
    if not dropped:
        return None
    if not out:
        raise ValueError("identify: no level of the channel is covered by the analytic model (every one clips "
                         "with the nonlinearity, or its prediction is not valid): simulate instead")
    return out


def _run_table(preds: Sequence[Any], obs: Sequence[Observation]) -> list[dict[str, Any]]:
    out = []
    for p, ob in zip(preds, obs):
        model = np.array([lv.vre_g for lv in p.levels])
        pulls = (ob.vre_g - model) / ob.u_g
        out.append({
            "run": ob.run, "label": ob.label, "method": ob.method, "static_g": ob.static_g,
            "freq_hz": ob.freq_hz, "profile": None if ob.profile is None else ob.profile.describe().split(",")[0],
            "n": ob.n, "chi2": float(pulls @ pulls),
            "vrc_ug_per_g2": None if ob.method != "sine" else dict(zip(("value", "u"), apparent_vrc(ob))),
            "residuals": [{"rms_g": float(r), "vre_g": float(v), "u_vre_g": float(u), "model_g": float(m),
                           "pull": float(z), "model_valid": bool(lv.valid)}
                          for r, v, u, m, z, lv in zip(ob.rms_g, ob.vre_g, ob.u_g, model, pulls, p.levels)],
        })  # fmt: skip
    return out


def _type_b(cov: NDArray[np.float64], values: Mapping[str, float], base: Any, obs: Sequence[Observation],
            free: Sequence[str], kind: ClipKind, typeb: Any) -> tuple[NDArray[np.float64], list[dict[str, Any]]]:
    """The Type B terms: refit with each declared input perturbed (:func:`vrelab.gum.type_b_shifts`);
    the covariance gains ``d·dᵀ`` per source."""
    from dataclasses import replace

    from vrelab.gum import type_b_shifts

    def refit(delta: Mapping[str, float]) -> dict[str, float] | None:
        moved = [replace(ob, rms_g=ob.rms_g * (1 + delta.get("rms_rel", 0.0)),
                         vre_g=ob.vre_g * (1 + delta.get("vre_rel", 0.0)) + delta.get("offset_g", 0.0),
                         static_g=ob.static_g + delta.get("static_g", 0.0)) for ob in obs]
        try:
            f = _fit(base, moved, free, values, kind)
        except ValueError:
            return None
        return dict(zip(free, (float(v) for v in f.x)))

    out = cov.copy()
    terms = []
    for source, delta, shift in type_b_shifts(values, refit, typeb):
        if shift is None:
            terms.append({"source": source, "type": "B", "shifts": None, "note": "not evaluated (the refit failed)"})
            continue
        d = np.array([shift[n] for n in free])
        out = out + np.outer(d, d)
        terms.append({"source": source, "type": "B", "perturbation": dict(delta),
                      "shifts": {n: float(shift[n]) for n in free}})
    return out, terms


# --------------------------------------------------------------------------- 2f cross-check


def cross_check_2f(obs: Sequence[Observation]) -> list[dict[str, Any]]:
    """Per sine run whose levels carry a 2f estimate: the apparent VRC from the DUT's 2f line
    (less the reference's own) beside the one from the DC shift, both ``(k2 + 3·k3·g0)·|H|²``
    for a cubic polynomial on the proof mass (SPEC 6.1): x = A·cos θ gives
    ``k·x² = k·A²/2 + k·A²/2·cos 2θ``, the same coefficient at DC and at 2f. Immune to drift,
    so a disagreement beyond the uncertainties points at a drifting baseline or at filters
    after the nonlinearity that attenuate 2f (the DC is untouched by them)."""
    from vrelab.fits import fit_vrc
    from vrelab.results import LevelResult

    out = []
    for ob in obs:
        if ob.method != "sine" or not ob.harmonic_g or not any(h is not None for h in ob.harmonic_g):
            continue
        pairs = [(r, h) for r, h in zip(ob.rms_g, ob.harmonic_g) if h is not None]
        two_f = fit_vrc([LevelResult(float(r), Estimate(h[0], h[1])) for r, h in pairs])
        dc = fit_vrc([LevelResult(float(r), Estimate(float(v), float(u))) for r, v, u in zip(ob.rms_g, ob.vre_g, ob.u_g)])
        a, b = two_f.params["vrc_ug_per_g2"], dc.params["vrc_ug_per_g2"]
        z = (a.value - b.value) / math.hypot(a.u, b.u) if math.hypot(a.u, b.u) > 0 else math.nan
        out.append({"run": ob.run, "label": ob.label, "freq_hz": ob.freq_hz, "static_g": ob.static_g,
                    "vrc_2f_ug_per_g2": {"value": a.value, "u": a.u}, "vrc_dc_ug_per_g2": {"value": b.value, "u": b.u},
                    "difference_sigma": finite_or_none(z), "agree": bool(abs(z) <= 3) if math.isfinite(z) else None})
    return out


# --------------------------------------------------------------------------- the whole campaign


@dataclass(frozen=True)
class Identification:
    """Every channel of a campaign identified on one base sensor."""

    campaign: str
    base_spec: str
    base: Any  # the resolved base Sensor
    channels: tuple[ChannelModel, ...]
    kind: ClipKind
    provenance: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self, sensor_file: str | None = None) -> dict[str, Any]:
        return {
            "kind": "identification",
            "campaign": self.campaign,
            "base_sensor": {"spec": self.base_spec, "name": self.base.name, "range_g": self.base.range_g,
                            "axis": self.base.axis, "odr_hz": self.base.odr_hz},
            "clip_model": self.kind,
            "sensor_file": sensor_file,
            "channels": [c.to_dict() for c in self.channels],
            "provenance": dict(self.provenance),
        }


def identify(doc: Mapping[str, Any], base_spec: str = "ideal", range_g: float | None = None,
             odr_hz: float | None = None, base_axis: str | None = None, kind: ClipKind = "censored",
             typeb: Any = None, workers: int = 1) -> Identification:
    """Identify every channel of a campaign document on the base sensor ``base_spec``.

    ``typeb`` (a :class:`vrelab.gum.TypeB`) overrides the budget the runs declared; without it
    the largest value each run declared is used (one reference, one DUT: their terms are common
    to every run). ``workers`` > 1 identifies channels in parallel processes.
    """
    from vrelab import _validate as V
    from vrelab.gum import TypeB
    from vrelab.models.clipping import KINDS
    from vrelab.sensor import load_sensor

    V.one_of("kind", kind, KINDS)
    workers = V.integer("workers", workers, 1)
    base = load_sensor(base_spec, range_g=range_g, axis=base_axis, odr_hz=odr_hz)
    obs, notes = observations(doc)
    if not obs:
        raise ValueError("identify: the campaign has no DUT channel with results")
    if typeb is None:
        keys = ("u_reference_pct", "u_dut_pct", "u_static_g", "u_thermal_g")
        runs = [r for r in doc["runs"] if isinstance(r.get("budget"), Mapping)]
        typeb = TypeB(**{k: max((float(r["budget"].get(k, 0.0)) for r in runs), default=0.0) for k in keys})
    name = str(doc.get("name", "campaign"))
    empty = [ch for ch, o in obs.items() if not o]
    if empty:
        raise ValueError(f"identify: channel {empty[0]!r} has no usable level in any run "
                         f"({'; '.join(notes.get(empty[0], [])) or 'no levels'})")
    jobs = [(ch, obs[ch], base, kind, name, typeb, notes.get(ch, [])) for ch in obs]
    if workers > 1 and len(jobs) > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(workers, len(jobs))) as pool:
            models = list(pool.map(_identify_job, jobs))
    else:
        models = [_identify_job(j) for j in jobs]
    return Identification(name, base_spec, base, tuple(models), kind)


def _identify_job(job: tuple[Any, ...]) -> ChannelModel:
    ch, ob, base, kind, name, typeb, notes = job
    return identify_channel(ch, ob, base, kind, name, typeb, notes)


# --------------------------------------------------------------------------- the sensor file


def sensor_file_document(ident: Identification) -> dict[str, Any]:
    """The identified sensor as a sensor-file document (the presets' schema, SPEC 6.1).

    The base sensor's file is the template: its other ranges, ODRs and filters stay as they
    are. Each channel becomes ``[axes.<channel>]`` holding every identifiable parameter
    (identified, or the base's value where the campaign could not determine it), its own
    ``facts`` (``"identified from <campaign>, ± u"`` or ``"from base sensor ..."``) and the
    covariance of the identified ones. The tested range's table loses the keys the axes now
    set, so they win there (resolution: top level < axis < range); other ranges keep the base's
    rails and threshold (they were not tested).
    """
    from vrelab.sensor.loader import _read

    data, _origin = _read(ident.base_spec)
    base = ident.base
    out: dict[str, Any] = {k: v for k, v in data.items() if k not in ("name", "description", "source", "axes",
                                                                     "default_axis", "facts")}
    out["schema"] = data.get("schema", 1)
    out["name"] = f"{base.name}-identified"
    out["description"] = f"{base.name} with its VRE model identified from campaign {ident.campaign!r} by vrelab identify"
    out["source"] = f"vrelab identify: campaign {ident.campaign!r} on base sensor {ident.base_spec}"
    out["default_range_g"] = base.range_g
    out["default_axis"] = ident.channels[0].channel
    keys = {"k2_ug_per_g2", "k3_ug_per_g3", "fn_hz", "q", "rails_g", "overrange_threshold_g"}
    ranges = data.get("ranges")
    if isinstance(ranges, dict):
        from vrelab.sensor import load_sensor

        tested = next((k for k in ranges if math.isclose(float(k), base.range_g, rel_tol=1e-6)), None)
        out["ranges"] = {}
        for k, t in ranges.items():
            if k == tested:
                out["ranges"][k] = {kk: vv for kk, vv in t.items() if kk not in keys}
            else:  # an untested range keeps the base's rails, never the tested range's identified ones
                rails = load_sensor(ident.base_spec, range_g=float(k), axis=base.axis, odr_hz=base.odr_hz).rails_g
                out["ranges"][k] = {**t, "rails_g": [float(rails[0]), float(rails[1])]}
    base_axis = (data.get("axes") or {}).get(base.axis, {})
    base_facts = dict(base.facts)
    facts_top = {k: v for k, v in (data.get("facts") or {}).items()}
    if facts_top:
        out["facts"] = facts_top
    axes: dict[str, Any] = {}
    for cm in ident.channels:
        t: dict[str, Any] = {k: v for k, v in base_axis.items() if k not in keys}
        f: dict[str, str] = {}
        for n in PARAMETERS:
            v = cm.values[n]
            e = cm.parameters[n]
            fk = TABLE[n].fact_key
            src = (f"identified from {ident.campaign}, {e.value:.6g} ± {e.u:.2g} {TABLE[n].text_unit}".rstrip()
                   if e is not None else f"from base sensor {ident.base_spec} ({cm.reasons.get(n, 'not identified')}): "
                   f"{base_facts.get(fk, 'unmarked')}")
            f[fk] = f"{f[fk]}; {_side(n)}: {src}" if fk in f else (f"{_side(n)}: {src}" if n.startswith("rail") else src)
            if v is None:
                continue
            if n.startswith("rail"):
                continue
            t[n] = float(v)
        lo, hi = cm.values["rail_low_g"], cm.values["rail_high_g"]
        t["rails_g"] = [float(lo), float(hi)]  # type: ignore[arg-type]
        t["facts"] = f
        if cm.covariance is not None:
            t["covariance"] = {"params": list(cm.covariance[0]), "matrix": [[float(c) for c in row]
                                                                           for row in cm.covariance[1]]}
        axes[cm.channel] = t
    out["axes"] = axes
    return out


def _side(name: str) -> str:
    return {"rail_low_g": "lower", "rail_high_g": "upper"}.get(name, name)


def write_sensor_file(path: str | Path, ident: Identification) -> Path:
    """Write :func:`sensor_file_document` as TOML to ``path``: written beside it, loaded for
    each channel, then renamed into place (a file that would not load is never left behind)."""
    import os

    import tomli_w

    from vrelab.sensor import load_sensor

    path = Path(path)
    doc = sensor_file_document(ident)
    text = tomli_w.dumps(doc)
    header = (f"# Identified by vrelab from campaign {ident.campaign!r} (SPEC 6.1): one [axes.<channel>] per channel,\n"
              "# every number's source in its facts, the identified parameters' covariance beside them.\n"
              "# Use it as --sensor with --axis <channel> in predict, simulate and sweep.\n")
    tmp = path.with_name(path.name + ".partial.toml")
    try:
        tmp.write_text(header + text, encoding="utf-8")
        for cm in ident.channels:
            load_sensor(str(tmp), axis=cm.channel)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


__all__ = ["Observation", "ChannelModel", "Identification", "observations", "identify", "identify_channel",
           "model_levels", "apparent_vrc", "cross_check_2f", "sensor_file_document", "write_sensor_file", "REACH_SIGMA", "NEAR_FN"]
