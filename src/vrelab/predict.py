"""Analytic VRE of a sensor in a vibration environment, without simulating it.

The sensor is read through :meth:`vrelab.sensor.Sensor.stages`, the same tuple of stages the
simulation runs, walked in signal order: each stage that changes the mean gives its own change
(its ``mean_shift``, :mod:`vrelab.sensor.meanshift`), fed the vibration that reaches it through
the linear stages before it and the static level the offsets before it leave (SPEC 1.3), and
predict sums what they say:

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
levels and coefficients (and adaptive quadrature for issue 18's part: +9.14/+16.17 mg), the
filtered case against a numpy Monte Carlo of the chain within ``model_error_g``, and the
simulated test within 3u + 10 % (ADXL355 ±2 g Z at 1-2 g rms). Over-range firing often
(ADXL355 X at 4 g rms on ±8 g: -96 mg against the simulation's -110 ± 5 mg) is not valid.
"""

from __future__ import annotations

import dataclasses
import functools
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
from vrelab.results import Conditions, level_vrc
from vrelab.sensor.meanshift import NUMERICAL_SHARE, SHARES, VRE_SHARES, Done, Drive, Motion, Response, Site
from vrelab.sensor.meanshift import response_key as _response_key

if TYPE_CHECKING:
    from vrelab.sensor import Sensor


# Shares below this fraction of the largest one are "negligible" in the validity notes.
_MINOR = 0.1


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
    # valid apart from the judgement of model_error_g against a u (:func:`judged`): a caller
    # with its own u (identify, each level's measured u) judges the bound itself
    valid_otherwise: bool = True

    @property
    def vrc_ug_per_g2(self) -> float:
        """The level's VRC, ``vre_g / rms_g²`` [µg/g²] (:func:`vrelab.results.level_vrc`): what a
        datasheet quotes, beside the VRE."""
        return level_vrc(self.vre_g, self.rms_g)[0]

    @property
    def u_vrc_ug_per_g2(self) -> float | None:
        """The VRC's standard uncertainty [µg/g²], ``u_vre_g / rms_g²`` (the level is exact); None
        without ``u_vre_g``."""
        return level_vrc(self.vre_g, self.rms_g, self.u_vre_g)[1]

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
        d["vrc_ug_per_g2"] = finite_or_none(self.vrc_ug_per_g2)
        if self.u_vre_g is not None:
            d["u_vrc_ug_per_g2"] = finite_or_none(self.u_vrc_ug_per_g2)
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


@dataclass(frozen=True)
class _Site:
    """A stage with a mean shift (its own ``mean_shift``, or the numerical fallback), and what
    reaches it: the linear stages before it, the offsets added before it, and the static level
    reaching it with no vibration."""

    stage: Any
    responses: tuple[Response, ...]  # the linear stages before it
    offset_g: float  # offsets added before it
    vibration_off_g: float  # the static level reaching it with no vibration


@dataclass(frozen=True)
class _Reading:
    """A sensor's stages, read once for the analytic model at one static field."""

    sites: tuple[_Site, ...]
    proof_mass: tuple[Response, ...]  # the mechanical responses (resonance)
    output: tuple[Response, ...]  # every linear response
    unmodelled: tuple[str, ...]  # stages with memory that say nothing of their mean
    numerical: tuple[str, ...]  # memoryless stages without a closed form (quadrature)
    vibration_off_g: float  # the reading with no vibration (SPEC 1.5)
    reference_note: str | None  # where the rails clip that reading


