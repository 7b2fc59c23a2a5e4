r"""Analytic VRE of one DUT axis under a triaxial vibration, by mechanism, cross terms included.

The model of one axis (the triaxial model contract, physics §1.6; IEEE Std 1293-2018's model
equation): the acceleration ``a = g + x`` in the part's frame (static vector ``g``, zero-mean
vibration ``x``) passes the axis's linear front end ``H`` (the stages before its
:class:`~vrelab.sensor.stages.Polynomial`, today the proof-mass resonance) on every component
alike, ``b = H*a`` (an ASSUMPTION: the proof mass answers every direction with its own
dynamics; a triaxial part's other modes are not modelled), then

``y = P(u) + Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``,  ``u = w·b``,

with ``w`` the axis's sensitivity row (:attr:`~vrelab.sensor.Sensor.sensitivity_row`), ``P``
its polynomial and ``(i, p, o)`` its triad; then the rest of its chain (over-range, rails,
filters, offset, ...) on ``y``. So

* with ``b = g + x_b`` (``x_b`` the vibration at the proof mass; the front end passes the static
  vector unchanged) the equation reads ``y = P(u0 + w·x_b) + gᵀKg + 2gᵀK·x_b + x_bᵀK·x_b``
  (``K`` the symmetric matrix of the cross terms, ``u0 = w·g``): the polynomial sees the sensed
  vibration ``w·x_b`` alone, and the cross terms' part linear in the vibration, ``2gᵀK·x_b``, is
  added after it, so it reaches the rails and over-range but not the polynomial;
* the **sensed vibration** is Gaussian (random drive) with PSD ``w_effᵀ Re S(f) w_eff``,
  ``w_eff = w + 2Kg``, and static level ``w·g``, or a sine of amplitude ``|w_eff·d|·A`` (sine
  along ``d``): the linear part of what the rails and over-range see, as on one axis, and
  :func:`vrelab.prediction.single.predict` of that projected vibration gives the clipping,
  nonlinearity and over-range shares. It also feeds ``2gᵀK·x_b`` through the polynomial, which
  the equation does not: that move ``Δ = R(u0 + w·x_b + 2gᵀK·x_b) - R(u0 + w·x_b)`` (``R`` the
  polynomial's nonlinear part) has its mean computed exactly (:func:`~vrelab.prediction._cross.poly_move`)
  and taken off, through the rails and holds as a static shift (their ``∂E[out]/∂(shift)``), so
  ``nonlinearity_g`` is ``E[P(u0 + w·x_b)] - P(u0)`` exactly; what its zero-mean part may do at
  the rails is bounded in ``model_error_g``;
* the **cross terms** rectify in closed form, ``VRE_jk = K_jk · Re ∫ S_jk(f)·|H(f)|² df``
  (sine: ``K_jk·d_j·d_k·rms²·|H(f)|²``): the products of the static vector with the zero-mean
  vibration average out, and ``K·g_j·g_k`` is in the vibration-off reading as well (physics §1.5);
* where rails or over-range act after the nonlinearity, the cross terms pass them to first
  order: their mean times the rails' response to a shift of their input, ``∂E[out]/∂(shift)``
  (the probability of being inside, for censored rails), plus the part of their fluctuation
  the rails see (its second Hermite component in the rails' Gaussian input, through the filters
  between: :func:`rails_pass`, :func:`filtered_he2`), plus the static cross terms ``K·g_j·g_k``
  moving the rails' working point; and times the time not held, ``1 - rate·hold``. What that
  misses (second order across a rail, the rails' input read as Gaussian, a truncated rail's
  correlation with the fluctuation, the over-range rate's change, the polynomial move's
  zero-mean part) is bounded in
  ``model_error_g``, as :mod:`vrelab.prediction.single` bounds its own, and ``valid`` is False where the
  bound may exceed the stated u.

The projected PSD is a sum of the axes' power laws (and coherences linear in ln f): where it is
one power law between the profile's breakpoints (a vibration along a direction, axes of one
shape with constant coherences) the single-axis profile is exact on those breakpoints; otherwise
it is tabulated on a dense log grid (steps of 0.002 in ln f), and the tabulation's error in what
every site sees is measured against adaptive quadrature of the exact PSD and bounded in
``model_error_g``.

References
----------
.. [1] IEEE Std 1293-2018, IEEE Specification Format Guide and Test Procedure for Linear
   Single-Axis, Nongyroscopic Accelerometers: the model equation's cross-coupling terms.
.. [2] physics §1.6 (the vibropendulous error ``Kip·σ²·sin φ·cos φ``) and 1.1-1.5.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Literal, Sequence, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as V
from vrelab.models.clipping import KINDS
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.prediction._cross import (
    CROSS_SHARES,
    After,
    CrossMean,
    filtered_he2,
    he2_step,
    k_matrix,
    overrange_pass,
    poly_move,
    rails_pass,
    read_axis,
)
from vrelab.prediction._projection import csd_integral, projected
from vrelab.prediction.checks import tilt_note
from vrelab.prediction.propagation import propagation
from vrelab.prediction.results import LevelPrediction, Prediction
from vrelab.prediction.single import predict
from vrelab.results import Conditions
from vrelab.triaxial.profile import AXES, TriaxialProfile, TriaxialSine
from vrelab.units import to_ug

if TYPE_CHECKING:
    from vrelab.profiles import RandomProfile, SineOnRandom
    from vrelab.sensor import Sensor


__all__ = ["CROSS_SHARES", "TriaxialLevelPrediction", "TriaxialPrediction", "predict_triaxial"]

Excitation = TriaxialProfile | TriaxialSine
Response = Callable[[NDArray[np.float64]], NDArray[np.complex128]]

# A level's note on the cross terms through the rails begins so (:func:`_judged` extends it).
_PASS_NOTE = "the cross terms' mean "


# the rails/holds pass the cross terms' mean unchanged to this (relative): below it no note
_PASS_TOL = 1e-6

# The triaxial result types of earlier releases (now one Prediction, its triaxial fields present when they apply):
# aliases for one release.
TriaxialLevelPrediction = LevelPrediction
TriaxialPrediction = Prediction


# --- prediction ---------------------------------------------------------------------------------


def _static_vector(static_g: ArrayLike) -> NDArray[np.float64]:
    g = np.asarray(static_g, dtype=np.float64).ravel()
    if g.size != 3 or not np.isfinite(g).all():
        raise ValueError(f"static_g must be three finite numbers (gx, gy, gz) [g], got {static_g!r}")
    return g


def _level_zero(rms: float, freq_hz: float | None, u0: float) -> LevelPrediction:
    """The single-axis part where the axis senses none of the vibration."""
    zero = {"clip_low_g": 0.0, "clip_high_g": 0.0, "clip_g": 0.0, "nonlinearity_g": 0.0, "overrange_g": 0.0}
    return LevelPrediction(rms, 0.0, tilt_note(0.0, u0)[0], zero, 0.0, 0.0, 0.0, 0.0, True, freq_hz=freq_hz)


def predict_along(sensor: Sensor,
                  vibration: RandomProfile | SineOnRandom | float | Sequence[float] | TriaxialProfile | TriaxialSine,
                  levels: Sequence[float] | NDArray[np.float64],
                  static_g: float | ArrayLike, kind: ClipKind, direction: ArrayLike | None) -> Prediction:
    """:func:`vrelab.prediction.predict` off the input axis: a single-axis profile or one sine
    frequency along ``direction`` (default: the input axis), or a TriaxialProfile/TriaxialSine as
    given; a scalar ``static_g`` along the input axis, else the vector. Then :func:`_predict`."""
    from vrelab.profiles import RandomProfile, SineOnRandom

    i = sensor.triad[0]  # refuses an axis that is none of x, y, z (no triad)
    if isinstance(vibration, (TriaxialProfile, TriaxialSine)):
        if direction is not None:
            raise ValueError("direction applies to a single-axis vibration: a TriaxialProfile or TriaxialSine carries "
                             "its own directions")
        tri: Excitation = vibration
    else:
        # the direction is checked and normalised where the vibration is built (triaxial.profile.unit_vector)
        d: Any = direction if direction is not None else tuple(1.0 if j == i else 0.0 for j in range(3))
        if isinstance(vibration, RandomProfile):
            tri = TriaxialProfile.along(vibration, d)
        elif not isinstance(vibration, SineOnRandom) and np.size(vibration) == 1:
            tri = TriaxialSine(float(np.ravel(np.asarray(vibration, dtype=np.float64))[0]), d, 1.0)
        else:
            raise ValueError("a vibration off the input axis (a direction or a static vector) takes a random profile "
                             "(no +sine tones) or one sine frequency: sine-on-random has no triaxial model")
    static = [float(cast(float, static_g)) if j == i else 0.0 for j in range(3)] if np.ndim(static_g) == 0 else static_g
    return _predict(sensor, tri, levels, static, kind, _judged)


def predict_triaxial(
    sensor: Sensor,
    excitation: TriaxialProfile | TriaxialSine,
    levels: Sequence[float] | NDArray[np.float64],
    static_g: ArrayLike = (0.0, 0.0, 1.0),
    kind: ClipKind = DEFAULT_CLIP_KIND,
) -> Prediction:
    r"""Deprecated (one release): :func:`vrelab.predict` takes a triaxial vibration and a static
    vector, ``vrelab.predict(sensor, excitation, levels, static_g=(gx, gy, gz))``.

    Predict the VRE of one DUT axis under a triaxial vibration, by mechanism, without simulating.

    Parameters
    ----------
    sensor : vrelab.sensor.Sensor
        One axis (loaded with ``axis`` x, y or z): its stages, sensitivity row ``w``, triad and
        cross-coupling coefficients (physics §1.6).
    excitation : TriaxialProfile or TriaxialSine
        Random: the cross-spectral density matrix's shape, scaled to each level (Gaussian
        drive). Sine: frequency and direction, at each level's rms.
    levels : sequence of float
        Total rms [g] (:attr:`TriaxialProfile.grms`: ``sqrt(trace ∫S df)``; along one direction,
        the rms along it), each > 0.
    static_g : three floats
        The static acceleration vector in the part's frame [g] (``(0, 0, 1)``: z up in 1 g).
    kind : {"censored", "truncated"}
        Clipping model (physics §1.1).

    Returns
    -------
    Prediction
        Per level: ``vre_g``, the single-axis shares of the sensed vibration and the cross
        terms' (``cross_kip_g`` ...), ``model_error_g``, ``u_vre_g`` where the sensor carries
        parameter uncertainties, ``valid`` and ``notes``; the conditions (excitation with its
        per-axis rms and coherences, static vector, triad, sensitivity row, coefficients).

    Notes
    -----
    ``VRE = VRE_1(u) - dc·E[Δ] + pass · Σ_jk K_jk·Re ∫ S_jk(f)|H(f)|² df`` (the module
    docstring): ``VRE_1`` is :func:`vrelab.prediction.single.predict` of the sensed vibration
    ``u = w_eff·b`` (PSD ``w_effᵀ Re S w_eff``, static ``w·g``); ``E[Δ]`` what its polynomial made
    of the part ``2gᵀK·b`` the model equation adds after the polynomial; ``dc`` and ``pass`` the
    rails' and over-range's response to a shift of their input. With the vibration along the
    input axis and every cross term 0 it is :func:`vrelab.prediction.single.predict` itself. ``u_vre_g``: the sensor's covariance and assumed
    uncertainties carried by :func:`vrelab.prediction.propagation.propagation` through this function.

    References
    ----------
    .. [1] IEEE Std 1293-2018, the model equation (cross-coupling coefficients Kip ... Kpo).
    .. [2] physics §1.6; the single-axis mechanisms: physics §1.1-1.3 and :func:`vrelab.prediction.single.predict`.
    """
    import warnings

    warnings.warn("predict_triaxial() is deprecated and will be removed in the next release: call "
                  "vrelab.predict(sensor, excitation, levels, static_g=(gx, gy, gz)), one predict for one axis and three",
                  DeprecationWarning, stacklevel=2)
    return _predict(sensor, excitation, levels, static_g, kind, _judged)


def _judged(lv: LevelPrediction) -> LevelPrediction:
    """:func:`vrelab.prediction.checks.judged` (one rule: a bound judged against the stated u), its reason
    naming the cross terms' part of the bound where they have one: predict's own reason speaks of
    the single-axis rails after filters, which is not what a cross term's bound is."""
    from vrelab.prediction import judged

    out = judged(lv)
    cross = float(lv.cross_error_g or 0.0)
    if out.valid or not lv.valid or not cross > 0 or len(out.notes) != len(lv.notes) + 1:
        return out
    reason = out.notes[-1]
    over = reason[reason.index("more than "):] if "more than " in reason else f"({reason})"
    passing = [n for n in out.notes[:-1] if n.startswith(_PASS_NOTE)]
    head = (passing[0].split("; what that misses")[0] if passing
            else "the cross terms pass the rails/over-range after the nonlinearity to first order")
    note = (f"{head}; what that misses is bounded by {cross * 1e3:.3g} mg, the rest of the model by "
            f"{(lv.model_error_g - cross) * 1e3:.3g} mg: model_error_g {lv.model_error_g * 1e3:.3g} mg, {over}")
    kept = tuple(n for n in out.notes[:-1] if not n.startswith(_PASS_NOTE))
    return dataclasses.replace(out, notes=(*kept, note))


