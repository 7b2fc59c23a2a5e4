"""IEEE 1293's cross-coupling coefficients from a campaign's mount-angle runs (physics §1.6)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab._format import finite_or_none
from vrelab.campaigns import (
    MOUNT_PLANES,
    Mount,
)
from vrelab.identification.fitting import covariance_of
from vrelab.identification.observation import Observation, drive_equivalent
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.cross_terms import FITTED, PLANES, TRIAD, CrossTerm
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.results import Estimate
from vrelab.sensor.parameters import TABLE, parameter
from vrelab.units import to_ug

if TYPE_CHECKING:
    from vrelab.gum import TypeB
    from vrelab.sensor.loader import Sensor


# The cross-coupling coefficients a mount-angle campaign identifies (physics §1.6), in the order of
# the JSON and the covariance: read off the one table of the model equation's cross terms.
CROSS: tuple[str, ...] = tuple(t.key for t in FITTED)
# the axis a plane tilts the input axis toward
_TOWARD = {"p": "pendulous", "o": "output"}
# A tilted run excites a product d_j·d_k when it is at least this (sin φ·cos φ is 0.5 at 45°).
_EXCITES = 0.05
# A parameter is estimable when the unit vector along it lies in the design's row space: its
# diagonal element of the projector onto that space is 1 within this.
_ESTIMABLE = 1e-6


@dataclass(frozen=True)
class CrossCoupling:
    """The cross-coupling fit of one channel (:func:`fit_cross_coupling`).

    Examples
    --------
    What :func:`fit_cross_coupling` returns: each coefficient determined (an Estimate) or not
    (its reason), their covariance and notes. Runs as in its example:

    >>> import math
    >>> import numpy as np
    >>> import vrelab
    >>> from vrelab.campaigns.manifest import Mount
    >>> from vrelab.identification.cross_coupling import fit_cross_coupling
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc, mount=None):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6), mount=mount)
    >>> c = math.cos(math.radians(45.0))
    >>> axial = [sine_run(1, 1.0, 100.0)]
    >>> tilted = [sine_run(2, 1.0, 90.0, Mount(45.0, "ip", (c, c, 0.0))), sine_run(3, 1.0, 40.0, Mount(-45.0, "ip", (c, -c, 0.0)))]
    >>> sensor = vrelab.load_sensor("ideal", range_g=2, k2_ug_per_g2=100)
    >>> cc = fit_cross_coupling(tilted, axial, sensor)
    >>> sorted(cc.estimates), sorted(cc.reasons)
    (['kip_ug_per_g2'], ['kio_ug_per_g2', 'koo_ug_per_g2', 'kpp_ug_per_g2'])
    """

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
            "model": "VRE/σ² = (k2 + 3·k3·w·g)·(w·d)² + " + " + ".join(f"{t.label}·{t.product}" for t in FITTED),
            "parameters": {n: est(e) for n, e in self.estimates.items()},
            "null_reasons": dict(self.reasons),
            "nuisance": {n: est(e) for n, e in self.nuisance.items()},
            "chi2": finite_or_none(self.chi2), "dof": self.dof,
            "chi2_reduced": finite_or_none(self.chi2 / self.dof) if self.dof > 0 else None,
            "points": list(self.points),
        }  # fmt: skip


def fit_cross_coupling(tilted: Sequence[Observation], axial: Sequence[Observation], sensor: Sensor,
                       typeb: TypeB | None = None, kind: ClipKind = DEFAULT_CLIP_KIND) -> CrossCoupling:
    r"""IEEE 1293's cross-coupling coefficients Kip, Kpp, Kio, Koo of one channel (physics §1.6)
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
    ``(AᵀWA)⁻¹`` by SVD (:func:`covariance_of`), scaled by χ²/dof when that exceeds 1 (the Birge
    ratio, as identification's other fits). Levels whose sensed peak reaches a rail of the
    identified model (:func:`vrelab.prediction.predict` at ``σ·|w·d|``) are left out; random runs
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

    Examples
    --------
    Sine runs at 80 Hz of a part with k2 = 100 µg/g², Kip = 50 µg/g² and Kpp = 30 µg/g² (k3 = 0):
    along the vibration axis up, and tilted ±45° in its IP plane on a vertical shaker, where
    VRE/σ² = k2·cos²φ + Kpp·sin²φ + Kip·sinφ·cosφ (90 and 40 µg/g²). Kip comes back from the ±45° pair;
    Kpp does not separate from k2 with these runs, and no run is tilted in the IO plane (Kio,
    Koo): each is left out with its reason.

    >>> import math
    >>> import numpy as np
    >>> import vrelab
    >>> from vrelab.campaigns.manifest import Mount
    >>> from vrelab.identification.cross_coupling import fit_cross_coupling
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc, mount=None):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6), mount=mount)
    >>> c = math.cos(math.radians(45.0))
    >>> axial = [sine_run(1, 1.0, 100.0)]
    >>> tilted = [sine_run(2, 1.0, 90.0, Mount(45.0, "ip", (c, c, 0.0))), sine_run(3, 1.0, 40.0, Mount(-45.0, "ip", (c, -c, 0.0)))]
    >>> sensor = vrelab.load_sensor("ideal", range_g=2, k2_ug_per_g2=100)
    >>> cc = fit_cross_coupling(tilted, axial, sensor)
    >>> kip = cc.estimates["kip_ug_per_g2"]
    >>> print(f"Kip {kip.value:.1f} ± {kip.u:.1f} µg/g²")
    Kip 50.0 ± 7.1 µg/g²
    >>> sorted(cc.reasons)
    ['kio_ug_per_g2', 'koo_ug_per_g2', 'kpp_ug_per_g2']
    >>> print(cc.reasons["kpp_ug_per_g2"])
    the runs (IP plane at -45°, +45°, and along the vibration) do not separate Kpp from the other terms (k2, k3, Kip): add a run at 90° in the IP plane
    """
    notes: list[str] = []
    if not tilted:
        why = ("no run mounted at an angle (mount_deg, mount_plane): IEEE 1293 measures the cross-coupling "
               "coefficients with the input axis at 0°, ±45° and 90° to the vibration in the IP and IO planes")
        return CrossCoupling({}, {n: why for n in CROSS}, None, ())
    for ob in tilted:
        if ob.method != "sine":
            notes.append(f"run {ob.run} ({ob.label!r}): a random run mounted at an angle is not used for the cross-coupling "
                         "fit (its rails rectify too; the sine runs carry the coefficients)")
    w = _sensitivity_row(sensor, notes)
    sines = [ob for ob in axial if ob.method == "sine"] + [ob for ob in tilted if ob.method == "sine"]
    design = _design(sines, sensor, w, kind, notes)
    if not design.rows:
        why = "no level of the runs mounted at an angle stays clear of the rails (or none is a sine run)"
        return CrossCoupling({}, {n: why for n in CROSS}, None, tuple(notes))
    names = ("k2_ug_per_g2", "k3_ug_per_g3", *CROSS)
    solved = _solve(design, len(names), notes)
    reasons = _null_reasons(design.groups, solved.estimable)
    kept = [n for n in CROSS if n not in reasons]
    theta, cov = solved.theta, solved.cov
    est = {n: Estimate(float(theta[names.index(n)]), math.sqrt(max(float(cov[names.index(n), names.index(n)]), 0.0)),
                       "ug/g^2") for n in kept}
    idx = [names.index(n) for n in est]
    est, block = _with_type_b(est, cov[np.ix_(idx, idx)].copy(), typeb, notes)
    nuisance = {n: Estimate(float(theta[j]), math.sqrt(max(float(cov[j, j]), 0.0)), TABLE[n].unit)
                for j, n in enumerate(names[:2]) if solved.estimable[j]}
    _feed_notes(w, kept, notes)
    fn, q = parameter(sensor, "fn_hz"), parameter(sensor, "q")
    if fn and q:
        notes.append(f"cross-coupling fit: σ_m² = rms²·|H(f)|² with the model's fn = {fn:.4g} Hz, Q = {q:.3g} (their u "
                     "not carried: small below fn)")
    if float(getattr(sensor, "k4_per_g3", 0.0) or 0.0):
        notes.append("cross-coupling fit: the sensor's k4 term is not in its model (VRE/σ² linear in the coefficients)")
    covariance = (tuple(est), block) if est else None
    return CrossCoupling(est, reasons, covariance, tuple(notes), _points(design.groups, w, theta), nuisance,
                         solved.chi2, solved.dof)


def _sensitivity_row(sensor: Sensor, notes: list[str]) -> NDArray[np.float64]:
    """The axis's sensitivity row w in its triad (i, p, o), 1 along i."""
    try:
        i, p, o = sensor.triad
        row = sensor.sensitivity_row
        return np.array([1.0, row[p], row[o]])
    except ValueError as exc:  # an axis not named x, y or z: no cross-axis row to read
        notes.append(f"cross-coupling fit: {exc}; the cross-axis sensitivity taken as 0")
        return np.array([1.0, 0.0, 0.0])


