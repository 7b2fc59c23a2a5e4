"""Identification's model of a level (:func:`vrelab.prediction.predict` at its conditions) and what
the campaign can determine (the plan before the fit, the checks after it, the resonance's
profile likelihood)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.campaigns import (
    SAME_ORIENTATION_G,  # static fields closer than this are one orientation
)
from vrelab.gum import MAX_REL_U
from vrelab.identification.observation import Observation, apparent_vrc, drive_equivalent
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.profiles import RandomProfile
from vrelab.results import group_by_frequency
from vrelab.sensor.parameters import parameter

if TYPE_CHECKING:
    from vrelab.prediction import Prediction
    from vrelab.sensor.loader import Sensor


# A rail or the over-range threshold is determined when its share of the VRE, summed in
# quadrature over the levels in units of their standard uncertainty, reaches this.
REACH_SIGMA = 3.0
# The highest sine frequency must reach this fraction of fn for Q (and fn) to be determined:
# below it |H|² ≈ 1 + (2 - 1/Q²)·r², and only that one combination of fn and Q shows.
NEAR_FN = 0.5
# fn or Q with a relative standard uncertainty beyond vrelab.gum.MAX_REL_U is not determined
# (the one threshold: a report says a fitted parameter is "not determined" by it too).
# fn or Q whose profile-likelihood u exceeds the fit's local one by this factor take the profile's.
_WIDER = 1.3
# Parameters that stay free when not determined (see post_checks).
NUISANCE = ("fn_hz", "q")


def model_levels(sensor: Sensor, ob: Observation, kind: ClipKind = DEFAULT_CLIP_KIND) -> Prediction:
    """:func:`vrelab.prediction.predict` at the observation's conditions (its levels' rms).

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
    >>> from vrelab.identification.model import model_levels
    >>> sensor = vrelab.load_sensor("ideal", range_g=2, k2_ug_per_g2=100, k3_ug_per_g3=10)
    >>> print([f"{level.vre_g * 1e6:.2f}" for level in model_levels(sensor, obs[0]).levels])
    ['5.20', '20.80', '46.80']
    """
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

        # each level rebuilt once, at its own rms (one replace a level: the fit's inner loop)
        return dataclasses.replace(at, levels=tuple(dataclasses.replace(
            a, vre_g=line(a.vre_g, b.vre_g, float(tk)),
            shares={k: line(v, b.shares.get(k, v), float(tk)) for k, v in a.shares.items()}, rms_g=float(r))
            for a, b, tk, r in zip(at.levels, moved.levels, t, ob.rms_g)))
    return dataclasses.replace(at, levels=tuple(dataclasses.replace(lv, rms_g=float(r))
                                                for lv, r in zip(levels, ob.rms_g)))


def model_runs(sensor: Sensor, obs: Sequence[Observation], kind: ClipKind) -> list[Prediction]:
    """:func:`model_levels` of each observation: the model's prediction of every run.

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
    >>> from vrelab.identification.model import model_runs
    >>> sensor = vrelab.load_sensor("ideal", range_g=2, k2_ug_per_g2=100, k3_ug_per_g3=10)
    >>> [f"{p.levels[-1].vre_g * 1e6:.2f}" for p in model_runs(sensor, obs, "censored")]
    ['46.80', '25.20']
    """
    return [model_levels(sensor, ob, kind) for ob in obs]


def _orientations(obs: Sequence[Observation]) -> list[float]:
    out: list[float] = []
    for g in sorted(ob.static_g for ob in obs):
        if not out or g - out[-1] >= SAME_ORIENTATION_G:
            out.append(g)
    return out


def _sine_frequencies(obs: Sequence[Observation]) -> list[float]:
    fs = [ob.freq_hz for ob in obs if ob.method == "sine" and ob.freq_hz]
    return [g[0] for g in group_by_frequency(fs, float)]


def plan_parameters(obs: Sequence[Observation], base: Sensor) -> tuple[list[str], dict[str, str]]:
    """Which parameters the data can determine before fitting, and why the others cannot.

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg: two orientations determine k2 and k3; one frequency cannot
    determine a resonance.

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.model import plan_parameters
    >>> free, reasons = plan_parameters(obs, base)
    >>> free
    ['k2_ug_per_g2', 'k3_ug_per_g3']
    >>> print(reasons["fn_hz"])
    sine runs at one frequency only (80 Hz): VRC(f) has no shape
    """
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


@dataclass
class Findings:
    """What :func:`post_checks` finds about fn and Q beyond the reasons, per parameter.

    Examples
    --------
    >>> from vrelab.identification.model import Findings
    >>> Findings()
    Findings(bounds={}, widen={}, loose={})
    """

    # only bounded: (its standard u from the profile, the reason, the bound's middle or None)
    bounds: dict[str, tuple[float, str, float | None]] = field(default_factory=dict)
    # the factor by which its covariance row and column are to be scaled (a non-quadratic likelihood)
    widen: dict[str, float] = field(default_factory=dict)
    # a note: its ±1σ interval closes but its 95 % one does not
    loose: dict[str, str] = field(default_factory=dict)


def post_checks(values: Mapping[str, float], cov: Mapping[str, float], free: Sequence[str], preds: Sequence[Prediction],
                obs: Sequence[Observation], base: Sensor | None = None, prefer_base: bool = False,
                found: Findings | None = None) -> dict[str, str]:
    """Parameters the fit freed that the fitted model shows the data do not determine.

    fn and Q stay in the fit as nuisance parameters when every sine frequency lies on one side
    of the fitted fn (or below ``NEAR_FN``·fn): VRC(f) then shows a flank, not the peak, and
    the local covariance of fn and Q is a confident wrong number (three frequencies below a
    1200 Hz fn gave Q 2.69 ± 0.15 for 4). Their reason gives the bound the data do support
    (:func:`_resonance_profile`, Δχ² <= 4), and ``found.bounds`` receives, per parameter, a standard
    uncertainty from the profile (Δχ² <= 1, half its width) for the sensor file. fn and Q seen
    on both flanks but with a relative u above ``MAX_REL_U`` are kept, value and u (a poorly
    known Q is still a resonance near fn), unless ``prefer_base``; where the profile's Δχ² <= 1
    half-width exceeds what the same profile's curvature at its bottom says by ``_WIDER`` (a
    non-quadratic likelihood), ``found.widen`` receives that ratio, by which the covariance's row and
    column are to be scaled; where the profile does not close, fn and Q are bounded (Q 2.0 ± 0.6
    for a true 6 on three frequencies far from fn was such a case). A rail or the threshold
    that the levels do not reach is fixed at the base sensor's value and the rest refitted (it
    shapes nothing the data see).

    Examples
    --------
    Two sine runs at one frequency (80 Hz) leave no resonance in the fit: with only k2 and k3
    freed, nothing the fit freed is found undetermined.

    >>> import numpy as np
    >>> import vrelab
    >>> from vrelab.identification.model import model_runs, post_checks
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> sensor = vrelab.load_sensor("ideal", range_g=2, k2_ug_per_g2=100, k3_ug_per_g3=10)
    >>> values = {"k2_ug_per_g2": 100.0, "k3_ug_per_g3": 10.0}
    >>> cov = {"k2_ug_per_g2": 3.57**2, "k3_ug_per_g3": 1.19**2}
    >>> post_checks(values, cov, list(values), model_runs(sensor, obs, "censored"), obs)
    {}
    """
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
            # one flank: neither is a value (once: Q 2.69 ± 0.15 for 4 from three frequencies below fn); both
            # flanks but an open profile: the open one only (a well-bounded fn stays identified)
            for n, label in (("fn_hz", "fn"), ("q", "Q")):
                if one_sided or prof[n].open:
                    lead = head if one_sided or not head.endswith(" of") else f"{head} {label}"
                    why[n] = f"{lead}; the data bound {label} to {prof[n].text} (Δχ² <= 4), not its value"
                    if found is not None:  # open: the interval's middle; closed (one flank): the fit's value
                        found.bounds[n] = (prof[n].u, why[n], prof[n].value)
        else:
            if found is not None:  # the fit's u read off a curvature where the likelihood is not quadratic
                for n in ("fn_hz", "q"):
                    if prof[n].ratio > _WIDER:
                        found.widen[n] = prof[n].ratio
            for n, label in (("fn_hz", "fn"), ("q", "Q")):
                if prof[n].open95 and found is not None:
                    found.loose[n] = (f"{n}: its ±1σ interval closes but its 95 % one does not ({prof[n].text}, Δχ² <= 4 on the "
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


def vrc_data(sines: Sequence[Observation]) -> tuple[NDArray[np.float64], ...]:
    """The sine runs' apparent VRCs, their u, frequencies and static fields, as arrays.

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
    >>> from vrelab.identification.model import vrc_data
    >>> vrc, u, freq, g0 = vrc_data(obs)
    >>> print(vrc.round(6), freq, g0)
    [130.  70.] [80. 80.] [ 1. -1.]
    """
    vrc, u = (np.array(a) for a in zip(*(apparent_vrc(ob) for ob in sines)))
    return vrc, u, np.array([ob.freq_hz for ob in sines]), np.array([vrc_static_g(ob) for ob in sines])


def vrc_static_g(ob: Observation) -> float:
    """The static field a sine observation's apparent VRC belongs to: g0, or under a distorted
    drive g0 + Σ w·E[x²]·s / Σ w·E[x²] (:func:`drive_equivalent`'s s per level, w = 1/u², the
    weights of :func:`apparent_vrc`), so that VRC = (k2 + 3·k3·that)·|H(f)|² (as
    :func:`vrelab.fits.fit_vrc`'s ``static_shift_g``).

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.model import vrc_static_g
    >>> vrc_static_g(obs[1])
    -1.0
    """
    if not ob.drive:
        return ob.static_g
    rms, shift = drive_equivalent(ob)
    w = rms**4 / ob.u_g**2
    return ob.static_g + float(np.sum(w * shift) / np.sum(w))


def vrc_chi2(data: tuple[NDArray[np.float64], ...], k3_free: bool, k3_fixed: float,
              fn: float | None, q: float | None) -> tuple[NDArray[np.float64], float]:
    """k2 (and k3) by weighted linear least squares of the apparent VRCs (:func:`vrc_data`)
    at the response ``|H|²`` of (fn, Q) (flat without fn); and the χ² there.

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg: k2 and k3 come back, with χ² = 0.

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.model import vrc_chi2, vrc_data
    >>> k, chi2 = vrc_chi2(vrc_data(obs), True, 0.0, None, None)
    >>> print(k.round(6), f"{chi2:.6f}")
    [100.  10.] 0.000000
    """
    from vrelab.models.dynamics import vrc_at_frequency

    vrc, u, f, g0 = data
    h = np.asarray(vrc_at_frequency(1.0, f, fn, q)) if fn and q else np.ones_like(f)
    a = np.column_stack([h, 3 * g0 * h] if k3_free else [h]) / u[:, None]
    y = (vrc - (0.0 if k3_free else 3 * k3_fixed * g0 * h)) / u
    k, *_ = np.linalg.lstsq(a, y, rcond=None)
    r = a @ k - y
    return k.astype(np.float64, copy=False), float(r @ r)


def resonance_grid(sines: Sequence[Observation], n_fn: int = 60, n_q: int = 15) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """fn from a third of the lowest to ten times the highest sine frequency, Q from 0.5 to 50 (log).

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.model import resonance_grid
    >>> fn, q = resonance_grid(obs)
    >>> print(f"fn {fn.min():.1f}-{fn.max():.0f} Hz ({fn.size}), Q {q.min():.1f}-{q.max():.0f} ({q.size})")
    fn 26.7-800 Hz (60), Q 0.5-50 (15)
    """
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


def vrc_chi2_grid(data: tuple[NDArray[np.float64], ...], k3_free: bool, k3_fixed: float,
                   fn: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`vrc_chi2`'s χ² at every (fn, Q) of two broadcastable arrays at once: the weighted
    linear least squares for k2 (and k3) in closed form (normal equations of one or two
    unknowns), so a fine grid costs a few array operations instead of one lstsq per point.

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.model import resonance_grid, vrc_chi2_grid, vrc_data
    >>> fn, q = resonance_grid(obs)
    >>> chi2 = vrc_chi2_grid(vrc_data(obs), True, 0.0, fn[:, None], q[None, :])
    >>> chi2.shape
    (60, 15)
    """
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
    """Per fn and Q, the profile likelihood of the sine runs' apparent VRCs (:func:`vrc_chi2_grid`,
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
    data = vrc_data(sines)
    f = data[2]
    fns, qs = np.geomspace(f.min() / 3, 10 * f.max(), 700), np.geomspace(0.05, 1000, 300)
    chi = vrc_chi2_grid(data, k3_free, k3_fixed, fns[:, None], qs[None, :])
    # the valley is narrower than the grid's step where the data determine a parameter well: each
    # column's (row's) best point refined over its two neighbouring steps, 41 points
    t = np.linspace(-1.0, 1.0, 41)[:, None]
    i = np.clip(np.argmin(chi, axis=0), 1, fns.size - 2)
    fine_fn = fns[i] * (fns[1] / fns[0]) ** t  # (41, n_q)
    prof_q = vrc_chi2_grid(data, k3_free, k3_fixed, fine_fn, qs[None, :]).min(axis=0)
    j = np.clip(np.argmin(chi, axis=1), 1, qs.size - 2)
    fine_q = qs[j] * (qs[1] / qs[0]) ** t  # (41, n_fn)
    prof_fn = vrc_chi2_grid(data, k3_free, k3_fixed, fns[None, :], fine_q).min(axis=0)
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
        chi = vrc_chi2_grid(data, k3_free, k3_fixed, grid["fn_hz"][:, None], grid["q"][None, :])
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
