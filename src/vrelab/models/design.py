"""The system designer's inverse questions and the test planner's checks (physics §1.3, §1.4, physics §4).

* how much vibration fits in a VRE budget (:func:`max_rms_for_budget`);
* the largest sine that stays clear of the rails (:func:`max_sine_level_clear_of_rails`);
* the grms at which Gaussian peaks reach over-range protection (:func:`grms_at_peak_threshold`)
  and the VRE the protection adds (:func:`overrange_vre`);
* a VRE as a tilt error (:func:`tilt_error_deg`); the fixture rule (:func:`fixture_resonance_ok`).
"""

from __future__ import annotations

import math
from typing import Sequence, TypedDict, Unpack, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _keywords, _validate
from vrelab.models.clipping import Kind, Shape, mean_shift, sine_on_random_mean_shift
from vrelab.models.dynamics import rice_upcrossing_rate
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.models.nonlinearity import vre_poly


def clip_vre(
    mean_g: ArrayLike,
    sigma_g: ArrayLike,
    rail_low_g: ArrayLike,
    rail_high_g: ArrayLike,
    shape: Shape = "gaussian",
    kind: Kind = DEFAULT_CLIP_KIND,
    tone_peaks_g: Sequence[float] = (),
) -> NDArray[np.float64] | float:
    """VRE of rails [g]: the mean shift the vibration causes, referred to the vibration-off reading
    (physics §1.5; ``vrelab model clip`` prints it). ``mean_g`` and the rails broadcast with ``sigma_g``
    (a scalar ``mean_g`` and ``sigma_g`` with tones). Censored, 1 g rms Gaussian at μ = 2.5 g on
    ±2 g rails: -0.198 g, where the mean shift measured from μ is -0.698 g.

    ``mean_shift(μ, σ, L, U) - (clip(μ, L, U) - μ)`` (:func:`vrelab.models.clipping.mean_shift`,
    physics §1.1). A VRE is measured against the reading with the vibration off, which a static
    field ``μ`` beyond a rail already clips: the second term removes that static part, so the
    result is 0 at σ = 0 wherever ``μ`` is. ``μ`` is the static level *at the rails*: the
    static field plus any offset the sensor adds before them. With ``tone_peaks_g`` [g peak]
    the vibration is Gaussian (rms ``sigma_g``, a scalar) plus those sine tones
    (:func:`vrelab.models.clipping.sine_on_random_mean_shift`).

    Examples
    --------
    The article's Figure 1 (±2 g rails, 1 g field, 1 g rms), referred to the vibration-off reading:

    >>> from vrelab.models.design import clip_vre
    >>> print(f"{clip_vre(1.0, 1.0, -2.0, 2.0) * 1e3:.1f} mg")
    -82.9 mg
    """
    if len(tone_peaks_g):
        if shape != "gaussian":
            raise ValueError(f"tone_peaks_g ride on Gaussian vibration: shape must be 'gaussian', got {shape!r}")
        with_vibration = np.asarray(
            sine_on_random_mean_shift(float(np.asarray(mean_g)), float(np.asarray(sigma_g)), tone_peaks_g,
                                      float(np.asarray(rail_low_g)), float(np.asarray(rail_high_g)), kind))
    else:
        with_vibration = np.asarray(mean_shift(mean_g, sigma_g, rail_low_g, rail_high_g, shape=shape, kind=kind))
    # the vibration-off reading of bare rails, clip(μ) (vrelab.models.memoryless.vibration_off_reading
    # with no polynomial), broadcast over μ and the rails
    mu = np.asarray(mean_g, dtype=np.float64)
    out = with_vibration - (np.clip(mu, rail_low_g, rail_high_g) - mu)
    return out[()] if out.ndim == 0 else out


