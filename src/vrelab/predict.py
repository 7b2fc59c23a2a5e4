"""Analytic VRE of a sensor in a vibration environment, without simulating it.

The sensor's mechanisms (SPEC 1) are evaluated one by one with the closed forms of
:mod:`vrelab.models`, each fed the vibration that reaches it through the sensor's linear
dynamics (:meth:`vrelab.sensor.Sensor.linear_responses`):

* **clipping** at each rail, with the rms that reaches the clip: at the proof mass
  (``σ_m² = ∫S·|H_mech|²df``) or, for an output-stage clip, after the anti-alias and digital
  filters (``σ_out² = ∫S·|H_mech·H_aa·H_lpf|²df``, SPEC 1.3) — censored or truncated mean of a
  Gaussian (random) or the sine closed form;
* **nonlinearity** on the proof-mass motion: ``(k2 + 3·k3·g0)·σ_m²`` (SPEC 1.2, plus the k4
  terms), exact for a cubic polynomial and any zero-mean vibration;
* **over-range protection**: Rice's up-crossing rate of the threshold by the Gaussian
  proof-mass motion times the hold time (:func:`vrelab.models.design.overrange_vre`).

The total is their sum. That is an approximation: the mechanisms interact (the clip sees the
output of the polynomial; while the protection holds, neither clips), the over-range model
assumes rare, non-overlapping holds, and the random case assumes a Gaussian drive. Each level
carries ``valid`` and ``notes`` saying where these assumptions stop holding, so a user knows
when to run the simulation (:mod:`vrelab.shaker`) instead.

How close: where ``valid`` holds, the tests hold the prediction within 3 standard
uncertainties of the simulated test plus 10 % (random, ADXL355 ±2 g Z at 1-2 g rms; output and
proof-mass clips) and within 3u + 1 % for the sine nonlinearity through the resonance. Beyond
(over-range protection firing often, ADXL355 X at 4 g rms on ±8 g) the estimate can be off by
a factor of two, and ``valid`` is False.
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
from vrelab.models.clipping import Kind as ClipKind
from vrelab.profiles import RandomProfile
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
    second.
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

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "rms_g": self.rms_g,
            "vre_g": finite_or_none(self.vre_g),
            "tilt_error_deg": finite_or_none(self.tilt_error_deg),
        }
        if self.freq_hz is not None:
            d["freq_hz"] = self.freq_hz
        d.update(
            shares={k: finite_or_none(v) for k, v in self.shares.items()},
            sigma_proof_mass_g=finite_or_none(self.sigma_proof_mass_g),
            sigma_output_g=finite_or_none(self.sigma_output_g),
            sigma_at_clip_g=finite_or_none(self.sigma_at_clip_g),
            overrange_rate_hz=finite_or_none(self.overrange_rate_hz),
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

    @property
    def valid(self) -> bool:
        return all(lv.valid for lv in self.levels)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "prediction",
            "conditions": self.conditions.to_dict(),
            "levels": [lv.to_dict() for lv in self.levels],
            "valid": self.valid,
            "notes": list(self.notes),
        }


# --- the sensor's linear dynamics ---------------------------------------------------------------


Response = Callable[[NDArray[np.float64]], NDArray[np.complex128]]


def _responses(sensor: Any, where: str) -> list[Response]:
    return list(sensor.linear_responses(where))


def _spectral(profile: RandomProfile, responses: Sequence[Response], sensor: Any) -> tuple[float, float]:
    """(σ² [g²], ν0 [Hz]) of the profile seen through ``responses``.

    ``σ² = ∫S·|H|²df`` (:func:`vrelab.models.dynamics.effective_rms`) and Rice's zero
    up-crossing rate ``ν0 = sqrt(∫f²·S·|H|²df / σ²)``
    (:func:`vrelab.models.dynamics.zero_crossing_rate_hz`), over the profile's band, split at
    its breakpoints and at the sensor's resonance.
    """
    from vrelab.models import dynamics

    lo, hi = profile.band
    psd = (np.asarray(profile.freq_hz), np.asarray(profile.psd_g2_per_hz))
    points = [float(sensor.fn_hz)] if getattr(sensor, "fn_hz", None) else []
    sigma = dynamics.effective_rms(psd, responses, lo, hi, points_hz=points)
    nu0 = dynamics.zero_crossing_rate_hz(psd, responses, lo, hi, points_hz=points)
    return sigma**2, nu0


def _clip_where(sensor: Any) -> str:
    pos = str(getattr(sensor, "clip_position", "output") or "output")
    return "output" if pos == "output" else "proof-mass"


def _rails(sensor: Any) -> tuple[float, float]:
    low, high = sensor.rails_g
    return float(low), float(high)


# --- prediction ---------------------------------------------------------------------------------


def predict(
    sensor: "Sensor",
    excitation: RandomProfile | float | Sequence[float],
    levels: Sequence[float],
    static_g: float = 1.0,
    kind: ClipKind = "censored",
) -> Prediction:
    r"""Predict VRE at each vibration level, by mechanism, without simulating.

    Parameters
    ----------
    sensor : vrelab.sensor.Sensor
        Rails, clip position, linear dynamics, k2/k3, over-range protection.
    excitation : RandomProfile, float or sequence of float
        A random profile (its shape is scaled to each level, Gaussian drive assumed) or sine
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
    Random drive with PSD S(f), proof-mass response ``H_m``, output response ``H_out``:

    * ``σ_m² = ∫S|H_m|²df``, ``σ_out² = ∫S|H_out|²df`` (SPEC 1.3);
    * clipping: :func:`vrelab.models.clipping.censored_mean_shift` ``(g0, σ_clip, L, U)``,
      each rail alone and both;
    * nonlinearity: :func:`vrelab.models.nonlinearity.vre_poly` on σ_m:
      ``(k2 + 3·k3·g0)·σ_m² + k4·(6·g0²·σ_m² + E[x⁴])`` (SPEC 1.2);
    * over-range: :func:`vrelab.models.design.overrange_vre` ``(g0, σ_m, threshold, hold,
      ν0)`` with ``ν0`` Rice's zero-crossing rate of the proof-mass motion.

    Sine at f, rms A/√2: the same with ``σ_m = rms·|H_m(f)|``, ``σ_out = rms·|H_out(f)|`` and
    :func:`~vrelab.models.clipping.sine_clip_mean_shift`. A sine whose proof-mass peak reaches
    the over-range threshold trips every period: not modelled (``valid`` False).

    References
    ----------
    .. [1] SPEC sections 1.1-1.3 (after the ADI article on VRE in MEMS accelerometers).
    .. [2] S. O. Rice, "Mathematical analysis of random noise", Bell Syst. Tech. J. 23 (1944):
       up-crossing rate ``ν0·exp(-(a-μ)²/(2σ²))``.
    """
    levels_arr = V.positive("levels", np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    if levels_arr.ndim != 1 or levels_arr.size == 0:
        raise ValueError(f"levels must be a non-empty list of rms values, got {levels!r}")
    g0 = V.finite_scalar("static_g", static_g)
    V.one_of("kind", kind, ("censored", "truncated"))
    clip_where = _clip_where(sensor)
    resp_m = _responses(sensor, "proof-mass")
    resp_out = _responses(sensor, "output")
    notes: list[str] = []
    out: list[LevelPrediction] = []
    if isinstance(excitation, RandomProfile):
        m0_m, nu0_m = _spectral(excitation, resp_m, sensor)
        m0_out, _ = _spectral(excitation, resp_out, sensor)
        m0_clip = m0_out if clip_where == "output" else m0_m
        m0_drive = excitation.mean_square_g2
        for rms in levels_arr:
            scale = float(rms) ** 2 / m0_drive
            out.append(_level(sensor, float(rms), None, g0, kind, "gaussian",
                              math.sqrt(m0_m * scale), math.sqrt(m0_out * scale),
                              math.sqrt(m0_clip * scale), nu0_m))
        text = excitation.describe().split(",")[0] + (f" ({excitation.name})" if excitation.name else "")
        notes.append("random drive assumed Gaussian (a clipped or high-kurtosis drive needs `simulate`)")
    else:
        freqs = np.atleast_1d(V.positive("freq_hz", np.asarray(excitation, dtype=np.float64)))
        from vrelab.models.dynamics import rms_through

        for f in freqs:
            for rms in levels_arr:
                sm = float(rms_through(float(f), float(rms), resp_m))
                so = float(rms_through(float(f), float(rms), resp_out))
                sc = so if clip_where == "output" else sm
                out.append(_level(sensor, float(rms), float(f), g0, kind, "sine", sm, so, sc, float(f)))
        text = "sine " + ", ".join(f"{f:g}" for f in freqs) + " Hz"
    notes.append(f"clip modelled at the {clip_where} ({kind}); mechanisms added as independent")
    base = sensor.conditions(static_g=g0, profile=text, model=f"prediction-{kind}")
    cond = dataclasses.replace(base, extra={**dict(base.extra), "clip_position": clip_where})
    return Prediction(cond, tuple(out), tuple(notes))


def _level(
    sensor: Any,
    rms_g: float,
    freq_hz: float | None,
    g0: float,
    kind: ClipKind,
    shape: Literal["gaussian", "sine"],
    sigma_m: float,
    sigma_out: float,
    sigma_clip: float,
    nu0_hz: float,
) -> LevelPrediction:
    from vrelab.models import clipping, design, nonlinearity

    low, high = _rails(sensor)
    notes: list[str] = []
    valid = True
    if not low < g0 < high:
        valid = False
        notes.append(f"the static field {g0:g} g is at or beyond a rail [{low:g}, {high:g}] g: the sensor "
                     "is saturated without vibration — simulate")

    def shift(lo: float, hi: float) -> float:
        # VRE is measured against the vibration-off reading, which a static field beyond a
        # rail already clips: subtract the shift at zero vibration.
        with_vibration = float(clipping.mean_shift(g0, sigma_clip, lo, hi, shape, kind))
        return with_vibration - float(np.clip(g0, lo, hi) - g0)

    clip_low, clip_high, clip = shift(low, math.inf), shift(-math.inf, high), shift(low, high)
    nonlin = float(nonlinearity.vre_poly(sigma_m, sensor.k2_per_g, sensor.k3_per_g2, sensor.k4_per_g3,
                                         static_g=g0, shape=shape))

    over = 0.0
    rate = 0.0
    if sensor.overrange_threshold_g is not None:
        thr = float(sensor.overrange_threshold_g)
        hold = float(sensor.overrange_hold_s)
        value = float(sensor.overrange_value_g)
        if shape == "gaussian":
            rate = _overrange_rate(thr, g0, sigma_m, nu0_hz)
            over = float(design.overrange_vre(g0, sigma_m, thr, hold, nu0_hz, value_g=value))
            duty = rate * hold
            if duty > _MAX_HOLD_DUTY:
                valid = False
                notes.append(
                    f"over-range holds fill {100 * duty:.0f} % of the time: holds overlap, "
                    "the rare-event model fails — simulate"
                )
        else:
            peak = math.sqrt(2) * sigma_m
            if abs(g0) + peak > thr:
                valid = False
                rate = freq_hz or 0.0
                notes.append(
                    f"sine peak at the proof mass ({abs(g0) + peak:.3g} g) reaches the over-range "
                    f"threshold ({thr:g} g): trips every period, not modelled — simulate"
                )
    total = clip + nonlin + over
    big = max(abs(clip), abs(nonlin), abs(over))
    if big > 0:
        if abs(over) > _MINOR * big and shape == "gaussian":
            valid = False
            notes.append("over-range share is large: the Rice×hold estimate is rough — simulate")
        if abs(clip) > _MINOR * big and abs(nonlin) > _MINOR * big:
            notes.append("clipping and nonlinearity both matter: not separable, their sum is approximate")
    tilt = float(design.tilt_error_deg(total))
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
    )


def _overrange_rate(threshold_g: float, mean_g: float, sigma_g: float, nu0_hz: float) -> float:
    """Expected over-range trips per second: up-crossings of +threshold plus down-crossings
    of -threshold by Gaussian motion N(mean, σ²) (Rice, via :mod:`vrelab.models.dynamics`)."""
    from vrelab.models import dynamics

    up = dynamics.rice_upcrossing_rate(threshold_g, mean_g, sigma_g, nu0_hz)
    down = dynamics.rice_upcrossing_rate(threshold_g, -mean_g, sigma_g, nu0_hz)
    return float(up) + float(down)