def _read_stages(stages: Sequence[Any], g0: float) -> _Reading:
    """Walk the stages in order, as the signal goes (SPEC 1.3), asking each what it does
    (:mod:`vrelab.sensor.meanshift`): a linear stage (``response``) shapes what every later
    stage sees, an offset (``static_shift_g``) moves the static level of every later stage, a
    stage with a ``mean_shift`` becomes a site evaluated with the vibration that reaches it,
    ``zero_mean_shift`` shifts nothing; a memoryless stage that says none of these gets the
    numerical fallback (:class:`vrelab.sensor.meanshift.Numerical`). The static level ``g0`` is
    walked through the stages too (their ``vibration_off``; the linear stages pass it): the
    vibration-off reading every VRE is referred to, and the level reaching each site."""
    from vrelab.sensor.meanshift import Numerical
    from vrelab.sensor.stages import Resonator

    responses: list[Response] = []
    mechanical: list[Response] = []
    offset = 0.0
    level, note = g0, None
    sites: list[_Site] = []
    unmodelled: list[str] = []
    numerical: list[str] = []
    for st in stages:
        if hasattr(st, "response"):
            responses.append(st.response)
            if isinstance(st, Resonator):
                mechanical.append(st.response)
            continue
        shift = getattr(st, "static_shift_g", None)
        if shift is not None:
            offset += float(shift)
            level = level + float(shift)
            continue
        if getattr(st, "zero_mean_shift", None):
            continue
        if not hasattr(st, "mean_shift"):
            if not (getattr(st, "is_static", False) and getattr(st, "rate_factor", 1) == 1):
                unmodelled.append(type(st).__name__)
                continue
            numerical.append(type(st).__name__)
            st = Numerical(st)
        sites.append(_Site(st, tuple(responses), offset, level))
        if hasattr(st, "vibration_off"):
            level, why = st.vibration_off(level)
            note = note or why
    return _Reading(tuple(sites), tuple(mechanical), tuple(responses), tuple(unmodelled), tuple(numerical),
                    level, note)


def _spectral(profile: RandomProfile, responses: Sequence[Response], points_hz: Sequence[float],
              rate: bool = True) -> tuple[float, float]:
    """(σ² [g²], ν0 [Hz]) of the profile seen through ``responses``.

    ``σ² = ∫S·|H|²df`` (:func:`vrelab.models.dynamics.effective_rms`) and Rice's zero
    up-crossing rate ``ν0 = sqrt(∫f²·S·|H|²df / σ²)``
    (:func:`vrelab.models.dynamics.zero_crossing_rate_hz`), over the profile's band, split at
    its breakpoints and at the sensor's resonance. Without ``rate`` (a site that needs no
    crossing rate) ν0 is NaN and its two integrals are not computed.

    The integrals are remembered by their exact inputs (:func:`_spectral_of`) where every
    response is a stage's: an identification or a propagation predicts again and again with
    parameters that leave the resonance and the filters as they were (a polynomial's or a rail's
    step), and the adaptive quadrature is most of a random level's prediction.
    """
    keys = tuple(_response_key(h) for h in responses)
    # the table as its float64 bytes: an exact key, 8 bytes a point
    freq = np.ascontiguousarray(profile.freq_hz, dtype=np.float64).tobytes()
    psd = np.ascontiguousarray(profile.psd_g2_per_hz, dtype=np.float64).tobytes()
    band = tuple(float(b) for b in profile.band)
    points = tuple(float(p) for p in points_hz)
    if all(k is not None for k in keys):
        return _spectral_of(freq, psd, band, keys, points, rate)
    return _spectral_at(freq, psd, band, responses, points, rate)


@functools.lru_cache(maxsize=256)
def _spectral_of(freq: bytes, psd: bytes, band: tuple[float, ...], keys: tuple[tuple[Any, Any], ...],
                 points: tuple[float, ...], rate: bool) -> tuple[float, float]:
    """:func:`_spectral_at` with the responses given as :func:`_response_key` values. A pure
    function of its exact inputs: cached, bounded (a fit's few profiles and resonances)."""
    return _spectral_at(freq, psd, band, [f.__get__(owner) for f, owner in keys], points, rate)


def _spectral_at(freq: bytes, psd: bytes, band: Sequence[float], responses: Sequence[Response],
                 points_hz: Sequence[float], rate: bool) -> tuple[float, float]:
    """:func:`_spectral` of the profile's table ``(freq, psd)`` (float64 bytes) over ``band``."""
    from vrelab.models import dynamics

    lo, hi = band
    table = (np.frombuffer(freq, dtype=np.float64), np.frombuffer(psd, dtype=np.float64))
    sigma = dynamics.effective_rms(table, list(responses), lo, hi, points_hz=list(points_hz))
    if not rate:
        return sigma**2, math.nan
    nu0 = dynamics.zero_crossing_rate_hz(table, list(responses), lo, hi, points_hz=list(points_hz))
    return sigma**2, nu0


