"""How a predicted level is judged: its model bound against its stated u, its tilt error, float64 cancellation."""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Mapping

import numpy as np

from vrelab.prediction.results import LevelPrediction

if TYPE_CHECKING:
    pass


# a preset's assumed-parameter u that happens to be tiny (the over-range threshold's, far below
# the threshold: 1e-13 g) would flag every filtered prediction for a sub-µg bound.
TOLERANCE_REL = 0.01
TOLERANCE_ABS_G = 1e-6
MODEL_SOURCE = "model approximation (model_error_g, rectangular)"


def judged(lv: LevelPrediction) -> LevelPrediction:
    """``valid`` False where ``model_error_g`` may exceed the stated u (the larger of ``u_vre_g``
    and 1 % of |VRE| or 1 µg), with the reason. Where the level states a u (its parameters'), the
    bound also enters it as a rectangular source (GUM 4.3.7: ``model_error_g/√3``), so that
    ``u_vre_g`` is never smaller than what the approximation may add.

    Examples
    --------
    A level whose approximation error may exceed its stated u is marked not valid, with the reason:

    >>> import dataclasses
    >>> import vrelab
    >>> from vrelab.prediction.checks import judged
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> level = vrelab.predict(sensor, 100.0, [2.0], static_g=1.0).levels[0]
    >>> judged(level).valid
    True
    >>> bad = judged(dataclasses.replace(level, model_error_g=0.1, u_vre_g=None))
    >>> bad.valid
    False
    """
    if lv.model_error_g > 0 and lv.u_vre_g is not None:
        u_model = float(lv.model_error_g) / math.sqrt(3.0)
        sources = {**dict(lv.u_sources_g or {}), MODEL_SOURCE: u_model}
        judged_u: float | None = lv.u_vre_g
        lv = dataclasses.replace(lv, u_vre_g=math.hypot(lv.u_vre_g, u_model), u_sources_g=sources)
    else:
        judged_u = lv.u_vre_g
    stated = max(judged_u or 0.0, TOLERANCE_REL * abs(lv.vre_g), TOLERANCE_ABS_G)
    if lv.model_error_g <= stated:
        return lv
    what = "u_vre_g" if judged_u is not None and judged_u >= TOLERANCE_REL * abs(lv.vre_g) else "1 % of |VRE|"
    return dataclasses.replace(lv, valid=False, notes=(*lv.notes, (
        f"the rails sit after filters that follow the nonlinearity: they see its non-Gaussian output, here "
        f"modelled as Gaussian with an error up to {lv.model_error_g * 1e3:.3g} mg, more than {what} "
        f"({stated * 1e3:.3g} mg) — simulate")))



def mount_note(sensor: object, band_hz: tuple[float, float]) -> str | None:
    """The fixture rule (:func:`vrelab.models.design.fixture_resonance_ok`: a mount's resonance at
    least 1.5 × the highest test frequency) applied to a sensor's mount stage (``mount_fn_hz``,
    :class:`vrelab.sensor.configs.Mount`) in a vibration spanning ``band_hz`` [Hz]: a warning
    naming the mount where it sits within reach of the band, else None. The prediction includes
    the mount's amplification (``|T(fn)| = sqrt(1 + Q²)``); the warning says the number is the
    mount's as much as the part's.

    Examples
    --------
    An ADXL355 on a board ringing at 500 Hz with Q 10, in 20-2000 Hz (sqrt(1 + 10²) = 10.05);
    the same board stiffened to 5 kHz is beyond 1.5 × 2000 Hz and says nothing:

    >>> import vrelab
    >>> from vrelab.prediction.checks import mount_note
    >>> board = vrelab.load_sensor("adxl355", range_g=8, axis="z", odr_hz=4000,
    ...                            overrides={"mount_fn_hz": 500.0, "mount_q": 10.0})
    >>> print(mount_note(board, (20.0, 2000.0)))
    mount resonance 500 Hz (Q 10) is inside the vibration's band 20-2000 Hz (fixture rule:
    fn >= 1.5 × 2000 Hz): the mount amplifies the vibration up to ×10 at 500 Hz, and the VRE
    predicted includes it
    >>> stiff = vrelab.load_sensor("adxl355", range_g=8, axis="z", odr_hz=4000,
    ...                            overrides={"mount_fn_hz": 5000.0, "mount_q": 10.0})
    >>> print(mount_note(stiff, (20.0, 2000.0)))
    None
    """
    from vrelab.models.design import fixture_resonance_ok

    fn, q = getattr(sensor, "mount_fn_hz", None), getattr(sensor, "mount_q", None)
    if fn is None or q is None or fixture_resonance_ok(fn, band_hz[1]):
        return None
    where = "inside" if band_hz[0] <= fn <= band_hz[1] else "within 1.5× of"
    return (f"mount resonance {fn:g} Hz (Q {q:g}) is {where} the vibration's band {band_hz[0]:g}-{band_hz[1]:g} Hz "
            f"(fixture rule: fn >= 1.5 × {band_hz[1]:g} Hz): the mount amplifies the vibration up to "
            f"×{math.sqrt(1 + q * q):.3g} at {fn:g} Hz, and the VRE predicted includes it")


def tilt_note(vre_g: float, g0: float) -> tuple[float, str | None]:
    """Tilt error [deg] of a VRE on an axis at ``asin(g0)`` (:func:`vrelab.models.design.tilt_error_from_static_deg`),
    NaN with the reason where it is undefined.

    Examples
    --------
    -10 mg on an axis reading 0.5 g (30° of tilt), and on one reading exactly 1 g, where a tilt
    error is undefined:

    >>> from vrelab.prediction.checks import tilt_note
    >>> deg, note = tilt_note(-0.010, 0.5)
    >>> print(f"{deg:.3f} deg", note)
    -0.659 deg None
    >>> deg, note = tilt_note(-0.010, 1.0)
    >>> print(deg, "|", note)
    nan | tilt error undefined: the static field (1 g) is within 1 mg of ±1 g (the axis is vertical: a tilt barely moves its reading): no tilt corresponds to it
    """
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
    number is not valid — float64 arithmetic cannot hold the model there.

    Examples
    --------
    Shares that cancel to float64's last digits, and shares that do not:

    >>> from vrelab.prediction.checks import cancellation
    >>> print(cancellation({"nonlinearity_g": 1e20, "clip_g": -1e20}, 0.0))
    the shares (up to 1e+20 g) cancel to 0 g, beyond what float64 arithmetic holds (±1.4e+06 g): the coefficients or levels are beyond the model's arithmetic
    >>> print(cancellation({"nonlinearity_g": 0.0004, "clip_g": -0.083}, -0.0826))
    None
    """
    big = max((abs(v) for v in shares.values() if math.isfinite(v)), default=0.0)
    lost = _ROUNDING_ULPS * float(np.finfo(np.float64).eps) * big
    if not math.isfinite(vre_g) or lost > max(TOLERANCE_REL * abs(vre_g), TOLERANCE_ABS_G):
        return (f"the shares (up to {big:.3g} g) cancel to {vre_g:.3g} g, beyond what float64 arithmetic holds "
                f"(±{lost:.2g} g): the coefficients or levels are beyond the model's arithmetic")
    return None

