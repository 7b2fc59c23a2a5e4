"""What a prediction returns: :class:`Prediction`, one :class:`LevelPrediction` a level."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from vrelab._display import Shown
from vrelab._format import finite_or_none
from vrelab.models.memoryless import REFERENCE
from vrelab.results import Conditions, Estimate, level_vrc


@dataclass(frozen=True, repr=False)
class LevelPrediction(Shown):
    """Predicted VRE at one vibration level, with its shares by mechanism.

    ``shares`` [g]: ``clip_low_g``, ``clip_high_g`` (each rail alone), ``clip_g`` (both
    rails), ``nonlinearity_g``, ``overrange_g``. ``vre_g`` is ``clip_g + nonlinearity_g +
    overrange_g``. ``sigma_*`` are rms values [g] of the vibration at the proof mass, at the
    output (after all filters) and at the clip; ``overrange_rate_hz`` the expected trips per
    second. The shares are each stage's change of the mean in signal order (see
    :func:`_level`). ``model_error_g`` [g] bounds what the remaining approximation (rails after
    filters that follow the nonlinearity) may add: 0 where polynomial and rails are evaluated
    exactly; ``valid`` is False where it may exceed ``u_vre_g`` (or, without one, 1 % of |VRE|).

    Off the input axis (a vibration along a direction, a triaxial one or a static vector: physics
    §1.6; None otherwise): ``shares`` also hold the cross terms after the rails and over-range
    (``cross_kip_g`` ... ``cross_kpo_g``, their sum ``cross_g``, in ``vre_g``), ``rms_g`` is the
    total rms; ``axis_rms_g``: the vibration's rms along x, y, z at this level;
    ``sensed_rms_g``: rms of ``w_eff·a`` (the vibration the axis senses, before its dynamics;
    ``w_eff = w + 2Kg``: the static vector across the cross terms adds a sensitivity to the
    other axes); ``proof_mass_cov_g2``: ``E[b bᵀ]`` over x, y, z at the proof mass;
    ``cross_pass``: the factor the rails and over-range pass the cross terms' mean with;
    ``cross_unpassed_g``: the cross terms' mean before them; ``cross_error_g``: the cross terms'
    part of ``model_error_g`` (what their first-order pass through the rails and over-range may
    miss, and what the rails may make of the zero-mean part of the polynomial's move: the
    polynomial sees ``w·b``, the rails ``w_eff·b``, and the mean of the difference is taken off
    exactly).

    Examples
    --------
    One level of a prediction: its VRE, u, shares by mechanism and whether it is valid.

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> level = vrelab.predict(sensor, 100.0, [1.0], static_g=1.0).levels[0]
    >>> print(f"{level.rms_g:.1f} g rms at {level.freq_hz:.0f} Hz: VRE {level.vre_g * 1e3:.1f} ± {level.u_vre_g * 1e3:.1f} mg, {level.valid}")
    1.0 g rms at 100 Hz: VRE -57.1 ± 0.8 mg, True
    >>> sorted(level.shares)[:3]
    ['clip_g', 'clip_high_g', 'clip_low_g']
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
    # off the input axis only (physics §1.6, see above): None for a vibration along it
    sensed_rms_g: float | None = None
    axis_rms_g: tuple[float, ...] | None = None
    proof_mass_cov_g2: tuple[tuple[float, ...], ...] | None = None
    cross_pass: float | None = None
    cross_unpassed_g: float | None = None
    cross_error_g: float | None = None
    _SHOW = ("freq_hz", "rms_g", "vre", "vrc", "model_error_g", "valid", "notes")

    @property
    def vre(self) -> Estimate:
        """The predicted VRE [g] and its u as an :class:`~vrelab.results.Estimate`, the shape of a
        measured level's ``vre`` (``vre_g`` and ``u_vre_g``; u NaN where the sensor carries no
        covariance: unknown, not zero)."""
        return Estimate(self.vre_g, math.nan if self.u_vre_g is None else self.u_vre_g, "g")

    @property
    def vrc(self) -> Estimate:
        """The level's VRC [µg/g²] and its u, as a measured level's ``vrc``
        (``vrc_ug_per_g2``, ``u_vrc_ug_per_g2``; u NaN without ``u_vre_g``)."""
        u = self.u_vrc_ug_per_g2
        return Estimate(self.vrc_ug_per_g2, math.nan if u is None else u, "ug/g^2")

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
        if self.sensed_rms_g is not None:  # off the input axis
            d.update(sensed_rms_g=finite_or_none(self.sensed_rms_g),
                     axis_rms_g=[finite_or_none(v) for v in self.axis_rms_g or ()],
                     proof_mass_cov_g2=[[finite_or_none(v) for v in row] for row in self.proof_mass_cov_g2 or ()],
                     cross_pass=finite_or_none(self.cross_pass), cross_unpassed_g=finite_or_none(self.cross_unpassed_g),
                     cross_error_g=finite_or_none(self.cross_error_g))
        return d


@dataclass(frozen=True, repr=False)
class Prediction(Shown):
    """The analytic VRE of a sensor at each level of one excitation.

    ``excitation``: off the input axis (physics §1.6), what the conditions carry of the vibration
    (kind, per-axis rms per unit total rms, coherences and phases, or a sine's direction); None
    along it. Its ``to_dict`` then has ``kind`` "triaxial-prediction".

    Examples
    --------
    The levels of one excitation, and the reading with the vibration off that each VRE is referred
    to. A triaxial vibration gives a Prediction too (a sine at 45° between the ADXL355's z axis and
    x: 0.707 g rms along z, the IEEE 1293 cross terms included).

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> prediction = vrelab.predict(sensor, 100.0, [0.5, 1.0], static_g=1.0)
    >>> len(prediction.levels), prediction.valid, prediction.conditions.sensor
    (2, True, 'adxl355')
    >>> print(f"vibration off: {prediction.vibration_off_g:.4f} g")
    vibration off: 1.0000 g
    >>> tri = vrelab.predict(sensor, vrelab.TriaxialSine(100.0, (1.0, 0.0, 1.0)), [1.0], static_g=(0, 0, 1))
    >>> print(f"{tri.levels[0].sensed_rms_g:.3f} g rms sensed: VRE {tri.levels[0].vre_g * 1e3:.3f} mg")
    0.707 g rms sensed: VRE 0.010 mg
    """

    conditions: Conditions
    levels: tuple[LevelPrediction, ...]
    notes: tuple[str, ...] = field(default=())
    # every vre_g is the mean output with vibration less this reading (physics §1.5) [g]
    vibration_off_g: float = math.nan
    excitation: Mapping[str, Any] | None = None
    _SHOW = ("conditions", "levels", "valid", "notes")
    _ROWS = "levels"

    @property
    def valid(self) -> bool:
        return all(lv.valid for lv in self.levels)

    def to_dict(self) -> dict[str, Any]:
        d = {
            "kind": "prediction" if self.excitation is None else "triaxial-prediction",
            "conditions": self.conditions.to_dict(),
            "reference": REFERENCE,
            "vibration_off_g": finite_or_none(self.vibration_off_g),
            "levels": [lv.to_dict() for lv in self.levels],
            "valid": self.valid,
            "notes": list(self.notes),
        }
        if self.excitation is not None:
            d["excitation"] = dict(self.excitation)
        return d