class IdealSensorOptions(TypedDict, total=False):
    """The keywords of :func:`ideal_vre_shares` and :func:`total_vre` after the polynomial:
    ``shape`` of the vibration and ``kind`` of clipping (:func:`vrelab.models.clipping.mean_shift`;
    defaults ``"gaussian"``, :data:`vrelab.models.kinds.DEFAULT_CLIP_KIND`) and the offset
    ``offset_g`` [g] added before the rails (default 0).

    Examples
    --------
    A sine of 1 g rms (1.41 g peak) on a 1 g field against ±2 g rails:

    >>> from vrelab.models.design import IdealSensorOptions, total_vre
    >>> opts: IdealSensorOptions = {"shape": "sine"}
    >>> print(f"{total_vre(1.0, 1.0, -2.0, 2.0, **opts) * 1e3:.2f} mg")
    -68.31 mg
    """

    shape: Shape
    kind: Kind
    offset_g: float


class BudgetSearchOptions(TypedDict, total=False):
    """The keywords of :func:`max_rms_for_budget` after the polynomial (its parameters' docs).

    Examples
    --------
    The largest sine a ±2 g sensor on a 1 g field takes within 1 mg of VRE:

    >>> from vrelab.models.design import BudgetSearchOptions, max_rms_for_budget
    >>> opts: BudgetSearchOptions = {"shape": "sine"}
    >>> print(f"{max_rms_for_budget(1e-3, 1.0, -2.0, 2.0, **opts):.2f} g rms")
    0.72 g rms
    """

    shape: Shape
    kind: Kind
    rms_max_g: float | None


class OverrangeOptions(TypedDict, total=False):
    """The keywords of :func:`overrange_vre` after ``value_g`` (its parameters' docs).

    Examples
    --------
    >>> from vrelab.models.design import OverrangeOptions
    >>> sorted(OverrangeOptions.__annotations__)
    ['held_mean_g', 'tone_freqs_hz', 'tone_peaks_g']
    """

    tone_peaks_g: Sequence[float]
    tone_freqs_hz: Sequence[float]
    held_mean_g: ArrayLike | None


def ideal_vre_shares(
    rms_g: ArrayLike,
    mean_g: float,
    rail_low_g: float,
    rail_high_g: float,
    k2_per_g: float = 0.0,
    k3_per_g2: float = 0.0,
    *legacy: object,
    **options: Unpack[IdealSensorOptions],
) -> tuple[NDArray[np.float64] | float, NDArray[np.float64] | float]:
    """(clipping, polynomial) VRE of an ideal sensor [g]: shares of one exact mean.

    The ideal sensor's chain (``vrelab.sensor`` preset ``ideal``): polynomial on the total input
    ``g0 + x``, then the offset, then the rails, with nothing between them, so its mean is the
    one memoryless map :func:`vrelab.models.memoryless.poly_clip_vre`. The polynomial share is
    :func:`vrelab.models.nonlinearity.vre_poly` (exact), the clipping share what the rails add
    to it: the convention :func:`vrelab.prediction.predict` follows for any sensor by walking its
    stages (the sweep's ``model`` points go through those stages, :func:`vrelab.prediction.memoryless_level`).

    ``shape``, ``kind`` and ``offset_g`` are keywords (:class:`IdealSensorOptions`); given by
    position, as before, they still work for one release with a ``DeprecationWarning``.

    Examples
    --------
    Clipping and k2 = 100 µg/g² (1e-4 /g) at 1 g rms on a 1 g field against ±2 g rails:

    >>> from vrelab.models.design import ideal_vre_shares
    >>> clip_g, poly_g = ideal_vre_shares(1.0, 1.0, -2.0, 2.0, k2_per_g=1e-4)
    >>> print(f"{clip_g * 1e3:.2f} mg, {poly_g * 1e3:.3f} mg")
    -83.04 mg, 0.100 mg
    """
    from vrelab.models.memoryless import poly_clip_vre

    o = cast(IdealSensorOptions, _keywords.merged("ideal_vre_shares", list(IdealSensorOptions.__annotations__),
                                                  legacy, options))
    shape, kind = o.get("shape", "gaussian"), o.get("kind", DEFAULT_CLIP_KIND)
    rms = np.asarray(_validate.non_negative("rms_g", rms_g), dtype=np.float64)
    poly = np.asarray(vre_poly(rms, k2_per_g, k3_per_g2, static_g=mean_g, shape=shape), dtype=np.float64)
    total = np.vectorize(lambda r: poly_clip_vre(mean_g, float(r), k2_per_g, k3_per_g2, 0.0,
                                                 offset_g=o.get("offset_g", 0.0), rail_low_g=rail_low_g,
                                                 rail_high_g=rail_high_g, shape=shape, kind=kind), otypes=[float])(rms)
    clip = total - poly
    return (clip[()] if clip.ndim == 0 else clip), (poly[()] if poly.ndim == 0 else poly)


