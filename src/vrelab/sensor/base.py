"""What every stage shares: the :class:`Stage` protocol, :class:`StageBase` and the field checks
that name the stage in their message."""

from __future__ import annotations

from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


@runtime_checkable
class Stage(Protocol):
    """What the chain needs from a stage (see the module docstring).

    Examples
    --------
    Any object with the protocol's methods is a stage (here :class:`Clip`):

    >>> from vrelab.sensor import Clip, Stage
    >>> isinstance(Clip(-2.0, 2.0), Stage)
    True
    """

    # read-only: stages give them as class constants or properties
    @property
    def is_static(self) -> bool: ...

    @property
    def rate_factor(self) -> int: ...

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> Any: ...

    def process(self, x: FloatArray, state: Any, fs_hz: float) -> tuple[FloatArray, Any]: ...

    def stats(self, state: Any) -> dict[str, int | float]: ...


# ----------------------------------------------------------------------------- validation


def _name(stage: object) -> str:
    return type(stage).__name__


def finite(stage: object, field: str) -> float:
    return V.finite_scalar(f"{_name(stage)} {field}", getattr(stage, field))


def positive(stage: object, field: str) -> float:
    x = finite(stage, field)
    if x <= 0:
        raise ValueError(f"{_name(stage)} {field} must be > 0, got {getattr(stage, field)!r}")
    return x


def non_negative(stage: object, field: str) -> float:
    x = finite(stage, field)
    if x < 0:
        raise ValueError(f"{_name(stage)} {field} must be >= 0, got {getattr(stage, field)!r}")
    return x


def positive_int(stage: object, field: str) -> int:
    value = getattr(stage, field)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{_name(stage)} {field} must be an integer >= 1, got {value!r}")
    return int(value)


def below_nyquist(stage: object, field: str, f_hz: float, fs_hz: float) -> None:
    if not f_hz < fs_hz / 2:
        raise ValueError(
            f"{_name(stage)} {field} must be below fs/2 = {fs_hz / 2:g} Hz, got {f_hz:g} Hz "
            "(raise the simulation rate)"
        )


class StageBase:
    """Defaults for a stage (static, rate factor 1, no state, no stats); inherit to write one.

    Examples
    --------
    A stage of one's own: a gain (memoryless, no state), inheriting the defaults:

    >>> import dataclasses
    >>> import numpy as np
    >>> from vrelab.sensor import SensorChain, StageBase
    >>> @dataclasses.dataclass(frozen=True)
    ... class Gain(StageBase):
    ...     gain: float
    ...     def process(self, x, state, fs_hz):
    ...         return self.gain * x, state
    >>> y, _ = SensorChain((Gain(2.0),)).apply(np.array([1.0, -0.5]), 1000.0)
    >>> print(y)
    [ 2. -1.]
    """

    is_static: ClassVar[bool] = True
    # What the analytic prediction (vrelab.predict) asks of a stage is what it defines (a
    # ``response``, ``static_shift_g``, ``mean_shift``, ``vibration_off``, ``zero_mean_shift``):
    # see vrelab.sensor.meanshift. A memoryless stage that defines none gets the numerical fallback.
    rate_factor: ClassVar[int] = 1

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> Any:
        return None

    def stats(self, state: Any) -> dict[str, int | float]:
        return {}