@dataclass(frozen=True)
class _HoldWeight:
    """The non-negative weight |W(f)| under which the hold's correlation integrals are spectral
    integrals ∫S·|H·W|² (:func:`_hold_correlation`): ``sqrt(1 - sinc(2f·hold))`` for the
    correlation averaged over the hold, ``sqrt(2)·|sin(πf·hold)|`` for ``1 - ρ(hold)``. A frozen
    dataclass, so :func:`_spectral` remembers its integrals as it does a stage's."""

    hold_s: float
    end: bool

    def response(self, f: NDArray[np.float64]) -> NDArray[np.complex128]:
        if self.end:
            return (math.sqrt(2.0) * np.abs(np.sin(np.pi * np.asarray(f) * self.hold_s))).astype(complex)
        return np.sqrt(np.maximum(1.0 - np.sinc(2.0 * np.asarray(f) * self.hold_s), 0.0)).astype(complex)


def _hold_correlation(profile: RandomProfile, responses: Sequence[Response], points_hz: Sequence[float],
                      hold_s: float, m0: float) -> tuple[float, float]:
    """(ρ̄, 1 - ρ(hold)) of the profile seen through ``responses``: the motion's correlation
    averaged over the hold, ``ρ̄ = ∫S·|H|²·sinc(2f·hold)df/σ²``, and ``1 - ρ(hold) =
    ∫S·|H|²·(1 - cos 2πf·hold)df/σ²``, both as ∫S·|H·W|² with a non-negative weight |W|²
    (1 - sinc and 2·sin², :class:`_HoldWeight`) so the one spectral integral (:func:`_spectral`)
    computes them."""
    if not m0 > 0:
        return math.nan, math.nan
    one_minus_mean, _ = _spectral(profile, [*responses, _HoldWeight(hold_s, False).response], points_hz, rate=False)
    one_minus_end, _ = _spectral(profile, [*responses, _HoldWeight(hold_s, True).response], points_hz, rate=False)
    return 1.0 - one_minus_mean / m0, one_minus_end / m0


def _needs_rate(site: _Site) -> bool:
    """Whether the stage at ``site`` needs Rice's crossing rate and the motion's correlation over
    its hold (over-range protection says so)."""
    return bool(getattr(site.stage, "needs_crossing_rate", False))


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


def _check_time(sensor: Sensor, excitation: Any, n_levels: int) -> None:
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
    * noise, quantisation, decimation, drift: no mean shift (each says why: ``zero_mean_shift``).
      A memoryless stage with no closed form: the mean of its map by quadrature
      (:func:`vrelab.models.memoryless.map_vre`, share ``numerical_g``, its error in
      ``model_error_g``), valid only as the chain's one nonlinearity. A stage with memory and no
      closed form makes every level invalid, naming it.

    Each stage owns its closed form (``mean_shift``, :mod:`vrelab.sensor.meanshift`); this
    function computes the vibration at each stage's site and sums what the stages say.

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
    _check_time(sensor, excitation, levels_arr.size)
    reading = _read_stages(sensor.stages(), g0)
    clip_where = _clip_where(sensor)
    notes: list[str] = []
    out: list[LevelPrediction] = []
    fn_hz = getattr(sensor, "fn_hz", None)
    if isinstance(excitation, RandomProfile):
        points = [float(fn_hz)] if fn_hz else []
        m0_drive = excitation.mean_square_g2
        # per unit drive mean square: σ²/m0 and ν0 at each site, at the proof mass and output
        # only the over-range site uses Rice's crossing rate
        seen = [_spectral(excitation, site.responses, points, rate=_needs_rate(site))
                for site in reading.sites]
        rho = [_hold_correlation(excitation, site.responses, points, float(site.stage.hold_s), m0)
               if _needs_rate(site) else (math.nan, math.nan)
               for site, (m0, _) in zip(reading.sites, seen)]
        m0_m, _ = _spectral(excitation, reading.proof_mass, points, rate=False)
        m0_out, _ = _spectral(excitation, reading.output, points, rate=False)
        for rms in levels_arr:
            scale = float(rms) ** 2 / m0_drive
            sites = [Motion(math.sqrt(m0 * scale), nu0, rho_mean=r[0], one_minus_rho_hold=r[1])
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
               if _needs_rate(site) else (math.nan, math.nan)
               for site, ((m0, _), _) in zip(reading.sites, seen_tones)]
        m0_m, _ = _spectral(rand, reading.proof_mass, points)
        m0_out, _ = _spectral(rand, reading.output, points)
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
        for f in sine_hz:
            f = float(f)
            # |H(f)| at each site, the proof mass and the output, once for every level: a sine's
            # rms there is rms·|H(f)| (vrelab.models.dynamics.rms_through, the same product)
            gains = [_gain(f, site.responses) for site in reading.sites]
            at_mass, at_out = _gain(f, reading.proof_mass), _gain(f, reading.output)
            for rms in levels_arr:
                sites = [Motion(float(rms) * g, f) for g in gains]
                out.append(_level(reading, float(rms), f, g0, kind, "sine", sites, float(rms) * at_mass,
                                  float(rms) * at_out))
        text = "sine " + ", ".join(f"{f:g}" for f in sine_hz) + " Hz"
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
    on_axis = {k: v for k, v in (getattr(sensor, "uncertainty", None) or {}).items() if not k.startswith(_OFF_AXIS)}
    if getattr(sensor, "covariance", None) or on_axis:
        if len(on_axis) < len(getattr(sensor, "uncertainty", None) or {}):
            sensor = dataclasses.replace(sensor, uncertainty=on_axis)
        prop = propagation(sensor, excitation, levels_arr, g0, kind, vre_g=np.array([lv.vre_g for lv in out]))
        out = [dataclasses.replace(lv, u_vre_g=float(prop.u_g[i]),
                                   u_sources_g={k: float(v[i]) for k, v in prop.sources_g.items()},
                                   valid=lv.valid and not prop.level_notes[i],
                                   notes=lv.notes + prop.level_notes[i]) for i, lv in enumerate(out)]
        notes += prop.notes
    out = [judged(lv) for lv in out]
    if getattr(sensor, "unstated", ()):
        out, said = unstated_check(sensor, excitation, levels_arr, g0, kind, out)
        notes += said
    why = tilt_note(0.0, g0)[1]
    if why:
        notes.append(why.replace("the static field", "the static field of every level"))
    off, off_note = reading.vibration_off_g, reading.reference_note
    notes.append(f"VRE referred to the {REFERENCE} ({off:.9g} g): mean output with vibration less that reading"
                 + (f"; {off_note}" if off_note else ""))
    return Prediction(cond, tuple(out), tuple(notes), vibration_off_g=off)


