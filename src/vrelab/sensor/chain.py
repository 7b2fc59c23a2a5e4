"""A sensor as an ordered tuple of stages, streamed block by block.

``SensorChain`` is immutable data (the stages and their order). Running it creates a
:class:`ChainRun`, the one object that holds per-stage state (filter ``zi``, decimation phase,
noise frame position, hold timers, counters), so a record of any length streams in bounded
memory and the output does not depend on how the input is cut into blocks::

    runner = chain.start(fs_hz=20000.0, seed=1)
    for block in blocks:
        y = runner.process(block)
    runner.stats.clipped_samples

or, as an iterator that keeps its stats::

    out = chain.run(blocks, fs_hz=20000.0, seed=1)
    y = np.concatenate(list(out)); out.stats
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Iterator, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab.sensor.base import Stage
from vrelab.sensor.filtering import fused_filter_state, is_sos_filter, process_fused
from vrelab.sensor.stages import Decimate

FloatArray = NDArray[np.float64]

__all__ = ["SensorChain", "ChainRun", "ChainStats", "seed_sequence"]


def seed_sequence(seed: int | np.random.SeedSequence) -> np.random.SeedSequence:
    """A SeedSequence from an int (>= 0) or a SeedSequence (returned as is)."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0 or a numpy SeedSequence, got {seed!r}")
    return np.random.SeedSequence(int(seed))


def _child(ss: np.random.SeedSequence, i: int) -> np.random.SeedSequence:
    # Same as the i-th ss.spawn() child, without mutating ss (spawn counts its children, so a
    # second run with the same SeedSequence object would otherwise get different noise).
    return np.random.SeedSequence(entropy=ss.entropy, spawn_key=(*ss.spawn_key, i))