def total_vre(
    rms_g: ArrayLike,
    mean_g: float,
    rail_low_g: float,
    rail_high_g: float,
    k2_per_g: float = 0.0,
    k3_per_g2: float = 0.0,
    *legacy: object,
    **options: Unpack[IdealSensorOptions],
) -> NDArray[np.float64] | float:
    """Clipping plus polynomial VRE of an ideal sensor [g]: the exact mean of the polynomial
    followed by the rails (:func:`ideal_vre_shares`, whose shares add up to it).

    ``shape``, ``kind`` and ``offset_g`` are keywords (:class:`IdealSensorOptions`); given by
    position, as before, they still work for one release with a ``DeprecationWarning``.

    Examples
    --------
    >>> from vrelab.models.design import total_vre
    >>> print(f"{total_vre(1.0, 1.0, -2.0, 2.0, k2_per_g=1e-4) * 1e3:.2f} mg")
    -82.94 mg
    """
    o = cast(IdealSensorOptions, _keywords.merged("total_vre", list(IdealSensorOptions.__annotations__), legacy,
                                                  options))
    clip, poly = ideal_vre_shares(rms_g, mean_g, rail_low_g, rail_high_g, k2_per_g, k3_per_g2, **o)
    return clip + poly


def max_rms_for_budget(
    budget_g: float,
    mean_g: float,
    rail_low_g: float,
    rail_high_g: float,
    k2_per_g: float = 0.0,
    k3_per_g2: float = 0.0,
    *legacy: object,
    **options: Unpack[BudgetSearchOptions],
) -> float:
    """Largest vibration rms whose |VRE| stays within ``budget_g`` at every lower level [g rms].

    Parameters
    ----------
    budget_g : float
        Allowed |VRE| > 0 [g].
    mean_g : float
        Static field along the axis g0 [g].
    rail_low_g, rail_high_g : float
        Rails [g] (±inf: none).
    k2_per_g, k3_per_g2 : float
        Nonlinearity [1/g, 1/g²] (VRC in µg/g² × 1e-6).
    shape, kind
        Vibration shape and clipping model (see :func:`vrelab.models.clipping.mean_shift`).
    rms_max_g : float, optional
        Upper end of the search; default 100 × the larger of the rail distances and 1 g.

    ``shape``, ``kind`` and ``rms_max_g`` are keywords (:class:`BudgetSearchOptions`); given by
    position, as before, they still work for one release with a ``DeprecationWarning``.

    Returns
    -------
    float
        The first rms at which |VRE| reaches the budget (rms_g at the crossing).

    Raises
    ------
    ValueError
        If |VRE| exceeds the budget with no vibration at all (mean outside the rails), or never
        reaches it up to ``rms_max_g``.

    Notes
    -----
    |VRE| is scanned on a log grid from 1e-9 g to ``rms_max_g`` up to the first grid point over
    budget, and the crossing is refined by ``scipy.optimize.brentq`` between that point and the
    one before, where |VRE| is monotone. Scanning first matters: with a nonlinearity of the
    opposite sign to the clipping shift, |VRE| can rise, fall through zero and rise again, and
    the designer wants the first crossing.

    Examples
    --------
    The largest vibration a ±2 g sensor on a 1 g field takes within 1 mg of VRE:

    >>> from vrelab.models.design import max_rms_for_budget
    >>> print(f"{max_rms_for_budget(1e-3, 1.0, -2.0, 2.0):.2f} g rms")
    0.41 g rms
    """
    o = cast(BudgetSearchOptions, _keywords.merged("max_rms_for_budget", list(BudgetSearchOptions.__annotations__),
                                                   legacy, options))
    shape, kind, rms_max_g = o.get("shape", "gaussian"), o.get("kind", DEFAULT_CLIP_KIND), o.get("rms_max_g")
    budget = _validate.positive_scalar("budget_g", budget_g)
    mu = _validate.finite_scalar("mean_g", mean_g)

    def excess(rms: float) -> float:
        return abs(float(total_vre(rms, mu, rail_low_g, rail_high_g, k2_per_g, k3_per_g2, shape=shape,
                                   kind=kind))) - budget

    if not rail_low_g < mu < rail_high_g or excess(0.0) >= 0:
        raise ValueError(
            f"budget_g={budget_g!r} is already exceeded with no vibration (mean_g={mean_g!r} "
            f"outside the rails [{rail_low_g!r}, {rail_high_g!r}])"
        )
    if rms_max_g is None:
        finite_rails = [abs(r - mu) for r in (rail_low_g, rail_high_g) if math.isfinite(r)]
        rms_max_g = 100.0 * max([1.0, *finite_rails])
    top = _validate.positive_scalar("rms_max_g", rms_max_g)
    grid = np.geomspace(1e-9, top, 400)
    ex = np.abs(np.asarray(total_vre(grid, mu, rail_low_g, rail_high_g, k2_per_g, k3_per_g2, shape=shape,
                                     kind=kind))) - budget
    over = np.flatnonzero(ex >= 0)
    if over.size == 0:
        raise ValueError(f"budget_g={budget_g!r} is never reached for rms up to {top:g} g")
    i = over[0]
    lo = grid[i - 1] if i > 0 else 0.0
    from scipy import optimize  # here: scipy.optimize costs 0.3 s to import, the other questions need none

    return float(optimize.brentq(excess, lo, grid[i], xtol=1e-15, rtol=1e-13))


