"""Analytic VRE of a sensor in a vibration environment, without simulating it.

The sensor is read through :meth:`vrelab.sensor.Sensor.stages`, the same tuple of stages the
simulation runs, walked in signal order: each stage that has a closed form gives it (its
``analytic`` tag), fed the vibration that reaches it through the linear stages before it and
the static level the offsets before it leave (SPEC 1.3):

* **nonlinearity** (:class:`~vrelab.sensor.stages.Polynomial`) on the proof-mass motion:
  ``E[P(g0 + x)] - P(g0)`` (SPEC 1.2), exact for any polynomial and any zero-mean vibration;
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
* noise, quantisation, decimation and drift shift no mean; a stage with no closed form makes
  the prediction say so (``valid`` False).

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
levels and coefficients (and adaptive quadrature for issue 18's part: +9.14/+16.17 mg), the
filtered case against a numpy Monte Carlo of the chain within ``model_error_g``, and the
simulated test within 3u + 10 % (ADXL355 ±2 g Z at 1-2 g rms). Over-range firing often
(ADXL355 X at 4 g rms on ±8 g: -96 mg against the simulation's -110 ± 5 mg) is not valid.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab._format import finite_or_none
from vrelab.models.clipping import KINDS
from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.models.memoryless import REFERENCE
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.results import Conditions

if TYPE_CHECKING:
    from vrelab.sensor import Sensor


# Shares below this fraction of the largest one are "negligible" in the validity notes.
_MINOR = 0.1
# The over-range model counts independent holds: beyond this fraction of time held, holds
# overlap and the output no longer returns to the vibration between them.
_MAX_HOLD_DUTY = 0.05


@dataclass(frozen=True)
class LevelPrediction:
    """Predicted VRE at one vibration level, with its shares by mechanism.

    ``shares`` [g]: ``clip_low_g``, ``clip_high_g`` (each rail alone), ``clip_g`` (both
    rails), ``nonlinearity_g``, ``overrange_g``. ``vre_g`` is ``clip_g + nonlinearity_g +
    overrange_g``. ``sigma_*`` are rms values [g] of the vibration at the proof mass, at the
    output (after all filters) and at the clip; ``overrange_rate_hz`` the expected trips per
    second. The shares are each stage's change of the mean in signal order (see
    :func:`_level`). ``model_error_g`` [g] bounds what the remaining approximation (rails after
    filters that follow the nonlinearity) may add: 0 where polynomial and rails are evaluated
    exactly; ``valid`` is False where it may exceed ``u_vre_g`` (or, without one, 1 % of |VRE|).
    """

    rms_g: float
    vre_g: float
    tilt_error_deg: float
    shares: Mapping[str, float]
    sigma_proof_mass_g: float
    sigma_output_g: float
    sigma_at_clip_g: float
    overrange_rate_hz: float
    valid: bool
    notes: tuple[str, ...] = ()
    freq_hz: float | None = None
    # standard uncertainty [g] from an identified sensor's parameter covariance (None: the
    # sensor carries none): linear propagation, see :func:`propagated_u`
    u_vre_g: float | None = None
    # its sources (:func:`propagation`): the identified covariance and each assumed parameter [g]
    u_sources_g: Mapping[str, float] | None = None
    # bound [g] on what the remaining approximation may add (0: exact; see _level)
    model_error_g: float = 0.0
    # valid apart from the judgement of model_error_g against a u (:func:`_judged`): a caller
    # with its own u (identify, each level's measured u) judges the bound itself
    valid_otherwise: bool = True

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "rms_g": self.rms_g,
            "vre_g": finite_or_none(self.vre_g),
            "tilt_error_deg": finite_or_none(self.tilt_error_deg),
        }
        if self.u_vre_g is not None:
            d["u_vre_g"] = finite_or_none(self.u_vre_g)
            if self.u_sources_g is not None:
                d["u_sources_g"] = {k: finite_or_none(v) for k, v in self.u_sources_g.items()}
        if self.freq_hz is not None:
            d["freq_hz"] = self.freq_hz
        d.update(
            shares={k: finite_or_none(v) for k, v in self.shares.items()},
            sigma_proof_mass_g=finite_or_none(self.sigma_proof_mass_g),
            sigma_output_g=finite_or_none(self.sigma_output_g),
            sigma_at_clip_g=finite_or_none(self.sigma_at_clip_g),
            overrange_rate_hz=finite_or_none(self.overrange_rate_hz),
            model_error_g=finite_or_none(self.model_error_g),
            valid=self.valid,
            notes=list(self.notes),
        )
        return d


@dataclass(frozen=True)
class Prediction:
    """The analytic VRE of a sensor at each level of one excitation."""

    conditions: Conditions
    levels: tuple[LevelPrediction, ...]
    notes: tuple[str, ...] = field(default=())
    # every vre_g is the mean output with vibration less this reading (SPEC 1.5) [g]
    vibration_off_g: float = math.nan

    @property
    def valid(self) -> bool:
        return all(lv.valid for lv in self.levels)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "prediction",
            "conditions": self.conditions.to_dict(),
            "reference": REFERENCE,
            "vibration_off_g": finite_or_none(self.vibration_off_g),
            "levels": [lv.to_dict() for lv in self.levels],
            "valid": self.valid,
            "notes": list(self.notes),
        }


# --- the sensor, read as its stages -------------------------------------------------------------


Response = Callable[[NDArray[np.float64]], NDArray[np.complex128]]
# What each stage's ``analytic`` tag makes of it (vrelab.sensor.stages.StageBase.analytic).
_NONLINEAR = ("polynomial", "overrange", "clip")
_NEUTRAL_WHY = {
    "Noise": "zero-mean noise",
    "Quantize": "rounding to the LSB (mean error 0 for vibration spanning many LSB)",
    "Decimate": "decimation (keeps the mean)",
    "Drift": "a slow drift (bracketing removes it from a measured VRE)",
}


@dataclass(frozen=True)
class _Motion:
    """The vibration reaching one site: Gaussian (``sigma_g``, Rice's ``nu0_hz``), a sine
    (``sigma_g`` its rms, ``nu0_hz`` its frequency), or Gaussian plus tones (``tone_peaks_g``
    [g peak] at ``tone_freqs_hz``, as seen there)."""

    sigma_g: float
    nu0_hz: float
    tone_peaks_g: tuple[float, ...] = ()
    tone_freqs_hz: tuple[float, ...] = ()
    # at an over-range site (random part): ρ̄ over the hold and 1 - ρ(hold), ρ the motion's
    # correlation (:func:`vrelab.models.design.overrange_held_mean_g`); NaN elsewhere
    rho_mean: float = math.nan
    one_minus_rho_hold: float = math.nan

    @property
    def rms_g(self) -> float:
        """Total rms [g]: the Gaussian (or sine) part with the tones' Σ A²/2."""
        return math.sqrt(self.sigma_g**2 + sum(a * a for a in self.tone_peaks_g) / 2.0)


@dataclass(frozen=True)
class _Site:
    """A stage with a closed-form mean shift, and what reaches it."""

    stage: Any
    responses: tuple[Response, ...]  # the linear stages before it
    offset_g: float  # offsets added before it


@dataclass(frozen=True)
class _Reading:
    """A sensor's stages, read once for the analytic model."""

    sites: tuple[_Site, ...]
    proof_mass: tuple[Response, ...]  # the mechanical responses (resonance)
    output: tuple[Response, ...]  # every linear response
    unmodelled: tuple[str, ...]  # stages without a closed form
    offset_g: float = 0.0  # every offset of the chain


def _read_stages(stages: Sequence[Any]) -> _Reading:
    """Walk the stages in order, as the signal goes (SPEC 1.3): a linear stage shapes what every
    later stage sees, an offset moves the static level of every later stage, and a stage with a
    closed-form mean shift becomes a site evaluated with the vibration that reaches it."""
    from vrelab.sensor.stages import Resonator

    responses: list[Response] = []
    mechanical: list[Response] = []
    offset = 0.0
    sites: list[_Site] = []
    unmodelled: list[str] = []
    for st in stages:
        tag = getattr(st, "analytic", None)
        if tag == "linear":
            responses.append(st.response)
            if isinstance(st, Resonator):
                mechanical.append(st.response)
        elif tag == "offset":
            offset += float(st.offset_g)
        elif tag in _NONLINEAR:
            sites.append(_Site(st, tuple(responses), offset))
        elif tag != "neutral":
            unmodelled.append(type(st).__name__)
    return _Reading(tuple(sites), tuple(mechanical), tuple(responses), tuple(unmodelled), offset)


def _vibration_off(reading: _Reading, g0: float) -> tuple[float, str | None]:
    """The reading with no vibration (SPEC 1.5: what every VRE is referred to), the static level
    walked through the sites in order (the polynomial, the rails by
    :func:`vrelab.models.memoryless.vibration_off_reading`, the offsets; the linear stages pass
    a static level unchanged), and the note where the rails clip it (None otherwise)."""
    from vrelab.models import memoryless

    level, added, note = g0, 0.0, None
    for site in reading.sites:
        st = site.stage
        level, added = level + (site.offset_g - added), site.offset_g
        if st.analytic == "polynomial":
            level = memoryless.vibration_off_reading(level, st.k2_per_g, st.k3_per_g2, st.k4_per_g3)
        elif st.analytic == "clip":
            low, high = float(st.low_g), float(st.high_g)
            note = note or memoryless.reference_note(level, rail_low_g=low, rail_high_g=high)
            level = memoryless.vibration_off_reading(level, rail_low_g=low, rail_high_g=high)
    return level + (reading.offset_g - added), note


def _spectral(profile: RandomProfile, responses: Sequence[Response], points_hz: Sequence[float],
              rate: bool = True) -> tuple[float, float]:
    """(σ² [g²], ν0 [Hz]) of the profile seen through ``responses``.

    ``σ² = ∫S·|H|²df`` (:func:`vrelab.models.dynamics.effective_rms`) and Rice's zero
    up-crossing rate ``ν0 = sqrt(∫f²·S·|H|²df / σ²)``
    (:func:`vrelab.models.dynamics.zero_crossing_rate_hz`), over the profile's band, split at
    its breakpoints and at the sensor's resonance. Without ``rate`` (a site that needs no
    crossing rate) ν0 is NaN and its two integrals are not computed.
    """
    from vrelab.models import dynamics

    lo, hi = profile.band
    psd = (np.asarray(profile.freq_hz), np.asarray(profile.psd_g2_per_hz))
    sigma = dynamics.effective_rms(psd, list(responses), lo, hi, points_hz=list(points_hz))
    if not rate:
        return sigma**2, math.nan
    nu0 = dynamics.zero_crossing_rate_hz(psd, list(responses), lo, hi, points_hz=list(points_hz))
    return sigma**2, nu0


def _hold_correlation(profile: RandomProfile, responses: Sequence[Response], points_hz: Sequence[float],
                      hold_s: float, m0: float) -> tuple[float, float]:
    """(ρ̄, 1 - ρ(hold)) of the profile seen through ``responses``: the motion's correlation
    averaged over the hold, ``ρ̄ = ∫S·|H|²·sinc(2f·hold)df/σ²``, and ``1 - ρ(hold) =
    ∫S·|H|²·(1 - cos 2πf·hold)df/σ²``, both as ∫S·|H·W|² with a non-negative weight |W|²
    (1 - sinc and 2·sin²) so the one spectral integral (:func:`_spectral`) computes them."""
    def w_mean(f: NDArray[np.float64]) -> NDArray[np.complex128]:
        return np.sqrt(np.maximum(1.0 - np.sinc(2.0 * np.asarray(f) * hold_s), 0.0)).astype(complex)

    def w_end(f: NDArray[np.float64]) -> NDArray[np.complex128]:
        return (math.sqrt(2.0) * np.abs(np.sin(np.pi * np.asarray(f) * hold_s))).astype(complex)

    if not m0 > 0:
        return math.nan, math.nan
    one_minus_mean, _ = _spectral(profile, [*responses, w_mean], points_hz, rate=False)
    one_minus_end, _ = _spectral(profile, [*responses, w_end], points_hz, rate=False)
    return 1.0 - one_minus_mean / m0, one_minus_end / m0


def _clip_where(sensor: Any) -> str:
    pos = str(getattr(sensor, "clip_position", "output") or "output")
    return "output" if pos == "output" else "proof-mass"


# --- prediction ---------------------------------------------------------------------------------


def _gain(f_hz: float, responses: Sequence[Response]) -> float:
    """|H(f)| of the linear stages ``responses`` in series."""
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
        Clipping model (SPEC 1.1); censored is what a saturating sensor does.

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
    PSD S(f): ``σ² = ∫S|H|²df`` (SPEC 1.3); sine at f, rms A/√2: ``σ = rms·|H(f)|``.
    Sine-on-random: the random part as a random drive (σ_r at each site) and each tone through
    its own gain, ``A_i·|H(f_i)|``; phases independent and uniform (random-phase ensemble).

    * polynomial: ``E[P(g0 + x)] - P(g0)`` (SPEC 1.2), exact
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
    * noise, quantisation, decimation, drift: no mean shift. A stage with no closed form makes
      every level invalid, naming it.

    References
    ----------
    .. [1] SPEC sections 1.1-1.3 (after the ADI article on VRE in MEMS accelerometers).
    .. [2] S. O. Rice, "Mathematical analysis of random noise", Bell Syst. Tech. J. 23 (1944):
       up-crossing rate ``ν0·exp(-(a-μ)²/(2σ²))``.
    """
    levels_arr = V.vibration_level("levels", np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    if levels_arr.ndim != 1 or levels_arr.size == 0:
        raise ValueError(f"levels must be a non-empty list of rms values, got {levels!r}")
    g0 = V.finite_scalar("static_g", static_g)
    V.one_of("kind", kind, KINDS)
    reading = _read_stages(sensor.stages())
    clip_where = _clip_where(sensor)
    notes: list[str] = []
    out: list[LevelPrediction] = []
    fn_hz = getattr(sensor, "fn_hz", None)
    if isinstance(excitation, RandomProfile):
        points = [float(fn_hz)] if fn_hz else []
        m0_drive = excitation.mean_square_g2
        # per unit drive mean square: σ²/m0 and ν0 at each site, at the proof mass and output
        # only the over-range site uses Rice's crossing rate
        seen = [_spectral(excitation, site.responses, points, rate=site.stage.analytic == "overrange")
                for site in reading.sites]
        rho = [_hold_correlation(excitation, site.responses, points, float(site.stage.hold_s), m0)
               if site.stage.analytic == "overrange" else (math.nan, math.nan)
               for site, (m0, _) in zip(reading.sites, seen)]
        m0_m, _ = _spectral(excitation, reading.proof_mass, points, rate=False)
        m0_out, _ = _spectral(excitation, reading.output, points, rate=False)
        for rms in levels_arr:
            scale = float(rms) ** 2 / m0_drive
            sites = [_Motion(math.sqrt(m0 * scale), nu0, rho_mean=r[0], one_minus_rho_hold=r[1])
                     for (m0, nu0), r in zip(seen, rho)]
            out.append(_level(reading, float(rms), None, g0, kind, "gaussian", sites,
                              math.sqrt(m0_m * scale), math.sqrt(m0_out * scale)))
        text = excitation.describe().split(",")[0] + (f" ({excitation.name})" if excitation.name else "")
        notes.append("random drive assumed Gaussian (a clipped or high-kurtosis drive needs `simulate`)")
    elif isinstance(excitation, SineOnRandom):
        points = [float(fn_hz)] if fn_hz else []
        rand, tones = excitation.random, excitation.tones
        freqs = tuple(t.freq_hz for t in tones)
        # per unit of the profile as given: (σ_r², ν0) of its random part and |H(f_i)| at each site
        seen_tones = [(_spectral(rand, site.responses, points), [_gain(f, site.responses) for f in freqs])
                for site in reading.sites]
        # the held stretches' mean from the random part's correlation (the tones left out of it)
        rho = [_hold_correlation(rand, site.responses, points, float(site.stage.hold_s), m0)
               if site.stage.analytic == "overrange" else (math.nan, math.nan)
               for site, ((m0, _), _) in zip(reading.sites, seen_tones)]
        m0_m, _ = _spectral(rand, reading.proof_mass, points)
        m0_out, _ = _spectral(rand, reading.output, points)
        gain_m = [_gain(f, reading.proof_mass) for f in freqs]
        gain_out = [_gain(f, reading.output) for f in freqs]
        motions: list[_Motion] = []
        for rms in levels_arr:
            r = float(rms) / excitation.grms  # the scaling rule: PSD × r², tones × r

            def motion(m0: float, nu0: float, gains: Sequence[float], rh: tuple[float, float] = (math.nan, math.nan)
                       ) -> _Motion:
                # noqa below: motion() is called within this iteration only, so r is the current level's
                return _Motion(r * math.sqrt(m0), nu0, tuple(r * t.peak_g * g for t, g in zip(tones, gains)), freqs,  # noqa: B023
                               *rh)

            sites = [motion(m0, nu0, gains, rh) for ((m0, nu0), gains), rh in zip(seen_tones, rho)]
            motions += sites
            out.append(_level(reading, float(rms), None, g0, kind, "sine-on-random", sites,
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
    else:
        sine_hz = np.atleast_1d(V.positive("freq_hz", np.asarray(excitation, dtype=np.float64)))
        from vrelab.models.dynamics import rms_through

        for f in sine_hz:
            f = float(f)
            for rms in levels_arr:
                sites = [_Motion(float(rms_through(f, float(rms), list(site.responses))), f) for site in reading.sites]
                out.append(_level(reading, float(rms), f, g0, kind, "sine", sites,
                                  float(rms_through(f, float(rms), list(reading.proof_mass))),
                                  float(rms_through(f, float(rms), list(reading.output)))))
        text = "sine " + ", ".join(f"{f:g}" for f in sine_hz) + " Hz"
    notes.append(f"clip modelled at the {clip_where} ({kind}); nonlinearity and rails evaluated together as one "
                 "memoryless map (exact where no filter sits between them; else the rails see the polynomial's "
                 "linear part through the filters, its remainder bounded in model_error_g); shares: the change "
                 "of the mean each stage makes, in signal order, summing to vre_g")
    if reading.unmodelled:
        notes.append(f"no closed form for stage(s) {', '.join(reading.unmodelled)}: simulate")
    base = sensor.conditions(static_g=g0, profile=text, model=f"prediction-{kind}")
    cond = dataclasses.replace(base, extra={**dict(base.extra), "clip_position": clip_where})
    if getattr(sensor, "covariance", None) or getattr(sensor, "uncertainty", None):
        prop = propagation(sensor, excitation, levels_arr, g0, kind, vre_g=np.array([lv.vre_g for lv in out]))
        out = [dataclasses.replace(lv, u_vre_g=float(prop.u_g[i]),
                                   u_sources_g={k: float(v[i]) for k, v in prop.sources_g.items()},
                                   valid=lv.valid and not prop.level_notes[i],
                                   notes=lv.notes + prop.level_notes[i]) for i, lv in enumerate(out)]
        notes += prop.notes
    out = [_judged(lv) for lv in out]
    why = tilt_note(0.0, g0)[1]
    if why:
        notes.append(why.replace("the static field", "the static field of every level"))
    off, off_note = _vibration_off(reading, g0)
    notes.append(f"VRE referred to the {REFERENCE} ({off:.9g} g): mean output with vibration less that reading"
                 + (f"; {off_note}" if off_note else ""))
    return Prediction(cond, tuple(out), tuple(notes), vibration_off_g=off)


# The approximation's error is judged against the level's u or this share of |VRE| (or 1 µg),
# whichever is larger: a prediction is not meant to be read to better than that. Without the floor,
# a preset's assumed-parameter u that happens to be tiny (the over-range threshold's, far below
# the threshold: 1e-13 g) would flag every filtered prediction for a sub-µg bound.
_TOLERANCE_REL = 0.01
_TOLERANCE_ABS_G = 1e-6
MODEL_SOURCE = "model approximation (model_error_g, rectangular)"


def _judged(lv: LevelPrediction) -> LevelPrediction:
    """``valid`` False where ``model_error_g`` may exceed the stated u (the larger of ``u_vre_g``
    and 1 % of |VRE| or 1 µg), with the reason. Where the level states a u (its parameters'), the
    bound also enters it as a rectangular source (GUM 4.3.7: ``model_error_g/√3``), so that
    ``u_vre_g`` is never smaller than what the approximation may add."""
    if lv.model_error_g > 0 and lv.u_vre_g is not None:
        u_model = float(lv.model_error_g) / math.sqrt(3.0)
        sources = {**dict(lv.u_sources_g or {}), MODEL_SOURCE: u_model}
        judged_u: float | None = lv.u_vre_g
        lv = dataclasses.replace(lv, u_vre_g=math.hypot(lv.u_vre_g, u_model), u_sources_g=sources)
    else:
        judged_u = lv.u_vre_g
    stated = max(judged_u or 0.0, _TOLERANCE_REL * abs(lv.vre_g), _TOLERANCE_ABS_G)
    if lv.model_error_g <= stated:
        return lv
    what = "u_vre_g" if judged_u is not None and judged_u >= _TOLERANCE_REL * abs(lv.vre_g) else "1 % of |VRE|"
    return dataclasses.replace(lv, valid=False, notes=(*lv.notes, (
        f"the rails sit after filters that follow the nonlinearity: they see its non-Gaussian output, here "
        f"modelled as Gaussian with an error up to {lv.model_error_g * 1e3:.3g} mg, more than {what} "
        f"({stated * 1e3:.3g} mg) — simulate")))


@dataclass(frozen=True)
class Propagation:
    """The standard uncertainty of each predicted VRE from the sensor's parameter uncertainties,
    by source (see :func:`propagation`)."""

    u_g: NDArray[np.float64]  # per level, every source combined
    sources_g: Mapping[str, NDArray[np.float64]]  # per source, its u per level (in quadrature: u_g)
    level_notes: tuple[tuple[str, ...], ...]  # per level: why the u is not a claim (empty: it is)
    notes: tuple[str, ...]  # which sources dominate


# The propagation is linear where the VRE moved by ±u of a parameter departs from the tangent by
# less than this fraction of the tangent's step; beyond, u_vre_g is not a claim (valid False).
_LINEAR = 0.3
# A source is named as dominant in the notes above this share of u².
_DOMINANT = 0.25
IDENTIFIED = "identified (covariance)"


def propagation(sensor: Sensor, excitation: RandomProfile | SineOnRandom | float | Sequence[float],
                levels: Sequence[float] | NDArray[np.float64], static_g: float,
                kind: ClipKind = DEFAULT_CLIP_KIND, vre_g: NDArray[np.float64] | None = None,
                predictor: Callable[..., Prediction] | None = None) -> Propagation:
    r"""Standard uncertainty [g] of each predicted VRE from the sensor's parameter uncertainties.

    Two sources (SPEC 6.1): the identified parameters' covariance ``Σ`` (``sensor.covariance``)
    and the assumed standard uncertainties of parameters no campaign measured
    (``sensor.uncertainty``: a datasheet tolerance, a base sensor's filter corner), independent
    of each other and of ``Σ``. Linear propagation (GUM 5.1.2): ``u² = J·Σ·Jᵀ + Σ_a (J_a·u_a)²``
    with ``J[i, j] = ∂VRE_i/∂θ_j`` by central differences of :func:`predict` itself, each step a
    tenth of the parameter's standard uncertainty. The tests hold it against a Monte Carlo over
    ``Σ`` (GUM Supplement 1).

    Linearity is checked, not assumed: the VRE is also evaluated at ``θ_j ± u_j``; where it
    departs from the tangent by more than ``_LINEAR`` of the tangent's step, or where ``θ ± u``
    leaves the parameter's domain (a Q whose u exceeds it), an assumed parameter's share is
    taken as the larger move (``max |VRE(θ ± u) − VRE(θ)|``, GUM 5.1.3's note), and the
    identified block is propagated by a Monte Carlo over ``Σ`` instead (GUM Supplement 1,
    :func:`_monte_carlo`); where more than ``_MC_OUTSIDE`` of its draws leave the parameters'
    domain (a Q whose u exceeds it: the campaign does not bound it) the level's u is no claim:
    ``valid`` False with a note.

    ``sources_g``: ``"identified (covariance)"`` (the covariance block, correlations in it) and
    one entry per assumed parameter; their quadrature sum is ``u_g``. ``vre_g``: the VRE already
    predicted at the parameters' values, one per predicted level (saves predicting it again).
    ``predictor``: what is propagated, called as :func:`predict` is (default :func:`predict`;
    :func:`vrelab.triaxial.predict.predict_triaxial` passes its own, so one rule carries both).
    """
    from vrelab.sensor.parameters import parameter, with_parameters

    cov = getattr(sensor, "covariance", None)
    assumed = dict(getattr(sensor, "uncertainty", None) or {})
    if not cov and not assumed:
        raise ValueError(f"sensor {sensor.name} carries no parameter uncertainty (an identified sensor file's "
                         "covariance, or a file's [uncertainty] table)")
    lv = np.atleast_1d(np.asarray(levels, dtype=np.float64))

    def vre_at(values: Mapping[str, float]) -> NDArray[np.float64] | None:
        try:
            p = (predictor or predict)(with_parameters(sensor, values), excitation, lv, static_g, kind)
        except ValueError:  # outside the parameter's domain (rails crossing the static level, Q <= 0)
            return None
        return np.array([x.vre_g for x in p.levels])

    # the VRE at the parameters' values: the caller's prediction when it has one (predict), else computed
    f0 = vre_at({}) if vre_g is None else np.asarray(vre_g, dtype=np.float64)
    assert f0 is not None
    # one VRE per predicted level: a sine at several frequencies predicts each level at each of them
    n_out = f0.size
    names = list(cov["params"]) if cov else []
    sigma = np.asarray(cov["matrix"], dtype=np.float64) if cov else np.zeros((0, 0))
    everything = [(n, math.sqrt(sigma[j, j]), True) for j, n in enumerate(names)] + [(n, u, False) for n, u in assumed.items()]
    jac = np.zeros((n_out, len(names)))
    sources: dict[str, NDArray[np.float64]] = {}
    level_notes: list[list[str]] = [[] for _ in range(n_out)]
    nonlinear = np.zeros(n_out, dtype=bool)
    bent_why: list[str] = []
    for j, (name, u, identified) in enumerate(everything):
        x = parameter(sensor, name)
        if x is None or not u > 0:
            continue
        ends = [vre_at({name: x + s}) for s in (0.1 * u, -0.1 * u)]
        if ends[0] is None or ends[1] is None:
            d = np.zeros(n_out)
            for i in range(n_out):
                level_notes[i].append(f"the VRE cannot be evaluated at {name} ± 0.1·u: u_vre_g is not a claim")
        else:
            d = (ends[0] - ends[1]) / (0.2 * u)
        wide = [vre_at({name: x + s}) for s in (u, -u)]
        step = np.abs(d) * u
        if wide[0] is None or wide[1] is None:
            bent = np.ones(n_out, dtype=bool)
            move = step
            why = f"{name} ± u ({x:.4g} ± {u:.2g}) leaves the parameter's domain"
            if not identified:  # an assumption that wide says the element is barely known: no u to claim
                for i in range(n_out):
                    level_notes[i].append(f"{why}: the VRE over that range is not known — u_vre_g is not a claim")
        else:
            curve = np.abs(wide[0] + wide[1] - 2 * f0) / 2
            bent = curve > _LINEAR * np.maximum(step, 1e-15)
            move = np.maximum(step, np.maximum(np.abs(wide[0] - f0), np.abs(wide[1] - f0)))
            why = f"the VRE is not linear in {name} over its u ({x:.4g} ± {u:.2g})"
        if identified:
            jac[:, j] = d
            nonlinear |= bent & (move > 0)
            if (bent & (move > 0)).any():
                bent_why.append(why)
        else:
            sources[name] = np.where(bent, move, step)
    notes = []
    if names:
        u_cov = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, sigma, jac), 0.0))
        if nonlinear.any():
            u_mc, outside, lo95, hi95 = _monte_carlo(sensor, excitation, lv, static_g, kind, names, sigma,
                                                      predictor or predict)
            for i in np.flatnonzero(nonlinear).tolist():
                if outside > _MC_OUTSIDE:
                    level_notes[i].append(f"{'; '.join(bent_why)}; a Monte Carlo over the covariance leaves the "
                                          f"parameters' domain in {100 * outside:.0f} % of draws: u_vre_g is not a claim "
                                          "(the campaign does not bound these parameters)")
                else:
                    u_cov[i] = u_mc[i]
            if outside <= _MC_OUTSIDE:
                notes.append(f"u_vre_g of the identified parameters by Monte Carlo over their covariance (GUM S1, "
                             f"{_MC_DRAWS} seeded draws; {100 * outside:.0f} % outside the parameters' domain dropped) "
                             f"where the VRE is not linear in them ({'; '.join(bent_why)}); 95 % intervals "
                             + ", ".join(f"[{1e3 * a:.4g}, {1e3 * b:.4g}] mg" for a, b in zip(lo95, hi95)))
        sources = {IDENTIFIED: u_cov, **sources}
    u2 = sum((v**2 for v in sources.values()), np.zeros(n_out))
    if names:
        notes.append("u_vre_g: the identified parameters' covariance (" + ", ".join(names) + ") carried by linear "
                     "propagation; the model's own approximations are not in it")
    if assumed:
        notes.append("u_vre_g carries the assumed uncertainties of parameters no measurement fixed ("
                     + ", ".join(f"{n} ± {u:.3g}" for n, u in assumed.items()) + ", the sensor file's [uncertainty])")
    share = {k: float(np.max(np.where(u2 > 0, v**2 / np.where(u2 > 0, u2, 1.0), 0.0))) for k, v in sources.items()}
    top = sorted((k for k in share if share[k] >= _DOMINANT), key=lambda k: -share[k])
    if top:
        notes.append("u_vre_g dominated by " + ", ".join(f"{'assumed ' if k != IDENTIFIED else ''}{k} "
                                                          f"(up to {100 * share[k]:.0f} % of u²)" for k in top)
                     + "; per source in u_sources_g")
    return Propagation(np.sqrt(u2), sources, tuple(tuple(n) for n in level_notes), tuple(notes))


# Monte Carlo propagation where the linear one fails: draws, and the fraction of draws outside the
# parameters' domain (Q <= 0, rails crossing the static field) beyond which u is no claim.
_MC_DRAWS = 200
_MC_OUTSIDE = 0.15


def _monte_carlo(sensor: Sensor, excitation: Any, levels: NDArray[np.float64], static_g: float, kind: ClipKind,
                 names: Sequence[str], sigma: NDArray[np.float64],
                 predictor: Callable[..., Prediction] | None = None) -> tuple[NDArray[np.float64], float,
                                                                           NDArray[np.float64], NDArray[np.float64]]:
    """GUM Supplement 1 over the identified parameters: ``_MC_DRAWS`` seeded draws from the
    normal distribution of mean the identified values and covariance ``Σ`` (numpy's
    multivariate_normal), :func:`predict` at each. Returns the standard deviation of the VRE
    per level, the fraction of draws outside the parameters' domain (dropped), and the 2.5 %
    and 97.5 % quantiles per level."""
    from vrelab.sensor.parameters import parameter, with_parameters

    mean = np.array([parameter(sensor, n) for n in names], dtype=np.float64)
    draws = np.random.default_rng(20240518).multivariate_normal(mean, sigma, size=_MC_DRAWS, method="eigh")
    vre = []
    for x in draws:
        try:
            p = (predictor or predict)(with_parameters(sensor, dict(zip(names, (float(v) for v in x)))), excitation, levels,
                        static_g, kind)
        except ValueError:
            continue
        vre.append([lv.vre_g for lv in p.levels])
    outside = 1.0 - len(vre) / _MC_DRAWS
    if len(vre) < 2:
        nan = np.full(levels.size, math.nan)
        return nan, outside, nan, nan
    v = np.array(vre)
    return v.std(axis=0, ddof=1), outside, np.quantile(v, 0.025, axis=0), np.quantile(v, 0.975, axis=0)


def propagated_u(sensor: Sensor, excitation: RandomProfile | SineOnRandom | float | Sequence[float],
                 levels: Sequence[float], static_g: float, kind: ClipKind = DEFAULT_CLIP_KIND) -> NDArray[np.float64]:
    """Standard uncertainty [g] of each predicted VRE, every source combined (:func:`propagation`)."""
    return propagation(sensor, excitation, levels, static_g, kind).u_g


def tilt_note(vre_g: float, g0: float) -> tuple[float, str | None]:
    """Tilt error [deg] of a VRE on an axis at ``asin(g0)`` (:func:`vrelab.models.design.tilt_error_from_static_deg`),
    NaN with the reason where it is undefined."""
    from vrelab.models import design

    try:
        return float(design.tilt_error_from_static_deg(vre_g, g0)), None
    except ValueError as err:
        return math.nan, f"tilt error undefined: {err}"


def _linear_gain_max(responses: Sequence[Response]) -> float:
    """sup_f |H(f)| of the linear stages ``responses`` in series (1 for none), on a log grid
    from 0.01 Hz to 10 MHz (the remainder's spectrum reaches several times the band)."""
    if not responses:
        return 1.0
    f = np.geomspace(1e-2, 1e7, 4001)
    h = np.ones(f.size)
    for r in responses:
        h = h * np.abs(np.asarray(r(f)))
    return float(max(1.0, h.max()))


def _level(
    reading: _Reading,
    rms_g: float,
    freq_hz: float | None,
    g0: float,
    kind: ClipKind,
    shape: Literal["gaussian", "sine", "sine-on-random"],
    sites: Sequence[_Motion],
    sigma_m: float,
    sigma_out: float,
) -> LevelPrediction:
    """One level: the stages walked in order, each share the change of the mean it makes.

    Breakdown (it telescopes to ``vre_g`` exactly): ``nonlinearity_g = E[P(g0 + x)] - P(g0)``
    (the polynomial alone, exact); ``clip_g`` = what the rails add to the mean of what reaches
    them (``E[clip(P(...))] - E[P(...)]`` less the same with no vibration), so where no filter
    sits between the polynomial and the rails ``nonlinearity_g + clip_g`` is the exact mean of
    the memoryless map :func:`vrelab.models.memoryless.poly_clip_vre`; ``overrange_g`` the
    change the holds make. ``clip_low_g``/``clip_high_g``: each rail alone on the same input.
    ``model_error_g`` bounds what the remaining approximation (a filter between the
    polynomial and the rails: the rails see a Gaussian with the polynomial's linear part, the
    non-Gaussian rest bounded) may add; the over-range estimate is judged by its share.
    """
    from vrelab.models import design, memoryless

    notes: list[str] = []
    valid = not reading.unmodelled
    clip_low = clip_high = clip = nonlin = over = rate = 0.0
    bound = 0.0
    sigma_clip = math.nan
    # the closed forms take the Gaussian part's σ plus the tones; a sine keeps its own shape
    base: Literal["gaussian", "sine"] = "sine" if shape == "sine" else "gaussian"
    poly: tuple[_Site, _Motion, float] | None = None  # the polynomial's site, motion there, its own share
    holds: list[tuple[Any, ...]] = []  # over-range sites' arguments, evaluated after the walk
    rails_after: list[tuple[float, float, float]] = []  # (L, U, rms at the rails) of rails after a hold
    clipped = False
    for site, mo in zip(reading.sites, sites):
        st, mean = site.stage, g0 + site.offset_g
        sigma, nu0, peaks = mo.sigma_g, mo.nu0_hz, mo.tone_peaks_g
        if st.analytic == "polynomial":
            if clipped:
                valid = False
                notes.append("a polynomial after the rails: its input is clipped, not Gaussian — simulate")
            share = float(memoryless.poly_clip_vre(mean, sigma, st.k2_per_g, st.k3_per_g2, st.k4_per_g3,
                                                   shape=base, tone_peaks_g=peaks))
            nonlin += share
            poly = (site, mo, share)
        elif st.analytic == "clip":
            low, high = float(st.low_g), float(st.high_g)
            if holds:
                rails_after.append((low, high, mo.rms_g))
            if clipped:
                valid = False
                notes.append("a second set of rails: evaluated as if alone — simulate")
            clipped = True
            k = (0.0, 0.0, 0.0)
            if poly is not None:
                p_site, p_mo, p_share = poly
                k = (p_site.stage.k2_per_g, p_site.stage.k3_per_g2, p_site.stage.k4_per_g3)
            c0 = float(memoryless.polynomial(*k)(g0 + (poly[0].offset_g if poly else 0.0))) + (
                site.offset_g - (poly[0].offset_g if poly else 0.0))
            if not low < c0 < high:
                valid = False
                notes.append(f"the static level {c0:g} g at the rails (field {g0:g} g, offsets, nonlinearity) is at "
                             f"or beyond a rail [{low:g}, {high:g}] g: the sensor is saturated without vibration — simulate")
            if poly is None or len(site.responses) == len(poly[0].responses):
                # nothing linear between the polynomial (if any) and the rails: one memoryless map, exact
                src_site, src_mo, own = (poly[0], poly[1], poly[2]) if poly else (site, mo, 0.0)
                args = (g0 + src_site.offset_g, src_mo.sigma_g, *k, site.offset_g - src_site.offset_g)
                rails: dict[str, Any] = dict(shape=base, kind=kind, tone_peaks_g=src_mo.tone_peaks_g)
                clip += float(memoryless.poly_clip_vre(*args, low, high, **rails)) - own
                clip_low += float(memoryless.poly_clip_vre(*args, low, math.inf, **rails)) - own
                clip_high += float(memoryless.poly_clip_vre(*args, -math.inf, high, **rails)) - own
                sigma_clip = mo.rms_g
            else:
                # filters between: the rails see the polynomial's mean and its linear part through
                # them (Gaussian), the rest (harmonics, higher Hermite terms) bounded below
                p_site, p_mo, p_share = poly
                gain, rest = memoryless.linear_part(g0 + p_site.offset_g, p_mo.sigma_g, *k, shape=base,
                                                    tone_peaks_g=p_mo.tone_peaks_g)
                m = c0 + p_share
                sz, pz = abs(gain) * sigma, tuple(abs(gain) * a for a in peaks)
                sigma_clip = mo.rms_g
                parts = []
                for lo_, hi_ in ((low, high), (low, math.inf), (-math.inf, high)):
                    moved = float(memoryless.poly_clip_vre(m, sz, rail_low_g=lo_, rail_high_g=hi_, shape=base,
                                                           kind=kind, tone_peaks_g=pz))
                    # referred to the vibration-off reading at the rails, clip(c0), not clip(m)
                    parts.append(moved + (float(np.clip(m, lo_, hi_)) - m) - (float(np.clip(c0, lo_, hi_)) - c0))
                clip, clip_low, clip_high = clip + parts[0], clip_low + parts[1], clip_high + parts[2]
                r = rest * _linear_gain_max(site.responses[len(p_site.responses):])
                if base == "sine":
                    # deterministic: the harmonics (rms r, peak at most 2r for the 2nd and 3rd)
                    # matter only where the sine, so widened, reaches a rail
                    if r > 0 and not (low < m - math.sqrt(2) * sz - 2 * r and m + math.sqrt(2) * sz + 2 * r < high):
                        bound += 2 * r
                elif r > 0 and sz > 0 and not peaks:
                    # the rest's n-th Hermite component (n >= 2, in the n-th Wiener chaos, through
                    # the filters at most gmax times its rms) correlates only with the n-th chaos
                    # part of 1{L < Z < U}, of norm |He_{n-1}(α)φ(α) - He_{n-1}(β)φ(β)|/sqrt(n!)
                    # (Cauchy-Schwarz within each chaos); plus the rest's second-order effect
                    # across the rails, r²·(pdf at the rails)
                    gmax = _linear_gain_max(site.responses[len(p_site.responses):])
                    comps = memoryless.hermite_rms(g0 + p_site.offset_g, p_mo.sigma_g, *k)[1:]
                    a, b = (low - m) / sz, (high - m) / sz
                    pa, pb = math.exp(-0.5 * a * a) / math.sqrt(2 * math.pi), math.exp(-0.5 * b * b) / math.sqrt(2 * math.pi)
                    for n, cn in enumerate(comps, start=2):
                        he = np.polynomial.hermite_e.hermeval([a, b], [0.0] * (n - 1) + [1.0])
                        bound += gmax * cn * abs(he[0] * pa - he[1] * pb) / math.sqrt(math.factorial(n))
                    bound += r * r * (pa + pb) / sz
                elif r > 0 and sz > 0:
                    from scipy import special

                    a, b = (low - m) / sz, (high - m) / sz
                    p_out = float(special.ndtr(a) + special.ndtr(-b))
                    dens = (math.exp(-0.5 * a * a) + math.exp(-0.5 * b * b)) / (math.sqrt(2 * math.pi) * sz)
                    bound += r * math.sqrt(p_out * (1.0 - p_out)) + r * r * dens
        elif st.analytic == "overrange":
            thr, hold = float(st.threshold_g), float(st.hold_s)
            if shape != "sine":
                rate += float(design.overrange_trip_rate_hz(thr, mean, sigma, nu0, peaks, mo.tone_freqs_hz))
                held = None
                if math.isfinite(mo.rho_mean) and sigma > 0:
                    held = design.overrange_held_mean_g(mean, sigma, thr, hold, nu0, mo.rho_mean, mo.one_minus_rho_hold)
                # evaluated after the walk: rails after the holds change what the held stretches
                # would have read
                holds.append((mean, sigma, thr, hold, nu0, float(st.value_g), peaks, mo.tone_freqs_hz, held))
                duty = rate * hold
                if duty > _MAX_HOLD_DUTY:
                    valid = False
                    notes.append(
                        f"over-range holds fill {100 * duty:.0f} % of the time: holds overlap, "
                        "the rare-event model fails — simulate"
                    )
            else:
                peak = math.sqrt(2) * sigma
                if abs(mean) + peak > thr:
                    valid = False
                    rate = freq_hz or 0.0
                    notes.append(
                        f"sine peak at the proof mass ({abs(mean) + peak:.3g} g) reaches the over-range "
                        f"threshold ({thr:g} g): trips every period, not modelled — simulate"
                    )
    for mean, sigma, thr, hold, nu0, value, peaks, freqs, held in holds:
        if held is not None and rails_after:
            # what the held stretches would have read: their motion, through the rails after
            # (the output stays near its mean over a stretch; its spread taken as the
            # unconditional one at the rails): E[clip(N(held, σ²))]
            from vrelab.models.clipping import censored_mean_shift

            for low, high, sig_r in rails_after:
                if sig_r > 0:
                    held = held + float(censored_mean_shift(held, sig_r, low, high))
        over += float(design.overrange_vre(mean, sigma, thr, hold, nu0, value_g=value, tone_peaks_g=peaks,
                                           tone_freqs_hz=freqs, held_mean_g=held))
    total = clip + nonlin + over
    big = max(abs(clip), abs(nonlin), abs(over))
    if big > 0 and abs(over) > _MINOR * big and shape != "sine":
        valid = False
        notes.append("over-range share is large: the Rice×hold estimate (mean of the held stretches from Rice's "
                     "conditioning on the crossing, holds taken as not overlapping) is rough"
                     + (" (Rice's rate for the Gaussian part with the tones as a moving mean)"
                        if shape == "sine-on-random" else "") + " — simulate")
    if reading.unmodelled:
        notes.append(f"stage(s) {', '.join(reading.unmodelled)} have no closed form — simulate")
    tilt, why = tilt_note(total, g0)
    if why and tilt_note(0.0, g0)[1] is None:  # the static field's own case is one note of the prediction
        notes.append(why)
    return LevelPrediction(
        rms_g=rms_g,
        vre_g=total,
        tilt_error_deg=tilt,
        shares={
            "clip_low_g": clip_low,
            "clip_high_g": clip_high,
            "clip_g": clip,
            "nonlinearity_g": nonlin,
            "overrange_g": over,
        },
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
