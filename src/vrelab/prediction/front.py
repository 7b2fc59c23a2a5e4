"""The one front door of the analytic prediction: a vibration along any direction of the part's
frame, a static field as a scalar along the sensed axis or a vector (physics §1.1-1.6)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab.models.kinds import DEFAULT_CLIP_KIND

if TYPE_CHECKING:
    from vrelab.models.clipping import Kind as ClipKind
    from vrelab.prediction.results import Prediction
    from vrelab.profiles import RandomProfile, SineOnRandom
    from vrelab.sensor import Sensor
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine


def predict(
    sensor: Sensor,
    vibration: RandomProfile | SineOnRandom | float | Sequence[float] | TriaxialProfile | TriaxialSine,
    levels: Sequence[float] | NDArray[np.float64],
    static_g: float | ArrayLike = 1.0,
    kind: ClipKind = DEFAULT_CLIP_KIND,
    *,
    direction: ArrayLike | None = None,
) -> Prediction:
    r"""Predict the VRE of one sensor axis at each vibration level, by mechanism, without simulating.

    Parameters
    ----------
    sensor : vrelab.sensor.Sensor
        One axis, read through :meth:`~vrelab.sensor.Sensor.stages` (the stages the simulation
        runs); off its input axis also its sensitivity row, triad and IEEE 1293 cross-coupling
        coefficients (physics §1.6).
    vibration : RandomProfile, SineOnRandom, sine frequencies [Hz], TriaxialProfile or TriaxialSine
        Along the sensed axis unless ``direction`` is given: a random profile (its shape scaled
        to each level, Gaussian drive), a sine-on-random profile (random part and tones scaled
        together) or sine frequencies (each level at each frequency in turn). A
        :class:`~vrelab.triaxial.TriaxialProfile` (a cross-spectral density over x, y, z) or
        :class:`~vrelab.triaxial.TriaxialSine` carries its own directions.
    levels : sequence of float
        Vibration levels [g rms], each > 0: the drive's rms (along a direction, the rms along it;
        triaxial, the total rms ``sqrt(trace ∫S df)``).
    static_g : float or three floats
        The static acceleration [g]: a number is along the sensed (input) axis, three numbers
        the vector in the part's frame (``(0, 0, 1)``: z up in 1 g).
    kind : {"censored", "truncated"}
        Clipping model (physics §1.1); censored is what a saturating sensor does.
    direction : three floats, optional
        The direction in the part's frame along which a single-axis profile or one sine
        frequency is applied (normalised): ``a = d·x(t)``.

    Returns
    -------
    Prediction
        Per level ``vre_g`` [g] with its shares by mechanism, ``model_error_g``, ``u_vre_g``
        where the sensor carries parameter uncertainties, ``valid`` and ``notes``; off the input
        axis also the cross terms' shares (``cross_kip_g`` ... ``cross_g``), the sensed rms and
        the proof-mass covariance, and the conditions carry the excitation, static vector, triad,
        sensitivity row and coefficients.

    Notes
    -----
    The model of one axis (physics §1.6, IEEE Std 1293-2018's model equation): the acceleration
    ``a = g + x`` passes the axis's linear front end ``H``, ``b = H*a``, then

    ``y = P(w·b) + Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``

    and the rest of its chain. ``VRE = VRE_1(u) + pass·Σ K_jk·Re ∫S_jk|H|²df``: ``VRE_1`` the
    stages' mean shifts walked in signal order for the sensed vibration ``u = w·b``
    (:func:`vrelab.prediction.single.predict`, physics §1.1-1.3), the cross terms in closed form
    passed through the rails and over-range to first order
    (:mod:`vrelab.prediction.triaxial`). A single-axis vibration with a scalar static field,
    the case of physics §1.1-1.5, is the first term alone: that call is
    :func:`vrelab.prediction.single.predict`, whose numbers the triaxial model gives along the
    input axis with every cross term 0 (tests/test_triaxial_predict.py).

    References
    ----------
    .. [1] docs/physics.md §1.1-1.6 (after the ADI article on VRE in MEMS accelerometers).
    .. [2] IEEE Std 1293-2018: the model equation's cross-coupling terms.

    Examples
    --------
    The ADXL355 at ±2 g, axis up in a 1 g field, under a 2 g rms sine at 100 Hz: the analytic VRE
    with its standard uncertainty from the datasheet's ranges (the simulated test of
    :func:`vrelab.simulate` reads -440 mg too). A profile (``vrelab.parse_profile("flat:50-2000")``)
    in place of the frequency predicts a random test.

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> prediction = vrelab.predict(sensor, 100.0, [2.0], static_g=1.0)
    >>> level = prediction.levels[0]
    >>> print(f"{level.rms_g:.1f} g rms: VRE {level.vre_g * 1e3:.0f} ± {level.u_vre_g * 1e3:.1f} mg, valid {level.valid}")
    2.0 g rms: VRE -440 ± 1.9 mg, valid True
    """
    from vrelab.prediction import single

    if direction is None and np.ndim(static_g) == 0 and not _is_triaxial(vibration):
        pred = single.predict(sensor, cast(Any, vibration), levels, static_g=cast(float, static_g), kind=kind)
    else:
        from vrelab.prediction import triaxial

        pred = triaxial.predict_along(sensor, vibration, levels, static_g, kind, direction)
    return _with_mount_note(pred, sensor, vibration)


def _with_mount_note(pred: Prediction, sensor: Sensor, vibration: object) -> Prediction:
    """The prediction with the fixture rule's warning on the sensor's mount (:func:`vrelab.prediction.checks.mount_note`)
    among its notes, where it has one."""
    if getattr(sensor, "mount_fn_hz", None) is None:
        return pred  # no mount: the prediction as it was, untouched
    import dataclasses

    from vrelab.prediction.checks import mount_note

    band = getattr(vibration, "band", None)
    if band is None:  # sine frequencies: a number, a list, or a triaxial sine's
        freqs = np.atleast_1d(np.asarray(getattr(vibration, "freq_hz", vibration), dtype=float))
        band = (float(freqs.min()), float(freqs.max()))
    note = mount_note(sensor, (float(band[0]), float(band[1])))
    return pred if note is None else dataclasses.replace(pred, notes=(*pred.notes, note))


def _is_triaxial(vibration: object) -> bool:
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

    return isinstance(vibration, (TriaxialProfile, TriaxialSine))