def max_sine_level_clear_of_rails(
    static_g: float, rail_low_g: float, rail_high_g: float, gain: float = 1.0
) -> float:
    """Largest sine rms (at the input) whose peaks stay within the rails [g rms] (physics §4).

    Parameters
    ----------
    static_g : float
        Static field g0 [g] along the axis.
    rail_low_g, rail_high_g : float
        Rails L < U [g].
    gain : float
        |H(f)| between the input and the rail at the test frequency (the proof-mass
        amplification |H| of :func:`vrelab.models.dynamics.second_order_response` for a rail at
        the proof mass, times the filters' gain for a rail at the output). DC passes with gain
        1, so g0 is not scaled.

    Returns
    -------
    float
        rms = min(U - g0, g0 - L)/(gain·√2): the amplitude at the rail is gain·A.

    Examples
    --------
    A 1 g field leaves 1 g of headroom under a +2 g rail: a sine of 1 g peak, 0.707 g rms.

    >>> from vrelab.models.design import max_sine_level_clear_of_rails
    >>> print(f"{max_sine_level_clear_of_rails(1.0, -2.0, 2.0):.3f} g rms")
    0.707 g rms
    """
    g0 = _validate.finite_scalar("static_g", static_g)
    lo = _validate.finite_scalar("rail_low_g", rail_low_g)
    hi = _validate.finite_scalar("rail_high_g", rail_high_g)
    k = _validate.positive_scalar("gain", gain)
    if not lo < g0 < hi:
        raise ValueError(f"static_g={static_g!r} must lie strictly between the rails [{rail_low_g!r}, {rail_high_g!r}]")
    return min(hi - g0, g0 - lo) / (k * math.sqrt(2.0))


def grms_at_peak_threshold(threshold_g: float, static_g: float = 0.0, crest_factor: float = 3.0) -> float:
    """grms at which a Gaussian drive's peaks (crest factor × rms) reach a threshold [g rms].

    σ = (T - |g0|)/CF: the peaks on the side of the static field reach T first (physics §1.3, §4).
    ADXL355 on ±2 g: T ≈ 8 g, g0 = 1 g, CF = 3 → 2.33 g rms (the article: "above about
    2.5 g rms" the data leave the clipping model).

    Examples
    --------
    An 8 g over-range threshold on a 1 g field, peaks at 3σ:

    >>> from vrelab.models.design import grms_at_peak_threshold
    >>> print(f"{grms_at_peak_threshold(8.0, 1.0):.3f} g rms")
    2.333 g rms
    """
    t = _validate.positive_scalar("threshold_g", threshold_g)
    g0 = _validate.finite_scalar("static_g", static_g)
    cf = _validate.positive_scalar("crest_factor", crest_factor)
    if abs(g0) >= t:
        raise ValueError(f"static_g={static_g!r} is already at or beyond threshold_g={threshold_g!r}")
    return (t - abs(g0)) / cf


