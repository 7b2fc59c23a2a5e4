"""The simulated record: a shaker test generated on demand, block by block, from its seed.

A test runs as a lab runs it (physics §4): a vibration-off baseline, a level, a baseline,
the next level, ..., each level bracketed by baselines. The device under test (DUT) sees the
*total* acceleration ``static_g + drive(t)`` through its signal chain
(:meth:`vrelab.sensor.Sensor.chain`), simulated block by block at an internal rate chosen by
the one rate rule (:func:`vrelab.rates.simulation_rate_hz`), so memory does not grow with the
duration. The drive itself is the reference channel (an ideal reference accelerometer: it sees
the vibration, not gravity).

Record rate
-----------
The record holds both channels at one rate ``fs_record_hz = fs_internal_hz / m``:

* the DUT output at its output data rate (ODR), held between updates as a DAQ logging a
  digital sensor does (each ODR sample repeated ``fs_record_hz/ODR`` times); for a sensor
  without decimation (``ideal``) the record rate is the internal rate;
* the reference, i.e. the drive, kept at every ``m``-th internal sample. ``m`` is the largest
  divisor of the chain's decimation for which the record's Nyquist frequency stays above
  ``1.25·f_max`` of the drive, so the drive (band-limited by construction to the profile's band
  or a single tone) is represented exactly, without an anti-alias filter: the level reported
  is the true vibration rms in the profile's band, not the part a low ODR lets through. A
  drive that is not band-limited (clipped at k·σ, or with a target kurtosis) is low-passed at
  the record's Nyquist frequency first, as a DAQ's anti-alias filter would.

The internal rate is a multiple of the ODR fast enough that every discretised analog filter
matches its analog response up to the drive's highest frequency and the nonlinearity's
harmonics are not aliased, chosen to minimise internal + record rate
(:func:`vrelab.rates.simulation_rate_hz`): for the ADXL355 at ODR 4 kHz and a 2 kHz profile, 16 kHz
internal and an 8 kHz record.

The record is never held in memory: :class:`SimulatedRecord` implements the
:class:`vrelab.record.Record` protocol by re-running the deterministic simulation (every random
draw comes from ``SeedSequence(seed)``), and the analysis reduces it exactly as it reduces a
file recorded in a lab (:func:`vrelab.analysis.reduce_record`), followed by the fits of
:mod:`vrelab.fits`.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterator, Mapping, Protocol, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from vrelab import _validate as V
from vrelab._ahead import Ahead
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.rates import record_step
from vrelab.record import Schedule, Segment
from vrelab.synthesis import Method as DriveMethod

if TYPE_CHECKING:
    from vrelab.sensor import Sensor

# Internal samples per simulated block: large enough that per-block Python overhead is small
# against the numpy/scipy work (2^16 runs as fast as 2^17, measured on the ADXL355 random test),
# small enough (0.5 MB per array) that the chain's temporaries and the drive synthesised ahead in
# its thread stay a few MB.
BLOCK_INTERNAL = 1 << 16
# Windows of the reduction a segment must hold after the settling trim (the reduction ignores
# shorter segments).
MIN_WINDOWS = 4
# DUT samples within this many LSB (or 1e-9 g) of a rail count as saturated.
_RAIL_TOL_LSB = 0.5




@dataclass(frozen=True)
class Stretch:
    """One stretch of the simulated test, in internal samples."""

    n_internal: int
    rms_g: float  # 0: vibration off
    freq_hz: float | None = None  # sine method
    seed: int | None = None  # random drive
    ramp: int = 0  # internal samples of the amplitude ramp at each end (inside n_internal)
    # sine: the drive's frequency against the simulation's clock (None: freq_hz) and its phase
    # at the stretch's first sample (see vrelab.simulation.plan.sine_drive)
    drive_hz: float | None = None
    phase_rad: float = 0.0
    lattice: int = 0  # sine: output samples per batch of whole periods, all on distinct phases


@dataclass(frozen=True)
class Rates:
    fs_internal_hz: float
    decimation: int  # internal samples per DUT output sample
    step: int  # internal samples per record sample
    fs_record_hz: float

    @property
    def hold(self) -> int:
        """Record samples per DUT output sample (zero-order hold of the DUT's ODR)."""
        return self.decimation // self.step


@dataclass(frozen=True)
class RandomDrive:
    """How a record's random stretches are synthesised (:func:`vrelab.synthesis.random_blocks`):
    the profile (scaled to each stretch's rms), the method, and the optional clip at
    ``clip_sigma``·σ or target ``kurtosis``. A record of sine stretches only has ``profile=None``."""

    profile: RandomProfile | SineOnRandom | None = None
    method: DriveMethod = "gaussian"
    clip_sigma: float | None = None
    kurtosis: float | None = None


class _Decimating(Protocol):
    """What the rate rule asks of a chain (:class:`vrelab.sensor.SensorChain`, the triaxial one): its output rate."""

    def fs_out_hz(self, fs_hz: float, /) -> float: ...


def choose_rates(chain: _Decimating, fs_internal_hz: float, f_max_hz: float) -> Rates:
    fs_out = float(chain.fs_out_hz(fs_internal_hz))
    ratio = fs_internal_hz / fs_out
    decimation = int(round(ratio))
    if decimation < 1 or abs(ratio - decimation) > 1e-9 * ratio:
        raise ValueError(
            f"internal rate {fs_internal_hz:g} Hz is not an integer multiple of the sensor's "
            f"output rate {fs_out:g} Hz"
        )
    step = record_step(decimation, fs_internal_hz, f_max_hz)
    return Rates(fs_internal_hz, decimation, step, fs_internal_hz / step)


def round_up(n: float, multiple: int) -> int:
    return max(multiple, int(math.ceil(n / multiple - 1e-9)) * multiple)


# --- the simulated record ---------------------------------------------------------------------


class SimulatedRecord:
    """A shaker test record generated on demand (the :class:`vrelab.record.Record` protocol).

    Channels ``reference`` (the drive, g) and ``dut`` (the sensor output, g, held at its ODR),
    both at :attr:`fs_hz`. Each call to :meth:`blocks` re-runs the simulation, deterministically
    from the seed, starting from the kept state of the segment where the pass begins, so two
    passes see the same samples and memory stays bounded whatever the duration. A complete pass
    also counts, per segment, the DUT output samples at a rail (:attr:`saturated`), the samples
    the chain clipped (:attr:`clipped`, at the clip's own rate) and the over-range episodes
    (:attr:`overrange_events`).

    Examples
    --------
    A planned test is a record like a lab file (the :class:`vrelab.record.Record` protocol): its
    channels are generated when read. A level between two vibration-off baselines:

    >>> import vrelab
    >>> from vrelab.shaker import plan_sine_test
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> record = plan_sine_test(sensor, [100.0], [1.0], static_g=1.0, seconds=2.0, seed=1)
    >>> record.channels
    ('reference', 'dut')
    >>> len(record.stretches)
    3
    """

    channels: tuple[str, ...] = ("reference", "dut")

    def __init__(
        self,
        sensor: Sensor,
        segments: Sequence[Stretch],
        rates: Rates,
        static_g: float,
        *,
        drive: RandomDrive,
        chain_seed: np.random.SeedSequence,
        meta: Mapping[str, Any],
        progress: bool = False,
    ) -> None:
        self.sensor = sensor
        self._segments = tuple(segments)
        self.rates = rates
        self.static_g = float(static_g)
        self._random = drive
        self._chain_seed = chain_seed
        self.meta = dict(meta)
        self._progress = progress
        self.fs_hz = rates.fs_record_hz
        self.n_samples = sum(s.n_internal for s in self._segments) // rates.step
        self.schedule = self._schedule()
        self.saturated: list[int] | None = None
        self.overrange_events: list[int] | None = None
        self.clipped: list[int] | None = None
        self.dut_span: list[float] | None = None  # per segment, max - min of the DUT output
        self.chain_stats: dict[str, Any] | None = None
        # A drive that is not band-limited (clipped at k·σ, or given a kurtosis) needs an
        # anti-alias filter on the reference when the record rate is below the internal rate.
        # Butterworth order 10 at the record's Nyquist frequency: flat to 1e-6 up to f_max
        # (<= 0.4·fs_record), 35 dB down where aliases into the band start (fs_record - f_max).
        self._ref_sos = None
        if rates.step > 1 and (drive.clip_sigma is not None or drive.kurtosis is not None):
            self._ref_sos = signal.butter(10, rates.fs_record_hz / 2, fs=rates.fs_internal_hz, output="sos")
        ref_zi = None if self._ref_sos is None else np.zeros((self._ref_sos.shape[0], 2))
        runner0 = sensor.chain(rates.fs_internal_hz).start(rates.fs_internal_hz, chain_seed)
        self._checkpoints: dict[int, Any] = {0: (runner0, ref_zi)}

    @property
    def stretches(self) -> tuple[Stretch, ...]:
        """The simulated test's stretches in order (baselines and levels, in internal samples),
        one per schedule segment."""
        return self._segments

    @property
    def chain_seed(self) -> np.random.SeedSequence:
        """The seed of the sensor chain's random draws (its noise); the drive's are in the stretches."""
        return self._chain_seed

    @property
    def block_internal(self) -> int:
        """Internal samples per simulated block: :data:`BLOCK_INTERNAL` rounded down to whole DUT
        output samples, so the decimation phase, the reference's sub-sampling and the DUT hold all
        restart at every block edge."""
        return max(1, BLOCK_INTERNAL // self.rates.decimation) * self.rates.decimation

    def _schedule(self) -> Schedule:
        """One schedule segment per simulated stretch; a level's segment leaves out its ramps
        (the drive is not at its level there), so the schedule has gaps where they are."""
        segs, t = [], 0
        for s in self._segments:
            n = s.n_internal // self.rates.step
            r = s.ramp // self.rates.step
            segs.append(Segment((t + r) / self.fs_hz, (t + n - r) / self.fs_hz, s.rms_g, s.freq_hz))
            t += n
        return Schedule(tuple(segs))

    # -- generation --

    def _drive(self, seg: Stretch) -> Iterator[NDArray[np.float64]]:
        blocks = self.level_blocks(seg)
        if seg.ramp == 0 or seg.rms_g == 0:
            yield from blocks
            return
        # A shaker controller brings the level up and down over the ramp: raised-cosine
        # amplitude envelope over the first and last `ramp` samples (smooth, so it spreads no
        # power far outside the drive's band), applied to the drive at its level.
        pos, n, r = 0, seg.n_internal, seg.ramp
        for x in blocks:
            i = pos + np.arange(x.size)
            env = np.ones(x.size)
            up, down = i < r, i >= n - r
            env[up] = 0.5 - 0.5 * np.cos(np.pi * (i[up] + 0.5) / r)
            env[down] = 0.5 - 0.5 * np.cos(np.pi * (n - i[down] - 0.5) / r)
            pos += x.size
            yield x * env

    def level_blocks(self, seg: Stretch) -> Iterator[NDArray[np.float64]]:
        """The drive of one stretch at its level, before any ramp, in blocks of
        :attr:`block_internal` samples (the last may be shorter): zeros for a baseline, the sine
        at its drive frequency and phase, or the profile's random drive scaled to the level."""
        from vrelab import synthesis

        fs = self.rates.fs_internal_hz
        block = self.block_internal
        if seg.rms_g == 0:
            left = seg.n_internal
            while left > 0:
                n = min(block, left)
                yield np.zeros(n)
                left -= n
        elif seg.freq_hz is not None:
            drive_hz = seg.freq_hz if seg.drive_hz is None else seg.drive_hz
            yield from synthesis.sine_blocks(drive_hz, seg.rms_g, fs, seg.n_internal, block, phase_rad=seg.phase_rad)
        else:
            drive = self._random
            assert drive.profile is not None and seg.seed is not None  # a random stretch has both
            yield from synthesis.random_blocks(
                drive.profile.scaled_to(seg.rms_g),
                fs,
                seg.n_internal,
                block,
                seed=seg.seed,
                method=drive.method,
                clip_sigma=drive.clip_sigma,
                kurtosis=drive.kurtosis,
            )

    def _drives(self, first: int) -> Iterator[NDArray[np.float64]]:
        """The drive blocks of every segment from ``first`` on, in order."""
        for seg in self._segments[first:]:
            yield from self._drive(seg)

    def _segment_starts(self) -> NDArray[np.int64]:
        """First record sample of each segment."""
        n = [s.n_internal // self.rates.step for s in self._segments]
        return np.concatenate(([0], np.cumsum(n)[:-1])).astype(np.int64)

    def _stream(self, first: int = 0) -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """Yield (reference, dut) pairs of equal length at the record rate from segment ``first`` on.

        The chain's state at the start of every segment is kept (a deep copy of the run: filter
        states, noise position, hold timers; kilobytes, independent of the duration), so a pass
        that starts inside the record (the sine reduction's second pass over each level)
        resumes there instead of re-simulating everything before it.
        """
        rates = self.rates
        step, hold = rates.step, rates.hold
        low, high = rail_window(self.sensor)
        full = first == 0
        if first not in self._checkpoints:
            first = max(k for k in self._checkpoints if k <= first)
        runner, ref_zi = copy.deepcopy(self._checkpoints[first])
        saturated = [0] * len(self._segments)
        events = [0] * len(self._segments)
        clipped = [0] * len(self._segments)
        span = [(math.inf, -math.inf)] * len(self._segments)
        # The drive does not depend on the sensor: it is synthesised in a second thread, one
        # block ahead, while this one runs the chain (numpy's Gaussian draws,
        # pocketfft and sosfilt release the GIL, so on two cores the two overlap).
        drives = Ahead(self._drives(first), depth=1, name="vrelab-drive")
        try:
            for k in range(first, len(self._segments)):
                if k not in self._checkpoints:
                    self._checkpoints[k] = copy.deepcopy((runner, ref_zi))
                seg = self._segments[k]
                before = runner.stats
                left = seg.n_internal
                while left > 0:
                    drive = next(drives)
                    left -= drive.size
                    out = runner.process(drive + self.static_g)
                    saturated[k] += int(np.count_nonzero((out <= low) | (out >= high)))
                    if out.size:
                        span[k] = (min(span[k][0], float(out.min())), max(span[k][1], float(out.max())))
                    if self._ref_sos is not None:
                        # A clipped or non-Gaussian drive spreads power above the profile's band:
                        # low-pass it at the record's Nyquist frequency before keeping every
                        # step-th sample, as a DAQ's anti-alias filter would.
                        ref, ref_zi = signal.sosfilt(self._ref_sos, drive, zi=ref_zi)
                        ref = ref[::step]
                    else:
                        # Band-limited by construction below the record's Nyquist frequency (see
                        # _choose_rates): keeping every step-th sample is exact.
                        ref = drive[::step]
                    dut = np.repeat(out, hold) if hold > 1 else out
                    yield ref, dut
                after = runner.stats
                events[k] = after.overrange_events - before.overrange_events
                clipped[k] = after.clipped_samples - before.clipped_samples
        finally:
            drives.close()
        if full:
            self.saturated, self.overrange_events, self.clipped = saturated, events, clipped
            self.dut_span = [hi - lo if hi >= lo else 0.0 for lo, hi in span]
            self.chain_stats = runner.stats.to_dict()

    def blocks(
        self, block_size: int, channels: Sequence[str], start: int = 0, stop: int | None = None
    ) -> Iterator[dict[str, NDArray[np.float64]]]:
        """Yield dicts channel -> float64 block of ``block_size`` samples (the last may be shorter)."""
        block_size = int(block_size)
        if block_size < 1:
            raise ValueError(f"block_size must be >= 1, got {block_size}")
        for c in channels:
            V.one_of("channel", c, self.channels)
        start = max(0, int(start))
        stop = self.n_samples if stop is None else min(int(stop), self.n_samples)
        if start >= stop:
            return
        starts = self._segment_starts()
        first = int(np.searchsorted(starts, start, side="right")) - 1
        first = max(k for k in self._checkpoints if k <= first)
        pos = int(starts[first])
        partial = first > 0 or stop < self.n_samples
        total = stop - start
        emitted = 0
        out: dict[str, NDArray[np.float64]] = {}
        filled = size = 0
        bar = progress_bar(total, self._progress and not partial)
        try:
            for ref, dut in self._stream(first):
                lo, hi = max(start - pos, 0), min(stop - pos, ref.size)
                pos += ref.size
                if hi > lo:
                    bar.update(hi - lo)
                    src = {"reference": ref, "dut": dut}
                    # Copy straight into the next output block (one copy of each requested
                    # channel, no concatenation keeping earlier buffers alive through views).
                    i = lo
                    while i < hi:
                        if not out:
                            size = min(block_size, total - emitted)
                            out = {c: np.empty(size) for c in channels}
                            filled = 0
                        take = min(hi - i, size - filled)
                        for c in channels:
                            out[c][filled : filled + take] = src[c][i : i + take]
                        filled += take
                        i += take
                        if filled == size:
                            yield out
                            emitted += size
                            out = {}
                # A pass that reaches the end lets the stream finish, so its counts are complete.
                if pos >= stop and partial:
                    break
            if out and filled:
                yield {c: v[:filled] for c, v in out.items()}
        finally:
            bar.close()


def rail_window(sensor: Sensor) -> tuple[float, float]:
    """(low, high): DUT output at or beyond these counts as saturated."""
    low, high = (float(r) for r in sensor.rails_g)
    lsb = getattr(sensor, "lsb_g", None) or 0.0
    tol = max(_RAIL_TOL_LSB * float(lsb), 1e-9)
    return low + tol, high - tol


def progress_bar(total: int, enabled: bool) -> Any:
    from tqdm import tqdm

    from vrelab._format import progress_stream

    return tqdm(total=total, disable=not enabled, unit="S", unit_scale=True, leave=False, desc="simulating",
                file=progress_stream())
