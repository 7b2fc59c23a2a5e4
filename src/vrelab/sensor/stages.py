"""Stages of a sensor signal chain: small frozen dataclasses with one job each.

A stage turns a block of samples (in g) into another block (in g), carrying whatever state it
needs across block edges, so a chain of stages streams a record of any length in bounded memory
and gives the same answer whatever the block size (physics §1.3, STYLE "a chain of replaceable
stages"). Order is data: :class:`vrelab.sensor.chain.SensorChain` is an ordered tuple of stages.

The :class:`Stage` protocol
---------------------------
``is_static``
    ``True`` for memoryless stages (python-control's ``_isstatic`` idea): they run on any block
    size and carry no signal state (only counters).
``rate_factor``
    1, or the decimation factor of the stage (output rate = input rate / rate_factor).
``init_state(fs_hz, seed_seq)``
    Designs whatever depends on the sample rate (filters are designed here, once per run) and
    returns the initial state. ``seed_seq`` (a :class:`numpy.random.SeedSequence`) seeds
    stochastic stages.
``process(x, state, fs_hz) -> (y, state)``
    Never modifies ``x``.
``stats(state) -> dict``
    Counters a run reports (clipped samples, over-range events); ``{}`` for most stages.

Filters and their analog equivalents
------------------------------------
Filters that stand for analog physics (:class:`Resonator`, :class:`AntiAlias`) are discretised
so their response matches the analog one whatever the simulation rate: poles are mapped exactly
(``z = exp(s/fs)``, the matched-z transform) and the numerator is fitted by linear least squares
to the analog complex response on [0, fs/8], relative error weighted. For a resonance at fs/5
or below this matches ``|H|`` within 0.03 % up to fs/8 (Q from 0.5 to 100), where the bilinear
transform is off by several percent (frequency warping); above fs/8, where a simulation at
8× the drive's highest frequency has no drive left, the match loosens to about 2.5 % at
fs/4. Digital filters of the sensor (:class:`LowPass`, :class:`HighPass`) are digital
Butterworth designs, as in the part. Consecutive filter stages run as one ``sosfilt`` over
their stacked sections (:class:`~vrelab.sensor.chain.ChainRun` fuses them). Each
filter stage has ``response(f_hz)``: the analog equivalent used by the analytic ``predict``.

What each stage does to the mean
--------------------------------
The analytic :func:`vrelab.predict.predict` asks each stage (:mod:`vrelab.sensor.meanshift`):
a filter shapes the vibration (``response``), an :class:`Offset` moves the static level
(``static_shift_g``), :class:`Polynomial`, :class:`Clip` and :class:`OverRange` give their
own change of the mean (``mean_shift``, in closed form) and what they make of a static level
(``vibration_off``), and noise, rounding, decimation and drift say why they shift none
(``zero_mean_shift``).
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from vrelab.sensor.base import (
    Stage,
    StageBase,
    below_nyquist,
    finite,
    non_negative,
    positive,
    positive_int,
)
from vrelab.sensor.filtering import FilterState, discretize_zpk, run_filter
from vrelab.sensor.meanshift import Shift, Site, gain_max
from vrelab.sensor.overrange import OverRange
from vrelab.units import from_ug

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
# an analog design's zeros: real for scipy's Butterworth and Bessel (none, or all at s = 0), complex in general
InexactArray = NDArray[np.float64] | NDArray[np.complex128]

__all__ = [
    "Stage",
    "StageBase",
    "Resonator",
    "Polynomial",
    "OverRange",
    "Clip",
    "AntiAlias",
    "AnalogLowPass",
    "LowPass",
    "HighPass",
    "Decimate",
    "Quantize",
    "Noise",
    "Offset",
    "Drift",
    "discretize_zpk",
]



# ----------------------------------------------------------------------------- dynamics


def _analog_response(z: InexactArray, p: ComplexArray, k: float, f_hz: ArrayLike) -> ComplexArray:
    """The analog filter ``(z, p, k)`` (rad/s) at the frequencies ``f_hz``, in their shape.

    ``k·Π(s - z)/Π(s - p)`` at ``s = j·2πf``: scipy's ``signal.freqs_zpk`` written out, its
    operations in its order (the same numbers: tests/test_sensor_stages.py holds it against
    scipy). By hand because a spectral integral's adaptive quadrature asks one frequency at a
    time, tens of thousands of times in a preset's propagated prediction, and scipy's array-API
    dispatch cost several times the arithmetic."""
    s = 1j * (2 * np.pi * np.ravel(np.asarray(f_hz, dtype=float)))
    num = np.prod(s - np.reshape(z, (-1, 1)), axis=0)
    den = np.prod(s - np.reshape(p, (-1, 1)), axis=0)
    h = np.asarray(k, dtype=np.float64) * num / den
    response: ComplexArray = h.reshape(np.shape(f_hz))
    return response


@functools.lru_cache(maxsize=64)
def _analog_prototype(kind: str, order: int, wn: float, btype: Literal["lowpass", "highpass"] = "lowpass"
                      ) -> tuple[InexactArray, ComplexArray, float]:
    """scipy's analog ``butter`` (or magnitude-normalised ``bessel``) zpk at ``wn`` [rad/s].

    A filter's ``response`` is asked at one frequency after another (a spectral integral's
    adaptive quadrature calls it hundreds of times): the design is kept by its exact inputs
    (cached, bounded), its arrays read-only so no caller can change what the next one gets."""
    zpk: tuple[InexactArray, ComplexArray, float] = (
        signal.bessel(order, wn, norm="mag", analog=True, output="zpk") if kind == "bessel"
        else signal.butter(order, wn, btype=btype, analog=True, output="zpk"))
    for a in zpk[:2]:
        a.setflags(write=False)
    return zpk


class FilterStage(StageBase):
    """A linear filter stage: ``design(fs)`` gives its second-order sections at rate ``fs``, run
    as one ``sosfilt`` whose state is carried across blocks (started in steady state for the
    first input), and ``response(f)`` its analog equivalent for the prediction."""

    is_static: ClassVar[bool] = False

    def design(self, fs_hz: float) -> FloatArray:
        raise NotImplementedError

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> FilterState:
        return FilterState(self.design(fs_hz), None)

    def process(self, x: FloatArray, state: FilterState, fs_hz: float) -> tuple[FloatArray, FilterState]:
        return run_filter(x, state)


@dataclass(frozen=True)
class Resonator(FilterStage):
    """Proof-mass resonance: a second-order low-pass with unity gain at DC.

    Parameters
    ----------
    fn_hz : natural frequency [Hz].
    q : quality factor [-]; the gain at ``fn_hz`` is ``q``.

    Notes
    -----
    ``H(f) = 1 / (1 - r² + j·r/Q)``, ``r = f/fn`` (physics §1.3). Discretised by
    :func:`discretize_zpk`: the analog poles ``s = ωn(-1/(2Q) ± j·sqrt(1 - 1/(4Q²)))`` are
    mapped exactly; the numerator is fitted so ``|H|`` matches within 0.03 % up to fs/8 when
    fn <= fs/5 (the simulation rate should be at least 5·fn and 8× the drive's highest
    frequency, see ``vrelab.rates.simulation_rate_hz``).

    Examples
    --------
    A 2.4 kHz, Q = 10 proof mass driven at its resonance amplifies 10 times:

    >>> import numpy as np
    >>> from vrelab.sensor import Resonator, SensorChain
    >>> fs_hz = 96000.0
    >>> t = np.arange(96000) / fs_hz
    >>> y, _ = SensorChain((Resonator(2400.0, 10.0),)).apply(np.sqrt(2) * np.sin(2 * np.pi * 2400.0 * t), fs_hz)
    >>> print(f"{np.sqrt(np.mean(y[48000:] ** 2)):.2f} g rms")
    10.00 g rms
    """

    fn_hz: float
    q: float
    is_static: ClassVar[bool] = False
    fusable_sos: ClassVar[bool] = True  # one sosfilt with a carried state (filtering.is_sos_filter)

    def __post_init__(self) -> None:
        positive(self, "fn_hz")
        positive(self, "q")

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        r = np.asarray(f_hz, dtype=float) / self.fn_hz
        return np.asarray(1.0 / (1.0 - r**2 + 1j * r / self.q), dtype=np.complex128)

    def analog_zpk(self) -> tuple[ComplexArray, ComplexArray, float]:
        wn = 2 * np.pi * self.fn_hz
        return np.array([], complex), np.roots([1.0, wn / self.q, wn**2]).astype(complex), wn**2

    def design(self, fs_hz: float) -> FloatArray:
        below_nyquist(self, "fn_hz", self.fn_hz, fs_hz)
        return discretize_zpk(*self.analog_zpk(), fs_hz)




@dataclass(frozen=True)
class AntiAlias(FilterStage):
    """Analog anti-alias filter, modelled as an analog Butterworth low-pass.

    Parameters
    ----------
    corner_hz : -3 dB corner [Hz].
    order : filter order (default 2).

    Notes
    -----
    The ADXL355 data sheet calls its anti-alias filter "about 1.5 kHz, sinc-like" without a
    response; a low-order Butterworth is an assumption that gives the right corner and a smooth
    roll-off (a sinc³ would add notches at multiples of the modulator rate, far above the band
    of interest). ``|H| = 1/sqrt(1 + (f/fc)^(2n))``. Discretised like :class:`Resonator`.

    Examples
    --------
    A second-order anti-alias filter at 10 kHz passes a 1 kHz sine whole:

    >>> import numpy as np
    >>> from vrelab.sensor import AntiAlias, SensorChain
    >>> fs_hz = 128000.0
    >>> t = np.arange(64000) / fs_hz
    >>> y, _ = SensorChain((AntiAlias(10000.0),)).apply(np.sqrt(2) * np.sin(2 * np.pi * 1000.0 * t), fs_hz)
    >>> print(f"{np.sqrt(np.mean(y[32000:] ** 2)):.3f} g rms")
    1.000 g rms
    """

    corner_hz: float
    order: int = 2
    is_static: ClassVar[bool] = False
    fusable_sos: ClassVar[bool] = True  # one sosfilt with a carried state (filtering.is_sos_filter)

    def __post_init__(self) -> None:
        positive(self, "corner_hz")
        positive_int(self, "order")

    def analog_zpk(self) -> tuple[InexactArray, ComplexArray, float]:
        z, p, k = _analog_prototype("butterworth", self.order, 2 * np.pi * self.corner_hz)
        return z.copy(), p.copy(), k

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        return _analog_response(*_analog_prototype("butterworth", self.order, 2 * np.pi * self.corner_hz), f_hz)

    def design(self, fs_hz: float) -> FloatArray:
        below_nyquist(self, "corner_hz", self.corner_hz, fs_hz)
        return discretize_zpk(*self.analog_zpk(), fs_hz)



LowPassKind = Literal["butterworth", "bessel"]


def _check_low_pass(stage: LowPass | AnalogLowPass) -> None:
    """A low-pass stage's fields (:class:`LowPass`, :class:`AnalogLowPass`): a corner > 0, a whole
    order >= 1, a known family."""
    positive(stage, "corner_hz")
    positive_int(stage, "order")
    if stage.kind not in ("butterworth", "bessel"):
        raise ValueError(f"{type(stage).__name__} kind must be one of butterworth, bessel; got {stage.kind!r}")


@dataclass(frozen=True)
class LowPass(FilterStage):
    """Digital low-pass of the sensor (ADXL355: corner = ODR/4), designed once per rate.

    Parameters
    ----------
    corner_hz : -3 dB corner [Hz].
    order : filter order (default 4; the data sheet gives no order: assumption).
    kind : "butterworth" or "bessel" (magnitude-normalised: -3 dB at the corner).

    Notes
    -----
    Digital design (bilinear with prewarp at the corner, scipy.signal.butter/bessel) at the
    simulation rate, applied as sos with zi carried across blocks. ``response`` is the analog
    prototype; with the corner ≤ fs/16 the two differ by well under 1 % in the pass band.

    Examples
    --------
    The ADXL355's digital low-pass at 4 kHz ODR (corner ODR/4 = 1 kHz) on a 100 Hz sine:

    >>> import numpy as np
    >>> from vrelab.sensor import LowPass, SensorChain
    >>> t = np.arange(8000) / 4000.0
    >>> y, _ = SensorChain((LowPass(1000.0),)).apply(np.sqrt(2) * np.sin(2 * np.pi * 100.0 * t), 4000.0)
    >>> print(f"{np.sqrt(np.mean(y[4000:] ** 2)):.4f} g rms")
    1.0000 g rms
    """

    corner_hz: float
    order: int = 4
    kind: LowPassKind = "butterworth"
    is_static: ClassVar[bool] = False
    fusable_sos: ClassVar[bool] = True  # one sosfilt with a carried state (filtering.is_sos_filter)

    def __post_init__(self) -> None:
        _check_low_pass(self)

    def _analog_zpk(self) -> tuple[InexactArray, ComplexArray, float]:
        return _analog_prototype(self.kind, self.order, 2 * np.pi * self.corner_hz)

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        return _analog_response(*self._analog_zpk(), f_hz)

    def design(self, fs_hz: float) -> FloatArray:
        below_nyquist(self, "corner_hz", self.corner_hz, fs_hz)
        sos: FloatArray = (
            signal.bessel(self.order, self.corner_hz, norm="mag", fs=fs_hz, output="sos") if self.kind == "bessel"
            else signal.butter(self.order, self.corner_hz, fs=fs_hz, output="sos"))
        return sos




@dataclass(frozen=True)
class AnalogLowPass(FilterStage):
    """Analog output filter of a part without an ODR (the ADXL354's overall bandwidth).

    Parameters
    ----------
    corner_hz : -3 dB corner [Hz] (the part's ``bandwidth_hz``).
    order : filter order (default 4, as :class:`LowPass`).
    kind : "butterworth" or "bessel" (magnitude-normalised: -3 dB at the corner).

    Notes
    -----
    The same analog prototype as :class:`LowPass`'s ``response`` (scipy.signal.butter/bessel,
    ``analog=True``), but the part's filter *is* analog: discretised like :class:`AntiAlias`
    (matched poles, numerator fitted to the analog response, :func:`discretize_zpk`) so the
    simulation matches ``|H|`` within 0.05 % up to fs/8 whatever the rate. It sits where the
    digital low-pass would (after the anti-alias, before the output rails): a band-limit the
    output clip sees (physics §1.3).

    Examples
    --------
    A 1 kHz fourth-order Butterworth passes a 100 Hz sine whole and a 4 kHz one some 48 dB down:

    >>> import numpy as np
    >>> from vrelab.sensor import AnalogLowPass, SensorChain
    >>> fs_hz = 64000.0
    >>> t = np.arange(64000) / fs_hz
    >>> chain = SensorChain((AnalogLowPass(1000.0, 4),))
    >>> for f in (100.0, 4000.0):
    ...     y, _ = chain.apply(np.sqrt(2) * np.sin(2 * np.pi * f * t), fs_hz)
    ...     print(f"{f:.0f} Hz: {np.sqrt(np.mean(y[32000:] ** 2)):.4f} g rms")
    100 Hz: 1.0000 g rms
    4000 Hz: 0.0037 g rms
    """

    corner_hz: float
    order: int = 4
    kind: LowPassKind = "butterworth"
    is_static: ClassVar[bool] = False
    fusable_sos: ClassVar[bool] = True  # one sosfilt with a carried state (filtering.is_sos_filter)

    def __post_init__(self) -> None:
        _check_low_pass(self)

    def analog_zpk(self) -> tuple[InexactArray, ComplexArray, float]:
        z, p, k = _analog_prototype(self.kind, self.order, 2 * np.pi * self.corner_hz)
        return z.copy(), p.copy(), k

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        return _analog_response(*_analog_prototype(self.kind, self.order, 2 * np.pi * self.corner_hz), f_hz)

    def design(self, fs_hz: float) -> FloatArray:
        below_nyquist(self, "corner_hz", self.corner_hz, fs_hz)
        return discretize_zpk(*self.analog_zpk(), fs_hz)


@dataclass(frozen=True)
class HighPass(FilterStage):
    """Digital high-pass (Butterworth). Off in every preset.

    A high-pass after the nonlinearity removes the very DC shift (VRE) one wants to measure;
    it exists to reproduce the part's optional HPF (corner = k·ODR, the presets page).

    Examples
    --------
    A first-order high-pass at 1 Hz removes a 1 g static field:

    >>> import numpy as np
    >>> from vrelab.sensor import HighPass, SensorChain
    >>> y, _ = SensorChain((HighPass(1.0),)).apply(np.ones(20000), 1000.0)
    >>> print(f"{abs(y[-1]) * 1e3:.3f} mg")
    0.000 mg
    """

    corner_hz: float
    order: int = 1
    is_static: ClassVar[bool] = False
    fusable_sos: ClassVar[bool] = True  # one sosfilt with a carried state (filtering.is_sos_filter)

    def __post_init__(self) -> None:
        positive(self, "corner_hz")
        positive_int(self, "order")

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        return _analog_response(*_analog_prototype("butterworth", self.order, 2 * np.pi * self.corner_hz, "highpass"),
                                f_hz)

    def design(self, fs_hz: float) -> FloatArray:
        below_nyquist(self, "corner_hz", self.corner_hz, fs_hz)
        # the steady state of a high-pass for a constant input is zero output, which is what
        # the shared start (sosfilt_zi·x0) gives too
        sos: FloatArray = signal.butter(self.order, self.corner_hz, btype="highpass", fs=fs_hz, output="sos")
        return sos





# ----------------------------------------------------------------------------- static maps


@dataclass(frozen=True)
class Polynomial(StageBase):
    """Scale-factor nonlinearity on the total input ``a`` (static field included).

    Parameters
    ----------
    k2_per_g : [1/g], k3_per_g2 : [1/g²], k4_per_g3 : [1/g³].

    Notes
    -----
    ``y = a + k2·a² + k3·a³ + k4·a⁴`` (physics §1.2, normalised ``k_n = K_n/K1``). Its mean shift
    for a zero-mean vibration ``x`` on a static ``g0`` is
    ``Σ_n k_n·(E[(g0+x)^n] - g0^n)``, e.g. ``k2·σ²`` for ``g0 = 0``.

    Examples
    --------
    k2 = 100 µg/g² on 2 g rms of Gaussian vibration, no static field: the mean shifts by
    k2·σ² = 0.4 mg (the closed form, :func:`vrelab.models.nonlinearity.vre_poly`).

    >>> import numpy as np
    >>> from vrelab.sensor import Polynomial, SensorChain
    >>> x = np.random.default_rng(2).normal(0.0, 2.0, 100_000)
    >>> y, _ = SensorChain((Polynomial(k2_per_g=1e-4),)).apply(x, 1000.0)
    >>> print(f"{(y - x).mean() * 1e3:.2f} mg")
    0.40 mg
    """

    k2_per_g: float = 0.0
    k3_per_g2: float = 0.0
    k4_per_g3: float = 0.0

    def __post_init__(self) -> None:
        for f in ("k2_per_g", "k3_per_g2", "k4_per_g3"):
            finite(self, f)

    @property
    def coefficients(self) -> tuple[float, float, float]:
        """(k2, k3, k4) [1/g, 1/g², 1/g³]."""
        return (self.k2_per_g, self.k3_per_g2, self.k4_per_g3)

    def vibration_off(self, level_g: float) -> tuple[float, str | None]:
        """``P(level)``: what a static level reads through the polynomial."""
        from vrelab.models.memoryless import vibration_off_reading

        return vibration_off_reading(level_g, *self.coefficients), None

    def mean_shift(self, site: Site) -> Shift:
        """``E[P(g0 + x)] - P(g0)`` at the site (physics §1.2): exact for any zero-mean vibration
        (:func:`vrelab.models.memoryless.poly_clip_vre` without rails; with tones, the average
        over their phases), ``g0`` the static field with the offsets before it. Its input must be
        the Gaussian (or sine) vibration: rails before it make the level invalid."""
        from vrelab.models.memoryless import poly_clip_each

        mo = site.motion
        share = poly_clip_each(site.level_g, mo.sigma_g, self.coefficients, [(-math.inf, math.inf)], shape=site.shape,
                               tone_peaks_g=mo.tone_peaks_g)[0]
        if any(d.shift.saturates for d in site.before):
            return Shift({"nonlinearity_g": share}, valid=False, notes=(
                "a polynomial after the rails: its input is clipped, not Gaussian — simulate",))
        return Shift({"nonlinearity_g": share})

    def process(self, x: FloatArray, state: None, fs_hz: float) -> tuple[FloatArray, None]:
        k2, k3, k4 = self.k2_per_g, self.k3_per_g2, self.k4_per_g3
        # Horner's rule on a buffer this stage owns (x itself is never written): with the
        # higher coefficients zero, as in most presets, the terms that would add 0 are skipped.
        if k4:
            y = x * k4
            y += k3
            y *= x
            y += k2
            y *= x
        elif k3:
            y = x * k3
            y += k2
            y *= x
        else:
            y = x * k2
        y *= x
        y += x
        return y, state


@dataclass(frozen=True)
class Offset(StageBase):
    """Constant offset ``y = x + offset_g`` (0 g offset of the part, ±25 mg typ. for ADXL355).

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.sensor import Offset, SensorChain
    >>> y, _ = SensorChain((Offset(0.025),)).apply(np.ones(3), 1000.0)
    >>> print(y)
    [1.025 1.025 1.025]
    """

    offset_g: float = 0.0

    def __post_init__(self) -> None:
        finite(self, "offset_g")

    @property
    def static_shift_g(self) -> float:
        """What it adds to the static level every later stage sees [g] (no VRE of its own)."""
        return float(self.offset_g)

    def process(self, x: FloatArray, state: None, fs_hz: float) -> tuple[FloatArray, None]:
        return x + self.offset_g, state


@dataclass(frozen=True)
class Drift(StageBase):
    """Slow linear drift of the output: ``y[n] = x[n] + rate_g_per_s·n/fs``.

    Parameters
    ----------
    rate_g_per_s : drift rate [g/s] (e.g. a bias settling after power-up or following a slow
        temperature change; 0.2 mg/s is an assumption, not a data-sheet value).

    Notes
    -----
    ``n`` counts samples from the start of the run (the state), so the output does not depend
    on the block size. A linear drift is what the bracketing of physics §4 removes exactly: the
    baseline interpolated linearly between the vibration-off segments before and after a level.

    Examples
    --------
    10 mg/s for 1 s:

    >>> import numpy as np
    >>> from vrelab.sensor import Drift, SensorChain
    >>> y, _ = SensorChain((Drift(0.010),)).apply(np.zeros(1001), 1000.0)
    >>> print(f"{y[-1] * 1e3:.1f} mg")
    10.0 mg
    """

    rate_g_per_s: float = 0.0
    is_static: ClassVar[bool] = False
    zero_mean_shift: ClassVar[str] = "a slow drift (bracketing removes it from a measured VRE)"

    def __post_init__(self) -> None:
        finite(self, "rate_g_per_s")

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> int:
        return 0  # samples seen so far

    def process(self, x: FloatArray, state: int, fs_hz: float) -> tuple[FloatArray, int]:
        t = (state + np.arange(x.size, dtype=np.float64)) / fs_hz
        return x + self.rate_g_per_s * t, state + x.size


class _ClipCount(NamedTuple):
    low: int
    high: int


@dataclass(frozen=True)
class Clip(StageBase):
    """Rails: samples beyond ``[low_g, high_g]`` read as the rail (censoring, physics §1.1).

    Counts the clipped samples (``stats``: ``clipped_low``, ``clipped_high``,
    ``clipped_samples``), which the simulated test reports as saturation.

    Examples
    --------
    The article's Figure 1 by simulation: 1 g rms Gaussian vibration on a 1 g field through ±2 g
    rails reads some 83 mg low (the closed form, :func:`vrelab.models.clipping.censored_mean_shift`:
    -82.9 mg; 200 000 independent samples know the mean to 2 mg).

    >>> import numpy as np
    >>> from vrelab.sensor import Clip, SensorChain
    >>> x = 1.0 + np.random.default_rng(1).normal(0.0, 1.0, 200_000)
    >>> y, stats = SensorChain((Clip(-2.0, 2.0),)).apply(x, 10000.0)
    >>> print(f"{(y.mean() - 1.0) * 1e3:.0f} mg, {stats.clipped_samples / x.size:.3f} of the samples clipped")
    -85 mg, 0.159 of the samples clipped
    """

    low_g: float
    high_g: float

    def __post_init__(self) -> None:
        lo = finite(self, "low_g")
        hi = finite(self, "high_g")
        if not lo < hi:
            raise ValueError(f"Clip low_g must be < high_g, got low_g={self.low_g!r}, high_g={self.high_g!r}")

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> _ClipCount:
        return _ClipCount(0, 0)

    def process(self, x: FloatArray, state: _ClipCount, fs_hz: float) -> tuple[FloatArray, _ClipCount]:
        low = int(np.count_nonzero(x < self.low_g))
        high = int(np.count_nonzero(x > self.high_g))
        return np.clip(x, self.low_g, self.high_g), _ClipCount(state.low + low, state.high + high)

    def stats(self, state: _ClipCount) -> dict[str, int | float]:
        return {"clipped_low": state.low, "clipped_high": state.high, "clipped_samples": state.low + state.high}

    @property
    def rails_g(self) -> tuple[float, float]:
        """(L, U) [g]."""
        return float(self.low_g), float(self.high_g)

    def vibration_off(self, level_g: float) -> tuple[float, str | None]:
        """``clip(level, L, U)``, and the note where the rails clip the vibration-off reading."""
        from vrelab.models import memoryless

        low, high = self.rails_g
        return (memoryless.vibration_off_reading(level_g, rail_low_g=low, rail_high_g=high),
                memoryless.reference_note(level_g, rail_low_g=low, rail_high_g=high))

    def mean_shift(self, site: Site) -> Shift:
        """What the rails add to the mean of what reaches them, each rail alone and both (physics §1.1),
        referred to the vibration-off reading at the rails ``c0`` (``site.vibration_off_g``).

        * Nothing linear between the :class:`Polynomial` before them (if any) and the rails:
          polynomial, offsets and rails are one memoryless map whose mean
          :func:`vrelab.models.memoryless.poly_clip_vre` gives in closed form (Gaussian, sine, or
          the tones' phase average); the rails' share is that mean less the polynomial's own.
          No approximation (``model_error_g`` 0).
        * Filters between (an output clip after the anti-alias and digital low-pass): the rails
          see the polynomial's mean ``c0 + share`` and its linear part through the filters
          (:func:`vrelab.models.memoryless.linear_part`, gain × the rms at the rails) as a
          Gaussian (or the sine); the rest (the higher Hermite terms, the harmonics, rms ``r``
          through the filters) is bounded in ``model_error_g``: for Gaussian drive each Hermite
          component's correlation with the rails' indicator (Cauchy-Schwarz within its Wiener
          chaos) plus ``r²·(pdf at the rails)``; with tones ``r·sqrt(P_out·(1 - P_out)) +
          r²·(pdf at the rails)``; for a sine ``2r`` where the widened sine reaches a rail.

        A second set of rails, or a static level at or beyond a rail, makes the level invalid.
        """
        from vrelab.models import memoryless

        notes: list[str] = []
        valid = True
        mo = site.motion
        base = site.shape
        if any(d.shift.saturates for d in site.before):
            valid = False
            notes.append("a second set of rails: evaluated as if alone — simulate")
        low, high = self.rails_g
        up = site.last(Polynomial)
        # (isinstance only narrows the type: last(Polynomial) finds a Polynomial or None)
        k: tuple[float, float, float] = (up.stage.coefficients if up is not None and isinstance(up.stage, Polynomial)
                                         else (0.0, 0.0, 0.0))
        c0 = site.vibration_off_g
        if not low < c0 < high:
            valid = False
            notes.append(f"the static level {c0:g} g at the rails (field {site.static_g:g} g, offsets, nonlinearity) "
                         f"is at or beyond a rail [{low:g}, {high:g}] g: the sensor is saturated without vibration "
                         "— simulate")
        each = ((low, high), (low, math.inf), (-math.inf, high)) if site.each_rail else ((low, high),)
        bound = 0.0
        if up is None or len(site.responses) == len(up.site.responses):
            # nothing linear between the polynomial (if any) and the rails: one memoryless map, exact
            src = up.site if up is not None else site
            own = up.shift.shares["nonlinearity_g"] if up is not None else 0.0
            # every pair of rails at once (memoryless.poly_clip_each: poly_clip_vre's numbers)
            parts = [v - own for v in memoryless.poly_clip_each(src.level_g, src.motion.sigma_g, k, each,
                                                                 offset_g=site.offset_g - src.offset_g, shape=base,
                                                                 kind=site.kind, tone_peaks_g=src.motion.tone_peaks_g)]
        else:
            # filters between: the rails see the polynomial's mean and its linear part through
            # them (Gaussian), the rest (harmonics, higher Hermite terms) bounded below
            p_mo, p_share = up.site.motion, up.shift.shares["nonlinearity_g"]
            gain, rest = memoryless.linear_part(up.site.level_g, p_mo.sigma_g, *k, shape=base,
                                                tone_peaks_g=p_mo.tone_peaks_g)
            m = c0 + p_share
            sz, pz = abs(gain) * mo.sigma_g, tuple(abs(gain) * a for a in mo.tone_peaks_g)
            parts = []
            for (lo_, hi_), moved in zip(each, memoryless.poly_clip_each(m, sz, (0.0, 0.0, 0.0), each, shape=base,
                                                                         kind=site.kind, tone_peaks_g=pz)):
                # referred to the vibration-off reading at the rails, clip(c0), not clip(m)
                parts.append(moved + (float(np.clip(m, lo_, hi_)) - m) - (float(np.clip(c0, lo_, hi_)) - c0))
            gmax = gain_max(site.responses[len(up.site.responses):])
            r = rest * gmax
            if base == "sine":
                # deterministic: the harmonics (rms r, peak at most 2r for the 2nd and 3rd)
                # matter only where the sine, so widened, reaches a rail
                if r > 0 and not (low < m - math.sqrt(2) * sz - 2 * r and m + math.sqrt(2) * sz + 2 * r < high):
                    bound += 2 * r
            elif r > 0 and sz > 0 and not pz:
                # the rest's n-th Hermite component (n >= 2, in the n-th Wiener chaos, through
                # the filters at most gmax times its rms) correlates only with the n-th chaos
                # part of 1{L < Z < U}, of norm |He_{n-1}(α)φ(α) - He_{n-1}(β)φ(β)|/sqrt(n!)
                # (Cauchy-Schwarz within each chaos); plus the rest's second-order effect
                # across the rails, r²·(pdf at the rails)
                comps = memoryless.hermite_rms(up.site.level_g, p_mo.sigma_g, *k)[1:]
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
        shares = {"clip_g": parts[0]}
        if site.each_rail:
            shares = {"clip_low_g": parts[1], "clip_high_g": parts[2], **shares}
        return Shift(shares, model_error_g=bound, valid=valid, notes=tuple(notes), sigma_at_clip_g=mo.rms_g,
                     saturates=True)


@dataclass(frozen=True)
class Quantize(StageBase):
    """Rounding to the output LSB: ``y = lsb·round(x/lsb)`` (ties to even).

    Examples
    --------
    The ADXL355's LSB at ±2 g, 1/256000 g (3.9 µg), in counts:

    >>> import numpy as np
    >>> from vrelab.sensor import Quantize, SensorChain
    >>> y, _ = SensorChain((Quantize(1 / 256000),)).apply(np.array([1.0e-5, 0.5]), 1000.0)
    >>> [int(v) for v in np.round(y * 256000)]
    [3, 128000]
    """

    lsb_g: float
    zero_mean_shift: ClassVar[str] = "rounding to the LSB (mean error 0 for vibration spanning many LSB)"

    def __post_init__(self) -> None:
        positive(self, "lsb_g")

    def process(self, x: FloatArray, state: None, fs_hz: float) -> tuple[FloatArray, None]:
        return np.round(x / self.lsb_g) * self.lsb_g, state


# ----------------------------------------------------------------------------- rate change


@dataclass(frozen=True)
class Decimate(StageBase):
    """Keep every ``factor``-th sample, the phase carried across blocks.

    No filtering: anti-aliasing is the job of the low-pass before it (as in the part, whose
    digital filter sets the bandwidth at ODR/4 and then drops samples).

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.sensor import Decimate, SensorChain
    >>> chain = SensorChain((Decimate(4),))
    >>> chain.fs_out_hz(16000.0)
    4000.0
    >>> y, _ = chain.apply(np.arange(12.0), 16000.0)
    >>> print(y)
    [0. 4. 8.]
    """

    factor: int
    zero_mean_shift: ClassVar[str] = "decimation (keeps the mean)"

    def __post_init__(self) -> None:
        positive_int(self, "factor")

    @property
    def rate_factor(self) -> int:  # type: ignore[override]
        return int(self.factor)

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> int:
        return 0  # index, in the next block, of the next sample to keep

    def process(self, x: FloatArray, state: int, fs_hz: float) -> tuple[FloatArray, int]:
        return x[state :: self.factor].copy(), (state - x.size) % self.factor


# ----------------------------------------------------------------------------- noise


class _NoiseState(NamedTuple):
    seed_seq: np.random.SeedSequence
    position: int  # samples generated so far
    frame_index: int  # index of the cached frame (-1: none)
    frame: FloatArray | None

    def __deepcopy__(self, memo: dict[int, Any]) -> _NoiseState:
        # The cached frame is derived data (redrawn from the seed when needed), so a copy of
        # the run (the simulated test keeps one per segment as a checkpoint) leaves it behind
        # instead of holding another frame_size·8 bytes per copy.
        return _NoiseState(copy.deepcopy(self.seed_seq, memo), self.position, -1, None)


@dataclass(frozen=True)
class Noise(StageBase):
    """Additive white Gaussian noise with one-sided density ``density_ug_per_rthz``.

    Parameters
    ----------
    density_ug_per_rthz : noise density [µg/√Hz].
    frame_size : internal frame length [samples].

    Notes
    -----
    White noise sampled at ``fs`` with one-sided density ``d`` has ``σ = d·sqrt(fs/2)``. Put it
    before the low-pass: the filtered output then shows the density ``d`` in band, which is how
    a data sheet states it. Samples come in fixed frames of ``frame_size``; frame ``i`` is drawn
    from the SeedSequence child ``spawn_key + (i,)`` of the stage's seed, so the sequence is the
    same whatever the block size (and frames can be generated independently).

    Examples
    --------
    The ADXL355's 22.5 µg/√Hz at a 4 kHz sample rate (2 kHz of one-sided band): 1.0 mg rms.

    >>> import numpy as np
    >>> from vrelab.sensor import Noise, SensorChain
    >>> y, _ = SensorChain((Noise(22.5),)).apply(np.zeros(400_000), 4000.0, seed=1)
    >>> print(f"{y.std() * 1e3:.2f} mg rms")
    1.01 mg rms
    """

    density_ug_per_rthz: float
    # 512 kB cached per run (not by its deep copies); drawing a frame starts a Generator
    # (about 23 µs), 0.35 ns per sample at this size against 1.4 ns at 2^14.
    frame_size: int = 65536
    is_static: ClassVar[bool] = False
    zero_mean_shift: ClassVar[str] = "zero-mean noise"

    def __post_init__(self) -> None:
        non_negative(self, "density_ug_per_rthz")
        positive_int(self, "frame_size")

    def sigma_g(self, fs_hz: float) -> float:
        return from_ug(self.density_ug_per_rthz) * math.sqrt(fs_hz / 2)

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> _NoiseState:
        # Without a chain seed the stage is still reproducible: seed 0.
        return _NoiseState(seed_seq if seed_seq is not None else np.random.SeedSequence(0), 0, -1, None)

    def _rng(self, ss: np.random.SeedSequence, i: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence(entropy=ss.entropy, spawn_key=(*ss.spawn_key, i)))

    def _frame(self, ss: np.random.SeedSequence, i: int) -> FloatArray:
        return self._rng(ss, i).standard_normal(self.frame_size)

    def process(self, x: FloatArray, state: _NoiseState, fs_hz: float) -> tuple[FloatArray, _NoiseState]:
        n = x.size
        if n == 0:
            return x.copy(), state
        fsz = self.frame_size
        start, stop = state.position, state.position + n
        frame_index, frame = state.frame_index, state.frame
        # Frame i covers samples [i·fsz, (i+1)·fsz); whole frames inside the block are drawn
        # straight into the output buffer (no concatenation), the partly used frames at the
        # block's ends come from (or go to) the one-frame cache.
        y = np.empty(n)
        pos = start
        while pos < stop:
            i, off = divmod(pos, fsz)
            take = min(fsz - off, stop - pos)
            out = y[pos - start : pos - start + take]
            if take == fsz:
                self._rng(state.seed_seq, i).standard_normal(out=out)
            else:
                if i != frame_index:
                    frame_index, frame = i, self._frame(state.seed_seq, i)
                assert frame is not None
                out[:] = frame[off : off + take]
            pos += take
        y *= self.sigma_g(fs_hz)
        y += x
        return y, _NoiseState(state.seed_seq, stop, frame_index, frame)