def memoryless_level(stages: Sequence[Any], static_g: float, rms_g: float,
                     shape: Literal["gaussian", "sine"] = "gaussian", kind: ClipKind = DEFAULT_CLIP_KIND,
                     each_rail: bool = True) -> tuple[LevelPrediction, float]:
    """One level of a chain of memoryless stages (no linear stage: every stage sees the same
    vibration, rms ``rms_g``, Gaussian or a sine), each stage's own mean shift summed as
    :func:`predict` sums them; and the vibration-off reading (SPEC 1.5) the VRE is referred to.

    What the sweep's ``model`` points evaluate (a polynomial, an offset and rails: one exact
    memoryless map). ``each_rail`` False skips each rail alone (``clip_low_g``/``clip_high_g``
    then 0). The level carries ``vre_g``, its shares, ``tilt_error_deg``, ``valid`` and notes,
    without the prediction's conditions.
    """
    g0 = V.finite_scalar("static_g", static_g)
    rms = float(V.non_negative("rms_g", rms_g))
    V.one_of("shape", shape, ("gaussian", "sine"))
    V.one_of("kind", kind, KINDS)
    reading = _read_stages(stages, g0)
    if reading.output:
        raise ValueError("memoryless_level takes memoryless stages; a chain with linear stages needs predict")
    motions = [Motion(rms, math.nan)] * len(reading.sites)
    lv = _level(reading, rms, None, g0, kind, shape, motions, rms, rms, each_rail)
    return lv, reading.vibration_off_g


# The approximation's error is judged against the level's u or this share of |VRE| (or 1 µg),
# whichever is larger: a prediction is not meant to be read to better than that. Without the floor,
# a preset's assumed-parameter u that happens to be tiny (the over-range threshold's, far below
# the threshold: 1e-13 g) would flag every filtered prediction for a sub-µg bound.
_TOLERANCE_REL = 0.01
_TOLERANCE_ABS_G = 1e-6
MODEL_SOURCE = "model approximation (model_error_g, rectangular)"