# one run's levels in the fit: the observation, its mount, the levels kept, and each level's σ_m²
_Group = tuple[Observation, Mount, NDArray[np.bool_], NDArray[np.float64]]


@dataclass
class _Design:
    """The weighted linear least squares of :func:`fit_cross_coupling`: one row per level."""

    rows: list[NDArray[np.float64]] = field(default_factory=list)
    ys: list[float] = field(default_factory=list)
    us: list[float] = field(default_factory=list)
    groups: list[_Group] = field(default_factory=list)


def _design(sines: Sequence[Observation], sensor: Sensor, w: NDArray[np.float64], kind: ClipKind,
            notes: list[str]) -> _Design:
    """Each sine level clear of the rails as one equation ``VRE = σ_m²·(column · θ)``."""
    from vrelab.models.dynamics import vrc_at_frequency
    from vrelab.prediction import predict
    from vrelab.units import UG_PER_G

    fn, q = parameter(sensor, "fn_hz"), parameter(sensor, "q")
    out = _Design()
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
        # a distorted drive (physics §4.4): E[x²] in place of rms², and its E[x³] as the sensed shift w·d·s
        rms_eq, shift = drive_equivalent(ob)
        s2 = rms_eq**2 * h2
        for k in np.flatnonzero(keep):
            col = np.array([wd**2, 3 * (gs + wd * shift[k]) * wd**2, *(d[t.axes[0]] * d[t.axes[1]] for t in FITTED)])
            out.rows.append(s2[k] / UG_PER_G * col)
            out.ys.append(float(ob.vre_g[k]))
            out.us.append(float(ob.u_g[k]))
        if keep.any():
            out.groups.append((ob, mount, keep, s2))
    return out


