"""A sensor read as its stages for the analytic model (physics §1.3): where each mean shift sits and what reaches it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

from vrelab.sensor.meanshift import Response

if TYPE_CHECKING:
    from vrelab.sensor import Sensor


# --- the sensor, read as its stages -------------------------------------------------------------


@dataclass(frozen=True)
class StageSite:
    """A stage with a mean shift (its own ``mean_shift``, or the numerical fallback), and what
    reaches it: the linear stages before it, the offsets added before it, and the static level
    reaching it with no vibration."""

    stage: Any
    responses: tuple[Response, ...]  # the linear stages before it
    offset_g: float  # offsets added before it
    vibration_off_g: float  # the static level reaching it with no vibration


@dataclass(frozen=True)
class Reading:
    """A sensor's stages, read once for the analytic model at one static field."""

    sites: tuple[StageSite, ...]
    proof_mass: tuple[Response, ...]  # the mechanical responses (resonance)
    output: tuple[Response, ...]  # every linear response
    unmodelled: tuple[str, ...]  # stages with memory that say nothing of their mean
    numerical: tuple[str, ...]  # memoryless stages without a closed form (quadrature)
    vibration_off_g: float  # the reading with no vibration (physics §1.5)
    reference_note: str | None  # where the rails clip that reading


def read_stages(stages: Sequence[Any], g0: float) -> Reading:
    """Walk the stages in order, as the signal goes (physics §1.3), asking each what it does
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
    sites: list[StageSite] = []
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
        sites.append(StageSite(st, tuple(responses), offset, level))
        if hasattr(st, "vibration_off"):
            level, why = st.vibration_off(level)
            note = note or why
    return Reading(tuple(sites), tuple(mechanical), tuple(responses), tuple(unmodelled), tuple(numerical),
                    level, note)



# The sensor last read and its stages: a fit step or a propagation's candidate predicts one
# (frozen) sensor many times in a row (a changed parameter is a new Sensor), so its stages are
# built once for them, not once per prediction. The sensor is held, so its identity is not reused.
_last: tuple[Any, tuple[Any, ...]] | None = None


def sensor_stages(sensor: Sensor) -> tuple[Any, ...]:
    """``sensor.stages()`` (rate-free), built once for the predictions of one sensor in a row."""
    global _last
    kept = _last
    if kept is None or kept[0] is not sensor:
        kept = (sensor, tuple(sensor.stages()))
        _last = kept
    return kept[1]


def needs_rate(site: StageSite) -> bool:
    """Whether the stage at ``site`` needs Rice's crossing rate and the motion's correlation over
    its hold (over-range protection says so)."""
    return bool(getattr(site.stage, "needs_crossing_rate", False))


def clip_position_of(sensor: Sensor) -> str:
    pos = str(getattr(sensor, "clip_position", "output") or "output")
    return "output" if pos == "output" else "proof-mass"

