"""A sinc^N decimation filter (a CIC or cascaded-averaging decimator) and the corner conventions
datasheets give filters by.

A decimator that averages over a time ``T`` (a boxcar) ``N`` times in cascade (a CIC of order
``N``, Hogenauer 1981) has the response

    H(f) = sinc(f·T)^N · exp(-jπ·f·N·T),    sinc(x) = sin(πx)/(πx),

so |H(f)|² = sinc(f·T)^(2N): nulls at multiples of 1/T, linear phase (a delay N·T/2). A
datasheet gives its corner as the −3 dB point (|H| = 1/√2) or the −6 dB point (|H| = 1/2);
:func:`corner_factor` turns a corner and its convention into ``T``. The same conversion gives a
Butterworth's or a Bessel's −3 dB design corner from a −6 dB datasheet corner.

Simulation (:class:`SincLowPass`): the continuous impulse response is the B-spline of degree
N−1 on [0, N·T] (the boxcar convolved N−1 times with itself), sampled at the simulation rate,
normalised to unit DC gain, and run as one FIR (``scipy.signal.lfilter``) with its state carried
across blocks: memory is the taps, whatever the record's length. Its response is the continuous
one plus the spectrum folded from the multiples of fs, which falls as 1/f^N: tests hold it to
the closed form in the pass band.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab.sensor.base import StageBase, below_nyquist, positive, positive_int

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

CornerConvention = Literal["-3dB", "-6dB"]
# |H| at a corner of each convention: -3 dB the half-power point (1/√2 = -3.01 dB), -6 dB the
# half-amplitude point (1/2 = -6.02 dB), as datasheets write them.
CORNER_GAIN: dict[str, float] = {"-3dB": 1.0 / math.sqrt(2.0), "-6dB": 0.5}
_MAX_ORDER = 12


@functools.lru_cache(maxsize=64)
def corner_factor(kind: str, order: int, convention: str) -> float:
    """x such that the unit filter has |H| = :data:`CORNER_GAIN` [convention] at x.

    * ``sinc``: |sinc(x)|^order = gain, x = f·T in (0, 1) (below the first null): T = x / corner.
    * ``butterworth``/``bessel``: the gain of the filter whose −3 dB design corner is 1 Hz at
      x Hz (x = 1 for "-3dB"): the design corner = corner / x.

    Solved with scipy.optimize.brentq on the closed-form (sinc) or analog (scipy.signal
    butter/bessel, ``norm="mag"``) magnitude, which falls monotonically through the gain."""
    from scipy import optimize, signal

    gain = CORNER_GAIN[convention]
    if kind == "sinc":
        return float(optimize.brentq(lambda x: abs(np.sinc(x)) ** order - gain, 1e-9, 1.0 - 1e-12, xtol=1e-14))
    if convention == "-3dB":
        return 1.0
    wn = 2 * np.pi  # the design corner at 1 Hz (rad/s)
    z, p, k = (signal.bessel(order, wn, norm="mag", analog=True, output="zpk") if kind == "bessel"
               else signal.butter(order, wn, analog=True, output="zpk"))

    def mag(x: float) -> float:
        _, h = signal.freqs_zpk(z, p, np.atleast_1d(k), worN=np.array([2 * np.pi * x]))
        return float(abs(h[0]))

    return float(optimize.brentq(lambda x: mag(x) - gain, 1e-6, 1e3, xtol=1e-14))


class _FirState:
    """The FIR's taps and its carried state (None until the first sample sets the steady state)."""

    __slots__ = ("taps", "zi")

    def __init__(self, taps: FloatArray, zi: FloatArray | None) -> None:
        self.taps, self.zi = taps, zi

    def __deepcopy__(self, memo: dict[int, Any]) -> _FirState:
        return _FirState(self.taps, None if self.zi is None else self.zi.copy())


@dataclass(frozen=True)
class SincLowPass(StageBase):
    """A sinc^N decimation filter with its corner as the datasheet gives it.

    Parameters
    ----------
    corner_hz : the datasheet's corner [Hz] (``bandwidth_hz``).
    order : N, the number of cascaded averages (3: a sinc³ / CIC3).
    convention : "-3dB" or "-6dB": which gain the corner is at (:data:`CORNER_GAIN`).

    Notes
    -----
    ``response`` is the closed form ``sinc(f·T)^N·exp(-jπ f N T)`` with
    ``T = corner_factor("sinc", N, convention) / corner_hz``; the simulation samples the
    B-spline impulse response (module docstring).
    """

    corner_hz: float
    order: int = 3
    convention: CornerConvention = "-3dB"
    is_static: ClassVar[bool] = False

    def __post_init__(self) -> None:
        positive(self, "corner_hz")
        positive_int(self, "order")
        if self.order > _MAX_ORDER:
            raise ValueError(f"SincLowPass: order must be at most {_MAX_ORDER}, got {self.order!r}")
        if self.convention not in CORNER_GAIN:
            raise ValueError(f"SincLowPass: convention must be one of {', '.join(CORNER_GAIN)}, got {self.convention!r}")

    @property
    def averaging_s(self) -> float:
        """T [s]: the duration of one average (the first null of |H| at 1/T)."""
        return corner_factor("sinc", self.order, self.convention) / self.corner_hz

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        f = np.asarray(f_hz, dtype=float)
        t = self.averaging_s
        h: ComplexArray = (np.sinc(f * t) ** self.order * np.exp(-1j * np.pi * f * self.order * t)).astype(complex)
        return h

    def taps(self, fs_hz: float) -> FloatArray:
        """The FIR at ``fs_hz``: the B-spline of degree N−1 on [0, N·T] sampled symmetrically
        about its centre, summing to 1 (unit DC gain)."""
        from scipy.interpolate import BSpline

        below_nyquist(self, "corner_hz", self.corner_hz, fs_hz)
        span = self.order * self.averaging_s * fs_hz  # the support in samples
        n = max(1, math.ceil(span - 1e-9))
        t = span / 2 + (np.arange(n) - (n - 1) / 2)  # symmetric about the centre, inside the support
        knots = np.linspace(0.0, span, self.order + 1)
        h = np.nan_to_num(BSpline.basis_element(knots, extrapolate=False)(t))
        if self.order == 1:
            # the boxcar is discontinuous: point samples would round its length to whole samples
            # (9 % in |H| at the corner at fs = 16·corner); each sample weighs the part of its
            # interval [k - 1/2, k + 1/2] inside the support instead (exact length and delay; the
            # extra factor sinc(f/fs) is 0.6 % at f = fs/16)
            n = math.ceil(span) + 1
            edges = span / 2 + (np.arange(n + 1) - n / 2)
            h = np.clip(edges[1:], 0.0, span) - np.clip(edges[:-1], 0.0, span)
        out: FloatArray = h / h.sum()
        return out

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> _FirState:
        return _FirState(self.taps(fs_hz), None)

    def process(self, x: FloatArray, state: _FirState, fs_hz: float) -> tuple[FloatArray, _FirState]:
        from scipy import signal

        if x.size == 0:
            return x.copy(), state
        zi = state.zi
        if zi is None:  # steady state for the first value (as run_filter: a static field, no transient)
            zi = signal.lfilter_zi(state.taps, [1.0]) * x[0]
        y, zi = signal.lfilter(state.taps, [1.0], x, zi=zi)
        return np.asarray(y, dtype=np.float64), _FirState(state.taps, zi)