@dataclass(frozen=True)
class _Solved:
    theta: NDArray[np.float64]
    cov: NDArray[np.float64]  # Birge-scaled
    estimable: list[bool]
    chi2: float
    dof: int


def _solve(design: _Design, n_params: int, notes: list[str]) -> _Solved:
    """θ by weighted least squares, its covariance ``(AᵀWA)⁻¹`` (Birge-scaled), and which
    parameters the design separates."""
    u = np.array(design.us)
    a = np.array(design.rows) / u[:, None]
    y = np.array(design.ys) / u
    theta, *_ = np.linalg.lstsq(a, y, rcond=None)
    cov, rank = covariance_of(a)
    proj = cov @ (a.T @ a)  # the projector onto the design's row space
    estimable = [abs(proj[j, j] - 1.0) < _ESTIMABLE for j in range(n_params)]
    resid = a @ theta - y
    chi2 = float(resid @ resid)
    dof = len(design.ys) - rank
    if dof > 0 and chi2 / dof > 1.0:
        cov = cov * (chi2 / dof)
        notes.append(f"cross-coupling fit: the levels scatter about the model more than their uncertainties "
                     f"(chi2/dof = {chi2 / dof:.3g}): its covariance is scaled by it")
    elif dof <= 0:
        notes.append("cross-coupling fit: as many unknowns as levels: chi2 undefined, u from the levels' uncertainties alone")
    return _Solved(theta, cov, estimable, chi2, dof)


def _partner(t: CrossTerm) -> CrossTerm:
    """The other term fitted in ``t``'s plane (Kip and Kpp, Kio and Koo)."""
    return next(o for o in FITTED if o.plane == t.plane and o is not t)


def _null_reasons(groups: Sequence[_Group], estimable: Sequence[bool]) -> dict[str, str]:
    """Why each coefficient the runs cannot determine is null (IEEE 1293's design: 0°, ±45°, 90°)."""
    reasons: dict[str, str] = {}
    tilts = {pl: sorted({ob.mount.deg for ob, *_ in groups if ob.mount is not None and ob.tilted and ob.mount.plane == pl})
             for pl in MOUNT_PLANES}
    for j, t in enumerate(FITTED, start=2):
        n, (ia, ib), plane = t.key, t.axes, str(t.plane)
        label, text = t.label, plane.upper()
        angles = ", ".join(f"{x:+g}°" for x in tilts[plane])
        prods = [float(np.prod([m.direction[ia], m.direction[ib]])) for ob, m, *_ in groups if ob.tilted and m.plane == plane]
        if not prods:
            reasons[n] = (f"no run mounted in the {text} plane (the input axis tilted toward the "
                          f"{_TOWARD[plane[1]]} axis): {label} needs one (IEEE 1293: 0°, ±45°, 90°)")
        elif ia != ib and not any(abs(x) >= _EXCITES for x in prods):
            reasons[n] = (f"no {text}-plane run between 0° and 90° (angles {angles}: sin φ·cos φ = 0 at each): {label} is "
                          "not excited (IEEE 1293: ±45°)")
        elif ia != ib and not (any(x >= _EXCITES for x in prods) and any(x <= -_EXCITES for x in prods)):
            reasons[n] = (f"the {text}-plane runs tilt one way only ({angles}): {label} would rest on k2, k3 and "
                          f"{_partner(t).label} being exact at the other angles; IEEE 1293 takes it from "
                          "a ±φ pair (+45° and −45°), where every term even in φ cancels: add the other side")
        elif not estimable[j]:
            others = f", {_partner(t).label}" if ia == ib else ""
            reasons[n] = (f"the runs ({text} plane at {angles}, and along the vibration) do not separate {label} from the "
                          f"other terms (k2, k3{others}): add a run at 90° in the {text} plane")
    return reasons


