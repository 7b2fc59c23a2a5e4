"""What a stage says about the mean output (physics §1.1-1.3): the vibration at its site and the change
of the mean it makes there.

:func:`vrelab.predict.predict` walks a sensor's stages in signal order and asks each one what it
does, by what the stage defines (no list of stage types in the prediction):

``response(f)``
    A linear stage (resonance, anti-alias, low-pass, high-pass): it shapes the vibration every
    later stage sees (``σ² = ∫S·|H|²df``, a tone ``A·|H(f)|``) and passes a static level unchanged.
``static_shift_g``
    A constant it adds (:class:`~vrelab.sensor.stages.Offset`): every later stage sees its static
    level moved; the VRE, referred to the vibration-off reading, is unchanged by it.
``mean_shift(site) -> Shift``
    Its change of the mean at its :class:`Site` (:class:`~vrelab.sensor.stages.Polynomial`,
    :class:`~vrelab.sensor.stages.Clip`, :class:`~vrelab.sensor.overrange.OverRange`), in closed
    form, with the bound on what its approximation may add and its notes.
``vibration_off(level_g) -> (level_g, note)``
    What it makes of a static level (the polynomial maps it, the rails clip it): the walk that
    gives the vibration-off reading every VRE is referred to (physics §1.5). Without it a stage
    passes the level unchanged.
``zero_mean_shift``
    Why it shifts no mean (zero-mean noise, rounding, decimation, a drift bracketing removes).

A memoryless stage (``is_static``, rate factor 1) that says none of these gets the numerical
fallback :func:`numerical_shift` (the mean of its map by quadrature,
:func:`vrelab.models.memoryless.map_vre`); a stage with memory that says none of these has no
model, and a prediction of a chain holding it says so.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any, Callable, Literal, Mapping, Protocol, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.models.kinds import DEFAULT_CLIP_KIND, Kind
from vrelab.sensor.base import Stage

Response = Callable[[NDArray[np.float64]], NDArray[np.complex128]]
Drive = Literal["gaussian", "sine", "sine-on-random"]
# The shares a LevelPrediction states, in this order; vre_g is the sum of the last three
# (the first two are each rail alone) and of any share a numerical fallback adds.
SHARES: tuple[str, ...] = ("clip_low_g", "clip_high_g", "clip_g", "nonlinearity_g", "overrange_g")
VRE_SHARES: tuple[str, ...] = ("clip_g", "nonlinearity_g", "overrange_g")
NUMERICAL_SHARE = "numerical_g"


@dataclass(frozen=True)
class Motion:
    """The vibration reaching one site: Gaussian (``sigma_g``, Rice's zero up-crossing rate
    ``nu0_hz``), a sine (``sigma_g`` its rms, ``nu0_hz`` its frequency), or Gaussian plus tones
    (``tone_peaks_g`` [g peak] at ``tone_freqs_hz``, as seen there)."""

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
class Shift:
    """A stage's change of the mean at its site.

    ``shares`` [g]: its share(s) of :data:`SHARES` (the rails also say each rail alone);
    ``model_error_g`` bounds what its approximation may add (0: exact); ``valid`` False with the
    reason in ``notes`` where the model does not hold; ``rate_hz`` the over-range trips per
    second; ``sigma_at_clip_g`` the rms at the rails; ``saturates`` True for rails (what a later
    nonlinearity must know); ``rough_if_large`` a note that makes the level invalid where this
    stage's share is more than a tenth of the largest (an estimate good only as a small part).
    """

    shares: Mapping[str, float]
    model_error_g: float = 0.0
    valid: bool = True
    notes: tuple[str, ...] = ()
    rate_hz: float = 0.0
    sigma_at_clip_g: float | None = None
    saturates: bool = False
    rough_if_large: str | None = None


class Shifting(Protocol):
    """A stage with a change of the mean of its own (Polynomial, Clip, OverRange) or the
    :class:`Numerical` fallback of a memoryless stage without one."""

    def mean_shift(self, site: Site) -> Shift: ...


@dataclass(frozen=True)
class Done:
    """A stage already walked: the stage, its site and what it said."""

    stage: Shifting
    site: Site
    shift: Shift


@dataclass(frozen=True)
class Site:
    """What reaches a stage with a mean shift, at one vibration level.

    ``static_g``: the static field g0 along the axis; ``offset_g``: the offsets added before the
    stage; ``vibration_off_g``: the static level reaching it with no vibration (g0 through the
    stages before it: polynomial, offsets, rails); ``motion``: the vibration there, through
    ``responses`` (the linear stages before it); ``drive``: the vibration's kind (a sine at
    ``freq_hz``); ``kind``: the clipping model; ``before``: the stages with a mean shift before
    it and what they said; ``after``: the stages with a mean shift after it and the vibration
    they see; ``each_rail``: whether rails also state each rail alone.
    """

    static_g: float
    offset_g: float
    vibration_off_g: float
    motion: Motion
    responses: tuple[Response, ...]
    drive: Drive
    freq_hz: float | None = None
    kind: Kind = DEFAULT_CLIP_KIND
    before: tuple[Done, ...] = ()
    after: tuple[tuple[Shifting, Motion], ...] = ()
    each_rail: bool = True

    @property
    def level_g(self) -> float:
        """The static field with the offsets before the stage [g] (the mean the closed forms take)."""
        return self.static_g + self.offset_g

    @property
    def shape(self) -> Literal["gaussian", "sine"]:
        """The closed forms' shape: a sine keeps its own; random and sine-on-random are the
        Gaussian part (with the tones)."""
        return "sine" if self.drive == "sine" else "gaussian"

    def last(self, kind: type) -> Done | None:
        """The latest stage of type ``kind`` walked before this one (None: none)."""
        for d in reversed(self.before):
            if isinstance(d.stage, kind):
                return d
        return None


def response_key(h: Response) -> tuple[Any, Any] | None:
    """A response as a hashable value: ``(function, stage)`` for the ``response`` method of a
    frozen dataclass whose equality compares every field (a stage's response is fixed by its
    fields), else None (not remembered)."""
    owner: Any = getattr(h, "__self__", None)
    if owner is None or not _fixed_by_fields(owner.__class__):
        return None
    key = (getattr(h, "__func__", None), owner)
    try:
        hash(key)
    except TypeError:  # a field that is not hashable (an array)
        return None
    return key


@functools.cache
def _fixed_by_fields(kind: type) -> bool:
    """Whether ``kind`` is a frozen dataclass whose equality compares every field (what
    :func:`response_key` asks of a response's owner; a property of the class, asked once)."""
    params = getattr(kind, "__dataclass_params__", None)
    return params is not None and params.frozen and params.eq and all(f.compare for f in dataclasses.fields(kind))


def gain_max(responses: Sequence[Response]) -> float:
    """sup_f |H(f)| of the linear stages ``responses`` in series (1 for none), on a log grid
    from 0.01 Hz to 10 MHz (the remainder's spectrum reaches several times the band).

    The same at every level of a prediction: remembered by the responses' exact identity where
    each is a frozen stage's (:func:`response_key`, the rule the prediction's spectral
    integrals' memory uses too), so a prediction of many levels evaluates it once."""
    if not responses:
        return 1.0
    keys = tuple(response_key(h) for h in responses)
    if all(k is not None for k in keys):
        return _gain_max_of(keys)
    return _gain_max_at(responses)


@functools.lru_cache(maxsize=256)
def _gain_max_of(keys: tuple[tuple[Any, Any], ...]) -> float:
    """:func:`_gain_max_at` of the responses given as ``(function, stage)`` keys (cached)."""
    return _gain_max_at([f.__get__(owner) for f, owner in keys])


def _gain_max_at(responses: Sequence[Response]) -> float:
    f = np.geomspace(1e-2, 1e7, 4001)
    h = np.ones(f.size)
    for r in responses:
        h = h * np.abs(np.asarray(r(f)))
    return float(max(1.0, h.max()))


def _name(stage: object) -> str:
    """A stage's class name (a :class:`Numerical` fallback: its stage's)."""
    return stage.name if isinstance(stage, Numerical) else type(stage).__name__


def memoryless_map(stage: Stage) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """A memoryless stage's map ``y = f(x)``, from its ``process`` (fresh state, rate 1 Hz: a
    memoryless stage keeps no signal state and does not depend on the rate)."""

    def f(x: NDArray[np.float64]) -> NDArray[np.float64]:
        y, _ = stage.process(np.asarray(x, dtype=np.float64), stage.init_state(1.0, None), 1.0)
        return np.asarray(y, dtype=np.float64)

    return f


class Numerical:
    """The numerical fallback of a memoryless stage with no closed form: the mean of its map
    over the vibration at its site by quadrature (:func:`vrelab.models.memoryless.map_vre`),
    the quadrature's estimated error in ``model_error_g``.

    Exact as a mean of that map under a Gaussian (or sine, or Gaussian plus tones) input; the
    stage alone: where another stage changes the mean too, one of them sees the other's
    non-Gaussian output as Gaussian, and the level is not valid.
    """

    def __init__(self, stage: Stage) -> None:
        self.stage = stage
        self.name = type(stage).__name__
        self._map = memoryless_map(stage)

    def vibration_off(self, level_g: float) -> tuple[float, str | None]:
        return float(self._map(np.array([level_g]))[0]), None

    def mean_shift(self, site: Site) -> Shift:
        from vrelab.models.memoryless import map_vre

        mo = site.motion
        value, err = map_vre(self._map, site.vibration_off_g, mo.sigma_g, shape=site.shape,
                             tone_peaks_g=mo.tone_peaks_g)
        notes: tuple[str, ...] = ()
        others = [_name(d.stage) for d in site.before] + [_name(s) for s, _ in site.after]
        if others:
            notes = (f"stage {self.name} has no closed form: its mean by quadrature of its memoryless map, "
                     f"alone; {', '.join(others)} and it see each other's non-Gaussian output as Gaussian — simulate",)
        return Shift({NUMERICAL_SHARE: value}, model_error_g=err, valid=not others, notes=notes)
