"""Analytic VRE of a sensor in a vibration environment, without simulating it.

The sensor is read through :meth:`vrelab.sensor.Sensor.stages`, the same tuple of stages the
simulation runs, walked in signal order: each stage that changes the mean gives its own change
(its ``mean_shift``, :mod:`vrelab.sensor.meanshift`), fed the vibration that reaches it through
the linear stages before it and the static level the offsets before it leave (physics §1.3), and
predict sums what they say:

* **nonlinearity** (:class:`~vrelab.sensor.stages.Polynomial`) on the proof-mass motion:
  ``E[P(g0 + x)] - P(g0)`` (physics §1.2), exact for any polynomial and any zero-mean vibration;
* **rails** (:class:`~vrelab.sensor.stages.Clip`) on what the polynomial puts out. With no
  filter between them (an ideal sensor, a proof-mass clip) polynomial and rails are one
  memoryless map whose mean :func:`vrelab.models.memoryless.poly_clip_vre` gives in closed
  form (Gaussian, sine, or the tones' phase average for sine-on-random): no approximation. With
  filters between (an output clip after the anti-alias and digital low-pass,
  ``σ_out² = ∫S·|H_mech·H_aa·H_lpf|²df``) the rails see the polynomial's mean and its linear
  part through the filters as a Gaussian; the rest (the higher Hermite terms, the harmonics)
  is bounded (``model_error_g``: ``r·sqrt(P_in·P_out) + r²·(pdf at the rails)``, r its rms
  through the filters);
* **over-range protection** (:class:`~vrelab.sensor.stages.OverRange`): Rice's up-crossing rate
  of the threshold by the Gaussian proof-mass motion times the hold time, the held stretches
  replacing motion whose mean is not g0 but :func:`vrelab.models.design.overrange_held_mean_g`
  (Rice's conditioning on the crossing), read through the rails after the holds (what those
  stretches would have read: the censored mean of a Gaussian of that mean and the rails' rms);
* noise, quantisation, decimation and drift shift no mean (their ``zero_mean_shift``); a
  memoryless stage with no closed form gets the mean of its map by quadrature
  (:func:`vrelab.models.memoryless.map_vre`, valid only as the one nonlinearity of the chain);
  a stage with memory and no closed form makes the prediction say so (``valid`` False).

Shares: each stage's change of the mean, in signal order, referred to the vibration-off
reading (``nonlinearity_g``, then what the rails add, ``clip_g``, and the holds,
``overrange_g``); they add up to ``vre_g``. ``clip_low_g``/``clip_high_g`` are each rail alone.

Validity: ``valid`` is False where ``model_error_g`` may exceed the stated u (``u_vre_g``, or
without one 1 % of |VRE|), where the over-range share is more than a tenth of the largest (the
held stretches are taken as not overlapping and their interaction with the rails after them
is not modelled), where the holds fill more than 5 % of the time, where a sine reaches the
over-range threshold, and where the static level is already at a rail. The random drive is
taken as Gaussian.

How close: the tests hold the memoryless map against a numpy Monte Carlo over static fields,
levels and coefficients (and adaptive quadrature for a resonant part with k2, k3 and
asymmetric rails: +9.14/+16.17 mg, tests/test_predict_exact.py), the filtered case against a numpy Monte Carlo of the chain within ``model_error_g``, and the
simulated test within 3u + 10 % (ADXL355 ±2 g Z at 1-2 g rms). Over-range firing often
(ADXL355 X at 4 g rms on ±8 g: -96 mg against the simulation's -110 ± 5 mg) is not valid.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab.models.clipping import KINDS
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.models.memoryless import REFERENCE
from vrelab.prediction._spectral import hold_correlation, spectral
from vrelab.prediction._stages import Reading, clip_position_of, needs_rate, read_stages, sensor_stages
from vrelab.prediction.checks import cancellation, judged, tilt_note
from vrelab.prediction.propagation import OFF_AXIS, propagation, unstated_check
from vrelab.prediction.results import LevelPrediction, Prediction
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.sensor.meanshift import (
    NUMERICAL_SHARE,
    SHARES,
    VRE_SHARES,
    Done,
    Drive,
    Motion,
    Response,
    Site,
    response_key,
)

if TYPE_CHECKING:
    from vrelab.sensor import Sensor




# Shares below this fraction of the largest one are "negligible" in the validity notes.
_MINOR = 0.1


# --- prediction ---------------------------------------------------------------------------------


def _gain(f_hz: float, responses: Sequence[Response]) -> float:
    """|H(f)| of the linear stages ``responses`` in series.

    Remembered by the exact frequency and the responses' identity where each is a frozen stage's
    (:func:`vrelab.sensor.meanshift.response_key`, the rule of the spectral integrals' memory): a
    fit predicts the same sine frequencies again and again through a resonance its step left as
    it was (a polynomial's or a rail's step, a level's second static field)."""
    keys = tuple(response_key(h) for h in responses)
    if isinstance(f_hz, float) and all(k is not None for k in keys):
        return _gain_of(f_hz, keys)
    return _gain_at(f_hz, responses)


@functools.lru_cache(maxsize=1024)
def _gain_of(f_hz: float, keys: tuple[tuple[Any, Any], ...]) -> float:
    """:func:`_gain_at` of the responses given as ``(function, stage)`` keys (cached, bounded)."""
    return _gain_at(f_hz, [f.__get__(owner) for f, owner in keys])


def _gain_at(f_hz: float, responses: Sequence[Response]) -> float:
    from vrelab.models.dynamics import rms_through

    return float(rms_through(f_hz, 1.0, list(responses)))


def _commensurate(freqs_hz: Sequence[float], largest: int = 4) -> list[tuple[float, float, int, int]]:
    """Pairs of tones whose frequencies stand in a ratio p:q with p, q <= ``largest`` (harmonics
    of one shaft): their relative phase is fixed in a machine, which the prediction averages."""
    out = []
    for i, fa in enumerate(freqs_hz):
        for fb in freqs_hz[i + 1:]:
            for q in range(1, largest + 1):
                p = round(fb / fa * q)
                if 1 <= p <= largest and math.isclose(fb * q, fa * p, rel_tol=1e-9) and math.gcd(p, q) == 1:
                    out.append((fa, fb, p, q))
                    break
    return out


def _check_time(sensor: Sensor, excitation: RandomProfile | SineOnRandom | float | Sequence[float],
                n_levels: int) -> None:
    """Refuse, before any level, a prediction beyond the time budget (:func:`vrelab._budget.check_prediction`,
    the simulation's budget): its levels, at each sine frequency, times the four predictions each
    parameter uncertainty costs the propagation (a lower bound: a Monte Carlo where the VRE is
    not linear costs more)."""
    from vrelab import _budget

    n_freqs = 1 if isinstance(excitation, (RandomProfile, SineOnRandom)) else int(np.size(excitation))
    cov = getattr(sensor, "covariance", None)
    n_u = len(getattr(sensor, "uncertainty", None) or {}) + (len(cov["params"]) if cov else 0)
    _budget.check_prediction(f"a prediction of {n_levels} levels" + (f" at {n_freqs} frequencies" if n_freqs > 1 else ""),
                             float(n_levels) * n_freqs * (1 + 4 * n_u))


def _random_levels(reading: Reading, excitation: RandomProfile, levels_arr: NDArray[np.float64], g0: float,
                   kind: ClipKind, points: list[float]) -> tuple[list[LevelPrediction], str, list[str]]:
    """Each level of a random drive (Gaussian): the spectral integrals at each site once, scaled
    to each level; the levels, the vibration's text and the notes."""
    notes: list[str] = []
    out: list[LevelPrediction] = []
    m0_drive = excitation.mean_square_g2
    # per unit drive mean square: σ²/m0 and ν0 at each site, at the proof mass and output
    # only the over-range site uses Rice's crossing rate
    seen = [spectral(excitation, site.responses, points, rate=needs_rate(site))
            for site in reading.sites]
    rho = [hold_correlation(excitation, site.responses, points, float(site.stage.hold_s), m0)
           if needs_rate(site) else (math.nan, math.nan)
           for site, (m0, _) in zip(reading.sites, seen)]
    m0_m, _ = spectral(excitation, reading.proof_mass, points, rate=False)
    m0_out, _ = spectral(excitation, reading.output, points, rate=False)
    for rms in levels_arr:
        scale = float(rms) ** 2 / m0_drive
        sites = [Motion(math.sqrt(m0 * scale), nu0, rho_mean=r[0], one_minus_rho_hold=r[1])
                 for (m0, nu0), r in zip(seen, rho)]
        out.append(_level(_Walk(reading, g0, kind, "gaussian"), float(rms), None, sites,
                          math.sqrt(m0_m * scale), math.sqrt(m0_out * scale)))
    text = excitation.describe().split(",")[0] + (f" ({excitation.name})" if excitation.name else "")
    notes.append("random drive assumed Gaussian (a clipped or high-kurtosis drive needs `simulate`)")
    return out, text, notes


def _sine_on_random_levels(reading: Reading, excitation: SineOnRandom, levels_arr: NDArray[np.float64], g0: float,
                           kind: ClipKind, points: list[float]) -> tuple[list[LevelPrediction], str, list[str]]:
    """Each level of a sine-on-random drive: the random part as a random drive and each tone
    through its own gain, scaled together; the levels, the vibration's text and the notes."""
    notes: list[str] = []
    out: list[LevelPrediction] = []
    rand, tones = excitation.random, excitation.tones
    freqs = tuple(t.freq_hz for t in tones)
    # per unit of the profile as given: (σ_r², ν0) of its random part and |H(f_i)| at each site
    seen_tones = [(spectral(rand, site.responses, points), [_gain(f, site.responses) for f in freqs])
            for site in reading.sites]
    # the held stretches' mean from the random part's correlation (the tones left out of it)
    rho = [hold_correlation(rand, site.responses, points, float(site.stage.hold_s), m0)
           if needs_rate(site) else (math.nan, math.nan)
           for site, ((m0, _), _) in zip(reading.sites, seen_tones)]
    m0_m, _ = spectral(rand, reading.proof_mass, points)
    m0_out, _ = spectral(rand, reading.output, points)
    gain_m = [_gain(f, reading.proof_mass) for f in freqs]
    gain_out = [_gain(f, reading.output) for f in freqs]
    motions: list[Motion] = []
    for rms in levels_arr:
        r = float(rms) / excitation.grms  # the scaling rule: PSD × r², tones × r

        def motion(m0: float, nu0: float, gains: Sequence[float], rh: tuple[float, float] = (math.nan, math.nan)
                   ) -> Motion:
            # noqa below: motion() is called within this iteration only, so r is the current level's
            return Motion(r * math.sqrt(m0), nu0, tuple(r * t.peak_g * g for t, g in zip(tones, gains)), freqs,  # noqa: B023
                           *rh)

        sites = [motion(m0, nu0, gains, rh) for ((m0, nu0), gains), rh in zip(seen_tones, rho)]
        motions += sites
        out.append(_level(_Walk(reading, g0, kind, "sine-on-random"), float(rms), None, sites,
                          motion(m0_m, 0.0, gain_m).rms_g, motion(m0_out, 0.0, gain_out).rms_g))
    text = excitation.describe().rsplit(",", 1)[0] + (f" ({excitation.name})" if excitation.name else "")
    notes.append("random part assumed Gaussian; tones with independent uniform phases (a random-phase "
                 "ensemble: the prediction is the average over the tones' phases)")
    for fa, fb, p, q in _commensurate(freqs):
        notes.append(f"tones at {fa:g} and {fb:g} Hz are harmonics of one frequency ({p}:{q}): a machine holds "
                     "their relative phase, and a fixed phase can move the clipping and odd-order shares away "
                     "from this phase average")
    from vrelab.models.tones import MAX_GRID, MC_DRAWS, nodes_per_tone

    if any(math.prod(nodes_per_tone(m.tone_peaks_g, m.sigma_g)) > MAX_GRID for m in motions):
        notes.append(f"several strong tones: phase averages by Monte Carlo over {MC_DRAWS} seeded draws "
                     "(standard error 0.2 % of their spread over the phases)")
    return out, text, notes


def _sine_levels(reading: Reading, excitation: float | Sequence[float], levels_arr: NDArray[np.float64], g0: float,
                 kind: ClipKind) -> tuple[list[LevelPrediction], str, list[str]]:
    """Each level at each sine frequency: ``rms·|H(f)|`` at each site; the levels, the
    vibration's text and the notes (none)."""
    notes: list[str] = []
    out: list[LevelPrediction] = []
    sine_hz = np.atleast_1d(V.positive("freq_hz", np.asarray(excitation, dtype=np.float64)))
    for f in sine_hz:
        f = float(f)
        # |H(f)| at each site, the proof mass and the output, once for every level: a sine's
        # rms there is rms·|H(f)| (vrelab.models.dynamics.rms_through, the same product)
        gains = [_gain(f, site.responses) for site in reading.sites]
        at_mass, at_out = _gain(f, reading.proof_mass), _gain(f, reading.output)
        for rms in levels_arr:
            sites = [Motion(float(rms) * g, f) for g in gains]
            out.append(_level(_Walk(reading, g0, kind, "sine"), float(rms), f, sites, float(rms) * at_mass,
                              float(rms) * at_out))
    text = "sine " + ", ".join(f"{f:g}" for f in sine_hz) + " Hz"
    return out, text, notes


def predict(
    sensor: Sensor,
    excitation: RandomProfile | SineOnRandom | float | Sequence[float],
    levels: Sequence[float] | NDArray[np.float64],
    static_g: float = 1.0,
    kind: ClipKind = DEFAULT_CLIP_KIND,
) -> Prediction:
    r"""Predict VRE at each vibration level, by mechanism, without simulating.

    Parameters
    ----------
    sensor : vrelab.sensor.Sensor
        Read through :meth:`~vrelab.sensor.Sensor.stages`, the same stages the simulation runs.
    excitation : RandomProfile, SineOnRandom, float or sequence of float
        A random profile (its shape is scaled to each level, Gaussian drive assumed), a
        sine-on-random profile (random part and tones scaled together to each level, the
        tones' rms included in it: :meth:`~vrelab.profiles.SineOnRandom.scaled_to`) or sine
        frequencies [Hz] (levels are then run at each frequency in turn).
    levels : sequence of float
        Vibration levels [g rms] of the drive (the reference accelerometer's rms), each > 0.
    static_g : float
        Static acceleration along the axis [g].
    kind : {"censored", "truncated"}
        Clipping model (physics §1.1); censored is what a saturating sensor does.

    Returns
    -------
    Prediction
        Per level: ``vre_g``, ``tilt_error_deg``, ``shares`` by mechanism, rms at the proof
        mass, output and clip, ``valid`` and ``notes``.

    Notes
    -----
    The stages are walked in order. A linear stage (resonance, anti-alias, low-pass,
    high-pass) shapes the vibration every later stage sees; an offset moves their static level;
    each stage with a closed form adds its mean shift, evaluated with the vibration ``H`` of the
    linear stages before it and the static level ``g0 + offsets`` before it. Random drive with
    PSD S(f): ``σ² = ∫S|H|²df`` (physics §1.3); sine at f, rms A/√2: ``σ = rms·|H(f)|``.
    Sine-on-random: the random part as a random drive (σ_r at each site) and each tone through
    its own gain, ``A_i·|H(f_i)|``; phases independent and uniform (random-phase ensemble).

    * polynomial: ``E[P(g0 + x)] - P(g0)`` (physics §1.2), exact
      (:func:`vrelab.models.memoryless.poly_clip_vre` without rails; with tones the average
      over their phases);
    * rails: with no linear stage between them and the polynomial, the exact mean of
      ``clip(P(g0 + x) + offset)`` (:func:`vrelab.models.memoryless.poly_clip_vre`) less the
      polynomial's share; with filters between, a Gaussian of mean ``P(g0) + offset +
      nonlinearity`` and rms ``gain·σ_clip`` (``gain`` the polynomial's best linear gain,
      :func:`vrelab.models.memoryless.linear_part`), the rest bounded in ``model_error_g``;
      each rail alone and both, referred to the vibration-off reading ``clip(P(g0) + offset)``;
    * over-range: :func:`vrelab.models.design.overrange_vre` ``(g0, σ, threshold, hold, ν0)``
      with ``ν0`` Rice's zero-crossing rate of the motion there and the held stretches' mean
      :func:`vrelab.models.design.overrange_held_mean_g` (with tones, Rice's rate for a
      Gaussian with the tones as a moving mean, averaged over their phases). A sine whose peak
      reaches the threshold trips every period: not modelled (``valid`` False). Where the
      over-range share is large against the others the Rice×hold estimate is rough and the
      level is not valid, for random and sine-on-random alike.
    * noise, quantisation, decimation, drift: no mean shift (each says why: ``zero_mean_shift``).
      A memoryless stage with no closed form: the mean of its map by quadrature
      (:func:`vrelab.models.memoryless.map_vre`, share ``numerical_g``, its error in
      ``model_error_g``), valid only as the chain's one nonlinearity. A stage with memory and no
      closed form makes every level invalid, naming it.

    Each stage owns its closed form (``mean_shift``, :mod:`vrelab.sensor.meanshift`); this
    function computes the vibration at each stage's site and sums what the stages say.

    References
    ----------
    .. [1] docs/physics.md §1.1-1.3 (after the ADI article on VRE in MEMS accelerometers).
    .. [2] S. O. Rice, "Mathematical analysis of random noise", Bell Syst. Tech. J. 23 (1944):
       up-crossing rate ``ν0·exp(-(a-μ)²/(2σ²))``.

    Examples
    --------
    The single-axis model behind :func:`vrelab.predict` (which chooses it for a vibration along the
    sensed axis): the ADXL355 at ±2 g, axis up, under a 2 g rms sine at 100 Hz, by mechanism.

    >>> import vrelab
    >>> from vrelab.prediction.single import predict
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> level = predict(sensor, 100.0, [2.0], static_g=1.0).levels[0]
    >>> print(f"VRE {level.vre_g * 1e3:.0f} mg: clipping {level.shares['clip_g'] * 1e3:.0f} mg, nonlinearity {level.shares['nonlinearity_g'] * 1e3:.2f} mg")
    VRE -440 mg: clipping -440 mg, nonlinearity 0.08 mg
    """
    levels_arr = V.vibration_level("levels", np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    if levels_arr.ndim != 1 or levels_arr.size == 0:
        raise ValueError(f"levels must be a non-empty list of rms values, got {levels!r}")
    g0 = V.finite_scalar("static_g", static_g)
    V.one_of("kind", kind, KINDS)
    _check_time(sensor, excitation, levels_arr.size)
    reading = read_stages(sensor_stages(sensor), g0)
    clip_where = clip_position_of(sensor)
    # the resonances (the proof mass's, the mount's) as breakpoints of the spectral quadrature
    points = [float(f) for f in (getattr(sensor, "fn_hz", None), getattr(sensor, "mount_fn_hz", None)) if f]
    if isinstance(excitation, RandomProfile):
        out, text, notes = _random_levels(reading, excitation, levels_arr, g0, kind, points)
    elif isinstance(excitation, SineOnRandom):
        out, text, notes = _sine_on_random_levels(reading, excitation, levels_arr, g0, kind, points)
    else:
        out, text, notes = _sine_levels(reading, excitation, levels_arr, g0, kind)
    notes.append(f"clip modelled at the {clip_where} ({kind}); nonlinearity and rails evaluated together as one "
                 "memoryless map (exact where no filter sits between them; else the rails see the polynomial's "
                 "linear part through the filters, its remainder bounded in model_error_g); shares: the change "
                 "of the mean each stage makes, in signal order, summing to vre_g")
    if reading.unmodelled:
        notes.append(f"no closed form for stage(s) {', '.join(reading.unmodelled)}: simulate")
    if reading.numerical:
        notes.append(f"stage(s) {', '.join(reading.numerical)} without a closed form: the mean of their memoryless "
                     "map by quadrature (vrelab.models.memoryless.map_vre), its error in model_error_g")
    base = sensor.conditions(static_g=g0, profile=text, model=f"prediction-{kind}")
    cond = dataclasses.replace(base, extra={**dict(base.extra), "clip_position": clip_where})
    # the off-axis terms' assumed u (cross-axis sensitivity, IEEE 1293 coupling): a vibration along
    # the axis does not reach them (the triaxial prediction carries them)
    on_axis = {k: v for k, v in (getattr(sensor, "uncertainty", None) or {}).items() if not k.startswith(OFF_AXIS)}
    if getattr(sensor, "covariance", None) or on_axis:
        if len(on_axis) < len(getattr(sensor, "uncertainty", None) or {}):
            sensor = dataclasses.replace(sensor, uncertainty=on_axis)
        prop = propagation(sensor, excitation, levels_arr, g0, kind, vre_g=np.array([lv.vre_g for lv in out]),
                           predictor=predict)
        out = prop.applied(out)
        notes += prop.notes
    out = [judged(lv) for lv in out]
    if getattr(sensor, "unstated", ()):
        out, said = unstated_check(sensor, excitation, levels_arr, g0, kind, out, predictor=predict)
        notes += said
    why = _static_tilt_note(g0)
    if why:
        notes.append(why.replace("the static field", "the static field of every level"))
    off, off_note = reading.vibration_off_g, reading.reference_note
    notes.append(f"VRE referred to the {REFERENCE} ({off:.9g} g): mean output with vibration less that reading"
                 + (f"; {off_note}" if off_note else ""))
    return Prediction(cond, tuple(out), tuple(notes), vibration_off_g=off)


def propagated_u(sensor: Sensor, excitation: RandomProfile | SineOnRandom | float | Sequence[float],
                 levels: Sequence[float], static_g: float, kind: ClipKind = DEFAULT_CLIP_KIND) -> NDArray[np.float64]:
    """Standard uncertainty [g] of each predicted VRE, every source combined (:func:`propagation`).

    Examples
    --------
    >>> import vrelab
    >>> from vrelab.prediction.single import propagated_u
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> print(f"{propagated_u(sensor, 100.0, [2.0], 1.0)[0] * 1e3:.1f} mg")
    1.9 mg
    """
    return propagation(sensor, excitation, levels, static_g, kind, predictor=predict).u_g


def memoryless_level(stages: Sequence[Any], static_g: float, rms_g: float,
                     shape: Literal["gaussian", "sine"] = "gaussian", kind: ClipKind = DEFAULT_CLIP_KIND,
                     each_rail: bool = True) -> tuple[LevelPrediction, float]:
    """One level of a chain of memoryless stages (no linear stage: every stage sees the same
    vibration, rms ``rms_g``, Gaussian or a sine), each stage's own mean shift summed as
    :func:`predict` sums them; and the vibration-off reading (physics §1.5) the VRE is referred to.

    What the sweep's ``model`` points evaluate (a polynomial, an offset and rails: one exact
    memoryless map). ``each_rail`` False skips each rail alone (``clip_low_g``/``clip_high_g``
    then 0). The level carries ``vre_g``, its shares, ``tilt_error_deg``, ``valid`` and notes,
    without the prediction's conditions.

    Examples
    --------
    k2 = 100 µg/g² and ±2 g rails at 1 g rms of Gaussian vibration on a 1 g field (the clipping
    share is the article's Figure 1, :func:`vrelab.models.clipping.censored_mean_shift`):

    >>> from vrelab.prediction.single import memoryless_level
    >>> from vrelab.sensor import Clip, Polynomial
    >>> level, off_g = memoryless_level([Polynomial(k2_per_g=1e-4), Clip(-2.0, 2.0)], 1.0, 1.0)
    >>> print(f"VRE {level.vre_g * 1e3:.2f} mg, vibration off {off_g:.4f} g")
    VRE -82.94 mg, vibration off 1.0001 g
    """
    g0 = V.finite_scalar("static_g", static_g)
    rms = float(V.non_negative("rms_g", rms_g))
    V.one_of("shape", shape, ("gaussian", "sine"))
    V.one_of("kind", kind, KINDS)
    reading = read_stages(stages, g0)
    if reading.output:
        raise ValueError("memoryless_level takes memoryless stages; a chain with linear stages needs predict")
    motions = [Motion(rms, math.nan)] * len(reading.sites)
    lv = _level(_Walk(reading, g0, kind, shape, each_rail), rms, None, motions, rms, rms)
    return lv, reading.vibration_off_g


# The approximation's error is judged against the level's u or this share of |VRE| (or 1 µg),
# whichever is larger: a prediction is not meant to be read to better than that. Without the floor,



@functools.lru_cache(maxsize=64)
def _static_tilt_note(g0: float) -> str | None:
    """Why the static field ``g0`` itself has no tilt error (:func:`tilt_note` of no VRE), or None:
    asked at every level, a pure function of g0 (cached, bounded)."""
    return tilt_note(0.0, g0)[1]


@dataclass(frozen=True)
class _Walk:
    """How the stages are walked at every level of one excitation: the sensor read at the static
    level ``g0``, the clipping model, the drive's shape, and whether each rail alone is evaluated."""

    reading: Reading
    g0: float
    kind: ClipKind
    shape: Drive
    each_rail: bool = True


def _level(
    walk: _Walk,
    rms_g: float,
    freq_hz: float | None,
    sites: Sequence[Motion],
    sigma_m: float,
    sigma_out: float,
) -> LevelPrediction:
    """One level: the stages walked in order, each one's ``mean_shift`` at its site, summed.

    Breakdown (it telescopes to ``vre_g`` exactly): ``nonlinearity_g = E[P(g0 + x)] - P(g0)``
    (:meth:`vrelab.sensor.stages.Polynomial.mean_shift`, exact); ``clip_g`` what the rails
    add to the mean of what reaches them (:meth:`vrelab.sensor.stages.Clip.mean_shift`), so
    where no filter sits between the polynomial and the rails ``nonlinearity_g + clip_g`` is the
    exact mean of the memoryless map :func:`vrelab.models.memoryless.poly_clip_vre`;
    ``overrange_g`` the change the holds make (:meth:`vrelab.sensor.overrange.OverRange.mean_shift`);
    ``numerical_g`` (present only then) what stages without a closed form add by quadrature.
    ``clip_low_g``/``clip_high_g``: each rail alone on the same input. ``model_error_g`` is the
    sum of the stages' bounds; a stage whose estimate is rough when large (over-range) makes the
    level invalid where its share is more than a tenth of the largest.
    """
    reading, g0, kind, shape, each_rail = walk.reading, walk.g0, walk.kind, walk.shape, walk.each_rail
    notes: list[str] = []
    valid = not reading.unmodelled
    totals = dict.fromkeys(SHARES, 0.0)
    bound = rate = 0.0
    sigma_clip = math.nan
    done: list[Done] = []
    for i, (rs, mo) in enumerate(zip(reading.sites, sites)):
        site = Site(g0, rs.offset_g, rs.vibration_off_g, mo, rs.responses, shape, freq_hz, kind, tuple(done),
                    tuple((later.stage, m) for later, m in zip(reading.sites[i + 1:], sites[i + 1:])), each_rail)
        shift = rs.stage.mean_shift(site)
        for k, v in shift.shares.items():
            totals[k] = totals.get(k, 0.0) + v
        valid = valid and shift.valid
        notes += shift.notes
        bound += shift.model_error_g
        rate += shift.rate_hz
        if shift.sigma_at_clip_g is not None:
            sigma_clip = shift.sigma_at_clip_g
        done.append(Done(rs.stage, site, shift))
    total = totals["clip_g"] + totals["nonlinearity_g"] + totals["overrange_g"]
    if NUMERICAL_SHARE in totals:
        total += totals[NUMERICAL_SHARE]
    big = max(abs(totals[k]) for k in totals if k in VRE_SHARES or k == NUMERICAL_SHARE)
    for d in done:
        if d.shift.rough_if_large and big > 0 and any(abs(totals[k]) > _MINOR * big for k in d.shift.shares):
            valid = False
            notes.append(d.shift.rough_if_large)
    if reading.unmodelled:
        notes.append(f"stage(s) {', '.join(reading.unmodelled)} have no closed form — simulate")
    lost = cancellation(totals, total)
    if lost:
        valid = False
        notes.append(lost)
    tilt, why = tilt_note(total, g0)
    if why and _static_tilt_note(g0) is None:  # the static field's own case is one note of the prediction
        notes.append(why)
    return LevelPrediction(
        rms_g=rms_g,
        vre_g=total,
        tilt_error_deg=tilt,
        shares=totals,
        sigma_proof_mass_g=sigma_m,
        sigma_output_g=sigma_out,
        sigma_at_clip_g=sigma_clip,
        overrange_rate_hz=rate,
        valid=valid,
        notes=tuple(notes),
        freq_hz=freq_hz,
        model_error_g=bound,
        valid_otherwise=valid,
    )