def _with_type_b(est: dict[str, Estimate], block: NDArray[np.float64], typeb: TypeB | None,
                 notes: list[str]) -> tuple[dict[str, Estimate], NDArray[np.float64]]:
    """The reference and DUT sensitivities scale every VRE/σ² alike: one fully correlated term."""
    from vrelab.gum import common_sensitivity_terms

    if typeb is None or not est:
        return est, block
    vals, note = common_sensitivity_terms(list(est.values()), [typeb.to_dict()])
    shift = np.array([math.copysign(math.sqrt(max(b.u**2 - a_.u**2, 0.0)), a_.value)
                      for a_, b in zip(est.values(), vals) if b is not None])
    block = block + np.outer(shift, shift)
    est = {n: e for n, e in zip(est, vals) if e is not None}
    if note:
        notes.append(note.replace("k2, k3", "the cross-coupling coefficients"))
    return est, block


def _feed_notes(w: NDArray[np.float64], kept: Sequence[str], notes: list[str]) -> None:
    """Per plane with a coefficient identified: the cross-axis feed it carries, or that it is modelled."""
    for plane in PLANES:
        if not any(t.plane == plane and t.key in kept for t in FITTED):
            continue
        c = plane[1]  # the axis the plane tilts toward
        wk = w[TRIAD.index(c)]
        prod, square = (next(t for t in FITTED if t.plane == plane and (t.axes[0] == t.axes[1]) is sq) for sq in (False, True))
        feeds = f"{prod.label} + 2·k2·w_{c} and {square.label} + k2·w_{c}²"
        ax = f"w_{c}"
        if wk == 0.0:
            notes.append(f"the sensor states no cross-axis sensitivity toward {c} ({ax} = 0): "
                         f"the coefficients identified in the {plane.upper()} plane are the apparent {feeds} (the "
                         "cross-axis feed of that component into the sensed input rectifies through k2 alike; with "
                         "k3, the static field's share adds ±9·k3·" + ax + "·cos φ on a vertical shaker); a "
                         f"base sensor with {ax} separates them")
        else:
            notes.append(f"the cross-axis sensitivity {ax} = {wk:.4g} of the base sensor is modelled (the k2·(w·d)² term "
                         f"carries its 2·k2·{ax}·sinφ·cosφ feed); its own u is not carried into the coefficients")


def _points(groups: Sequence[_Group], w: NDArray[np.float64], theta: NDArray[np.float64]) -> tuple[dict[str, Any], ...]:
    """Per run and frequency: its angle, plane, VRE/σ_m² measured (weighted mean) and modelled."""
    from vrelab.gum import weighted_mean

    points = []
    for ob, m, keep, s2 in groups:
        d = np.array(m.direction)
        g = np.array(m.static_g)
        wd, gs = float(w @ d), float(w @ g)
        col = np.array([wd**2, 3 * gs * wd**2, *(d[t.axes[0]] * d[t.axes[1]] for t in FITTED)])
        ratio = weighted_mean([Estimate(to_ug(float(v / x)), to_ug(float(uu / x)), "ug/g^2")
                               for v, uu, x in zip(ob.vre_g[keep], ob.u_g[keep], s2[keep])])
        points.append({"run": ob.run, "label": ob.label, "freq_hz": ob.freq_hz, "mount_deg": m.deg,
                       "mount_plane": m.plane, "shaker": m.shaker, "static_vector_g": list(m.static_g),
                       "axial": not ob.tilted, "n": int(keep.sum()),
                       "vre_per_ms_ug_per_g2": {"value": ratio.value, "u": ratio.u},
                       "model_ug_per_g2": finite_or_none(float(col @ theta))})
    return tuple(points)