@dataclass(frozen=True)
class _Drive:
    """The excitation as the axis sees it: ``moments`` ``E[b bᵀ]`` per unit total mean square at
    the proof mass, the sensed vibration as a single-axis one (a profile or a frequency; None
    where ``w_eff·a = 0``), its mean square per unit of the total (``ratio``), the tabulation's
    error (``interp_err``), a sine's frequency, direction ``d`` and ``|H(f)|²`` at the proof mass."""

    shape: Literal["gaussian", "sine"]
    moments: NDArray[np.float64]
    sensed: Any
    ratio: float
    interp_err: float
    sensed_hz: float | None
    cond_profile: str
    d: NDArray[np.float64]
    h2: float


@dataclass(frozen=True)
class _Axis:
    """What every level of one axis's triaxial prediction shares: the static vector ``g``, the
    sensitivity row ``w`` and ``w_eff = w + 2Kg``, the cross terms' K, ``u0 = w·g``,
    ``static_cross = gᵀKg``, the sites after the nonlinearity, the drive, and the filtered
    rails' He2 coefficients with their grid error."""

    sensor: Any
    triad: tuple[int, int, int]
    g: NDArray[np.float64]
    w: NDArray[np.float64]
    w_eff: NDArray[np.float64]
    kmat: NDArray[np.float64]
    u0: float
    static_cross: float
    after: tuple[After, ...]
    kind: ClipKind
    drive: _Drive
    any_cross: bool
    g_filtered: NDArray[np.float64] | None
    g_err: NDArray[np.float64]


