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
  them (random levels carry k·σ² under the clipping's share, which the rails also shape). A
  level whose drive was measured distorted (the document's ``drive``, SPEC 4.4) gives
  ``k2·E[x²] + k3·(3·g0·E[x²] + E[x³])``, modelled as the pure sine of its E[x²] at
  g0 + E[x³]/(3·E[x²]) (:func:`drive_equivalent`);
* ``fn_hz``, ``q`` — from VRC(f) across the sine frequencies, ``|H(f)|² = 1/((1-r²)² + (r/Q)²)``;
* ``rail_low_g``, ``rail_high_g`` — from the random runs, through the identified dynamics and
  the base sensor's filters (the physical rail where the clip sits, not the effective rail that
  a fit against the reference's rms gives);
* ``overrange_threshold_g`` — from the random runs, where the data reach it (the base sensor
  must give the hold time);
* ``kip_ug_per_g2``, ``kpp_ug_per_g2``, ``kio_ug_per_g2``, ``koo_ug_per_g2`` — IEEE 1293's
  cross-coupling coefficients (SPEC 1.6), from the sine runs mounted at an angle (the manifest's
  ``mount_deg``, ``mount_plane``), by their own linear fit on the model identified from the
  others (:func:`fit_cross_coupling`); those runs stay out of the fit above.

What the campaign cannot determine is null with its reason: k2 and k3 without a sine run; k3
with one orientation; k2 too when that orientation is not 0 g (then only ``k2 + 3·k3·g0`` is
known, and said); fn and Q with fewer than three sine frequencies (two fix k and one combination
of fn and Q); a rail or the over-range threshold whose share of the VRE stays within 3 standard
uncertainties over the levels (fixed at the base sensor's value, the rest refitted). The sensor
file takes those from the base sensor as assumptions, with the u the base states for them (its
``[uncertainty]`` table: a datasheet tolerance, a filter corner) or said to have none.

fn and Q are judged by their profile likelihood on the sine runs' apparent VRCs
(:func:`_resonance_profile`), not by the fit's local curvature alone: where every sine frequency
lies on one flank of the fitted fn (or below ``NEAR_FN``·fn), or a parameter's ±1σ profile
interval does not close (a Q the runs bound from below only), the parameter is null with the
bound the data give in its reason ("Q > 4.2"), stays free in the fit as a nuisance parameter
(k2 and k3 must not absorb a resonance the runs show), and goes into the sensor file as an
assumption whose u spans that bound, so ``predict`` says where its u is no claim. Where the
interval closes, fn and Q are kept with their value, u and correlations however large the u
(``prefer_base`` takes the base's instead), the u widened where the profile is wider than its
own curvature says. Levels the analytic sum does not cover (a sine peak at a rail, judged with
the identified rails; a random level where clipping and the nonlinearity interact beyond half
its u) are left out with a note; the choice is iterated with the fit.

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

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Mapping, NotRequired, Sequence, TypedDict

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab._format import finite_or_none
from vrelab.campaign import (
    MOUNT_PLANES,
    SAME_ORIENTATION_G,  # static fields closer than this are one orientation
    Mount,
)
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.profiles import RandomProfile
from vrelab.results import Estimate, group_by_frequency
from vrelab.sensor.parameters import PARAMETERS, TABLE, parameter, with_parameters
from vrelab.sensor.writer import file_values
from vrelab.units import to_ug

if TYPE_CHECKING:
    from vrelab.gum import TypeB
    from vrelab.prediction import LevelPrediction, Prediction
    from vrelab.sensor.loader import Sensor

# A rail or the over-range threshold is determined when its share of the VRE, summed in
# quadrature over the levels in units of their standard uncertainty, reaches this.
REACH_SIGMA = 3.0
# The highest sine frequency must reach this fraction of fn for Q (and fn) to be determined:
# below it |H|² ≈ 1 + (2 - 1/Q²)·r², and only that one combination of fn and Q shows.
NEAR_FN = 0.5
# fn or Q with a relative standard uncertainty beyond this is not determined.
MAX_REL_U = 0.5
# fn or Q whose profile-likelihood u exceeds the fit's local one by this factor take the profile's.
_WIDER = 1.3
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
    # per sine level: the analysis flagged DUT samples at a rail (its own rail, not the identified one)
    saturated: tuple[bool, ...] = ()
    mount: Mount | None = None  # an IEEE 1293 mount-angle run (SPEC 1.6): its angle, plane and static vector
    # per sine level: the reference's measured waveform as (E[x²]/rms², E[x³]/rms³), rms the
    # fundamental's (SPEC 4.4, :class:`vrelab.results.DriveWaveform`); None: a pure sine. Held
    # relative to rms so that a Type B scaling of the levels scales the moments with them.
    drive: tuple[tuple[float, float] | None, ...] = ()

    @property
    def n(self) -> int:
        return int(self.rms_g.size)

    @property
    def tilted(self) -> bool:
        """Mounted with the input axis off the vibration: the cross-coupling fit's, not the model's."""
        return self.mount is not None and self.mount.tilted


class ValueU(TypedDict):
    value: float
    u: float


class Residual(TypedDict):
    """One level of a run in :class:`RunFit`: measured, modelled, and the pull between them."""

    rms_g: float
    vre_g: float
    u_vre_g: float
    model_g: float
    pull: float
    model_valid: bool


class RunFit(TypedDict):
    """One run of a channel as the fitted model meets it (``ChannelModel.runs``, the JSON's ``runs``)."""

    run: int
    label: str
    method: str
    static_g: float
    freq_hz: float | None
    profile: str | None  # the random drive's description
    n: int
    chi2: float
    vrc_ug_per_g2: ValueU | None  # a sine run's apparent VRC
    residuals: list[Residual]


class TypeBTerm(TypedDict):
    """One Type B source's effect on the fitted parameters (``ChannelModel.budget``): the refit's
    shifts under its perturbation, or None with a note where the refit failed."""

    source: str
    type: Literal["B"]
    shifts: dict[str, float] | None
    perturbation: NotRequired[dict[str, float]]
    note: NotRequired[str]


class Check2f(TypedDict):
    """One sine run's 2f cross-check (:func:`cross_check_2f`)."""

    run: int
    label: str
    freq_hz: float | None
    static_g: float
    vrc_2f_ug_per_g2: ValueU
    vrc_dc_ug_per_g2: ValueU
    filter_gain_2f: float
    difference_sigma: float | None
    agree: bool | None


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
    runs: tuple[RunFit, ...]  # per run: chi2, n, residuals
    notes: tuple[str, ...]
    budget: tuple[TypeBTerm, ...] = ()
    cross_check_2f: tuple[Check2f, ...] = ()
    # parameters written to the sensor file as assumptions (not identified): their standard u
    # (from the base sensor's [uncertainty], or the profile of a resonance only bounded) and why
    assumed: Mapping[str, tuple[float | None, str]] = field(default_factory=dict)
    cross_coupling: CrossCoupling | None = None  # the mount-angle runs' fit (fit_cross_coupling)

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
            "assumed": {n: {"value": finite_or_none(self.values.get(n)), "u": finite_or_none(u), "source": why}
                        for n, (u, why) in self.assumed.items()},
            "cross_coupling": None if self.cross_coupling is None else self.cross_coupling.to_dict(),
            "notes": list(self.notes),
        }  # fmt: skip


def _value_u(value: float, u: float) -> ValueU:
    return {"value": value, "u": u}


# --------------------------------------------------------------------------- observations


def _is_num(v: Any, finite: bool = True) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and (not finite or math.isfinite(v))


# A level's numbers within physical bounds (vrelab._validate's: beyond any shaker, centrifuge or
# shock test), so that a hand-edited document's 1e308 is refused by name instead of overflowing
# in its square deep in the fit.
_LEVEL_BOUNDS = {
    "rms_g": (0.0, V.MAX_LEVEL_G_RMS, f"a vibration rms within 0..{V.MAX_LEVEL_G_RMS:g} g"),
    "vre_g": (-V.MAX_ACCELERATION_G, V.MAX_ACCELERATION_G, f"a VRE within ±{V.MAX_ACCELERATION_G:g} g"),
    "u_vre_g": (0.0, V.MAX_ACCELERATION_G, f"an uncertainty within 0..{V.MAX_ACCELERATION_G:g} g"),
    "freq_hz": (V.MIN_FREQ_HZ, V.MAX_FREQ_HZ, f"a frequency within {V.MIN_FREQ_HZ:g}..{V.MAX_FREQ_HZ:g} Hz"),
}


def check_document(doc: Any) -> None:
    """The campaign document's schema, as identification reads it (``vrelab campaign``'s
    results.json, :func:`vrelab.campaign.campaign_doc`): a ValueError naming the first field
    that is missing or of the wrong type (``runs[2].channels[0].static_g``), never a KeyError or
    a TypeError deep in the fit."""

    def need(where: str, ok: bool, what: str, value: Any) -> None:
        if not ok:
            shown = repr(value)
            raise ValueError(f"identify: campaign document {where} must be {what}, got "
                             f"{shown if len(shown) <= 60 else shown[:57] + '...'}")

    missing = object()
    need("(the whole)", isinstance(doc, Mapping), "an object", type(doc).__name__)
    need("runs", isinstance(doc.get("runs"), list), "a list of runs (give a manifest or a `vrelab campaign --out` "
         "folder)", doc.get("runs"))
    for i, run in enumerate(doc["runs"]):
        w = f"runs[{i}]"
        need(w, isinstance(run, Mapping), "an object", run)
        need(f"{w}.index", _is_num(run.get("index")) and float(run["index"]).is_integer(), "an integer",
             run.get("index", "missing"))
        need(f"{w}.status", isinstance(run.get("status"), str), "a string (ok or failed)", run.get("status", "missing"))
        if run["status"] != "ok":
            continue
        need(f"{w}.method", isinstance(run.get("method"), str), "a string (sine or random)", run.get("method", "missing"))
        need(f"{w}.channels", isinstance(run.get("channels"), list), "a list", run.get("channels", "missing"))
        if run.get("budget") is not None:
            need(f"{w}.budget", isinstance(run["budget"], Mapping) and all(_is_num(v) for v in run["budget"].values()),
                 "an object of numbers", run["budget"])
        prof = run.get("profile")
        if prof is not None:
            need(f"{w}.profile", isinstance(prof, Mapping), "an object", prof)
            bp = prof.get("breakpoints")
            need(f"{w}.profile.breakpoints", bp is None or (isinstance(bp, list) and all(
                isinstance(r, list) and len(r) == 2 and all(_is_num(x) for x in r) for r in bp)),
                "a list of [frequency, psd] pairs", bp)
        for j, ch in enumerate(run["channels"]):
            wc = f"{w}.channels[{j}]"
            need(wc, isinstance(ch, Mapping), "an object", ch)
            need(f"{wc}.channel", isinstance(ch.get("channel"), str) and bool(ch.get("channel")), "a channel name",
                 ch.get("channel", "missing"))
            need(f"{wc}.static_g", _is_num(ch.get("static_g", missing)), "a finite number [g]",
                 ch.get("static_g", "missing"))
            need(f"{wc}.static_g", abs(ch["static_g"]) <= V.MAX_ACCELERATION_G,
                 f"a static field within ±{V.MAX_ACCELERATION_G:g} g", ch["static_g"])
            need(f"{wc}.levels", isinstance(ch.get("levels"), list), "a list", ch.get("levels", "missing"))
            if ch.get("mount_deg") is not None or ch.get("mount_plane") is not None:
                need(f"{wc}.mount_deg", _is_num(ch.get("mount_deg")), "a finite number [°]", ch.get("mount_deg"))
                need(f"{wc}.mount_plane", ch.get("mount_plane") in MOUNT_PLANES, "ip or io", ch.get("mount_plane"))
                vec = ch.get("static_vector_g")
                need(f"{wc}.static_vector_g", isinstance(vec, list) and len(vec) == 3 and all(_is_num(v) for v in vec),
                     "three finite numbers [i, p, o] in g", vec)
            for k, lv in enumerate(ch["levels"]):
                wl = f"{wc}.levels[{k}]"
                need(wl, isinstance(lv, Mapping), "an object", lv)
                for key in ("rms_g", "vre_g", "u_vre_g", "freq_hz", "dof"):
                    v = lv.get(key)
                    need(f"{wl}.{key}", v is None or _is_num(v, finite=False), "a number or null", v)
                    if v is not None and math.isfinite(v) and key in _LEVEL_BOUNDS:
                        lo, hi, what = _LEVEL_BOUNDS[key]
                        need(f"{wl}.{key}", lo <= v <= hi, what, v)
                need(f"{wl}.flags", isinstance(lv.get("flags", []), list), "a list", lv.get("flags"))
                b = lv.get("budget")
                need(f"{wl}.budget", b is None or (isinstance(b, list) and all(isinstance(t, Mapping) for t in b)),
                     "a list of terms", b)
                for t in b or ():
                    need(f"{wl}.budget[].u_g", t.get("u_g") is None or _is_num(t.get("u_g"), finite=False),
                         "a number or null", t.get("u_g"))
                h = lv.get("vre_2f")
                need(f"{wl}.vre_2f", h is None or (isinstance(h, Mapping) and all(
                    h.get(x) is None or _is_num(h.get(x), finite=False) for x in ("value", "u"))),
                    "an object with value and u", h)
                for x, key in (("value", "vre_g"), ("u", "u_vre_g")):
                    v = None if h is None else h.get(x)
                    if v is not None and math.isfinite(v):
                        lo, hi, what = _LEVEL_BOUNDS[key]
                        need(f"{wl}.vre_2f.{x}", lo <= v <= hi, what, v)
                dw = lv.get("drive")
                need(f"{wl}.drive", dw is None or isinstance(dw, Mapping), "an object (the reference's waveform)", dw)
                for key, p in (("mean_square_g2", 2), ("mean_cube_g3", 3)):
                    m = None if dw is None else dw.get(key)
                    need(f"{wl}.drive.{key}", m is None or (isinstance(m, Mapping) and all(
                        m.get(x) is None or _is_num(m.get(x), finite=False) for x in ("value", "u"))),
                        "an object with value and u", m)
                    v = None if m is None else m.get("value")
                    if v is not None and math.isfinite(v):
                        top = V.MAX_LEVEL_G_RMS**p
                        need(f"{wl}.drive.{key}.value", (0.0 if p == 2 else -top) <= v <= top,
                             f"within {0 if p == 2 else -top:g}..{top:g} g^{p}", v)


def failed_runs(doc: Mapping[str, Any]) -> list[str]:
    """One line per run of the campaign that failed: it is not in the identification."""
    return [f"run {r['index']} ({r.get('label')!r}) failed ({r.get('error') or 'no error given'}): not used"
            for r in doc["runs"] if r.get("status") != "ok"]


def observations(doc: Mapping[str, Any]) -> tuple[dict[str, list[Observation]], dict[str, list[str]]]:
    """Per channel, its runs' levels from a campaign document (:func:`vrelab.campaign.campaign_doc`).

    The document is checked first (:func:`check_document`). Levels without a finite VRE and a
    positive uncertainty are left out; a random run without its profile (the manifest's
    ``profile``) cannot be modelled and is left out with a note. A failed run is named in every
    channel's notes (:func:`failed_runs`).
    """
    check_document(doc)
    obs: dict[str, list[Observation]] = {}
    notes: dict[str, list[str]] = {}
    for run in doc["runs"]:
        if run.get("status") != "ok":
            continue
        for ch in run.get("channels") or ():
            name = ch["channel"]
            obs.setdefault(name, [])
            notes.setdefault(name, [])
            obs[name] += _observation(run, ch, notes[name])
    failed = failed_runs(doc)
    for name in notes:
        notes[name] = failed + notes[name]
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
    through the origin of VRE = VRC·rms² over its levels, which is the weighted mean of each
    level's VRE/rms² (u: its u/rms²), so it is :func:`vrelab.gum.weighted_mean`'s: u scaled up by
    the Birge ratio when the levels scatter about the line more than their u say."""
    from vrelab.gum import weighted_mean

    x2 = drive_equivalent(ob)[0] ** 2 if ob.drive else ob.rms_g**2
    e = weighted_mean([Estimate(to_ug(float(v / x)), to_ug(float(u / x)), "ug/g^2")
                       for v, u, x in zip(ob.vre_g, ob.u_g, x2)])
    return e.value, e.u


def _type_a(level: Mapping[str, Any]) -> float | None:
    """A level's Type A standard uncertainty (its budget's record term when a budget was declared)."""
    for term in level.get("budget") or ():
        if term.get("type") == "A":
            u_a: float | None = term.get("u_g")
            return u_a
    u: float | None = level.get("u_vre_g")
    return u


def _drive_moments(level: Mapping[str, Any], rms: float) -> tuple[float, float] | None:
    """A sine level's measured drive moments relative to its fundamental's rms, (E[x²]/rms²,
    E[x³]/rms³) (the campaign document's ``drive``, SPEC 4.4), or None (a pure sine assumed, as
    without them) when the level carries none or they are not finite."""
    d = level.get("drive")
    if not isinstance(d, Mapping):
        return None
    m2, m3 = ((d.get(k) or {}).get("value") for k in ("mean_square_g2", "mean_cube_g3"))
    if m2 is None or m3 is None or not (math.isfinite(m2) and math.isfinite(m3) and m2 > 0):
        return None
    return float(m2) / rms**2, float(m3) / rms**3


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
        sat = method == "sine" and "saturated" in (lv.get("flags") or ())
        if sat:
            saturated.append(f"{rms:.4g}")  # the DUT reached a rail: see _modelled for why a sine level must not
        h = lv.get("vre_2f")
        h2f = (float(h["value"]), float(h["u"])) if isinstance(h, Mapping) and h.get("value") is not None \
            and h.get("u") else None
        dof = lv.get("dof")
        rows.append((float(rms), float(v), float(u), lv.get("freq_hz"), h2f,
                     float(dof) if dof is not None and math.isfinite(dof) and dof > 0 else math.inf, sat,
                     _drive_moments(lv, float(rms)) if method == "sine" else None))
    if saturated:
        notes.append(f"{where}: sine level(s) {', '.join(saturated)} g rms flagged saturated by the analysis (DUT "
                     "samples at its rail): left out, unless the identified rails clear their peaks")
    if not rows:
        notes.append(f"{where}: no level with a VRE and its uncertainty: not used")
        return []
    g0 = float(ch["static_g"])
    index, label = int(run["index"]), str(run.get("label", ""))
    mount = None
    if ch.get("mount_deg") is not None:
        vec = ch["static_vector_g"]
        mount = Mount(float(ch["mount_deg"]), str(ch["mount_plane"]), (float(vec[0]), float(vec[1]), float(vec[2])))

    def make(sel: Sequence[tuple[Any, ...]], freq: float | None, profile: RandomProfile | None) -> Observation:
        rms, vre, u, _, h2f, dof, sat, drv = zip(*sel)
        return Observation(index, label, str(method), g0, freq, profile, np.array(rms), np.array(vre),
                           _pooled(np.array(u), np.array(dof)) if freq is not None else np.array(u), tuple(h2f),
                           tuple(sat), mount, tuple(drv) if any(d is not None for d in drv) else ())

    if method == "sine":
        if any(r[3] is None for r in rows):
            notes.append(f"{where}: sine levels without a drive frequency: not used")
            return []
        groups = group_by_frequency(rows, lambda r: r[3])
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


def model_levels(sensor: Sensor, ob: Observation, kind: ClipKind = DEFAULT_CLIP_KIND) -> Prediction:
    """:func:`vrelab.predict.predict` at the observation's conditions (its levels' rms)."""
    from vrelab.prediction import predict

    excitation: RandomProfile | list[float]
    if ob.method == "random":
        if ob.profile is None:
            raise ValueError(f"a random observation ({ob.label}) without its profile")
        excitation = ob.profile
    else:
        if ob.freq_hz is None:
            raise ValueError(f"a sine observation ({ob.label}) without its frequency")
        excitation = [ob.freq_hz]
        if ob.drive:
            return _model_distorted(sensor, ob, kind)
    return predict(sensor, excitation, ob.rms_g, static_g=ob.static_g, kind=kind)


def drive_equivalent(ob: Observation) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per sine level, the pure sine a polynomial sensor rectifies as it does the measured drive
    (SPEC 4.4): its rms √E[x²] and its static-field shift s = E[x³]/(3·E[x²]) [g].

    For ``f(a) = a + k2·a² + k3·a³`` at ``a = g0 + x``, ``VRE = E[f(g0 + x)] - f(g0) =
    k2·E[x²] + k3·(3·g0·E[x²] + E[x³])`` (the drive's mean is 0), which a pure sine y with
    E[y²] = E[x²] gives exactly at the static field g0 + s: ``k2·E[x²] + 3·k3·(g0 + s)·E[x²]``.
    Exact for the cubic polynomial; assumed, as in the reduction, that the DUT sees the reference's
    waveform (its response at the harmonics that of the fundamental). Levels without a measured
    drive: their rms and no shift (a pure sine)."""
    q = np.array([d if d is not None else (1.0, 0.0) for d in ob.drive] if ob.drive else [(1.0, 0.0)] * ob.n)
    return ob.rms_g * np.sqrt(q[:, 0]), ob.rms_g * q[:, 1] / (3.0 * q[:, 0])


def _model_distorted(sensor: Sensor, ob: Observation, kind: ClipKind) -> Prediction:
    """:func:`model_levels` for sine levels with a measured drive: each level predicted as the
    pure sine of :func:`drive_equivalent` at its own static field g0 + s, reported at the
    level's fundamental rms.

    The VRE is linear in the static field where the cubic polynomial sets it (``3·k3·g0·E[x²]``),
    so each level's value at g0 + s is interpolated, exactly there, between two predictions of
    all the levels (at g0 and at g0 plus the largest |s|) rather than one prediction per level
    (the fit evaluates the model many times). What is curved in g0 (a k4 term, a rail's reach)
    is interpolated over |s| <= d·A1/2 (0.11 g for 8 % at 2 g rms): its second-order remainder
    is left, far below a level's u where the rails stay clear."""
    from vrelab.prediction import predict

    rms, shift = drive_equivalent(ob)
    freq = [float(ob.freq_hz or 0.0)]
    at = predict(sensor, freq, rms, static_g=ob.static_g, kind=kind)
    j = int(np.argmax(np.abs(shift)))
    if shift[j] == 0.0:
        levels = at.levels
    else:
        moved = predict(sensor, freq, rms, static_g=ob.static_g + float(shift[j]), kind=kind)
        t = shift / shift[j]  # each level's place between the two static fields

        def line(a: float, b: float, tk: float) -> float:
            return a + tk * (b - a)

        levels = tuple(dataclasses.replace(
            a, vre_g=line(a.vre_g, b.vre_g, float(tk)),
            shares={k: line(v, b.shares.get(k, v), float(tk)) for k, v in a.shares.items()})
            for a, b, tk in zip(at.levels, moved.levels, t))
    return dataclasses.replace(at, levels=tuple(dataclasses.replace(lv, rms_g=float(r))
                                                for lv, r in zip(levels, ob.rms_g)))


def _model(sensor: Sensor, obs: Sequence[Observation], kind: ClipKind) -> list[Prediction]:
    return [model_levels(sensor, ob, kind) for ob in obs]


# --------------------------------------------------------------------------- determinability


def _orientations(obs: Sequence[Observation]) -> list[float]:
    out: list[float] = []
    for g in sorted(ob.static_g for ob in obs):
        if not out or g - out[-1] >= SAME_ORIENTATION_G:
            out.append(g)
    return out


def _sine_frequencies(obs: Sequence[Observation]) -> list[float]:
    fs = [ob.freq_hz for ob in obs if ob.method == "sine" and ob.freq_hz]
    return [g[0] for g in group_by_frequency(fs, float)]


def _plan(obs: Sequence[Observation], base: Sensor) -> tuple[list[str], dict[str, str]]:
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


def _reach(preds: Sequence[Prediction], obs: Sequence[Observation], share: str) -> float:
    """Σ (share / u)² over every level, square-rooted: how far a mechanism's share of the VRE
    stands out of the levels' noise (a sine level whose peak stays inside a rail has none)."""
    s = 0.0
    for p, ob in zip(preds, obs):
        for lv, u in zip(p.levels, ob.u_g):
            s += (float(lv.shares.get(share, 0.0)) / u) ** 2
    return math.sqrt(s)


def _post_checks(values: Mapping[str, float], cov: Mapping[str, float], free: Sequence[str], preds: Sequence[Prediction],
                 obs: Sequence[Observation], base: Sensor | None = None, prefer_base: bool = False,
                 bounds: dict[str, tuple[float, str, float | None]] | None = None,
                 widen: dict[str, float] | None = None, loose: dict[str, str] | None = None) -> dict[str, str]:
    """Parameters the fit freed that the fitted model shows the data do not determine.

    fn and Q stay in the fit as nuisance parameters when every sine frequency lies on one side
    of the fitted fn (or below ``NEAR_FN``·fn): VRC(f) then shows a flank, not the peak, and
    the local covariance of fn and Q is a confident wrong number (three frequencies below a
    1200 Hz fn gave Q 2.69 ± 0.15 for 4). Their reason gives the bound the data do support
    (:func:`_resonance_profile`, Δχ² <= 4), and ``bounds`` receives, per parameter, a standard
    uncertainty from the profile (Δχ² <= 1, half its width) for the sensor file. fn and Q seen
    on both flanks but with a relative u above ``MAX_REL_U`` are kept, value and u (a poorly
    known Q is still a resonance near fn), unless ``prefer_base``; where the profile's Δχ² <= 1
    half-width exceeds what the same profile's curvature at its bottom says by ``_WIDER`` (a
    non-quadratic likelihood), ``widen`` receives that ratio, by which the covariance's row and
    column are to be scaled; where the profile does not close, fn and Q are bounded (Q 2.0 ± 0.6
    for a true 6 on three frequencies far from fn was such a case). A rail or the threshold
    that the levels do not reach is fixed at the base sensor's value and the rest refitted (it
    shapes nothing the data see)."""
    why: dict[str, str] = {}
    if "fn_hz" in free:
        freqs = _sine_frequencies(obs)
        fmin, fmax = min(freqs), max(freqs)
        fn = values["fn_hz"]
        side = "below" if fmax < fn else "above" if fmin > fn else None
        text = ", ".join(f"{f:g}" for f in freqs)
        prof = _resonance_profile(obs, base, free, values, {n: math.sqrt(cov.get(n, 0.0)) for n in ("fn_hz", "q")})
        one_sided = side is not None or fmax / fn < NEAR_FN
        if one_sided or prof["fn_hz"].open or prof["q"].open:
            if side is not None:
                head = f"every sine frequency ({text} Hz) is {side} the fitted fn ({fn:.4g} Hz): VRC(f) shows one flank"
            elif fmax / fn < NEAR_FN:
                head = (f"no sine run near fn (the highest, {fmax:g} Hz, is {fmax / fn:.2f}·fn of the fitted {fn:.4g} Hz; "
                        f"Q needs f >= {NEAR_FN:g}·fn)")
            else:
                head = f"the sine runs ({text} Hz) do not close the likelihood of"
            # one flank: neither is a value (issue: Q 2.69 ± 0.15 for 4 from three frequencies below fn); both
            # flanks but an open profile: the open one only (a well-bounded fn stays identified)
            for n, label in (("fn_hz", "fn"), ("q", "Q")):
                if one_sided or prof[n].open:
                    lead = head if one_sided or not head.endswith(" of") else f"{head} {label}"
                    why[n] = f"{lead}; the data bound {label} to {prof[n].text} (Δχ² <= 4), not its value"
                    if bounds is not None:  # open: the interval's middle; closed (one flank): the fit's value
                        bounds[n] = (prof[n].u, why[n], prof[n].value)
        else:
            if widen is not None:  # the fit's u read off a curvature where the likelihood is not quadratic
                for n in ("fn_hz", "q"):
                    if prof[n].ratio > _WIDER:
                        widen[n] = prof[n].ratio
            for n, label in (("fn_hz", "fn"), ("q", "Q")):
                if prof[n].open95 and loose is not None:
                    loose[n] = (f"{n}: its ±1σ interval closes but its 95 % one does not ({prof[n].text}, Δχ² <= 4 on the "
                                f"sine runs): u holds at 1σ only, the tail toward large {label} stays open")
            if prefer_base:
                for n in ("fn_hz", "q"):
                    rel = max(math.sqrt(cov.get(n, math.inf)), prof[n].u) / abs(values[n])
                    if not rel <= MAX_REL_U:
                        why["fn_hz"] = why["q"] = (f"poorly determined by the sine runs ({n} has a relative standard "
                                                   f"uncertainty of {100 * rel:.0f} %): the base sensor's taken, as asked")
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


def _vrc_data(sines: Sequence[Observation]) -> tuple[NDArray[np.float64], ...]:
    """The sine runs' apparent VRCs, their u, frequencies and static fields, as arrays."""
    vrc, u = (np.array(a) for a in zip(*(apparent_vrc(ob) for ob in sines)))
    return vrc, u, np.array([ob.freq_hz for ob in sines]), np.array([vrc_static_g(ob) for ob in sines])


def vrc_static_g(ob: Observation) -> float:
    """The static field a sine observation's apparent VRC belongs to: g0, or under a distorted
    drive g0 + Σ w·E[x²]·s / Σ w·E[x²] (:func:`drive_equivalent`'s s per level, w = 1/u², the
    weights of :func:`apparent_vrc`), so that VRC = (k2 + 3·k3·that)·|H(f)|² (as
    :func:`vrelab.fits.fit_vrc`'s ``static_shift_g``)."""
    if not ob.drive:
        return ob.static_g
    rms, shift = drive_equivalent(ob)
    w = rms**4 / ob.u_g**2
    return ob.static_g + float(np.sum(w * shift) / np.sum(w))


def _vrc_chi2(data: tuple[NDArray[np.float64], ...], k3_free: bool, k3_fixed: float,
              fn: float | None, q: float | None) -> tuple[NDArray[np.float64], float]:
    """k2 (and k3) by weighted linear least squares of the apparent VRCs (:func:`_vrc_data`)
    at the response ``|H|²`` of (fn, Q) (flat without fn); and the χ² there."""
    from vrelab.models.dynamics import vrc_at_frequency

    vrc, u, f, g0 = data
    h = np.asarray(vrc_at_frequency(1.0, f, fn, q)) if fn and q else np.ones_like(f)
    a = np.column_stack([h, 3 * g0 * h] if k3_free else [h]) / u[:, None]
    y = (vrc - (0.0 if k3_free else 3 * k3_fixed * g0 * h)) / u
    k, *_ = np.linalg.lstsq(a, y, rcond=None)
    r = a @ k - y
    return k.astype(np.float64, copy=False), float(r @ r)


def _resonance_grid(sines: Sequence[Observation], n_fn: int = 60, n_q: int = 15) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """fn from a third of the lowest to ten times the highest sine frequency, Q from 0.5 to 50 (log)."""
    f = [ob.freq_hz for ob in sines if ob.freq_hz is not None]  # a sine observation has its frequency
    return np.geomspace(min(f) / 3, 10 * max(f), n_fn), np.geomspace(0.5, 50, n_q)


@dataclass(frozen=True)
class _Profile:
    """What the sine runs' apparent VRCs say of fn or Q, the other and k2, k3 profiled out."""

    text: str  # the Δχ² <= 4 interval (about 95 %): "900-960 Hz", "Q > 3.1"
    open: bool  # the interval reaches the grid's edge: a bound, not a value
    u: float  # half the width of the Δχ² <= 1 interval (a standard uncertainty where the profile is closed)
    value: float | None = None  # open: the geometric middle of the Δχ² <= 4 interval (the value to assume)
    ratio: float = 1.0  # closed: the Δχ² <= 1 half-width over the profile's own quadratic u (1: quadratic)
    open95: bool = False  # closed at ±1σ but the Δχ² <= 4 interval (``text``) reaches the grid's edge


def _vrc_chi2_grid(data: tuple[NDArray[np.float64], ...], k3_free: bool, k3_fixed: float,
                   fn: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`_vrc_chi2`'s χ² at every (fn, Q) of two broadcastable arrays at once: the weighted
    linear least squares for k2 (and k3) in closed form (normal equations of one or two
    unknowns), so a fine grid costs a few array operations instead of one lstsq per point."""
    vrc, u, f, g0 = data
    r = f / fn[..., None]
    h = 1.0 / ((1 - r * r) ** 2 + (r / q[..., None]) ** 2)
    a1 = h / u
    y = (vrc - (0.0 if k3_free else 3 * k3_fixed * g0 * h)) / u
    # (numpy's stubs type a sum over an axis as Any: the arrays named here)
    yy: NDArray[np.float64] = np.sum(y * y, axis=-1)
    s11: NDArray[np.float64] = np.sum(a1 * a1, axis=-1)
    b1: NDArray[np.float64] = np.sum(a1 * y, axis=-1)
    if not k3_free:
        return yy - b1 * b1 / s11
    a2 = 3 * g0 * a1
    s12, s22, b2 = np.sum(a1 * a2, axis=-1), np.sum(a2 * a2, axis=-1), np.sum(a2 * y, axis=-1)
    det = s11 * s22 - s12 * s12
    ok = det > 1e-12 * s11 * s22
    two = yy - (s22 * b1 * b1 - 2 * s12 * b1 * b2 + s11 * b2 * b2) / np.where(ok, det, 1.0)
    return np.where(ok, two, yy - b1 * b1 / s11)


def _resonance_profile(obs: Sequence[Observation], base: Sensor | None, free: Sequence[str],
                       values: Mapping[str, float] | None = None,
                       local_u: Mapping[str, float] | None = None) -> dict[str, _Profile]:
    """Per fn and Q, the profile likelihood of the sine runs' apparent VRCs (:func:`_vrc_chi2_grid`,
    k2 and k3 profiled out in closed form), Δχ² scaled by the reduced χ² at its minimum when that
    exceeds 1 (as the fit's covariance is).

    Global: a fine log grid (fn from a third of the lowest to ten times the highest frequency, Q
    0.05 to 1000) says whether the Δχ² <= 1 interval closes or reaches an edge (then the data
    give a bound, said by the Δχ² <= 4 interval, about 95 %: "Q > 3.1"). Local (``values`` and the fit's ``local_u`` given): a grid
    of ±8 local u about the fit, widened until the Δχ² <= 1 region is inside it, gives the
    half-width that a non-quadratic likelihood (a valley of large Q) really supports."""
    sines = [ob for ob in obs if ob.method == "sine"]
    k3_free = "k3_ug_per_g3" in free
    k3_fixed = (parameter(base, "k3_ug_per_g3") or 0.0) if base is not None else 0.0
    data = _vrc_data(sines)
    f = data[2]
    fns, qs = np.geomspace(f.min() / 3, 10 * f.max(), 700), np.geomspace(0.05, 1000, 300)
    chi = _vrc_chi2_grid(data, k3_free, k3_fixed, fns[:, None], qs[None, :])
    # the valley is narrower than the grid's step where the data determine a parameter well: each
    # column's (row's) best point refined over its two neighbouring steps, 41 points
    t = np.linspace(-1.0, 1.0, 41)[:, None]
    i = np.clip(np.argmin(chi, axis=0), 1, fns.size - 2)
    fine_fn = fns[i] * (fns[1] / fns[0]) ** t  # (41, n_q)
    prof_q = _vrc_chi2_grid(data, k3_free, k3_fixed, fine_fn, qs[None, :]).min(axis=0)
    j = np.clip(np.argmin(chi, axis=1), 1, qs.size - 2)
    fine_q = qs[j] * (qs[1] / qs[0]) ** t  # (41, n_fn)
    prof_fn = _vrc_chi2_grid(data, k3_free, k3_fixed, fns[None, :], fine_q).min(axis=0)
    prof_q, prof_fn = np.minimum(prof_q, chi.min(axis=0)), np.minimum(prof_fn, chi.min(axis=1))
    dof = len(sines) - (2 if k3_free else 1) - 2
    best = float(min(prof_q.min(), prof_fn.min()))
    birge = max(1.0, best / dof) if dof > 0 else 1.0
    out: dict[str, _Profile] = {}
    for name, axis, prof, label, unit in (("fn_hz", fns, prof_fn, "fn", " Hz"), ("q", qs, prof_q, "Q", "")):
        d = (prof - prof.min()) / birge  # each against its own minimum (the two grids resolve it differently)
        inside = np.flatnonzero(d <= 4.0)
        lo, hi = int(inside[0]), int(inside[-1])
        open95 = lo == 0 or hi == axis.size - 1
        one = np.flatnonzero(d <= 1.0)
        # a value needs its ±1σ interval closed; a 95 % interval that stays open is said, not hidden
        is_open = one[0] == 0 or one[-1] == axis.size - 1
        if lo == 0 and hi == axis.size - 1:
            text = f"{label} anywhere in {axis[0]:.3g}-{axis[-1]:.3g}{unit}"
        elif hi == axis.size - 1:
            text = f"{label} > {axis[lo]:.3g}{unit}"
        elif lo == 0:
            text = f"{label} < {axis[hi]:.3g}{unit}"
        else:
            text = f"{axis[lo]:.4g}-{axis[hi]:.4g}{unit}"
        if is_open or values is None or local_u is None:
            out[name] = _Profile(text, True, (axis[hi] - axis[lo]) / 2, math.sqrt(axis[lo] * axis[hi])) if is_open \
                else _Profile(text, False, (axis[hi] - axis[lo]) / 4)
            continue
        half, quad = _local_half_width(data, k3_free, k3_fixed, values, local_u, name, best, birge)
        out[name] = _Profile(text, False, half, ratio=half / quad if quad > 0 else 1.0, open95=open95)
    return out


def _local_half_width(data: tuple[NDArray[np.float64], ...], k3_free: bool, k3_fixed: float,
                      values: Mapping[str, float], local_u: Mapping[str, float], name: str, best: float,
                      birge: float) -> tuple[float, float]:
    """Half the width of the Δχ² <= 1 profile interval of ``name`` about the fit (a 2-D grid of
    ±w local u in fn and Q, w = 8, then 24, 72 until the region is inside it), and the u the same
    profile's curvature at its bottom gives: their ratio says how far the likelihood is from
    quadratic over ±1 u (1 for a quadratic one)."""
    x = {n: float(values[n]) for n in ("fn_hz", "q")}
    su = {n: max(float(local_u.get(n, 0.0)), 1e-6 * x[n]) for n in ("fn_hz", "q")}
    for w in (8.0, 24.0, 72.0):
        grid = {n: np.linspace(max(x[n] - w * su[n], 1e-3 * x[n]), x[n] + w * su[n], 241) for n in ("fn_hz", "q")}
        chi = _vrc_chi2_grid(data, k3_free, k3_fixed, grid["fn_hz"][:, None], grid["q"][None, :])
        prof = chi.min(axis=1 if name == "fn_hz" else 0)
        axis = grid[name]
        d = (prof - min(best, float(chi.min()))) / birge
        one = np.flatnonzero(d <= 1.0)
        if one.size and one[0] > 0 and one[-1] < axis.size - 1:
            half = max(float(axis[one[-1]] - axis[one[0]]) / 2, float(axis[1] - axis[0]))
            # the same profile's own quadratic reading: a parabola through its bottom (Δχ² <= 0.3)
            near = np.flatnonzero(d <= 0.3)
            if near.size >= 5:
                a = np.polyfit(axis[near], d[near], 2)[0]
                if a > 0:
                    return half, 1.0 / math.sqrt(a)
            return half, half
    return float(w * su[name]), float(w * su[name])


# --------------------------------------------------------------------------- fitting


@dataclass
class _Fit:
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
    """The grid point (fn, Q) where :func:`_vrc_chi2` is least, the first such with fn the outer
    loop: what ``min`` over every point's lstsq picks, found for the cost of a few lstsq. The
    closed form over the whole grid (:func:`_vrc_chi2_grid`, the same χ² to rounding) keeps the
    points within a millionth of the χ² scale of its least, and :func:`_vrc_chi2` itself, in
    the grid's order, settles among them (where the closed form is not finite: every point)."""
    chi = _vrc_chi2_grid(data, k3_free, k3_fixed, fns[:, None], qs[None, :]).ravel()
    vrc, u = data[0], data[1]
    tol = _GRID_TIE_REL * (float(np.sum((vrc / u) ** 2)) + float(np.nanmax(np.abs(chi), initial=0.0)))
    every = [(fn, q) for fn in fns for q in qs]
    if np.isfinite(chi).all():
        every = [every[i] for i in np.flatnonzero(chi <= chi.min() + tol).tolist()]
    fn0, q0 = min(every, key=lambda g: _vrc_chi2(data, k3_free, k3_fixed, *g)[1])
    return fn0, q0


def _start(obs: Sequence[Observation], base: Sensor, free: Sequence[str]) -> dict[str, float]:
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
        data = _vrc_data(sines)
        vrc, u, f, g0 = data
        k3_free = "k3_ug_per_g3" in free
        k3_fixed = start["k3_ug_per_g3"]
        if "fn_hz" in free:
            fns, qs = _resonance_grid(sines)
            fn0, q0 = _grid_best(data, k3_free, k3_fixed, fns, qs)

            def resid(p: NDArray[np.float64]) -> NDArray[np.float64]:
                k = p[:-2]
                h: NDArray[np.float64] = np.asarray(vrc_at_frequency(1.0, f, p[-2], p[-1]))
                k2: float = k[0]
                k3: float = k[1] if k3_free else k3_fixed
                return ((k2 + 3 * k3 * g0) * h - vrc) / u

            k0, _ = _vrc_chi2(data, k3_free, k3_fixed, fn0, q0)
            r = least_squares(resid, np.r_[k0, fn0, q0], x_scale="jac",
                              bounds=([-np.inf] * len(k0) + [1e-3, 0.05], [np.inf] * len(k0) + [1e6, 1e4]))
            k, (start["fn_hz"], start["q"]) = r.x[:-2], (float(r.x[-2]), float(r.x[-1]))
        else:
            k, _ = _vrc_chi2(data, k3_free, k3_fixed, base.fn_hz, base.q)
        start["k2_ug_per_g2"] = float(k[0])
        if k3_free:
            start["k3_ug_per_g3"] = float(k[1])
    for n in ("rail_low_g", "rail_high_g", "overrange_threshold_g"):
        if n in free:
            lo, hi = _bounds(n, obs)
            start[n] = min(max(start[n], lo + 1e-3), hi - 1e-3)
    return start


def _residuals(sensor: Sensor, obs: Sequence[Observation], kind: ClipKind) -> tuple[NDArray[np.float64], list[Prediction]]:
    preds = _model(sensor, obs, kind)
    r = np.concatenate([(np.array([lv.vre_g for lv in p.levels]) - ob.vre_g) / ob.u_g for p, ob in zip(preds, obs)])
    return r, preds


def _fit(base: Sensor, obs: Sequence[Observation], free: Sequence[str], start: Mapping[str, float],
         kind: ClipKind) -> _Fit:
    """Least squares over the ``free`` parameters; the others keep the base sensor's values."""
    from scipy.optimize import least_squares

    def sensor_at(x: NDArray[np.float64]) -> Sensor:
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
        # diff_step as a one-element list: scipy-stubs types it 1-D; scipy broadcasts it (the same steps)
        res = least_squares(resid, x0, bounds=(bounds[0], bounds[1]), x_scale="jac", diff_step=[1e-5], max_nfev=60,
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


def _subset(ob: Observation, keep: NDArray[np.bool_]) -> Observation:
    """``ob`` with only the levels ``keep`` marks."""
    from dataclasses import replace

    def pick(t: tuple[Any, ...]) -> tuple[Any, ...]:
        return tuple(x for x, k in zip(t, keep) if k) if t else ()

    return replace(ob, rms_g=ob.rms_g[keep], vre_g=ob.vre_g[keep], u_g=ob.u_g[keep], harmonic_g=pick(ob.harmonic_g),
                   saturated=pick(ob.saturated), drive=pick(ob.drive))


def _unsaturated(obs: Sequence[Observation]) -> list[Observation]:
    """The observations without the sine levels the analysis flagged saturated."""
    out = []
    for ob in obs:
        keep = ~np.array(ob.saturated, dtype=bool) if ob.saturated else np.ones(ob.n, dtype=bool)
        if keep.any():
            out.append(_subset(ob, keep))
    return out


def _key(obs: Sequence[Observation]) -> list[tuple[int, float | None, tuple[float, ...]]]:
    return [(ob.run, ob.freq_hz, tuple(ob.rms_g)) for ob in obs]


def identify_channel(channel: str, obs: Sequence[Observation], base: Sensor, kind: ClipKind = DEFAULT_CLIP_KIND,
                     campaign: str = "the campaign", typeb: TypeB | None = None, notes: Sequence[str] = (),
                     prefer_base: bool = False) -> ChannelModel:
    """Identify one channel's model from its observations (see the module docstring).

    Which levels the fit uses is decided with the fitted model and iterated: a sine level the
    analysis flagged saturated (against its own rail) comes back when the identified rails clear
    its peak, and a level the fitted model does not cover goes (:func:`_modelled`)."""
    notes = list(notes)
    tilted = [ob for ob in obs if ob.tilted]
    full = [ob for ob in obs if not ob.tilted]
    if not full:
        raise ValueError(f"identify: channel {channel!r} has no usable level in any run"
                         + (" with its input axis along the vibration (every run is mounted at an angle: the model "
                            "needs a 0° run)" if tilted else ""))
    obs = _unsaturated(full) or full
    free, why = _plan(obs, base)
    base_values = {n: parameter(base, n) for n in PARAMETERS}
    fit: _Fit | None = None
    start = _start(obs, base, free)
    bounds: dict[str, tuple[float, str, float | None]] = {}
    widen: dict[str, float] = {}
    loose: dict[str, str] = {}
    level_notes: list[str] = []
    for attempt in range(8):
        fit = _fit(base, obs, free, start, kind)
        fitted = with_parameters(base, dict(zip(free, fit.x)))
        # the candidates: every level, the flagged sine ones only where the rails were identified
        rails_known = "rail_low_g" in free and "rail_high_g" in free
        cand = full if rails_known else (_unsaturated(full) or full)
        level_notes = []
        kept = _modelled(cand, _model(fitted, cand, kind), level_notes, fitted)
        kept = cand if kept is None else kept
        start = {n: float(v) for n, v in zip(free, fit.x)}  # go on from here
        if _key(kept) != _key(obs) and attempt < 7:  # the fitted model covers other levels: refit on them
            obs = kept
            continue
        dof = sum(ob.n for ob in obs) - len(free)
        scale = max(1.0, fit.chi2 / dof) if dof > 0 else 1.0
        values = dict(zip(free, fit.x))
        var = {n: fit.cov[i, i] * scale for i, n in enumerate(free)}
        widen.clear()
        loose.clear()
        later = _post_checks(values, var, free, fit.preds, obs, base, prefer_base, bounds, widen, loose)
        why.update(later)
        fixed = [n for n in later if n not in NUISANCE]
        if not fixed:
            break
        free = [n for n in free if n not in fixed]
        start = {n: v for n, v in start.items() if n in free}
    assert fit is not None
    notes += level_notes
    notes += [t for n, t in loose.items() if n not in why]
    readmitted = [f"{ob.freq_hz:.4g} Hz {r:.4g} g rms" for ob in obs for r, sat in zip(ob.rms_g, ob.saturated or ()) if sat]
    if readmitted:
        notes.append("sine level(s) flagged saturated by the analysis kept: their peaks stay inside the identified rails ("
                     + ", ".join(readmitted) + ")")
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
    for n, factor in widen.items():
        if n in free and n not in why and math.isfinite(factor):
            i = free.index(n)
            before = math.sqrt(max(cov[i, i], 0.0))
            cov[i, :] *= factor
            cov[:, i] *= factor
            notes.append(f"{n}: the likelihood is not quadratic over its u (the sine runs' profile Δχ² <= 1 half-width is "
                         f"{factor:.2g}× what its curvature says): its u {before:.2g} widened by that, correlations kept")
    values = dict(zip(free, (float(v) for v in fit.x)))
    budget: list[TypeBTerm] = []
    if typeb is not None and typeb.declared and free:
        cov, budget = _type_b(cov, values, base, obs, free, kind, typeb)
    if "k2_ug_per_g2" in why and "k3_ug_per_g3" in why and "k2_ug_per_g2" in values:
        g0 = obs[0].static_g
        k3b = base_values["k3_ug_per_g3"] or 0.0
        i = free.index("k2_ug_per_g2")
        notes.append(f"one orientation: k2 + 3·k3·g0 = {values['k2_ug_per_g2'] + 3 * k3b * g0:.6g} ± "
                     f"{math.sqrt(cov[i, i]):.2g} µg/g² at g0 = {g0:+g} g (valid at that orientation only)")
    # the cross-coupling coefficients from the runs mounted at an angle, on the model just identified
    cross = fit_cross_coupling(tilted, [ob for ob in obs if ob.method == "sine"],
                               with_parameters(base, values), typeb, kind)
    why.update(cross.reasons)
    notes += cross.notes
    params: dict[str, Estimate | None] = {}
    used: dict[str, float | None] = {}
    assumed: dict[str, tuple[float | None, str]] = {}
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
        elif n in bounds and n in values and not prefer_base:
            # a resonance the runs show on one flank: kept at the fitted value as an assumption with the u its
            # profile allows (never the base's "no resonance", never the fit's local, overconfident u)
            params[n] = None
            u, text, middle = bounds[n]
            used[n] = values[n] if middle is None else middle
            assumed[n] = (u, f"fitted as a nuisance parameter, only bounded: {text}"
                          + ("" if middle is None else f"; written at the bound's middle {middle:.4g} ± {u:.3g}"))
        else:
            params[n] = None
            used[n] = base_values[n]
            why.setdefault(n, "not fitted")
            if used[n] is not None:
                u_stated = base.uncertainty.get(n)
                assumed[n] = (u_stated, f"from base sensor ({why[n]}); "
                              + (f"its stated u {u_stated:.3g}" if u_stated is not None else "the base states no u for it"))
    # (the cross-coupling terms act only off the input axis: without a mount-angle run they are not news)
    no_u = [n for n, (u, _w) in assumed.items() if u is None and (tilted or n not in CROSS)]
    if no_u:
        notes.append("taken from the base sensor without a stated u (its file has no [uncertainty] for them): "
                     + ", ".join(f"{n} = {used[n]:.6g}" for n in no_u) + "; the sensor file marks them as assumptions "
                     "without u: predict names them and is not valid where the VRE moves with them (±10 %) beyond "
                     "its u")
    nuisance = [n for n in free if n in NUISANCE and params[n] is None]
    if nuisance:
        notes.append("fitted as nuisance parameters, only bounded (null): "
                     + ", ".join(f"{n} = {values[n]:.4g} (local ± {math.sqrt(max(cov[free.index(n), free.index(n)], 0)):.2g}"
                                 f" not a claim)" for n in nuisance)
                     + "; the other parameters are estimated with them free; the sensor file carries them as "
                     "assumptions with the profile's u" + (" (--prefer-base: the base's instead)" if prefer_base else ""))
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
    runs = _run_table(fit.preds, obs)
    return ChannelModel(channel, params, {n: why[n] for n in PARAMETERS if params[n] is None}, used, covariance,
                        fit.chi2, dof, tuple(runs), tuple(notes), tuple(budget), tuple(cross_check_2f(obs, base)),
                        assumed, cross if tilted else None)


def _modelled(obs: Sequence[Observation], preds: Sequence[Prediction], notes: list[str], sensor: Sensor) -> list[Observation] | None:
    """The observations without the levels the analytic model does not cover well enough to fit
    through; None when every level is covered. Each level left out is said in ``notes``.

    :func:`vrelab.predict.predict` evaluates the nonlinearity and the rails as one map: exactly
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
            out.append(_subset(ob, keep))
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
            "vrc_ug_per_g2": None if ob.method != "sine" else _value_u(*apparent_vrc(ob)),
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
            f = _fit(base, moved, free, values, kind)
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


# --------------------------------------------------------------------------- 2f cross-check


def _post_filter_gain(base: Sensor | None, f_hz: float) -> float:
    """|H(f)| of the linear stages after the proof mass (anti-alias, low-pass, high-pass: every
    output response but the resonance) relative to DC: what they do to the 2f line that they
    do not do to the mean shift. 1 without a base sensor or without filters; NaN where the
    chain blocks DC (a high-pass: no DC reference)."""
    if base is None:
        return 1.0
    f = np.array([0.0, float(f_hz)])
    post = np.abs(base.response(f, "output") / base.response(f, "proof-mass"))
    return float(post[1] / post[0]) if post[0] > 0 else math.nan


def cross_check_2f(obs: Sequence[Observation], base: Sensor | None = None) -> list[Check2f]:
    """Per sine run whose levels carry a 2f estimate: the apparent VRC from the DUT's 2f line
    (less the reference's own) beside the one from the DC shift, both ``(k2 + 3·k3·g0)·|H|²``
    for a cubic polynomial on the proof mass (SPEC 6.1): x = A·cos θ gives
    ``k·x² = k·A²/2 + k·A²/2·cos 2θ``, the same coefficient at DC and at 2f. Immune to drift,
    so a disagreement beyond the uncertainties points at a drifting baseline or at filters
    after the nonlinearity that attenuate 2f (the DC is untouched by them). The base sensor's
    own output filters are known: the 2f VRC is divided by their gain at 2f relative to DC
    (:func:`_post_filter_gain`; 0.30 at 600 Hz on an ADXL355 at 4 kHz ODR), and the gain is
    reported beside it."""
    from vrelab.fits import fit_vrc
    from vrelab.results import LevelResult

    out: list[Check2f] = []
    for ob in obs:
        if ob.method != "sine" or ob.freq_hz is None or not ob.harmonic_g or not any(h is not None for h in ob.harmonic_g):
            continue
        pairs = [(r, h) for r, h in zip(ob.rms_g, ob.harmonic_g) if h is not None]
        two_f = fit_vrc([LevelResult(float(r), Estimate(h[0], h[1])) for r, h in pairs])
        dc = fit_vrc([LevelResult(float(r), Estimate(float(v), float(u))) for r, v, u in zip(ob.rms_g, ob.vre_g, ob.u_g)])
        a, b = two_f.params["vrc_ug_per_g2"], dc.params["vrc_ug_per_g2"]
        gain = _post_filter_gain(base, 2 * float(ob.freq_hz))
        if not gain > 0:
            continue  # a chain that blocks DC or 2f: nothing to compare
        a = Estimate(a.value / gain, a.u / gain)
        z = (a.value - b.value) / math.hypot(a.u, b.u) if math.hypot(a.u, b.u) > 0 else math.nan
        out.append({"run": ob.run, "label": ob.label, "freq_hz": ob.freq_hz, "static_g": ob.static_g,
                    "vrc_2f_ug_per_g2": {"value": a.value, "u": a.u}, "vrc_dc_ug_per_g2": {"value": b.value, "u": b.u},
                    "filter_gain_2f": gain,
                    "difference_sigma": finite_or_none(z), "agree": bool(abs(z) <= 3) if math.isfinite(z) else None})
    return out


# --------------------------------------------------------------------------- cross-coupling (IEEE 1293)

# The cross-coupling coefficients a mount-angle campaign identifies, with the triad positions
# (0 = input i, 1 = pendulous p, 2 = output o) of the product each multiplies (SPEC 1.6).
CROSS_TERMS: tuple[tuple[str, int, int], ...] = (
    ("kip_ug_per_g2", 0, 1), ("kpp_ug_per_g2", 1, 1), ("kio_ug_per_g2", 0, 2), ("koo_ug_per_g2", 2, 2),
)  # fmt: skip
CROSS: tuple[str, ...] = tuple(n for n, _, _ in CROSS_TERMS)
_PLANE_OF = {"kip_ug_per_g2": "ip", "kpp_ug_per_g2": "ip", "kio_ug_per_g2": "io", "koo_ug_per_g2": "io"}
_LABEL = {"kip_ug_per_g2": "Kip", "kpp_ug_per_g2": "Kpp", "kio_ug_per_g2": "Kio", "koo_ug_per_g2": "Koo"}
# A tilted run excites a product d_j·d_k when it is at least this (sin φ·cos φ is 0.5 at 45°).
_EXCITES = 0.05
# A parameter is estimable when the unit vector along it lies in the design's row space: its
# diagonal element of the projector onto that space is 1 within this.
_ESTIMABLE = 1e-6


@dataclass(frozen=True)
class CrossCoupling:
    """The cross-coupling fit of one channel (:func:`fit_cross_coupling`)."""

    estimates: Mapping[str, Estimate]  # the identified ones of CROSS
    reasons: Mapping[str, str]  # why each other one of CROSS is null
    covariance: tuple[tuple[str, ...], NDArray[np.float64]] | None  # over ``estimates``
    notes: tuple[str, ...]
    points: tuple[dict[str, Any], ...] = ()  # per run and frequency: angle, plane, VRE/σ² measured and modelled
    nuisance: Mapping[str, Estimate] = field(default_factory=dict)  # the fit's own k2, k3
    chi2: float = math.nan
    dof: int = 0

    def to_dict(self) -> dict[str, Any]:
        def est(e: Estimate) -> dict[str, Any]:
            return {"value": finite_or_none(e.value), "u": finite_or_none(e.u), "unit": e.unit}

        return {
            "model": "VRE/σ² = (k2 + 3·k3·w·g)·(w·d)² + Kip·d_i·d_p + Kpp·d_p² + Kio·d_i·d_o + Koo·d_o²",
            "parameters": {n: est(e) for n, e in self.estimates.items()},
            "null_reasons": dict(self.reasons),
            "nuisance": {n: est(e) for n, e in self.nuisance.items()},
            "chi2": finite_or_none(self.chi2), "dof": self.dof,
            "chi2_reduced": finite_or_none(self.chi2 / self.dof) if self.dof > 0 else None,
            "points": list(self.points),
        }  # fmt: skip


def fit_cross_coupling(tilted: Sequence[Observation], axial: Sequence[Observation], sensor: Sensor,
                       typeb: TypeB | None = None, kind: ClipKind = DEFAULT_CLIP_KIND) -> CrossCoupling:
    r"""IEEE 1293's cross-coupling coefficients Kip, Kpp, Kio, Koo of one channel (SPEC 1.6)
    from its runs mounted at an angle (``tilted``) beside its sine runs along the vibration
    (``axial``), on the model identified from the latter (``sensor``: its dynamics, rails,
    cross-axis sensitivity row).

    A sine of rms σ along the unit direction d (in the triad i, p, o: ``(cos φ, sin φ, 0)`` in
    the IP plane, ``(cos φ, 0, sin φ)`` in the IO plane) with the static field g moves the proof
    mass by ``b = g + d·x`` with ``E[x²] = σ_m² = σ²·|H(f)|²``; the model equation
    (:mod:`vrelab.triaxial.chain`) then rectifies, below the rails,

        VRE / σ_m² = (k2 + 3·k3·w·g)·(w·d)² + Kip·d_i·d_p + Kpp·d_p² + Kio·d_i·d_o + Koo·d_o²

    (w the axis's sensitivity row in the triad, 1 along i): in the IP plane with w = (1, 0, 0),
    ``k2_eff·cos²φ + Kpp·sin²φ + Kip·sinφ·cosφ``. Every level is one equation of a weighted
    linear least-squares fit (weights 1/u², the levels' Type A u) of (k2, k3, Kip, Kpp, Kio, Koo),
    k2 and k3 nuisance parameters here (the channel's k2 and k3 are the model's); covariance
    ``(AᵀWA)⁻¹`` by SVD (:func:`_covariance`), scaled by χ²/dof when that exceeds 1 (the Birge
    ratio, as identification's other fits). Levels whose sensed peak reaches a rail of the
    identified model (:func:`vrelab.predict.predict` at ``σ·|w·d|``) are left out; random runs
    at an angle are not used (their rails rectify too).

    **The cross-axis feed.** ``(w·d)² = cos²φ + 2·w_p·sinφ·cosφ + w_p²·sin²φ``: the p component
    that the cross-axis sensitivity w_p feeds into the sensed input rectifies through k2 with
    the same angle dependence as Kip. With w_p in ``sensor`` it is modelled, and Kip is the
    model equation's own; where the sensor states none (w_p = 0), what is identified is the
    apparent ``Kip + 2·k2·w_p`` (and ``Kpp + k2·w_p²``), said in the notes; with k3 the static
    field's p component fed in too adds ``3·k3·w_p·(g_p·cos²φ + 2·g_i·sinφ·cosφ)``, which on a
    vertical shaker (g = ±d) is ``±9·k3·w_p·cos φ`` more on the apparent Kip. The same holds for
    w_o, Kio and Koo.

    What the runs cannot determine is null with the reason: no run tilted in the plane; Kip
    (Kio) from runs tilted one way only (IEEE 1293 takes it from a ±φ pair, where every term
    even in φ cancels: from one side it would rest on k2, k3 and Kpp being exact at the other
    angles); a coefficient the design does not separate from the others (not estimable: its
    unit vector outside the row space of the design). The sensitivity terms of ``typeb``
    (reference and DUT, common to every run) are added as for k2
    (:func:`vrelab.gum.common_sensitivity_terms`, fully correlated across the coefficients); its
    static-field and thermal terms are not carried (a ±φ pair cancels both in Kip).
    """
    from vrelab.gum import common_sensitivity_terms, weighted_mean
    from vrelab.models.dynamics import vrc_at_frequency
    from vrelab.prediction import predict
    from vrelab.units import UG_PER_G

    notes: list[str] = []
    reasons: dict[str, str] = {}
    if not tilted:
        why = ("no run mounted at an angle (mount_deg, mount_plane): IEEE 1293 measures the cross-coupling "
               "coefficients with the input axis at 0°, ±45° and 90° to the vibration in the IP and IO planes")
        return CrossCoupling({}, {n: why for n in CROSS}, None, ())
    for ob in tilted:
        if ob.method != "sine":
            notes.append(f"run {ob.run} ({ob.label!r}): a random run mounted at an angle is not used for the cross-coupling "
                         "fit (its rails rectify too; the sine runs carry the coefficients)")
    try:
        i, p, o = sensor.triad
        row = sensor.sensitivity_row
        w = np.array([1.0, row[p], row[o]])
    except ValueError as exc:  # an axis not named x, y or z: no cross-axis row to read
        w = np.array([1.0, 0.0, 0.0])
        notes.append(f"cross-coupling fit: {exc}; the cross-axis sensitivity taken as 0")
    fn, q = parameter(sensor, "fn_hz"), parameter(sensor, "q")
    rows: list[NDArray[np.float64]] = []
    ys: list[float] = []
    us: list[float] = []
    groups: list[tuple[Observation, Mount, NDArray[np.bool_], NDArray[np.float64]]] = []
    sines = [ob for ob in axial if ob.method == "sine"] + [ob for ob in tilted if ob.method == "sine"]
    for ob in sines:
        mount = ob.mount if ob.mount is not None else Mount(0.0, "ip", (ob.static_g, 0.0, 0.0))
        d = np.array(mount.direction)
        g = np.array(mount.static_g)
        wd, gs = float(w @ d), float(w @ g)
        h2 = float(vrc_at_frequency(1.0, float(ob.freq_hz or 0.0), fn, q)) if fn and q else 1.0
        keep = np.ones(ob.n, dtype=bool)
        if ob.tilted and abs(wd) > 1e-9:  # the rails see the sensed part of the vibration, σ·|w·d|, about w·g
            pred = predict(sensor, [float(ob.freq_hz or 0.0)], ob.rms_g * abs(wd), static_g=gs, kind=kind)
            keep = np.array([lv.valid_otherwise and lv.shares["clip_g"] == 0.0 for lv in pred.levels])
            for r, k in zip(ob.rms_g, keep):
                if not k:
                    notes.append(f"run {ob.run} ({ob.label!r}): level {r:.4g} g rms left out of the cross-coupling fit: "
                                 "its sensed peak reaches a rail of the identified model")
        # a distorted drive (SPEC 4.4): E[x²] in place of rms², and its E[x³] as the sensed shift w·d·s
        rms_eq, shift = drive_equivalent(ob)
        s2 = rms_eq**2 * h2
        for k in np.flatnonzero(keep):
            col = np.array([wd**2, 3 * (gs + wd * shift[k]) * wd**2, *(d[a] * d[b] for _, a, b in CROSS_TERMS)])
            rows.append(s2[k] / UG_PER_G * col)
            ys.append(float(ob.vre_g[k]))
            us.append(float(ob.u_g[k]))
        if keep.any():
            groups.append((ob, mount, keep, s2))
    names = ("k2_ug_per_g2", "k3_ug_per_g3", *CROSS)
    if not rows:
        why = "no level of the runs mounted at an angle stays clear of the rails (or none is a sine run)"
        return CrossCoupling({}, {n: why for n in CROSS}, None, tuple(notes))
    u = np.array(us)
    a = np.array(rows) / u[:, None]
    y = np.array(ys) / u
    theta, *_ = np.linalg.lstsq(a, y, rcond=None)
    cov, rank = _covariance(a)
    proj = cov @ (a.T @ a)  # the projector onto the design's row space
    estimable = [abs(proj[j, j] - 1.0) < _ESTIMABLE for j in range(len(names))]
    resid = a @ theta - y
    chi2 = float(resid @ resid)
    dof = len(ys) - rank
    if dof > 0 and chi2 / dof > 1.0:
        cov = cov * (chi2 / dof)
        notes.append(f"cross-coupling fit: the levels scatter about the model more than their uncertainties "
                     f"(chi2/dof = {chi2 / dof:.3g}): its covariance is scaled by it")
    elif dof <= 0:
        notes.append("cross-coupling fit: as many unknowns as levels: chi2 undefined, u from the levels' uncertainties alone")
    tilts = {pl: sorted({ob.mount.deg for ob, *_ in groups if ob.mount is not None and ob.tilted and ob.mount.plane == pl})
             for pl in MOUNT_PLANES}
    for j, (n, ia, ib) in enumerate(CROSS_TERMS, start=2):
        plane = _PLANE_OF[n]
        label, text = _LABEL[n], plane.upper()
        angles = ", ".join(f"{x:+g}°" for x in tilts[plane])
        prods = [float(np.prod([m.direction[ia], m.direction[ib]])) for ob, m, *_ in groups if ob.tilted and m.plane == plane]
        if not prods:
            reasons[n] = (f"no run mounted in the {text} plane (the input axis tilted toward the "
                          f"{'pendulous' if plane == 'ip' else 'output'} axis): {label} needs one (IEEE 1293: 0°, ±45°, 90°)")
        elif ia != ib and not any(abs(x) >= _EXCITES for x in prods):
            reasons[n] = (f"no {text}-plane run between 0° and 90° (angles {angles}: sin φ·cos φ = 0 at each): {label} is "
                          "not excited (IEEE 1293: ±45°)")
        elif ia != ib and not (any(x >= _EXCITES for x in prods) and any(x <= -_EXCITES for x in prods)):
            reasons[n] = (f"the {text}-plane runs tilt one way only ({angles}): {label} would rest on k2, k3 and "
                          f"{'Kpp' if plane == 'ip' else 'Koo'} being exact at the other angles; IEEE 1293 takes it from "
                          "a ±φ pair (+45° and −45°), where every term even in φ cancels: add the other side")
        elif not estimable[j]:
            reasons[n] = (f"the runs ({text} plane at {angles}, and along the vibration) do not separate {label} from the "
                          f"other terms (k2, k3{', Kip' if n == 'kpp_ug_per_g2' else ', Kio' if n == 'koo_ug_per_g2' else ''}): "
                          f"add a run at 90° in the {text} plane")
    kept = [n for n in CROSS if n not in reasons]
    est = {n: Estimate(float(theta[names.index(n)]), math.sqrt(max(float(cov[names.index(n), names.index(n)]), 0.0)),
                       "ug/g^2") for n in kept}
    idx = [names.index(n) for n in est]
    block = cov[np.ix_(idx, idx)].copy()
    if typeb is not None and est:
        # the reference and DUT sensitivities scale every VRE/σ² alike: one fully correlated term
        vals, note = common_sensitivity_terms(list(est.values()), [typeb.to_dict()])
        shift = np.array([math.copysign(math.sqrt(max(b.u**2 - a_.u**2, 0.0)), a_.value)
                          for a_, b in zip(est.values(), vals) if b is not None])
        block = block + np.outer(shift, shift)
        est = {n: e for n, e in zip(est, vals) if e is not None}
        if note:
            notes.append(note.replace("k2, k3", "the cross-coupling coefficients"))
    nuisance = {n: Estimate(float(theta[j]), math.sqrt(max(float(cov[j, j]), 0.0)), TABLE[n].unit)
                for j, n in enumerate(names[:2]) if estimable[j]}
    for plane, (wk, feeds) in (("ip", (w[1], "Kip + 2·k2·w_p and Kpp + k2·w_p²")),
                               ("io", (w[2], "Kio + 2·k2·w_o and Koo + k2·w_o²"))):
        if not any(_PLANE_OF[n] == plane for n in kept):
            continue
        ax = "w_p" if plane == "ip" else "w_o"
        if wk == 0.0:
            notes.append(f"the sensor states no cross-axis sensitivity toward {'p' if plane == 'ip' else 'o'} ({ax} = 0): "
                         f"the coefficients identified in the {plane.upper()} plane are the apparent {feeds} (the "
                         "cross-axis feed of that component into the sensed input rectifies through k2 alike; with "
                         "k3, the static field's share adds ±9·k3·" + ax + "·cos φ on a vertical shaker); a "
                         f"base sensor with {ax} separates them")
        else:
            notes.append(f"the cross-axis sensitivity {ax} = {wk:.4g} of the base sensor is modelled (the k2·(w·d)² term "
                         f"carries its 2·k2·{ax}·sinφ·cosφ feed); its own u is not carried into the coefficients")
    if fn and q:
        notes.append(f"cross-coupling fit: σ_m² = rms²·|H(f)|² with the model's fn = {fn:.4g} Hz, Q = {q:.3g} (their u "
                     "not carried: small below fn)")
    if float(getattr(sensor, "k4_per_g3", 0.0) or 0.0):
        notes.append("cross-coupling fit: the sensor's k4 term is not in its model (VRE/σ² linear in the coefficients)")
    points = []
    for ob, m, keep, s2 in groups:
        d = np.array(m.direction)
        g = np.array(m.static_g)
        wd, gs = float(w @ d), float(w @ g)
        col = np.array([wd**2, 3 * gs * wd**2, *(d[a2] * d[b2] for _, a2, b2 in CROSS_TERMS)])
        ratio = weighted_mean([Estimate(to_ug(float(v / x)), to_ug(float(uu / x)), "ug/g^2")
                               for v, uu, x in zip(ob.vre_g[keep], ob.u_g[keep], s2[keep])])
        points.append({"run": ob.run, "label": ob.label, "freq_hz": ob.freq_hz, "mount_deg": m.deg,
                       "mount_plane": m.plane, "shaker": m.shaker, "static_vector_g": list(m.static_g),
                       "axial": not ob.tilted, "n": int(keep.sum()),
                       "vre_per_ms_ug_per_g2": {"value": ratio.value, "u": ratio.u},
                       "model_ug_per_g2": finite_or_none(float(col @ theta))})
    covariance = (tuple(est), block) if est else None
    return CrossCoupling(est, reasons, covariance, tuple(notes), tuple(points), nuisance, chi2, dof)


# --------------------------------------------------------------------------- the whole campaign


@dataclass(frozen=True)
class Identification:
    """Every channel of a campaign identified on one base sensor."""

    campaign: str
    base_spec: str
    base: Sensor  # the resolved base Sensor
    channels: tuple[ChannelModel, ...]
    kind: ClipKind
    provenance: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()  # the campaign's: runs that failed

    def to_dict(self, sensor_file: str | None = None) -> dict[str, Any]:
        return {
            "kind": "identification",
            "campaign": self.campaign,
            "base_sensor": {"spec": self.base_spec, "name": self.base.name, "range_g": self.base.range_g,
                            "axis": self.base.axis, "odr_hz": self.base.odr_hz},
            "clip_model": self.kind,
            "sensor_file": sensor_file,
            "channels": [c.to_dict() for c in self.channels],
            "notes": list(self.notes),
            "provenance": dict(self.provenance),
        }


def identify(doc: Mapping[str, Any], base_spec: str = "ideal", range_g: float | None = None,
             odr_hz: float | None = None, base_axis: str | None = None, kind: ClipKind = DEFAULT_CLIP_KIND,
             typeb: TypeB | None = None, workers: int = 1, prefer_base: bool = False) -> Identification:
    """Identify every channel of a campaign document on the base sensor ``base_spec``.

    ``typeb`` (a :class:`vrelab.gum.TypeB`) overrides the budget the runs declared; without it
    the largest value each run declared is used (one reference, one DUT: their terms are common
    to every run). ``workers`` > 1 identifies channels in parallel processes. ``prefer_base``:
    fn and Q that the runs see but determine poorly (relative u above ``MAX_REL_U``) are
    replaced by the base sensor's (by default they are kept with their u). Failed runs are
    listed in ``notes`` and in every channel's notes.
    """
    from vrelab import _validate as V
    from vrelab.gum import TYPE_B_KEYS, TypeB
    from vrelab.models.clipping import KINDS
    from vrelab.sensor import load_sensor

    V.one_of("kind", kind, KINDS)
    workers = V.integer("workers", workers, 1)
    base = load_sensor(base_spec, range_g=range_g, axis=base_axis, odr_hz=odr_hz)
    if base_axis in ("x", "y", "z") and base.input_axis is None:
        # named on purpose: the channels measured the part's base_axis (a default axis says nothing)
        base = dataclasses.replace(base, input_axis=base_axis)
    obs, notes = observations(doc)
    failed = failed_runs(doc)
    if not obs:
        raise ValueError("identify: the campaign has no DUT channel with results"
                         + (f" ({len(failed)} run(s) failed: {'; '.join(failed)})" if failed else ""))
    if typeb is None:
        runs = [r for r in doc["runs"] if isinstance(r.get("budget"), Mapping)]
        typeb = TypeB(**{k: max((float(r["budget"].get(k, 0.0)) for r in runs), default=0.0) for k in TYPE_B_KEYS})
    name = str(doc.get("name", "campaign"))
    empty = [ch for ch, o in obs.items() if not o]
    if empty:
        raise ValueError(f"identify: channel {empty[0]!r} has no usable level in any run "
                         f"({'; '.join(notes.get(empty[0], [])) or 'no levels'})")
    jobs: list[_Job] = [(ch, obs[ch], base, kind, name, typeb, notes.get(ch, []), prefer_base) for ch in obs]
    if workers > 1 and len(jobs) > 1:
        from vrelab._pool import worker_pool  # workers die with this process (Ctrl-C, SIGTERM, SIGKILL)

        with worker_pool(min(workers, len(jobs))) as pool:
            models = list(pool.map(_identify_job, jobs))
    else:
        models = [_identify_job(j) for j in jobs]
    return Identification(name, base_spec, base, tuple(models), kind, notes=tuple(failed))


# one channel's identification as a worker process gets it (picklable):
# (channel, observations, base sensor, clipping kind, campaign name, Type B budget, notes, prefer_base)
_Job = tuple[str, list["Observation"], "Sensor", ClipKind, str, "TypeB", list[str], bool]


def _identify_job(job: _Job) -> ChannelModel:
    ch, ob, base, kind, name, typeb, notes, prefer_base = job
    return identify_channel(ch, ob, base, kind, name, typeb, notes, prefer_base)


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
    from vrelab.sensor.loader import read_spec

    data, _origin = read_spec(ident.base_spec)
    base = ident.base
    out: dict[str, Any] = {k: v for k, v in data.items() if k not in ("name", "description", "source", "axes",
                                                                     "default_axis", "facts")}
    out["schema"] = data.get("schema", 1)
    out["name"] = f"{base.name}-identified"
    out["description"] = f"{base.name} with its VRE model identified from campaign {ident.campaign!r} by vrelab identify"
    out["source"] = f"vrelab identify: campaign {ident.campaign!r} on base sensor {ident.base_spec}"
    out["default_range_g"] = base.range_g
    out["default_axis"] = ident.channels[0].channel
    keys = {TABLE[n].file_key for n in PARAMETERS}
    out.pop("uncertainty", None)  # resolved per axis below (an identified parameter carries its covariance instead)
    ranges = data.get("ranges")
    if isinstance(ranges, dict):
        from vrelab.sensor import load_sensor

        tested = next((k for k in ranges if math.isclose(float(k), base.range_g, rel_tol=1e-6)), None)
        out["ranges"] = {}
        for k, t in ranges.items():
            if k == tested:
                out["ranges"][k] = {kk: vv for kk, vv in t.items() if kk not in keys and kk != "uncertainty"}
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
        t = {k: v for k, v in base_axis.items() if k not in keys and k != "uncertainty"}
        f: dict[str, str] = {}
        # the base's assumed u of what the campaign did not identify (its filters, its threshold), and the
        # profile u of a resonance the runs only bound
        unc = {n: u for n, u in base.uncertainty.items() if n not in PARAMETERS or cm.parameters.get(n) is None}
        for n, (u, _why) in cm.assumed.items():
            if u is not None:
                unc[n] = float(u)
        for n in PARAMETERS:
            v = cm.values[n]
            e = cm.parameters[n]
            fk = TABLE[n].fact_key
            if e is not None:
                src = f"identified from {ident.campaign}, {e.value:.6g} ± {e.u:.2g} {TABLE[n].text_unit}".rstrip()
            elif n in cm.assumed and cm.assumed[n][1].startswith("fitted"):
                src = f"assumption: {cm.assumed[n][1]}; {v:.6g} ± {unc[n]:.2g} {TABLE[n].text_unit} (profile)".rstrip()
            else:
                src = (f"assumption, from base sensor {ident.base_spec} ({cm.reasons.get(n, 'not identified')})"
                       + (f", u {unc[n]:.3g} {TABLE[n].text_unit}".rstrip() if n in unc else ", no stated u")
                       + f": {base_facts.get(fk, 'unmarked')}")
            f[fk] = f"{f[fk]}; {_side(n)}: {src}" if fk in f else (f"{_side(n)}: {src}" if TABLE[n].rail is not None else src)
        t.update(file_values({n: cm.values[n] for n in PARAMETERS}))
        # the part's axis the channel measured (the base sensor's): the identified axis is named
        # by its channel, and a triaxial prediction needs its IEEE 1293 triad
        if base.input_axis is not None:  # given by --base-axis or the base file, never the default axis
            t["input_axis"] = base.input_axis
        t["facts"] = f
        if cm.covariance is not None:
            t["covariance"] = {"params": list(cm.covariance[0]), "matrix": [[float(c) for c in row]
                                                                           for row in cm.covariance[1]]}
        if unc:
            t["uncertainty"] = unc
        axes[cm.channel] = t
    out["axes"] = axes
    return out


def _side(name: str) -> str:
    rail = TABLE[name].rail
    return name if rail is None else ("lower", "upper")[rail]


def write_sensor_file(path: str | Path, ident: Identification) -> Path:
    """Write :func:`sensor_file_document` as TOML to ``path`` by the one sensor-file writer
    (:func:`vrelab.sensor.writer.write_sensor_file`: loaded for each channel before it is renamed
    into place, so a file that would not load is never left behind)."""
    from vrelab.sensor.writer import write_sensor_file as write

    doc = sensor_file_document(ident)
    header = (f"# Identified by vrelab from campaign {ident.campaign!r} (SPEC 6.1): one [axes.<channel>] per channel,\n"
              "# every number's source in its facts, the identified parameters' covariance beside them.\n"
              "# Use it as --sensor with --axis <channel> in predict, simulate and sweep.\n")
    return write(path, doc, header, axes=[cm.channel for cm in ident.channels])


__all__ = ["Observation", "ChannelModel", "Identification", "observations", "identify", "identify_channel",
           "CrossCoupling", "fit_cross_coupling", "CROSS",
           "model_levels", "apparent_vrc", "cross_check_2f", "sensor_file_document", "write_sensor_file", "REACH_SIGMA", "NEAR_FN"]