def overrange_trip_rate_hz(
    threshold_g: ArrayLike,
    mean_g: ArrayLike,
    sigma_g: ArrayLike,
    nu0_hz: ArrayLike,
    tone_peaks_g: Sequence[float] = (),
    tone_freqs_hz: Sequence[float] = (),
) -> NDArray[np.float64] | float:
    r"""Expected over-range trips per second of Gaussian motion N(mean, σ²) [Hz] (physics §1.3).

    ``ν = ν⁺(+T) + ν⁻(-T)``: up-crossings of +T plus down-crossings of -T (the latter are the
    up-crossings of +T by the mirrored motion), each Rice's
    ``ν0·exp(-(T ∓ μ)²/(2σ²))`` (:func:`~vrelab.models.dynamics.rice_upcrossing_rate`).

    With sine tones (``tone_peaks_g`` [g peak] at ``tone_freqs_hz``, scalar inputs) the motion
    is the Gaussian part plus the tones' sum s(t), a deterministic mean for given phases. Rice's
    crossing formula [1] for a Gaussian process with a moving mean: x and ẋ are independent
    Gaussians (a stationary G and its derivative are uncorrelated at one instant), x ~ N(μ + s,
    σ²), ẋ ~ N(ṡ, σ̇²) with σ̇ = 2π·ν0·σ, so

    .. math:: ν^+(T) = E_θ\left[\frac{φ(z)}{σ}\,\left(ṡ\,Φ(ṡ/σ̇) + σ̇\,φ(ṡ/σ̇)\right)\right],
              \quad z = \frac{T - μ - s}{σ},

    the time average taken as the average over the tones' independent uniform phases
    (:mod:`vrelab.models.tones`); ν⁻(-T) is the same with μ, s, ṡ negated. Without tones it is
    Rice's ν0·exp(-z²/2). Held against crossings counted on simulated records in the tests.

    References
    ----------
    .. [1] S. O. Rice, "Mathematical analysis of random noise", Bell Syst. Tech. J. 23 (1944),
       §3.3: expected number of crossings ∫|ẋ| p(T, ẋ) dẋ.

    Examples
    --------
    2 g rms on a 1 g field against a 6 g threshold, 1 kHz mean-crossing rate:

    >>> from vrelab.models.design import overrange_trip_rate_hz
    >>> print(f"{overrange_trip_rate_hz(6.0, 1.0, 2.0, 1000.0):.2f} trips/s")
    46.12 trips/s
    """
    t = _validate.positive("threshold_g", threshold_g)
    mu = _validate.finite("mean_g", mean_g)
    if not len(tone_peaks_g):
        out = np.asarray(rice_upcrossing_rate(t, mu, sigma_g, nu0_hz) + rice_upcrossing_rate(t, -mu, sigma_g, nu0_hz),
                         dtype=np.float64)
        return out[()] if out.ndim == 0 else out
    from scipy import special

    from vrelab.models.tones import phase_grid

    if len(tone_freqs_hz) != len(tone_peaks_g):
        raise ValueError(f"tone_freqs_hz must give one frequency per tone, got {len(tone_freqs_hz)} for "
                         f"{len(tone_peaks_g)} tones")
    thr, m0 = float(t), float(mu)
    sigma = _validate.positive_scalar("sigma_g", sigma_g)
    sigma_dot = 2.0 * math.pi * _validate.positive_scalar("nu0_hz", nu0_hz) * sigma
    freqs = _validate.positive("tone_freqs_hz", np.asarray(tone_freqs_hz, dtype=np.float64))
    peaks = _validate.non_negative("tone_peaks_g", np.asarray(tone_peaks_g, dtype=np.float64))
    grid = phase_grid(list(peaks), sigma)
    s, ds = grid.sum_of(peaks), grid.slope_of(peaks, freqs)

    def upcrossings(level: NDArray[np.float64], slope: NDArray[np.float64]) -> float:
        density = np.exp(-0.5 * (level / sigma) ** 2) / (sigma * math.sqrt(2.0 * math.pi))
        r = slope / sigma_dot
        mean_positive_slope = slope * special.ndtr(r) + sigma_dot * np.exp(-0.5 * r * r) / math.sqrt(2.0 * math.pi)
        return float(np.mean(density * mean_positive_slope))

    return upcrossings(thr - m0 - s, ds) + upcrossings(thr + m0 + s, -ds)