def _drive(excitation: Excitation, sensor: Sensor, front: Sequence[Response], w_eff: NDArray[np.float64]) -> _Drive:
    """The excitation at the proof mass and as the axis senses it (:class:`_Drive`)."""
    interp_err = 0.0
    sensed: Any
    d, h2 = np.zeros(3), 1.0  # a sine's direction and |H(f)|² at the proof mass
    if isinstance(excitation, TriaxialProfile):
        m_tot = excitation.mean_square_g2
        m0, mh = csd_integral(excitation, front)
        if not math.isclose(float(np.trace(m0)), m_tot, rel_tol=1e-8):  # the quadrature failed: no number
            raise RuntimeError(f"trace ∫S df by quadrature {np.trace(m0)!r} is not the profile's {m_tot!r}")
        moments = mh / m_tot  # E[b bᵀ] per unit total mean square
        sensed, ratio, interp_err = projected(excitation, w_eff, sensor, front)
        frac = np.sqrt(excitation.axis_mean_square_g2 / m_tot)
        cond_profile = (f"{excitation.name or 'triaxial random'}, {excitation.band[0]:g}-{excitation.band[1]:g} Hz: "
                        f"rms x {frac[0]:.3g}, y {frac[1]:.3g}, z {frac[2]:.3g} of the total")
        return _Drive("gaussian", moments, sensed, ratio, interp_err, None, cond_profile, d, h2)
    d = np.asarray(excitation.direction)
    for r in front:
        h2 *= float(abs(np.asarray(r(np.array([excitation.freq_hz])))[0])) ** 2
    moments = np.outer(d, d) * h2
    ratio = float(w_eff @ d) ** 2
    sensed = excitation.freq_hz if ratio > 0 else None
    cond_profile = f"sine {excitation.freq_hz:g} Hz along ({d[0]:.4g}, {d[1]:.4g}, {d[2]:.4g})"
    return _Drive("sine", moments, sensed, ratio, interp_err, excitation.freq_hz, cond_profile, d, h2)


