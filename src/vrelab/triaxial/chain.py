"""One DUT axis under a triaxial acceleration: the axis's signal chain, extended (physics §1.6).

The model of one sensing axis (a :class:`~vrelab.sensor.Sensor` loaded with ``axis=a``) under
the acceleration vector ``a(t) = g + x(t)`` in the part's frame (x, y, z), the contract of
every issue-22 module (``/work/wt/TRIAXIAL.md``):

1. **Front end**: the axis's linear stages before its :class:`~vrelab.sensor.stages.Polynomial`
   (today only the :class:`~vrelab.sensor.stages.Resonator`) act on every component alike,
   ``b_j = H * a_j``. ASSUMPTION: the axis's proof mass responds along every direction with its
   own dynamics; a triaxial part's other modes are not modelled.
2. **Sensed input**: ``u = w · b`` with ``w = sensor.sensitivity_row`` (1 on the own axis, the
   cross-axis sensitivity elsewhere).
3. **Nonlinearity** (:class:`TriaxialPolynomial`, IEEE 1293's model equation):
   ``y = u + k2·u² + k3·u³ + k4·u⁴ + Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``,
   ``(i, p, o) = sensor.triad``.
4. **The rest** of the axis's chain (over-range, clip, noise, filters, offset, drift, decimation,
   output clip, quantiser) on ``y``, unchanged, each stage seeded as in the single-axis chain
   (stage ``j`` of :meth:`Sensor.stages` takes child ``j`` of the seed).

With ``a`` along the input axis (``b_p = b_o = 0``) every cross term adds an exact 0 and
``u = b_i``: the output is that of :meth:`Sensor.chain` bit for bit, the same seed giving the
same noise. Without cross-coupling terms (all five K zero) ``y`` depends on ``a`` only through
``w · a`` (the front end is linear and time-invariant, its steady start linear in the first
sample), so the run feeds ``w · a`` to the single-axis chain itself: one filter instead of three.

References
----------
.. [1] IEEE Std 1293-1998, IEEE Standard Specification Format Guide and Test Procedure for
   Linear, Single-Axis, Nongyroscopic Accelerometers: the model equation's cross-coupling
   terms and the vibropendulous error ``Kip·σ²·sin φ cos φ``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Iterable, Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab.models import cross_terms
from vrelab.sensor.base import Stage, StageBase, finite
from vrelab.sensor.chain import ChainRun, ChainStats, SensorChain, seed_sequence
from vrelab.sensor.stages import FilterStage, Polynomial, Resonator

if TYPE_CHECKING:
    from vrelab.sensor import Sensor

FloatArray = NDArray[np.float64]

__all__ = ["TriaxialPolynomial", "TriaxialChain", "TriaxialRun", "triaxial_chain", "CROSS_TERMS"]

# The model equation's cross-coupling terms: (Sensor attribute, the two triad positions it
# multiplies; 0 = input i, 1 = pendulous p, 2 = output o), read off their one table.
CROSS_TERMS: tuple[tuple[str, int, int], ...] = tuple((t.attr, t.axes[0], t.axes[1]) for t in cross_terms.CROSS_TERMS)


@dataclass(frozen=True)
class TriaxialPolynomial:
    """IEEE 1293's model equation on the proof-mass motion ``b`` (3, n) of one axis.

    Parameters
    ----------
    sensitivity_row : (w_x, w_y, w_z), the axis's output per g along x, y, z (1 on its own axis).
    triad : (i, p, o), the input, pendulous and output axes as indices of (x, y, z).
    k2_per_g [1/g], k3_per_g2 [1/g²], k4_per_g3 [1/g³] : the scale-factor nonlinearity on ``u``.
    kip_per_g, kio_per_g, kpp_per_g, koo_per_g, kpo_per_g : cross-coupling coefficients [1/g].

    Notes
    -----
    ``u = w · b``;
    ``y = u + k2·u² + k3·u³ + k4·u⁴ + Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``
    (physics §1.2 and 1.6; IEEE Std 1293-1998 model equation, K in µg/g² there, 1/g here). The
    polynomial in ``u`` is :class:`~vrelab.sensor.stages.Polynomial`'s own (one owner), so
    with ``b`` along the input axis the output is its output bit for bit. For a zero-mean
    Gaussian ``b`` (no static part) the cross terms' mean is ``Σ K_jk·E[b_j b_k]`` (the
    vibropendulous error for ``jk = ip``).

    Examples
    --------
    The ADXL355's z axis: its sensitivity row, its k2 (20 µg/g²) and no IEEE 1293 cross-coupling
    terms in the preset:

    >>> import vrelab
    >>> from vrelab.triaxial.chain import TriaxialPolynomial
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> poly = TriaxialPolynomial.from_sensor(sensor)
    >>> poly.sensitivity_row, f"{poly.k2_per_g * 1e6:.0f} µg/g²", poly.has_cross_terms
    ((0.0, 0.0, 1.0), '20 µg/g²', False)
    """

    sensitivity_row: tuple[float, float, float]
    triad: tuple[int, int, int]
    k2_per_g: float = 0.0
    k3_per_g2: float = 0.0
    k4_per_g3: float = 0.0
    kip_per_g: float = 0.0
    kio_per_g: float = 0.0
    kpp_per_g: float = 0.0
    koo_per_g: float = 0.0
    kpo_per_g: float = 0.0
    is_static: ClassVar[bool] = True
    rate_factor: ClassVar[int] = 1

    def __post_init__(self) -> None:
        w = np.asarray(self.sensitivity_row, dtype=np.float64).ravel()
        if w.size != 3 or not np.isfinite(w).all():
            raise ValueError(f"TriaxialPolynomial sensitivity_row must be three finite numbers, got {self.sensitivity_row!r}")
        t = tuple(int(k) for k in self.triad)
        if sorted(t) != [0, 1, 2]:
            raise ValueError(f"TriaxialPolynomial triad must be a permutation of (0, 1, 2), got {self.triad!r}")
        if w[t[0]] != 1.0:
            raise ValueError(f"TriaxialPolynomial sensitivity_row must be 1 on the input axis {t[0]}, got {w[t[0]]!r}")
        for name in ("k2_per_g", "k3_per_g2", "k4_per_g3") + tuple(n for n, _, _ in CROSS_TERMS):
            finite(self, name)
        object.__setattr__(self, "sensitivity_row", tuple(float(x) for x in w))
        object.__setattr__(self, "triad", t)

    @classmethod
    def from_sensor(cls, sensor: Sensor) -> TriaxialPolynomial:
        """The axis's polynomial and cross-coupling terms from a :class:`~vrelab.sensor.Sensor`."""
        w = sensor.sensitivity_row
        return cls((float(w[0]), float(w[1]), float(w[2])), sensor.triad, sensor.k2_per_g, sensor.k3_per_g2,
                   sensor.k4_per_g3, *(float(getattr(sensor, n)) for n, _, _ in CROSS_TERMS))

    @property
    def has_cross_terms(self) -> bool:
        """True when any of Kip, Kio, Kpp, Koo, Kpo is set (the output then needs b, not only u)."""
        return any(getattr(self, n) for n, _, _ in CROSS_TERMS)

    def needed_axes(self) -> tuple[int, ...]:
        """Indices of the components of ``b`` the output depends on (the others need no filtering)."""
        need = {self.triad[0]} | {j for j in range(3) if self.sensitivity_row[j]}
        for name, a, b in CROSS_TERMS:
            if getattr(self, name):
                need |= {self.triad[a], self.triad[b]}
        return tuple(sorted(need))

    def sensed(self, b: Sequence[FloatArray | None]) -> FloatArray:
        """``u = w · b``; ``b[j]`` may be None where ``w_j`` is 0."""
        i = self.triad[0]
        bi = b[i]
        assert bi is not None
        u = bi.copy()
        for j in range(3):
            bj = b[j]
            if j != i and self.sensitivity_row[j]:
                assert bj is not None
                u += self.sensitivity_row[j] * bj
        return u

    def output(self, b: Sequence[FloatArray | None]) -> FloatArray:
        """``y`` for the proof-mass motion components ``b`` (each (n,); None where not needed)."""
        u = self.sensed(b)
        if self.k2_per_g or self.k3_per_g2 or self.k4_per_g3:
            y, _ = Polynomial(self.k2_per_g, self.k3_per_g2, self.k4_per_g3).process(u, None, 0.0)
        else:
            y = u
        for name, a, c in CROSS_TERMS:
            k = getattr(self, name)
            if k:
                ba, bc = b[self.triad[a]], b[self.triad[c]]
                assert ba is not None and bc is not None
                y += k * (ba * bc)
        return y

    def process(self, b: ArrayLike, state: Any = None, fs_hz: float = 0.0) -> tuple[FloatArray, Any]:
        """The stage form: ``b`` of shape (3, n) in, ``y`` (n,) out (``b`` is never modified)."""
        arr = np.asarray(b, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[0] != 3:
            raise ValueError(f"TriaxialPolynomial input must have shape (3, n), got {arr.shape}")
        return self.output([arr[0], arr[1], arr[2]]), state


class _Slot(StageBase):
    """Holds the index of a single-axis stage the triaxial run computes itself (front end and
    polynomial), so the rest of the chain keeps its stage indices and with them its seeds."""

    def process(self, x: FloatArray, state: Any, fs_hz: float) -> tuple[FloatArray, Any]:
        return x, state


def _front_split(stages: tuple[Stage, ...]) -> tuple[int, int]:
    """(n_front, n_skip): the front end is ``stages[:n_front]``; the rest starts at ``n_skip``
    (n_front + 1 when the axis has a Polynomial stage, which the triaxial polynomial replaces)."""
    poly = [k for k, s in enumerate(stages) if type(s) is Polynomial]
    if len(poly) > 1:
        raise ValueError("a triaxial axis needs at most one Polynomial stage, got several")
    if poly:
        n_front = poly[0]
        for s in stages[:n_front]:
            if not isinstance(s, FilterStage):
                raise ValueError(f"the stages before the Polynomial must be linear filters (the front end), "
                                 f"got {type(s).__name__}")
        return n_front, n_front + 1
    # No scale-factor nonlinearity: the front end is the mechanics (the leading resonances).
    n_front = 0
    while n_front < len(stages) and isinstance(stages[n_front], Resonator):
        n_front += 1
    return n_front, n_front


@dataclass(frozen=True)
class TriaxialChain:
    """One DUT axis's chain under a triaxial acceleration (see the module docstring).

    Parameters
    ----------
    stages : the axis's single-axis stages (:meth:`Sensor.stages` at the simulation rate).
    polynomial : the extended nonlinearity (:class:`TriaxialPolynomial`).

    ``start(fs_hz, seed).process(block)`` takes a (3, n) block of the total acceleration
    ``g + x(t)`` [g] along (x, y, z) and returns the axis's output block [g].

    Examples
    --------
    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> import numpy as np
    >>> from vrelab.triaxial.chain import triaxial_chain
    >>> chain = triaxial_chain(sensor, 64000.0)
    >>> type(chain).__name__, len(chain.stages) > 0
    ('TriaxialChain', True)
    """

    stages: tuple[Stage, ...]
    polynomial: TriaxialPolynomial

    def __post_init__(self) -> None:
        object.__setattr__(self, "stages", tuple(SensorChain(tuple(self.stages)).stages))
        if not isinstance(self.polynomial, TriaxialPolynomial):
            raise ValueError(f"polynomial must be a TriaxialPolynomial, got {self.polynomial!r}")
        _front_split(self.stages)

    @property
    def front(self) -> tuple[Stage, ...]:
        """The linear stages applied to every component (the proof mass's dynamics)."""
        return self.stages[: _front_split(self.stages)[0]]

    @property
    def rest(self) -> tuple[Stage, ...]:
        """The stages after the nonlinearity, on its output."""
        return self.stages[_front_split(self.stages)[1]:]

    @property
    def single_axis(self) -> SensorChain:
        """The axis's single-axis chain (what it is for ``a`` along the input axis)."""
        return SensorChain(self.stages)

    @property
    def rate_factor(self) -> int:
        return self.single_axis.rate_factor

    def fs_out_hz(self, fs_in_hz: float) -> float:
        return float(fs_in_hz) / self.rate_factor

    def start(self, fs_hz: float, seed: int | np.random.SeedSequence = 0) -> TriaxialRun:
        """A fresh run at input rate ``fs_hz`` [Hz], seeded as :meth:`SensorChain.start`."""
        return TriaxialRun(self, fs_hz, seed)

    def run(self, blocks: Iterable[ArrayLike], fs_hz: float,
            seed: int | np.random.SeedSequence = 0) -> Iterator[FloatArray]:
        """Stream (3, n) blocks through the chain: the output blocks."""
        runner = self.start(fs_hz, seed)
        for block in blocks:
            yield runner.process(block)

    def apply(self, a: ArrayLike, fs_hz: float, seed: int | np.random.SeedSequence = 0,
              block_size: int = 1 << 16) -> tuple[FloatArray, ChainStats]:
        """Whole (3, n) record in, whole output and stats out (streamed in ``block_size``)."""
        arr = np.asarray(a, dtype=np.float64)
        runner = self.start(fs_hz, seed)
        out = [runner.process(arr[:, k : k + block_size]) for k in range(0, arr.shape[-1], block_size)]
        return (np.concatenate(out) if out else np.empty(0)), runner.stats


def triaxial_chain(sensor: Sensor, fs_hz: float) -> TriaxialChain:
    """The triaxial chain of ``sensor``'s axis at internal rate ``fs_hz`` (a multiple of its ODR).

    The stages are :meth:`Sensor.stages` (the one reading of a sensor description); the
    polynomial adds the axis's sensitivity row and IEEE 1293 cross-coupling terms
    (:meth:`TriaxialPolynomial.from_sensor`).

    Examples
    --------
    The ADXL355's z axis as a triaxial chain at 64 kHz: its stages, and the polynomial that reads
    its sensitivity row (z) from the three components:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> from vrelab.triaxial.chain import triaxial_chain
    >>> chain = triaxial_chain(sensor, 64000.0)
    >>> chain.polynomial.sensitivity_row, [type(s).__name__ for s in chain.stages][:3]
    ((0.0, 0.0, 1.0), ['Resonator', 'Polynomial', 'OverRange'])
    """
    return TriaxialChain(sensor.stages(fs_hz), TriaxialPolynomial.from_sensor(sensor))


class TriaxialRun:
    """One run of a :class:`TriaxialChain`: the state of the front end (per component) and of
    the rest of the chain, carried across blocks.

    Examples
    --------
    A run keeps each stage's state across blocks of (3, n) acceleration:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> import numpy as np
    >>> from vrelab.triaxial.chain import triaxial_chain
    >>> run = triaxial_chain(sensor, 64000.0).start(64000.0)
    >>> a = np.zeros((3, 6400))
    >>> a[2] = 1.0
    >>> y = run.process(a)
    >>> print(y.shape)
    (400,)
    """

    def __init__(self, chain: TriaxialChain, fs_hz: float, seed: int | np.random.SeedSequence = 0) -> None:
        ss = seed_sequence(seed)
        self.chain = chain
        poly = chain.polynomial
        self._linear = not poly.has_cross_terms
        self._w = np.asarray(poly.sensitivity_row)
        self._single: ChainRun | None = None
        self._fronts: dict[int, ChainRun] = {}
        self._rest: ChainRun | None = None
        if self._linear:
            # y depends on a only through u = w·b = H*(w·a): the single-axis chain on w·a.
            self._single = chain.single_axis.start(fs_hz, ss)
            self.fs_in_hz, self.fs_out_hz = self._single.fs_in_hz, self._single.fs_out_hz
        else:
            n_front, n_skip = _front_split(chain.stages)
            front = SensorChain(chain.stages[:n_front])
            # stage k of the front end takes child k of the seed in every component's run, as
            # in the single-axis chain (the front end is deterministic anyway)
            self._fronts = {j: front.start(fs_hz, ss) for j in poly.needed_axes()} if n_front else {}
            rest = SensorChain((_Slot(),) * n_skip + chain.stages[n_skip:])
            self._rest = rest.start(fs_hz, ss)
            self.fs_in_hz, self.fs_out_hz = self._rest.fs_in_hz, self._rest.fs_out_hz
        self._n_in = 0

    def process(self, block: ArrayLike) -> FloatArray:
        """One (3, n) block of the total acceleration [g] along x, y, z; the output block [g]."""
        a = np.asarray(block, dtype=np.float64)
        if a.ndim != 2 or a.shape[0] != 3:
            raise ValueError(f"a triaxial block must have shape (3, n) (x, y, z rows), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError("block must be finite, got NaN or inf")
        self._n_in += a.shape[1]
        poly = self.chain.polynomial
        if self._single is not None:
            return self._single.process(poly.sensed([a[0], a[1], a[2]]))
        assert self._rest is not None
        b: list[FloatArray | None] = [None, None, None]
        for j in poly.needed_axes():
            b[j] = self._fronts[j].process(a[j]) if self._fronts else a[j]
        return self._rest.process(poly.output(b))

    @property
    def stats(self) -> ChainStats:
        """The rest of the chain's counters (clipped samples, over-range events); samples in
        counts the triaxial input samples."""
        run = self._single if self._single is not None else self._rest
        assert run is not None
        s = run.stats
        return ChainStats(self._n_in, s.samples_out, s.clipped_samples, s.overrange_events,
                          s.overrange_samples, s.per_stage)