def overrange_vre(
    mean_g: ArrayLike,
    sigma_g: ArrayLike,
    threshold_g: ArrayLike,
    hold_s: ArrayLike,
    nu0_hz: ArrayLike,
    value_g: ArrayLike = 0.0,
    *legacy: object,
    **options: Unpack[OverrangeOptions],
) -> NDArray[np.float64] | float:
    r"""Estimated extra VRE from over-range protection [g] (physics §1.3).

    Parameters
    ----------
    mean_g : array_like
        Static field g0 [g].
    sigma_g : array_like
        rms of the proof-mass motion (after the resonance) [g].
    threshold_g : array_like
        Protection threshold T > 0 [g]; it trips above +T and below -T (ADXL355: ≈ 8 g on the
        ±2 g range, 16 g on ±4/±8 g, ±25 %).
    hold_s : array_like
        How long the output is held after a trip [s] (ADXL355: 0.5 ms).
    nu0_hz : array_like
        Mean up-crossing rate of the motion, √(m2/m0) [Hz]
        (:func:`vrelab.models.dynamics.zero_crossing_rate_hz`).
    value_g : array_like
        What the output reads while held [g] (0: "floats toward zero"; the ADXL354 goes to
        mid-scale, also 0 g).
    tone_peaks_g, tone_freqs_hz : sequence of float
        Sine tones on the Gaussian motion (sine-on-random) [g peak, Hz]: the trip rate is then
        the phase-averaged Rice rate of :func:`overrange_trip_rate_hz`.
    held_mean_g : array_like, optional
        Mean of the motion over the stretches the holds replace [g]
        (:func:`overrange_held_mean_g`); default ``mean_g`` (the static field: too small where
        the holds start beyond the threshold, by half on the ADXL355 X at ±8 g, 4 g rms).

    The parameters after ``value_g`` are keywords (:class:`OverrangeOptions`); given by position,
    as before, they still work for one release with a ``DeprecationWarning``.

    Returns
    -------
    numpy.ndarray or float
        VRE_or ≈ p·(value_g - held_mean_g) [g].

    Notes
    -----
    Trips arrive at the Rice rate ν = ν⁺(+T) + ν⁻(-T) (up-crossings of +T plus down-crossings of
    -T, :func:`~vrelab.models.dynamics.rice_upcrossing_rate`). Treating them as a Poisson
    stream and the hold as re-triggered by every trip, the output is held when a trip fell in
    the last ``hold_s``: p = 1 - exp(-ν·hold). During the hold the output reads ``value_g``
    instead of the motion, whose mean over those stretches is ``held_mean_g``.

    This is an **estimate**: it assumes Gaussian proof-mass motion, takes crossings as
    independent (ignores the clustering of crossings within one excursion and the correlation of
    re-triggering with the motion), and ignores the transient as the output floats.

    Examples
    --------
    The same motion held at 0 g for 1 ms after each trip:

    >>> from vrelab.models.design import overrange_vre
    >>> print(f"{overrange_vre(1.0, 2.0, 6.0, 1e-3, 1000.0) * 1e3:.2f} mg")
    -45.08 mg
    """
    o = cast(OverrangeOptions, _keywords.merged("overrange_vre", list(OverrangeOptions.__annotations__), legacy,
                                                options))
    held_mean_g = o.get("held_mean_g")
    mu = _validate.finite("mean_g", mean_g)
    hold = _validate.non_negative("hold_s", hold_s)
    v = _validate.finite("value_g", value_g)
    held = mu if held_mean_g is None else _validate.finite("held_mean_g", held_mean_g)
    nu = overrange_trip_rate_hz(threshold_g, mu, sigma_g, nu0_hz, o.get("tone_peaks_g", ()), o.get("tone_freqs_hz", ()))
    p = -np.expm1(-nu * hold)
    out = np.asarray(p * (v - held), dtype=np.float64)
    return out[()] if out.ndim == 0 else out