def _axis(sensor: Sensor, excitation: Excitation, static_g: ArrayLike, kind: ClipKind) -> _Axis:
    """The axis read once for a prediction (:class:`_Axis`)."""
    g = _static_vector(static_g)
    w = sensor.sensitivity_row
    kmat = k_matrix(sensor)
    # the cross terms' part linear in the vibration, 2gᵀK·x (a static vector across K: a
    # sensitivity to the other axes), joins the sensed vibration: the rails and over-range see it
    # as the rest of u; the model equation adds it after the polynomial, so what predict's
    # polynomial makes of it comes off at each level (_level, poly_move)
    w_eff = w + 2.0 * kmat @ g
    front, after = read_axis(sensor.stages())
    drive = _drive(excitation, sensor, front, w_eff)
    any_cross = bool(np.any(kmat))
    g_filtered, g_err = None, np.zeros((3, 3))
    clips = [site for site in after if site.kind == "clip"]
    if (any_cross and isinstance(excitation, TriaxialProfile) and clips and clips[-1].filtered
            and drive.sensed is not None):
        # the filtered rails' He2 coefficients, and their grid error: the same on a grid twice as fine
        g_filtered = filtered_he2(excitation, w_eff, front, clips[-1].responses)
        finer = filtered_he2(excitation, w_eff, front, clips[-1].responses,
                              df_hz=he2_step(excitation, [*front, *clips[-1].responses]) / 2.0)
        g_err = 2.0 * np.abs(finer - g_filtered)
    return _Axis(sensor, sensor.triad, g, w, w_eff, kmat, float(w @ g), float(g @ kmat @ g), tuple(after), kind, drive,
                 any_cross, g_filtered, g_err)