@dataclass(frozen=True)
class ChainStats:
    """Counters of a run so far.

    ``clipped_samples`` sums every :class:`~vrelab.sensor.stages.Clip` stage (at that stage's
    rate); ``overrange_events`` counts hold episodes of every over-range stage,
    ``overrange_samples`` their held samples. ``per_stage`` keeps each stage's own dict.

    Examples
    --------
    What a run counted: samples in and out, and those the rails clipped.

    >>> import numpy as np
    >>> from vrelab.sensor import Clip, SensorChain
    >>> _, stats = SensorChain((Clip(-2.0, 2.0),)).apply(np.array([1.0, 3.0, -3.0, 0.5]), 1000.0)
    >>> stats.samples_in, stats.samples_out, stats.clipped_samples
    (4, 4, 2)
    """

    samples_in: int = 0
    samples_out: int = 0
    clipped_samples: int = 0
    overrange_events: int = 0
    overrange_samples: int = 0
    per_stage: tuple[tuple[str, Mapping[str, int | float]], ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        return {
            "samples_in": self.samples_in,
            "samples_out": self.samples_out,
            "clipped_samples": self.clipped_samples,
            "overrange_events": self.overrange_events,
            "overrange_samples": self.overrange_samples,
            "per_stage": [{"stage": name, **dict(d)} for name, d in self.per_stage],
        }


@dataclass(frozen=True)
class SensorChain:
    """An ordered tuple of stages (order is data).

    Parameters
    ----------
    stages : the stages, input first. Each follows :class:`vrelab.sensor.stages.Stage`.

    Examples
    --------
    A chain is its stages in order; the order is data. The rails before or after a 100 Hz
    low-pass give different outputs for a 200 Hz sine of 3 g peak on ±2 g rails:

    >>> import numpy as np
    >>> from vrelab.sensor import Clip, LowPass, SensorChain
    >>> t = np.arange(4000) / 4000.0
    >>> x = 3.0 * np.sin(2 * np.pi * 200.0 * t)
    >>> for chain in (SensorChain((Clip(-2.0, 2.0), LowPass(100.0))), SensorChain((LowPass(100.0), Clip(-2.0, 2.0)))):
    ...     y, stats = chain.apply(x, 4000.0)
    ...     print([type(s).__name__ for s in chain.stages], stats.clipped_samples)
    ['Clip', 'LowPass'] 2000
    ['LowPass', 'Clip'] 0
    """

    stages: tuple[Stage, ...]

    def __post_init__(self) -> None:
        stages = tuple(self.stages)
        for i, s in enumerate(stages):
            if not isinstance(s, Stage):
                raise ValueError(
                    f"stages[{i}] must follow the Stage protocol (is_static, rate_factor, init_state, "
                    f"process, stats), got {s!r}"
                )
        object.__setattr__(self, "stages", stages)

    @property
    def rate_factor(self) -> int:
        """Input rate / output rate (product of the stages' decimation factors)."""
        return math.prod(int(s.rate_factor) for s in self.stages)

    @property
    def is_static(self) -> bool:
        return all(s.is_static for s in self.stages)

    def fs_out_hz(self, fs_in_hz: float) -> float:
        return float(fs_in_hz) / self.rate_factor

    def start(self, fs_hz: float, seed: int | np.random.SeedSequence = 0) -> ChainRun:
        """A fresh run at input rate ``fs_hz`` [Hz]; stage ``i`` is seeded with child ``i`` of ``seed``."""
        return ChainRun(self, fs_hz, seed)

    def run(
        self, blocks: Iterable[ArrayLike], fs_hz: float, seed: int | np.random.SeedSequence = 0
    ) -> ChainOutput:
        """Stream ``blocks`` through the chain: an iterator of output blocks with ``.stats``."""
        return ChainOutput(self.start(fs_hz, seed), iter(blocks))

    def apply(
        self, x: ArrayLike, fs_hz: float, seed: int | np.random.SeedSequence = 0, block_size: int = 1 << 16
    ) -> tuple[FloatArray, ChainStats]:
        """Whole array in, whole output and stats out (streams internally in ``block_size``)."""
        arr = np.asarray(x, dtype=np.float64)
        runner = self.start(fs_hz, seed)
        out = [runner.process(arr[i : i + block_size]) for i in range(0, arr.size, block_size)]
        y = np.concatenate(out) if out else np.empty(0)
        return y, runner.stats


class ChainRun:
    """One run of a chain: holds the per-stage state (the only mutable object here).

    Examples
    --------
    A run keeps each stage's state from one block to the next, so two halves give the whole:

    >>> import numpy as np
    >>> from vrelab.sensor import LowPass, SensorChain
    >>> x = np.random.default_rng(0).normal(0.0, 1.0, 2000)
    >>> chain = SensorChain((LowPass(100.0),))
    >>> run = chain.start(1000.0)
    >>> halves = np.concatenate([run.process(x[:1000]), run.process(x[1000:])])
    >>> whole, _ = chain.apply(x, 1000.0)
    >>> bool(np.allclose(halves, whole, rtol=0, atol=1e-12))
    True
    """

    def __init__(self, chain: SensorChain, fs_hz: float, seed: int | np.random.SeedSequence = 0) -> None:
        try:
            fs = float(fs_hz)
        except (TypeError, ValueError):
            raise ValueError(f"fs_hz must be a number, got {fs_hz!r}") from None
        if not math.isfinite(fs) or fs <= 0:
            raise ValueError(f"fs_hz must be a finite number > 0, got {fs_hz!r}")
        ss = seed_sequence(seed)
        self.chain = chain
        self.fs_in_hz = fs
        self._rates: list[float] = []
        self._states: list[Any] = []
        rate = fs
        # Whole samples (at the current rate) by which the stages so far delay the signal (the
        # over-range stage looks two samples ahead). A decimator keeps the samples that fall
        # on the undelayed grid, so the output samples the same instants at any internal rate
        # (delayed by whole output samples); otherwise a delay of 2/fs would move the instants
        # where the output clip and quantiser act with the internal rate.
        latency = 0
        for i, stage in enumerate(chain.stages):
            self._rates.append(rate)
            state = stage.init_state(rate, _child(ss, i))
            latency += int(getattr(stage, "delay_samples", 0))
            if isinstance(stage, Decimate):
                state = latency % stage.factor
                latency //= stage.factor
            self._states.append(state)
            rate = rate / int(stage.rate_factor)
        self.fs_out_hz = rate
        # Consecutive linear filters (e.g. anti-alias -> low-pass) run as one sosfilt over their
        # stacked sections: one pass over the block instead of one per stage. _ends[i] is the
        # exclusive end of the run of stages starting at i that one step processes; a fused
        # run keeps its state in the slot of its first stage.
        stages = chain.stages
        self._ends = list(range(1, len(stages) + 1))
        i = 0
        while i < len(stages):
            j = i
            while j < len(stages) and is_sos_filter(stages[j]):
                j += 1
            fused = fused_filter_state(stages[i:j], tuple(self._states[i:j])) if j - i >= 2 else None
            if fused is not None:
                self._ends[i] = j
                self._states[i] = fused
                i = j
            else:
                i += 1
        self._n_in = 0
        self._n_out = 0

    def process(self, block: ArrayLike) -> FloatArray:
        """Process one block (1-D, in g); returns the output block (a new array)."""
        x = np.asarray(block, dtype=np.float64)
        if x.ndim != 1:
            raise ValueError(f"block must be one-dimensional, got shape {x.shape}")
        if not np.isfinite(x).all():
            raise ValueError("block must be finite, got NaN or inf")
        y = x
        stages, ends, i = self.chain.stages, self._ends, 0
        while i < len(stages):
            if ends[i] > i + 1:
                y, self._states[i] = process_fused(y, self._states[i])
            else:
                y, self._states[i] = stages[i].process(y, self._states[i], self._rates[i])
            i = ends[i]
        if np.may_share_memory(y, x):
            y = y.copy()  # the caller owns the output; never hand back (a view of) the input
        self._n_in += x.size
        self._n_out += y.size
        return y

    @property
    def stats(self) -> ChainStats:
        per_stage = []
        totals = {"clipped_samples": 0, "overrange_events": 0, "overrange_samples": 0}
        for stage, state in zip(self.chain.stages, self._states):
            get = getattr(stage, "stats", None)
            d = dict(get(state)) if get is not None else {}
            if d:
                per_stage.append((type(stage).__name__, d))
            for key in totals:
                totals[key] += int(d.get(key, 0))
        return ChainStats(self._n_in, self._n_out, per_stage=tuple(per_stage), **totals)


class ChainOutput(Iterator[FloatArray]):
    """Iterator returned by :meth:`SensorChain.run`; ``stats`` is live."""

    def __init__(self, runner: ChainRun, blocks: Iterator[ArrayLike]) -> None:
        self.runner = runner
        self._blocks = blocks

    def __next__(self) -> FloatArray:
        return self.runner.process(next(self._blocks))

    @property
    def stats(self) -> ChainStats:
        return self.runner.stats

    @property
    def fs_out_hz(self) -> float:
        return self.runner.fs_out_hz