def overrange_held_mean_g(
    mean_g: float,
    sigma_g: float,
    threshold_g: float,
    hold_s: float,
    nu0_hz: float,
    rho_mean: float,
    one_minus_rho_hold: float,
) -> float:
    r"""Mean of the Gaussian proof-mass motion over the stretches an over-range hold replaces [g].

    A retriggered hold covers an excursion beyond ±T and ``hold_s`` after it. That stretch is
    not a typical one: it starts beyond the threshold, and the motion after the crossing is
    correlated with it. Its mean, for one trip at +T (Gaussian motion N(μ, σ²), correlation
    ρ(τ), Rice's conditioning on a crossing [1]: x and ẋ independent, the slope at a down-crossing
    distributed as ``|v|·φ(v/σ̇)``, mean ``-σ̇·sqrt(π/2)``, ``σ̇ = 2π·ν0·σ``):

    * during the excursion (mean duration ``d = P(x > T)/ν⁺``): ``E[x | x > T] = μ + σ·φ(z)/Q(z)``;
    * during ``[b, b + hold]`` after the down-crossing at b:
      ``E[x(b + τ)] = μ + (T - μ)·ρ(τ) + E[v]·σ²·(-ρ'(τ))/σ̇²``, averaged over τ:
      ``μ + (T - μ)·ρ̄ - sqrt(π/2)·(σ²/σ̇)·(1 - ρ(hold))/hold``, ``ρ̄ = (1/hold)∫ρ dτ``;

    weighted by duration, and the trips at -T (mirror image) weighted by their Rice rates.
    ``rho_mean`` is ρ̄ and ``one_minus_rho_hold`` is ``1 - ρ(hold)``, both from the motion's
    spectrum (``ρ̄ = ∫S·|H|²·sinc(2f·hold)df/σ²``, ``1 - ρ(h) = ∫S·|H|²·(1 - cos 2πfh)df/σ²``).

    Assumes non-overlapping holds (a trip during a hold extends it: clustered crossings of a
    narrow-band motion are not modelled), and Gaussian motion. ADXL355 X, ±8 g range (T = 16 g),
    4 g rms 50-2000 Hz at +1 g: 1.87 g rather than the static 1 g.

    References
    ----------
    .. [1] S. O. Rice, "Mathematical analysis of random noise", Bell Syst. Tech. J. 23 (1944), §3.3;
       M. R. Leadbetter, G. Lindgren, H. Rootzén, *Extremes and related properties of random
       sequences and processes* (1983), ch. 10 (the Palm distribution of the slope at a crossing).

    Examples
    --------
    2 g rms on a 1 g field against a 6 g threshold, 1 kHz mean-crossing rate, held 1 ms, a hold
    far longer than the motion's correlation time (ρ̄ = 0, ρ(hold) = 0): the held stretches
    average more than the static 1 g.

    >>> from vrelab.models.design import overrange_held_mean_g
    >>> print(f"{overrange_held_mean_g(1.0, 2.0, 6.0, 1e-3, 1000.0, 0.0, 1.0):.3f} g")
    1.316 g
    """
    mu = _validate.finite_scalar("mean_g", mean_g)
    sigma = _validate.positive_scalar("sigma_g", sigma_g)
    t = _validate.positive_scalar("threshold_g", threshold_g)
    hold = _validate.positive_scalar("hold_s", hold_s)
    sigma_dot = 2.0 * math.pi * _validate.positive_scalar("nu0_hz", nu0_hz) * sigma
    from scipy import special

    weight = total = 0.0
    for sign in (1.0, -1.0):  # +T, then -T as +T of the mirrored motion
        m = sign * mu
        z = (t - m) / sigma
        rate = math.exp(-0.5 * z * z)  # ∝ Rice's ν⁺ (ν0 cancels in the weights)
        if rate == 0.0:
            continue
        tail = float(special.ndtr(-z))
        d = tail / (rate * float(nu0_hz))  # mean excursion duration [s]
        above = m + sigma * math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi) / tail if tail > 0 else t
        after = m + (t - m) * rho_mean - math.sqrt(math.pi / 2.0) * sigma**2 / sigma_dot * one_minus_rho_hold / hold
        stretch = (d * above + hold * after) / (d + hold)
        weight += rate
        total += rate * sign * stretch
    return total / weight if weight > 0 else mu