def _predict(sensor: Sensor, excitation: object, levels: ArrayLike, static_g: ArrayLike, kind: ClipKind,
             judged: Callable[[LevelPrediction], LevelPrediction] | None) -> Prediction:
    if not isinstance(excitation, (TriaxialProfile, TriaxialSine)):
        raise ValueError(f"a triaxial prediction needs a TriaxialProfile or TriaxialSine, got {type(excitation).__name__}")
    levels_arr = V.vibration_level("levels", np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    if levels_arr.ndim != 1 or levels_arr.size == 0:
        raise ValueError(f"levels must be a non-empty list of rms values, got {levels!r}")
    V.one_of("kind", kind, KINDS)
    ax = _axis(sensor, excitation, static_g, kind)
    u0, sensed = ax.u0, ax.drive.sensed
    bare = dataclasses.replace(sensor, covariance=None, uncertainty={})  # u below, over the whole prediction
    notes: list[str] = []
    sensed_rms = levels_arr * math.sqrt(ax.drive.ratio)
    axis_frac = (np.sqrt(excitation.axis_mean_square_g2 / excitation.mean_square_g2)
                 if isinstance(excitation, TriaxialProfile) else np.abs(ax.drive.d))
    single: Prediction | None = None
    slope = np.zeros(levels_arr.size)
    if sensed is not None:
        single = predict(bare, sensed, sensed_rms, static_g=u0, kind=kind)
        if ax.drive.interp_err > 0:
            # how the VRE moves with the mean square the sites see: the tabulation's error times it
            bumped = predict(bare, sensed, sensed_rms * math.sqrt(1.0 + 1e-3), static_g=u0, kind=kind)
            slope = np.array([(b.vre_g - a.vre_g) / 1e-3 for a, b in zip(single.levels, bumped.levels)])
    else:
        notes.append("the axis senses none of this vibration (w·a = 0): its single-axis mechanisms are 0, the "
                     "cross terms act alone")
    out: list[LevelPrediction] = [
        _level(ax, float(rms), single.levels[n] if single is not None else None, float(slope[n]),
               float(sensed_rms[n]), axis_frac) for n, rms in enumerate(levels_arr)]
    if single is not None:
        notes += [nt for nt in single.notes if not nt.startswith("VRE referred to")]
    if ax.drive.interp_err > 0:
        notes.append(f"the sensed PSD wᵀ Re S w is no power law between the profile's breakpoints: tabulated on "
                     f"{sensed.freq_hz.size} log-spaced points, whose error in what the sites see "
                     f"({ax.drive.interp_err:.2g} relative, against adaptive quadrature) is bounded in model_error_g")
    if ax.any_cross:
        notes.append("cross terms (IEEE 1293 model equation): K_jk·Re ∫S_jk|H|²df at the proof mass, H the axis's "
                     "front end on every component alike (assumption: the part's other modes are not modelled), "
                     "passed through the rails and over-range after the nonlinearity to first order (bound in "
                     "model_error_g)" + ("; their part linear in the vibration, 2gᵀK·x, added after the polynomial "
                                         "(the rails and over-range see it, the polynomial does not)"
                                         if np.any(ax.w_eff != ax.w) else ""))
    # the reading with no vibration does not depend on the excitation: predict's, of any one
    off = (single or predict(bare, [100.0], [1e-6], static_g=u0, kind=kind)).vibration_off_g + ax.static_cross
    notes.append(f"VRE referred to the vibration-off reading ({off:.9g} g, the static vector {_vec(ax.g)} g through "
                 "the axis: w·g and the cross terms' K·g_j·g_k): mean output with vibration less that reading")
    cond = _conditions(ax, bare, excitation)
    if judged is not None and (getattr(sensor, "covariance", None) or getattr(sensor, "uncertainty", None)):
        def again(s: Sensor, _e: object, lv: ArrayLike, _g: float, k: ClipKind) -> Prediction:
            return _predict(s, excitation, lv, ax.g, k, None)

        prop = propagation(sensor, cast(Any, excitation), levels_arr, u0, kind, vre_g=np.array([lv.vre_g for lv in out]),
                           predictor=again)
        out = prop.applied(out)
        notes += prop.notes
    if ax.any_cross:
        notes += _bare_coefficients(sensor)
    if judged is not None:
        out = [judged(lv) for lv in out]
    why0 = tilt_note(0.0, u0)[1]
    if why0 and single is None:
        notes.append(why0.replace("the static field", "the static field of every level"))
    return Prediction(cond, tuple(out), tuple(notes), vibration_off_g=off,
                      excitation=_excitation_summary(excitation))


def _bare_coefficients(sensor: Sensor) -> list[str]:
    """The note naming the cross-coupling coefficients set with no stated u (none: empty)."""
    stated = set(dict(getattr(sensor, "uncertainty", None) or {}))
    stated |= set((getattr(sensor, "covariance", None) or {}).get("params", []))
    bare_k = [f"{attr[:3].capitalize()}" for _, attr, _, _ in CROSS_SHARES
              if getattr(sensor, attr) and f"{attr[:3]}_ug_per_g2" not in stated]
    if not bare_k:
        return []
    return [f"{', '.join(bare_k)} {'carries' if len(bare_k) == 1 else 'carry'} no stated uncertainty (no [uncertainty] entry, not identified): "
            "u_vre_g takes them as exact"]


def _conditions(ax: _Axis, bare: Sensor, excitation: Excitation) -> Conditions:
    """The prediction's conditions: the sensor's, with the static vector, triad, sensitivity row,
    coefficients and excitation in ``extra``."""
    sensor, g, triad = ax.sensor, ax.g, ax.triad
    base_cond = bare.conditions(static_g=float(g[triad[0]]), profile=ax.drive.cond_profile,
                                model=f"prediction-{ax.kind}-triaxial")
    extra = {**dict(base_cond.extra),
             "clip_position": str(getattr(sensor, "clip_position", "output") or "output"),
             "level": "total rms sqrt(trace ∫S df) [g]",
             "static_vector_g": [float(x) for x in g],
             "sensed_static_g": ax.u0,
             "triad": {"input": AXES[triad[0]], "pendulous": AXES[triad[1]], "output": AXES[triad[2]]},
             "sensitivity_row": [float(x) for x in ax.w],
             "cross_coupling_ug_per_g2": {attr[:3]: to_ug(float(getattr(sensor, attr))) for _, attr, _, _ in CROSS_SHARES},
             "excitation": _excitation_summary(excitation)}
    return Conditions(sensor=base_cond.sensor, model=base_cond.model, profile=base_cond.profile,
                      static_g=base_cond.static_g, range_g=base_cond.range_g, bandwidth_hz=base_cond.bandwidth_hz,
                      odr_hz=base_cond.odr_hz, axis=base_cond.axis, extra=extra)


def _fluctuation(ax: _Axis, rms: float, cov_b: NDArray[np.float64]) -> tuple[float, float]:
    """(r_fluct, q_peak): the rms of the quadratic cross terms' zero-mean part, and (sine) its peak."""
    kmat, d = ax.kmat, ax.drive.d
    if ax.drive.shape == "gaussian":
        kc = kmat @ cov_b
        # the quadratic cross terms' zero-mean part bᵀKb - E (second Wiener chaos): Var = 2 tr((KΣ)²)
        return math.sqrt(max(2.0 * float(np.trace(kc @ kc)), 0.0)), 0.0
    s2 = 2.0 * float(rms) ** 2 * ax.drive.h2  # the sine's peak² at the proof mass
    dkd = float(d @ kmat @ d)  # Q = dᵀKd·s²·cos²θ: its zero-mean part dᵀKd·s²·cos 2θ/2
    return abs(dkd) * s2 / math.sqrt(8.0), abs(dkd) * s2 / 2.0


def _through(ax: _Axis, lv_s: LevelPrediction | None, rms: float, cov_b: NDArray[np.float64],
             cross: CrossMean) -> tuple[float, float, float, float, dict[str, float], dict[str, float]]:
    """(factor, dc, he2, bound, c2, moved): what the rails and holds after the nonlinearity make of
    the cross terms at one level (:func:`rails_pass`, :func:`overrange_pass`), each term's He2
    coefficient ``c2``, the bound on what that misses, and the polynomial's move (``cross.poly``)
    as the shares carry it: ``-mean`` off the nonlinearity, ``mean·(1 - dc)`` of each site onto
    its share (the rails and holds took that part of it), ``-mean·dc`` in all."""
    sensor, triad, shape, w_eff = ax.sensor, ax.triad, ax.drive.shape, ax.w_eff
    factor, dc, bound = 1.0, 1.0, 0.0
    p_mean = cross.poly[0]
    moved = {"nonlinearity_g": -p_mean, "clip_g": 0.0, "overrange_g": 0.0}
    # each term's He2 coefficient in the rails' Z: K·v_j·v_k/σ_u² (v = Σ_b·w_eff) with nothing
    # between, else K·G_jk (:func:`filtered_he2`); with two sets of rails the last one's
    v = cov_b @ w_eff
    var_u = float(w_eff @ v)
    gmat = (ax.g_filtered * float(rms) ** 2 if ax.g_filtered is not None
            else np.outer(v, v) / var_u if var_u > 0 else np.zeros((3, 3)))
    c2 = ({key: float(getattr(sensor, attr)) * float(gmat[triad[a], triad[b]]) for key, attr, a, b in CROSS_SHARES}
          if shape == "gaussian" else {key: 0.0 for key, _, _, _ in CROSS_SHARES})
    c2_err = sum(abs(float(getattr(sensor, attr))) * float(ax.g_err[triad[a], triad[b]]) * float(rms) ** 2
                 for _, attr, a, b in CROSS_SHARES)
    he2 = 0.0
    if ax.any_cross:
        cross = dataclasses.replace(cross, c2_total=sum(c2.values()))
        for site in ax.after:
            if site.kind == "clip":
                dc_, f_, h_, b_ = rails_pass(lv_s, site, sensor, ax.u0, shape, ax.kind, cross, ax.drive.sensed_hz)
                b_ += c2_err * abs(h_)
                he2 = he2 * dc_ + h_  # a first set of rails' He2 part, through a second one
            else:
                # the holds lose the polynomial's move as they lose the cross terms' mean
                f_, b_ = overrange_pass(lv_s, site, ax.u0, abs(cross.mean_g) + abs(p_mean),
                                        cross.r_fluct + cross.poly[1])
                dc_, he2 = f_, he2 * f_
            moved["clip_g" if site.kind == "clip" else "overrange_g"] += p_mean * dc * (1.0 - dc_)
            factor *= f_
            dc *= dc_
            bound += b_
    return factor, dc, he2, bound, c2, moved


def _level(ax: _Axis, rms: float, lv_s: LevelPrediction | None, slope: float, sensed_rms: float,
           axis_frac: NDArray[np.float64]) -> LevelPrediction:
    """One level: the sensed vibration's single-axis level ``lv_s`` (None: the axis senses none
    of it) and the cross terms passed through what follows the nonlinearity."""
    sensor, triad, g, u0, sensed_hz = ax.sensor, ax.triad, ax.g, ax.u0, ax.drive.sensed_hz
    cov_b = ax.drive.moments * float(rms) ** 2  # E[b bᵀ] [g²] (sine: its mean square)
    terms = {key: float(getattr(sensor, attr)) * float(cov_b[triad[a], triad[b]])
             for key, attr, a, b in CROSS_SHARES}
    cross_mean = sum(terms.values())
    statics = {key: float(getattr(sensor, attr)) * float(g[triad[a]] * g[triad[b]]) for key, attr, a, b in CROSS_SHARES}
    r_fluct, q_peak = _fluctuation(ax, rms, cov_b)
    # the model equation's polynomial sees u0 + w·x; the sensed vibration predicted (w_eff·x) also
    # carries 2gᵀK·x, which the equation adds after it: what the polynomial made of that comes off
    lin = ax.w_eff - ax.w
    k = (sensor.k2_per_g, sensor.k3_per_g2, sensor.k4_per_g3)
    pair = np.array([[ax.w @ cov_b @ ax.w, ax.w @ cov_b @ lin], [lin @ cov_b @ ax.w, lin @ cov_b @ lin]])
    poly = poly_move(k, u0, pair, ax.drive.shape) if ax.any_cross else (0.0, 0.0, 0.0)
    factor, dc, he2, bound, c2, moved = _through(ax, lv_s, rms, cov_b,
                                                 CrossMean(cross_mean, r_fluct, q_peak, ax.static_cross, poly=poly))
    shares = dict(lv_s.shares) if lv_s is not None else dict(_level_zero(float(rms), sensed_hz, u0).shares)
    for key, v in moved.items():
        shares[key] += v
    # each term: its rectified mean through the rails and holds, its He2 part, and its static
    # part K·g_j·g_k, which moves the reading with vibration by dc times it, the vibration-off
    # reading by all of it
    passed = {key: c * factor + c2[key] * he2 + statics[key] * (dc - 1.0) for key, c in terms.items()}
    shares.update(passed)
    shares["cross_g"] = sum(passed.values())
    through = shares["cross_g"] / cross_mean if cross_mean else factor
    base = lv_s if lv_s is not None else _level_zero(float(rms), sensed_hz, u0)
    lv_notes = list(base.notes)
    if lv_s is not None and lv_s.valid_otherwise and not lv_s.valid and lv_notes:
        lv_notes.pop()  # predict's judgement of its own bound: judged again below on the whole one
    vre = base.vre_g + sum(moved.values()) + shares["cross_g"]
    tilt, why = tilt_note(vre, u0)
    # the level's tilt note, of the whole VRE (the sensed part's, if any, replaced)
    lv_notes = [nt for nt in lv_notes if nt != tilt_note(base.vre_g, u0)[1]]
    if why and tilt_note(0.0, u0)[1] is None:  # the static field's own case is one note of the prediction
        lv_notes.append(why)
    interp_bound = 2.0 * ax.drive.interp_err * abs(float(slope))
    if abs(through - 1.0) > _PASS_TOL:
        lv_notes.append(f"{_PASS_NOTE}({cross_mean * 1e3:.3g} mg) passes the rails/over-range after the "
                        f"nonlinearity times {through:.4g}; what that misses is bounded ({bound * 1e3:.3g} mg, in "
                        "model_error_g)")
    return LevelPrediction(
        rms_g=float(rms), vre_g=vre, tilt_error_deg=tilt, shares=shares,
        sigma_proof_mass_g=base.sigma_proof_mass_g, sigma_output_g=base.sigma_output_g,
        sigma_at_clip_g=base.sigma_at_clip_g, overrange_rate_hz=base.overrange_rate_hz,
        valid=base.valid_otherwise, notes=tuple(lv_notes), freq_hz=base.freq_hz,
        model_error_g=float(base.model_error_g) + bound + interp_bound, valid_otherwise=base.valid_otherwise,
        sensed_rms_g=float(sensed_rms), axis_rms_g=tuple(float(rms) * float(x) for x in axis_frac),
        proof_mass_cov_g2=tuple(tuple(float(v) for v in row) for row in cov_b),
        cross_pass=through, cross_unpassed_g=cross_mean, cross_error_g=bound)


def _vec(v: Sequence[float] | NDArray[np.float64]) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in v) + ")"


def _excitation_summary(excitation: Excitation) -> dict[str, Any]:
    """What the conditions carry of the excitation: kind, per-axis rms per unit total rms, the
    coherences and phases at the breakpoints (random) or the direction (sine)."""
    if isinstance(excitation, TriaxialSine):
        d = excitation.to_dict()
        d.pop("rms_g")  # the levels are the rms
        return d
    d = excitation.to_dict()
    ms = excitation.axis_mean_square_g2
    d["axis_rms_fraction"] = [float(math.sqrt(x / excitation.mean_square_g2)) for x in ms]
    # the breakpoints are the shape's, scaled to each level: its own rms is not a level
    d["shape_grms"], d["shape_axis_grms"] = d.pop("grms"), d.pop("axis_grms")
    return d