def judged(lv: LevelPrediction) -> LevelPrediction:
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
    ``Σ`` and one over a preset's assumptions (GUM Supplement 1).

    A filter order (a whole number: the filter's shape, which a datasheet rarely gives) has a
    span of orders as its u: its share is the larger move of the VRE to an end of the span.

    Linearity is checked, not assumed: the VRE is also evaluated at ``θ_j ± u_j``; where it
    departs from the tangent by more than ``_LINEAR`` of the tangent's step, or where ``θ ± u``
    leaves the parameter's domain (a Q whose u exceeds it), an assumed parameter's share is
    taken as the larger move (``max |VRE(θ ± u) − VRE(θ)|``, GUM 5.1.3's note), and the
    identified block is propagated by a Monte Carlo over ``Σ`` instead (GUM Supplement 1,
    :func:`_monte_carlo`); where more than ``_MC_OUTSIDE`` of its draws leave the parameters'
    domain (a Q whose u exceeds it: the campaign does not bound it) the level's u is no claim:
    ``valid`` False with a note. The assumed parameters in which the VRE is curved (a rail or a
    threshold at the edge of clipping) are cross-checked the same way, by a Monte Carlo over them
    (:func:`_assumed_monte_carlo`): where their spread exceeds the shares, the excess enters as
    its own source with a note.

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
    # assumed parameters whose VRE is not linear over their u: their shares are cross-checked by a
    # Monte Carlo over them (_assumed_monte_carlo)
    curved: dict[str, float] = {}
    for j, (name, u, identified) in enumerate(everything):
        x = parameter(sensor, name)
        if x is None or not u > 0:
            continue
        if _whole_valued(name):  # a filter order (its shape): the VRE at the span's ends, no tangent
            span = max(1, round(u))
            ends_k = [vre_at({name: k}) for k in _orders(x, span, name)]
            if any(e is None for e in ends_k) or not ends_k:
                for i in range(n_out):
                    level_notes[i].append(f"the VRE cannot be evaluated over {name} {x:g} ± {span}: u_vre_g is not a claim")
                continue
            # the larger move to an end: for a VRE monotone in the order, at least the spread of the
            # orders drawn uniformly over the span (what the tests' Monte Carlo draws)
            sources[name] = np.max([np.abs(e - f0) for e in ends_k if e is not None], axis=0)
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
            if (bent & (move > 0)).any() and wide[0] is not None and wide[1] is not None:
                curved[name] = u
    notes: list[str] = []
    # the Monte Carlo only where the curved parameters weigh: above _CURVED_SHARE of the assumed u²
    # at some level (a curve in a parameter that moves the VRE by a hundredth of the rest is not
    # worth 60 predictions; the larger move at ±u stands for it)
    assumed_u2 = sum((v**2 for v in sources.values()), np.zeros(n_out))
    weigh = sum((sources[n] ** 2 for n in curved), np.zeros(n_out))
    if curved and np.any(weigh > _CURVED_SHARE * assumed_u2):
        _assumed_monte_carlo(sensor, excitation, lv, static_g, kind, curved, sources, level_notes, notes,
                             predictor or predict)
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
        notes.append("u_vre_g dominated by " + ", ".join(f"{'assumed ' if k not in (IDENTIFIED, CURVED_SOURCE) else ''}{k} "
                                                          f"(up to {100 * share[k]:.0f} % of u²)" for k in top)
                     + "; per source in u_sources_g")
    return Propagation(np.sqrt(u2), sources, tuple(tuple(n) for n in level_notes), tuple(notes))


# Monte Carlo propagation where the linear one fails: draws, and the fraction of draws outside the
# parameters' domain (Q <= 0, rails crossing the static field) beyond which u is no claim.
_MC_DRAWS = 200
_MC_OUTSIDE = 0.15
# The assumed parameters' Monte Carlo (where the VRE is curved in them): fewer draws (each is a
# prediction; the standard deviation of 60 normal draws is known to ±9 %, enough to see an
# understatement by the tangent), and the source's name in u_sources_g.
_MC_ASSUMED_DRAWS = 60
CURVED_SOURCE = "assumed, beyond the tangent (Monte Carlo)"
_CURVED_SHARE = 0.01


def _whole_valued(name: str) -> bool:
    """Whether the assumable parameter ``name`` takes whole values only (a filter order)."""
    from vrelab.sensor.parameters import ASSUMABLE

    p = ASSUMABLE.get(name)
    return bool(p is not None and p.integer)


def _orders(x: float, span: int, name: str) -> list[int]:
    """The ends of a filter order's span ``x ± span``, within the orders the field allows (1 to its upper bound)."""
    from vrelab.sensor.parameters import ASSUMABLE

    top = int(ASSUMABLE[name].upper or 12)
    return sorted({min(max(int(round(x)) + s, 1), top) for s in (-span, span)} - {int(round(x))})


def _assumed_monte_carlo(sensor: Sensor, excitation: Any, levels: NDArray[np.float64], static_g: float,
                         kind: ClipKind, curved: Mapping[str, float], sources: dict[str, NDArray[np.float64]],
                         level_notes: list[list[str]], notes: list[str],
                         predictor: Callable[..., Prediction]) -> None:
    """Cross-check the shares of the assumed parameters in which the VRE is curved (GUM
    Supplement 1): ``_MC_ASSUMED_DRAWS`` seeded joint draws, each parameter independent and
    uniform: over the bound ``±√3·u`` its assumed standard uncertainty stands for (an assumption
    or a datasheet tolerance is a bound, read as rectangular: GUM 4.3.7, GUM S1 6.4.2; the
    presets write u = a/√3 for a bound ±a) or, for a filter order, over the whole orders of its
    span; :func:`predict` at
    each. Where the draws' standard deviation exceeds the quadrature sum of those parameters'
    shares (the tangent, or the larger move at ±u), the excess enters ``sources`` as
    :data:`CURVED_SOURCE` (so ``u_vre_g`` is the Monte Carlo's) with a note; where more than
    ``_MC_OUTSIDE`` of the draws leave the parameters' domain, the level's u is no claim."""
    from vrelab.sensor.parameters import parameter, with_parameters

    rng = np.random.default_rng(20261128)
    names = list(curved)
    centre = {n: float(parameter(sensor, n) or 0.0) for n in names}
    vre = []
    for _ in range(_MC_ASSUMED_DRAWS):
        point = {}
        for n in names:
            if _whole_valued(n):
                span = int(curved[n])
                lo = max(1, int(round(centre[n])) - span)
                point[n] = float(rng.integers(lo, int(round(centre[n])) + span + 1))
            else:  # the bound ±√3·u the u stands for (GUM 4.3.7), uniform within it
                half = math.sqrt(3.0) * curved[n]
                point[n] = float(rng.uniform(centre[n] - half, centre[n] + half))
        try:
            p = predictor(with_parameters(sensor, point), excitation, levels, static_g, kind)
        except ValueError:  # outside the parameters' domain (a rail across the static field, Q <= 0)
            continue
        vre.append([x.vre_g for x in p.levels])
    n_out = len(level_notes)
    outside = 1.0 - len(vre) / _MC_ASSUMED_DRAWS
    what = ", ".join(names)
    if outside > _MC_OUTSIDE or len(vre) < 2:
        for i in range(n_out):
            level_notes[i].append(f"a Monte Carlo over the assumed {what} leaves their domain in {100 * outside:.0f} % "
                                  "of draws: the VRE over their stated u is not known — u_vre_g is not a claim")
        return
    v = np.asarray(vre, dtype=np.float64)
    spread = v.std(axis=0, ddof=1)
    tangent = np.sqrt(sum((sources[n] ** 2 for n in names), np.zeros(n_out)))
    excess = np.sqrt(np.maximum(spread**2 - tangent**2, 0.0))
    if np.any(excess > 0):
        sources[CURVED_SOURCE] = excess
        worst = int(np.argmax(spread - tangent))
        notes.append(f"the VRE is curved in the assumed {what}: the linearised propagation understates its spread "
                     f"over their u; a Monte Carlo ({len(vre)} seeded draws, GUM S1) gives "
                     f"{1e3 * spread[worst]:.4g} mg against the tangent's {1e3 * tangent[worst]:.4g} mg: u_vre_g takes the "
                     f"Monte Carlo's (95 % of draws in [{1e3 * np.quantile(v[:, worst], 0.025):.4g}, "
                     f"{1e3 * np.quantile(v[:, worst], 0.975):.4g}] mg)")


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


# An assumption with no stated u is probed by this relative change (a conservative engineering
# spread for a number nobody bounded: a rail's headroom, a corner's convention are of this order).
PROBE_REL = 0.1
# The parameters only a vibration off the input axis reaches (SPEC 1.6; the triaxial prediction's).
_OFF_AXIS = ("cross_axis_", "kip_", "kio_", "kpp_", "koo_", "kpo_")


def unstated_check(sensor: Sensor, excitation: Any, levels: NDArray[np.float64], static_g: float, kind: ClipKind,
                   out: Sequence[LevelPrediction],
                   predictor: Callable[..., Prediction] | None = None) -> tuple[list[LevelPrediction], list[str]]:
    """The assumptions with no stated u (``sensor.unstated``: facts "assumption..." and no
    ``[uncertainty]`` or covariance entry) are never silently exact (SPEC 1.5, 6.1): each one is
    named, and where moving it by ``PROBE_REL`` (±10 %) moves a level's VRE by more than the
    level's stated u (the larger of ``u_vre_g``, 1 % of |VRE| and 1 µg), that level is not valid,
    naming the parameter and the move. A parameter at 0 cannot be moved relatively: it is named
    only. Returns the levels and the prediction's notes."""
    from vrelab.sensor.parameters import parameter, with_parameters

    levels_out = list(out)
    probed: list[str] = []
    zero: list[str] = []
    for name in sensor.unstated:
        x = parameter(sensor, name)
        if x is None:
            continue
        if x == 0:
            if not name.startswith(_OFF_AXIS):  # (off-axis terms: a single-axis vibration does not reach them)
                zero.append(name)
            continue
        probed.append(f"{name} = {x:.6g}")
        moves: list[NDArray[np.float64] | None] = []
        for r in (1 + PROBE_REL, 1 - PROBE_REL):
            try:
                p = (predictor or predict)(with_parameters(sensor, {name: x * r}), excitation, levels, static_g, kind)
                moves.append(np.array([lv.vre_g for lv in p.levels]))
            except ValueError:  # outside its domain (a rail moved across the static field)
                moves.append(None)
        for i, lv in enumerate(levels_out):
            stated = max(lv.u_vre_g or 0.0, _TOLERANCE_REL * abs(lv.vre_g), _TOLERANCE_ABS_G)
            ends = [m[i] for m in moves if m is not None]
            move = max((abs(e - lv.vre_g) for e in ends), default=math.inf) if len(ends) == 2 else math.inf
            if move > stated:
                shown = "cannot be evaluated" if not math.isfinite(move) else f"moves by up to {move * 1e3:.3g} mg"
                levels_out[i] = dataclasses.replace(lv, valid=False, notes=(*lv.notes, (
                    f"{name} = {x:.6g} is an assumption with no stated u: at ±{100 * PROBE_REL:.0f} % the VRE {shown}, "
                    f"more than its stated u ({stated * 1e3:.3g} mg) — give it a u ([uncertainty]) or measure it")))
    said = []
    if probed:
        said.append("assumed with no stated u (probed at ±{:.0f} %, not in u_vre_g): {}".format(
            100 * PROBE_REL, ", ".join(probed)))
    if zero:
        said.append("assumed exactly 0 with no stated u (not in u_vre_g): " + ", ".join(zero))
    return levels_out, said


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


# The shares are closed forms good to a few ulps each; their sum may lose this many ulps of the
# largest share (a generous bound: a handful of terms, each from differences of cdfs and pdfs).
_ROUNDING_ULPS = 64.0


def cancellation(shares: Mapping[str, float], vre_g: float) -> str | None:
    """Why a level's VRE is rounding noise, or None: where shares of opposite sign cancel
    (a nonlinearity of 1e23 g clipped back by rails) the sum keeps only ``ulps × eps × max|share|``
    of precision; beyond the tolerance a prediction is read to (1 % of |VRE| or 1 µg) the
    number is not valid — float64 arithmetic cannot hold the model there."""
    big = max((abs(v) for v in shares.values() if math.isfinite(v)), default=0.0)
    lost = _ROUNDING_ULPS * float(np.finfo(np.float64).eps) * big
    if not math.isfinite(vre_g) or lost > max(_TOLERANCE_REL * abs(vre_g), _TOLERANCE_ABS_G):
        return (f"the shares (up to {big:.3g} g) cancel to {vre_g:.3g} g, beyond what float64 arithmetic holds "
                f"(±{lost:.2g} g): the coefficients or levels are beyond the model's arithmetic")
    return None


def _level(
    reading: _Reading,
    rms_g: float,
    freq_hz: float | None,
    g0: float,
    kind: ClipKind,
    shape: Drive,
    sites: Sequence[Motion],
    sigma_m: float,
    sigma_out: float,
    each_rail: bool = True,
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
    if why and tilt_note(0.0, g0)[1] is None:  # the static field's own case is one note of the prediction
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