def tilt_error_deg(vre_g: ArrayLike, tilt_deg: ArrayLike = 0.0) -> NDArray[np.float64] | float:
    """A VRE as an inclinometer's tilt error [deg] (physics §4).

    An axis at tilt θ reads g·sin θ, so an offset δ [g] reads as Δθ ≈ δ/cos θ radians
    (first order in δ), reported in degrees. 1 mg at θ = 0 is 0.0573°.

    Examples
    --------
    A VRE of -10 mg on an inclinometer at 0° tilt:

    >>> from vrelab.models.design import tilt_error_deg
    >>> print(f"{tilt_error_deg(-0.010):.3f} deg")
    -0.573 deg
    """
    d = _validate.finite("vre_g", vre_g)
    th = np.radians(_validate.finite("tilt_deg", tilt_deg))
    if (np.abs(np.cos(th)) < 1e-12).any():
        raise ValueError(f"tilt_deg must be away from ±90 deg (the tilt is unobservable there), got {tilt_deg!r}")
    out = np.degrees(d / np.cos(th))
    return out[()] if np.ndim(out) == 0 else out


# Within this of ±1 g the axis is near vertical: a tilt barely changes its reading
# (d(asin g)/dg = 1/sqrt(1 - g²) → ∞), so a VRE has no meaningful tilt there.
NEAR_VERTICAL_G = 1e-3


def tilt_error_from_static_deg(vre_g: float, static_g: float) -> float:
    """A VRE as the tilt error of an inclinometer axis at tilt ``asin(g0)`` [deg] (physics §1.5).

    The axis reads ``g0 = sin θ`` with no vibration and ``g0 + δ`` with it, which it takes for
    the tilt ``asin(g0 + δ)``: the error is ``asin(g0 + δ) - asin(g0)`` (≈ δ/cos θ). 1 mg is
    0.0573° on a horizontal axis (g0 = 0) and 0.1318° at g0 = 0.9 g.

    Raises
    ------
    ValueError
        Where it is undefined: ``g0`` or ``g0 + δ`` beyond ±1 g, or within ``NEAR_VERTICAL_G``
        (1 mg) of ±1 g, where the axis is vertical and a tilt barely moves its reading.

    Examples
    --------
    The same -10 mg on an axis reading 0.5 g (30° tilt):

    >>> from vrelab.models.design import tilt_error_from_static_deg
    >>> print(f"{tilt_error_from_static_deg(-0.010, 0.5):.3f} deg")
    -0.659 deg
    """
    d = _validate.finite_scalar("vre_g", vre_g)
    g0 = _validate.finite_scalar("static_g", static_g)
    for name, g in (("the static field", g0), ("the reading with vibration", g0 + d)):
        if abs(g) > 1.0 - NEAR_VERTICAL_G:
            where = "beyond ±1 g" if abs(g) > 1.0 else (
                "within 1 mg of ±1 g (the axis is vertical: a tilt barely moves its reading)")
            raise ValueError(f"{name} ({g:.6g} g) is {where}: no tilt corresponds to it")
    return math.degrees(math.asin(g0 + d) - math.asin(g0))


def fixture_resonance_ok(fixture_fn_hz: float, f_max_hz: float, factor: float = 1.5) -> bool:
    """True when the fixture's lowest resonance is at least ``factor`` × the highest test
    frequency (the article's rule: >= 1.5×), so the fixture does not add its own amplification.

    Examples
    --------
    >>> from vrelab.models.design import fixture_resonance_ok
    >>> fixture_resonance_ok(3500.0, 2000.0), fixture_resonance_ok(2500.0, 2000.0)
    (True, False)
    """
    fn = _validate.positive_scalar("fixture_fn_hz", fixture_fn_hz)
    fmax = _validate.positive_scalar("f_max_hz", f_max_hz)
    k = _validate.positive_scalar("factor", factor)
    return fn >= k * fmax
