"""The virtual lab: a simulated shaker test of a sensor, reduced like a recorded one.

A test runs as a lab runs it (SPEC section 4): a vibration-off baseline, a level, a baseline,
the next level, ..., each level bracketed by baselines. The device under test (DUT) sees the
*total* acceleration ``static_g + drive(t)`` through its signal chain
(:meth:`vrelab.sensor.Sensor.chain`), simulated block by block at an internal rate chosen by
the sensor (:meth:`~vrelab.sensor.Sensor.internal_rate_hz`), so memory does not grow with the
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
import dataclasses
import math
from concurrent.futures import Executor
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from vrelab import __version__
from vrelab import _validate as V
from vrelab._ahead import Ahead
from vrelab.models.clipping import Kind as ClipKind
from vrelab.profiles import RandomProfile
from vrelab.rates import NYQUIST_MARGIN, record_step, simulation_rate_hz
from vrelab.record import Schedule, Segment, write_record_hdf5
from vrelab.results import Conditions, FitResult, LevelResult, Method, Notice, VreResult
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


# --- the test plan ----------------------------------------------------------------------------


@dataclass(frozen=True)
class _Seg:
    """One stretch of the simulated test, in internal samples."""

    n_internal: int
    rms_g: float  # 0: vibration off
    freq_hz: float | None = None  # sine method
    seed: int | None = None  # random drive
    ramp: int = 0  # internal samples of the amplitude ramp at each end (inside n_internal)


@dataclass(frozen=True)
class _Rates:
    fs_internal_hz: float
    decimation: int  # internal samples per DUT output sample
    step: int  # internal samples per record sample
    fs_record_hz: float

    @property
    def hold(self) -> int:
        """Record samples per DUT output sample (zero-order hold of the DUT's ODR)."""
        return self.decimation // self.step


def _choose_rates(chain: Any, fs_internal_hz: float, f_max_hz: float) -> _Rates:
    fs_out = float(chain.fs_out_hz(fs_internal_hz))
    ratio = fs_internal_hz / fs_out
    decimation = int(round(ratio))
    if decimation < 1 or abs(ratio - decimation) > 1e-9 * ratio:
        raise ValueError(
            f"internal rate {fs_internal_hz:g} Hz is not an integer multiple of the sensor's "
            f"output rate {fs_out:g} Hz"
        )
    step = record_step(decimation, fs_internal_hz, f_max_hz)
    return _Rates(fs_internal_hz, decimation, step, fs_internal_hz / step)


def _round_up(n: float, multiple: int) -> int:
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
    """

    channels: tuple[str, ...] = ("reference", "dut")

    def __init__(
        self,
        sensor: Any,
        segments: Sequence[_Seg],
        rates: _Rates,
        static_g: float,
        *,
        profile: RandomProfile | None,
        drive_method: DriveMethod,
        clip_sigma: float | None,
        kurtosis: float | None,
        chain_seed: np.random.SeedSequence,
        meta: Mapping[str, Any],
        progress: bool = False,
    ) -> None:
        self.sensor = sensor
        self._segments = tuple(segments)
        self.rates = rates
        self.static_g = float(static_g)
        self._profile = profile
        self._drive_method = drive_method
        self._clip_sigma = clip_sigma
        self._kurtosis = kurtosis
        self._chain_seed = chain_seed
        self.meta = dict(meta)
        self._progress = progress
        self.fs_hz = rates.fs_record_hz
        self.n_samples = sum(s.n_internal for s in self._segments) // rates.step
        self.schedule = self._schedule()
        self.saturated: list[int] | None = None
        self.overrange_events: list[int] | None = None
        self.clipped: list[int] | None = None
        self.chain_stats: dict[str, Any] | None = None
        # A drive that is not band-limited (clipped at k·σ, or given a kurtosis) needs an
        # anti-alias filter on the reference when the record rate is below the internal rate.
        # Butterworth order 10 at the record's Nyquist frequency: flat to 1e-6 up to f_max
        # (<= 0.4·fs_record), 35 dB down where aliases into the band start (fs_record - f_max).
        self._ref_sos = None
        if rates.step > 1 and (clip_sigma is not None or kurtosis is not None):
            self._ref_sos = signal.butter(10, rates.fs_record_hz / 2, fs=rates.fs_internal_hz, output="sos")
        ref_zi = None if self._ref_sos is None else np.zeros((self._ref_sos.shape[0], 2))
        runner0 = sensor.chain(rates.fs_internal_hz).start(rates.fs_internal_hz, chain_seed)
        self._checkpoints: dict[int, Any] = {0: (runner0, ref_zi)}

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

    def _drive(self, seg: _Seg) -> Iterator[NDArray[np.float64]]:
        blocks = self._drive_at_level(seg)
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

    def _drive_at_level(self, seg: _Seg) -> Iterator[NDArray[np.float64]]:
        from vrelab import synthesis

        fs = self.rates.fs_internal_hz
        # Blocks hold whole DUT output samples, so the decimation phase, the reference's
        # sub-sampling and the DUT hold all restart at every block edge.
        block = max(1, BLOCK_INTERNAL // self.rates.decimation) * self.rates.decimation
        if seg.rms_g == 0:
            left = seg.n_internal
            while left > 0:
                n = min(block, left)
                yield np.zeros(n)
                left -= n
        elif seg.freq_hz is not None:
            yield from synthesis.sine_blocks(seg.freq_hz, seg.rms_g, fs, seg.n_internal, block)
        else:
            assert self._profile is not None
            yield from synthesis.random_blocks(
                self._profile.scaled_to(seg.rms_g),
                fs,
                seg.n_internal,
                block,
                seed=seg.seed,
                method=self._drive_method,
                clip_sigma=self._clip_sigma,
                kurtosis=self._kurtosis,
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
        low, high = _rail_window(self.sensor)
        full = first == 0
        if first not in self._checkpoints:
            first = max(k for k in self._checkpoints if k <= first)
        runner, ref_zi = copy.deepcopy(self._checkpoints[first])
        saturated = [0] * len(self._segments)
        events = [0] * len(self._segments)
        clipped = [0] * len(self._segments)
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
        bar = _progress_bar(total, self._progress and not partial)
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


def _rail_window(sensor: Any) -> tuple[float, float]:
    """(low, high): DUT output at or beyond these counts as saturated."""
    low, high = (float(r) for r in sensor.rails_g)
    lsb = getattr(sensor, "lsb_g", None) or 0.0
    tol = max(_RAIL_TOL_LSB * float(lsb), 1e-9)
    return low + tol, high - tol


def _progress_bar(total: int, enabled: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, disable=not enabled, unit="S", unit_scale=True, leave=False, desc="simulating")


# --- running a test ---------------------------------------------------------------------------


def _sensor_name(sensor: Any) -> str:
    return str(getattr(sensor, "name", type(sensor).__name__))


def _conditions(sensor: Any, profile_text: str, static_g: float, extra: Mapping[str, Any]) -> Conditions:
    """The sensor's conditions (range, axis, ODR, bandwidth, rails) plus the test's."""
    base = sensor.conditions(static_g=float(static_g), profile=profile_text, model="simulation")
    return dataclasses.replace(base, extra={**dict(base.extra), **dict(extra)})


def _provenance(function: str, sensor: Any) -> dict[str, Any]:
    prov: dict[str, Any] = {
        "software": f"vrelab {__version__}",
        "function": function,
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    to_dict = getattr(sensor, "to_dict", None)
    if callable(to_dict):
        prov["sensor"] = to_dict()
    return prov


def _fs_internal(sensor: Any, f_max_hz: float, fs_internal_hz: float | None) -> float:
    if fs_internal_hz is not None:
        return V.positive_scalar("fs_internal_hz", fs_internal_hz)
    return simulation_rate_hz(sensor, f_max_hz)


def _reduce_and_fit(
    record: SimulatedRecord,
    method: Method,
    band_hz: tuple[float, float] | None,
    settle_s: float,
    record_path: str | Path | None,
    progress: bool,
    clip_kind: str = "censored",
) -> tuple[list[LevelResult], list[FitResult], list[str]]:
    """Reduce the record as a lab file (saturation counts and over-range flags from the
    simulation's truth), then fit it with the one fit policy (:func:`vrelab.fits.fit_levels`)
    that ``vrelab analyze`` applies to the same record."""
    from vrelab.analysis import reduce
    from vrelab.fits import fit_levels

    source: Any = record
    if record_path is not None:
        # One simulation pass writes the file; the analysis then reads the file back, which
        # costs far less than simulating twice and closes the loop the way a lab does.
        write_record_hdf5(
            record_path,
            record.fs_hz,
            record.blocks(1 << 16, record.channels),
            schedule=record.schedule,
            meta=record.meta,
        )
        from vrelab.analysis.readers import open_record

        source = open_record(record_path, dut="dut", reference="reference")
    # The simulation's own progress bar covers the pass that generates the record; the
    # reduction shows one only when it reads the file back.
    red = reduce(
        source, schedule=record.schedule, method=method, band_hz=band_hz, settle_s=settle_s,
        progress=progress and record_path is not None,
    )
    levels, warnings = _with_simulated_saturation(record, list(red.levels), list(red.warnings))
    nominal = [seg.freq_hz for seg in red.level_segments]
    fits, notes = fit_levels(levels, method, red.static_g, clip_kind, nominal_freqs_hz=nominal)
    return levels, fits, warnings + notes


def _with_simulated_saturation(
    record: SimulatedRecord, levels: list[LevelResult], warnings: list[str]
) -> tuple[list[LevelResult], list[str]]:
    # The simulation knows exactly which DUT samples sat on a rail and where the chain clipped
    # or tripped its over-range protection; the reduction can only guess rails from the
    # record (a noise-free sine repeats its peak value every period and looks like a rail).
    # Replace its saturation guess by the truth, keep its other flags.
    warnings = [w for w in warnings if getattr(w, "code", None) not in ("rail-found", "saturated-levels")]
    on = [i for i, s in enumerate(record.schedule.segments) if not s.is_baseline]
    if record.saturated is None or len(levels) != len(on):
        warnings.append(Notice("simulation", "saturation counts of the simulation could not be matched to the levels"))
        return levels, warnings
    n_flagged = 0
    for j, i in enumerate(on):
        flags = tuple(f for f in levels[j].flags if f not in ("saturated", "overrange"))
        n_sat = record.saturated[i]
        if n_sat or (record.clipped and record.clipped[i]):
            flags += ("saturated",)
            n_flagged += 1
        if record.overrange_events and record.overrange_events[i]:
            flags += ("overrange",)
        levels[j] = dataclasses.replace(levels[j], n_saturated=n_sat, flags=flags)
    if n_flagged:
        warnings.append(Notice("saturated-levels", f"{n_flagged} level(s) reached a rail of the sensor (flagged 'saturated')"))
    return levels, warnings


def _settle(settle_s: float | None) -> float:
    """The settling time trimmed at each segment edge: by default the reduction's own default
    (its DUT low-pass must settle after every level change)."""
    if settle_s is None:
        from vrelab.analysis.reduction import DEFAULT_SETTLE_S

        return float(DEFAULT_SETTLE_S)
    return float(V.non_negative("settle_s", settle_s))


def min_segment_seconds(settle_s: float | None = None) -> float:
    """Shortest baseline or level [s] the simulated test accepts for a settling time ``settle_s``.

    The reduction ignores a segment with fewer than 3 whole averaging windows after the trim
    (4 windows of length guarantee 3 whole ones), and trims at most a quarter of a segment
    per edge, so a segment shorter than 4·settle_s would be trimmed less than asked.
    """
    from vrelab.analysis.reduction import WINDOW_S

    settle_s = _settle(settle_s)
    return max(2 * settle_s + MIN_WINDOWS * WINDOW_S, 4 * settle_s)


def _check_durations(seconds: float, baseline_s: float, settle_s: float) -> None:
    """Each segment must leave the reduction enough to average after the settling trim."""
    from vrelab.analysis.reduction import WINDOW_S

    need = min_segment_seconds(settle_s)
    for name, value in (("seconds", seconds), ("baseline_s", baseline_s)):
        if value < need - 1e-9:
            raise ValueError(
                f"{name} must be >= {need:g} s with settle_s={settle_s:g} s (the settling trim at both "
                f"edges, at most a quarter of the segment each, plus {MIN_WINDOWS} averaging windows of "
                f"{WINDOW_S:g} s), got {name}={value:g}"
            )


def _ramp_samples(ramp_s: float, fs_internal_hz: float, rates: _Rates) -> int:
    """Internal samples of one ramp: whole DUT output samples, so the schedule's level segment
    starts on a record sample (0 for no ramp)."""
    return _round_up(ramp_s * fs_internal_hz, rates.decimation) if ramp_s > 0 else 0


def _validate_levels(name: str, levels: Sequence[float]) -> list[float]:
    arr = V.positive(name, np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty list of levels, got {levels!r}")
    return [float(x) for x in arr]


def plan_random_test(
    sensor: "Sensor",
    profile: RandomProfile,
    levels_grms: Sequence[float],
    static_g: float = 1.0,
    seconds: float = 4.0,
    baseline_s: float = 2.0,
    settle_s: float | None = None,
    seed: int = 0,
    drive_method: DriveMethod = "gaussian",
    clip_sigma: float | None = None,
    kurtosis: float | None = None,
    fs_internal_hz: float | None = None,
    progress: bool = False,
    ramp_s: float = 0.0,
) -> SimulatedRecord:
    """The record of a random-method test, not yet run (see :func:`run_random_test`)."""
    if not isinstance(profile, RandomProfile):
        raise ValueError(f"profile must be a RandomProfile, got {type(profile).__name__}")
    levels = _validate_levels("levels_grms", levels_grms)
    static_g = V.finite_scalar("static_g", static_g)
    seconds = V.positive_scalar("seconds", seconds)
    baseline_s = V.positive_scalar("baseline_s", baseline_s)
    settle_s = _settle(settle_s)
    V.one_of("drive_method", drive_method, ("gaussian", "multisine"))
    ramp_s = float(V.non_negative("ramp_s", ramp_s))
    _check_durations(seconds, baseline_s, settle_s)
    f_lo, f_hi = profile.band
    fs_int = _fs_internal(sensor, f_hi, fs_internal_hz)
    rates = _choose_rates(sensor.chain(fs_int), fs_int, f_hi)
    root = np.random.SeedSequence(int(seed))
    chain_seed, *level_seeds = root.spawn(len(levels) + 1)
    n_base = _round_up(baseline_s * fs_int, rates.decimation)
    n_level = _round_up(seconds * fs_int, rates.decimation)
    n_ramp = _ramp_samples(ramp_s, fs_int, rates)
    segs: list[_Seg] = [_Seg(n_base, 0.0)]
    for g, s in zip(levels, level_seeds):
        seed_g = int(s.generate_state(1, np.uint32)[0])
        segs += [_Seg(n_level + 2 * n_ramp, g, None, seed_g, n_ramp), _Seg(n_base, 0.0)]
    extra = {
        "seed": int(seed),
        "seconds": seconds,
        "baseline_s": baseline_s,
        "settle_s": settle_s,
        "fs_internal_hz": fs_int,
        "fs_record_hz": rates.fs_record_hz,
        "drive_method": drive_method,
        "clip_sigma": clip_sigma,
        "kurtosis": kurtosis,
        "band_hz": [f_lo, f_hi],
    }
    if n_ramp:
        extra["ramp_s"] = n_ramp / fs_int
    return SimulatedRecord(
        sensor,
        segs,
        rates,
        static_g,
        profile=profile,
        drive_method=drive_method,
        clip_sigma=clip_sigma,
        kurtosis=kurtosis,
        chain_seed=chain_seed,
        meta={"simulation": extra, "sensor": _sensor_name(sensor), "static_g": static_g, "profile": profile.to_dict()},
        progress=progress,
    )


def run_random_test(
    sensor: "Sensor",
    profile: RandomProfile,
    levels_grms: Sequence[float],
    static_g: float = 1.0,
    seconds: float = 4.0,
    baseline_s: float = 2.0,
    settle_s: float | None = None,
    seed: int = 0,
    drive_method: DriveMethod = "gaussian",
    clip_sigma: float | None = None,
    kurtosis: float | None = None,
    record_path: str | Path | None = None,
    progress: bool = False,
    fs_internal_hz: float | None = None,
    clip_kind: ClipKind = "censored",
    ramp_s: float = 0.0,
) -> VreResult:
    """Simulate the random method (SPEC 4) on ``sensor`` and reduce it like a lab record.

    Parameters
    ----------
    sensor : vrelab.sensor.Sensor
        The device under test.
    profile : RandomProfile
        PSD shape [g²/Hz]; scaled to each level (``profile.scaled_to(grms)``).
    levels_grms : sequence of float
        Vibration levels [g rms], each > 0, run in the order given.
    static_g : float
        Static acceleration along the axis [g] (+1: axis up in a 1 g field).
    seconds, baseline_s, settle_s : float
        Duration of each level, of each vibration-off baseline, and the settling time trimmed
        at each edge by the analysis [s] (default: the reduction's default, long enough for its
        DUT low-pass to settle after a level change).
    seed : int
        Root of every random draw (drive of each level, sensor noise): same seed, same result.
    drive_method, clip_sigma, kurtosis
        Passed to :func:`vrelab.synthesis.random_blocks`.
    record_path : path, optional
        Also write the raw record (``reference``, ``dut``, schedule, meta) as HDF5; the
        analysis then reads it back, so ``vrelab analyze`` on that file gives the same levels.
    progress : bool
        A progress bar on stderr.
    fs_internal_hz : float, optional
        Override the sensor's internal simulation rate (for convergence checks).
    clip_kind : {"censored", "truncated"}
        Clipping model of the effective-rail fit.
    ramp_s : float
        Duration [s] of the drive's amplitude ramp at each end of every level (raised cosine
        from 0 to the level and back, as a shaker controller brings a level up and down),
        added outside the ``seconds`` at level; rounded up to whole DUT output samples. The
        schedule embedded in the record leaves the ramps out. 0 (default): the level starts
        and stops at once.

    Returns
    -------
    VreResult
        One level per ``levels_grms`` (VRE ± standard uncertainty from the record's own noise,
        rms of the drive in the profile's band, saturated-sample counts), the effective-rail
        fit and a VRC fit over the levels that stay clear of the rails, conditions, provenance.

    Notes
    -----
    Schedule: baseline, level 1, baseline, ..., level n, baseline. Each level's drive is an
    independent realisation (``SeedSequence(seed)`` children) of the profile scaled to its
    grms; the sensor sees ``static_g + drive``. The reduction (SPEC 4) gives
    ``VRE = mean(DUT over the level) − baseline interpolated between the bracketing
    off-segments``, its standard uncertainty from the record's own scatter, and
    ``vib_rms`` = reference rms over the profile's band widened by an octave on each side (the
    drive has no power outside the band, and the band-pass edges then do not bias it). Fits:
    the one policy :func:`vrelab.fits.fit_levels`, as ``vrelab analyze`` applies it to the
    same record: the effective rail of the clipping model (SPEC 1.1, at the static reading
    of the baselines, with the level where the data depart from it), then ``VRE = VRC·rms²``
    (SPEC 1.2) over levels whose 4σ peaks stay inside the fitted rails.

    References
    ----------
    .. [1] SPEC sections 1 and 4; the seed article's random method (ADXL355, 50 Hz-2 kHz).
    .. [2] IEEE Std 1293-1998 (vibration rectification test procedure).
    """
    record = plan_random_test(
        sensor, profile, levels_grms, static_g, seconds, baseline_s, settle_s, seed,
        drive_method, clip_sigma, kurtosis, fs_internal_hz, progress, ramp_s=ramp_s,
    )
    settle = record.meta["simulation"]["settle_s"]
    levels, fits, warnings = _reduce_and_fit(record, "random", _measurement_band(profile), settle, record_path,
                                             progress, clip_kind)
    return VreResult(
        method="random",
        conditions=_conditions(sensor, f"random {profile.band[0]:g}-{profile.band[1]:g} Hz"
                               + (f" ({profile.name})" if profile.name else ""), static_g,
                               record.meta["simulation"]),
        levels=tuple(levels),
        fits=tuple(fits),
        warnings=tuple(warnings),
        provenance=_provenance("vrelab.shaker.run_random_test", sensor),
        kind="simulation",
    )


def _measurement_band(profile: RandomProfile) -> tuple[float, float]:
    """Band in which the reduction measures the reference rms: the profile's band widened by
    an octave on each side. The drive has no power outside the profile's band (it is
    synthesised that way), so the wider band measures the same rms, but the band-pass edges
    (a Butterworth is 3 dB down at its corners) no longer eat into the profile's edges."""
    f_lo, f_hi = profile.band
    return f_lo / 2, f_hi * 2


def _sine_band(record: SimulatedRecord) -> tuple[float, float] | None:
    """The reduction's default band (50-2000 Hz) unless the record rate cannot hold it; then
    an octave around the drive frequencies, below the record's Nyquist frequency. (For the
    sine method the band only serves the window statistics: levels come from the lock-in.)"""
    nyquist = record.fs_hz / 2
    if 50.0 < 0.9 * nyquist:
        return None
    freqs = [s.freq_hz for s in record.schedule.segments if s.freq_hz]
    return min(freqs) / 2, min(2 * max(freqs), 0.9 * nyquist)


def plan_sine_test(
    sensor: "Sensor",
    freqs_hz: Sequence[float],
    levels_rms_g: Sequence[float],
    static_g: float = 1.0,
    seconds: float = 2.0,
    baseline_s: float = 2.0,
    settle_s: float | None = None,
    seed: int = 0,
    fs_internal_hz: float | None = None,
    progress: bool = False,
    ramp_s: float = 0.0,
) -> SimulatedRecord:
    """The record of a sine-method test, not yet run (see :func:`run_sine_test`)."""
    freqs = _validate_levels("freqs_hz", freqs_hz)
    levels = _validate_levels("levels_rms_g", levels_rms_g)
    static_g = V.finite_scalar("static_g", static_g)
    seconds = V.positive_scalar("seconds", seconds)
    baseline_s = V.positive_scalar("baseline_s", baseline_s)
    settle_s = _settle(settle_s)
    ramp_s = float(V.non_negative("ramp_s", ramp_s))
    _check_durations(seconds, baseline_s, settle_s)
    f_max = max(freqs)
    fs_int = _fs_internal(sensor, f_max, fs_internal_hz)
    if f_max >= fs_int / (2 * NYQUIST_MARGIN):
        raise ValueError(f"freqs_hz: {f_max:g} Hz is too high for the internal rate {fs_int:g} Hz")
    rates = _choose_rates(sensor.chain(fs_int), fs_int, f_max)
    chain_seed = np.random.SeedSequence(int(seed)).spawn(1)[0]
    n_base = _round_up(baseline_s * fs_int, rates.decimation)
    n_ramp = _ramp_samples(ramp_s, fs_int, rates)
    segs: list[_Seg] = [_Seg(n_base, 0.0)]
    for f in freqs:
        # IEEE 1293: average over whole periods; the window left after trimming settle_s at
        # each edge holds a whole number of periods (to within one record sample).
        periods = max(1, round((seconds - 2 * settle_s) * f))
        n_level = _round_up((periods / f + 2 * settle_s) * fs_int, rates.decimation)
        for g in levels:
            segs += [_Seg(n_level + 2 * n_ramp, g, f, None, n_ramp), _Seg(n_base, 0.0)]
    extra = {
        "seed": int(seed),
        "seconds": seconds,
        "baseline_s": baseline_s,
        "settle_s": settle_s,
        "fs_internal_hz": fs_int,
        "fs_record_hz": rates.fs_record_hz,
        "drive_method": "sine",
    }
    if n_ramp:
        extra["ramp_s"] = n_ramp / fs_int
    return SimulatedRecord(
        sensor,
        segs,
        rates,
        static_g,
        profile=None,
        drive_method="gaussian",
        clip_sigma=None,
        kurtosis=None,
        chain_seed=chain_seed,
        meta={"simulation": extra, "sensor": _sensor_name(sensor), "static_g": static_g,
              "freqs_hz": freqs},
        progress=progress,
    )


def run_sine_test(
    sensor: "Sensor",
    freqs_hz: Sequence[float],
    levels_rms_g: Sequence[float],
    static_g: float = 1.0,
    seconds: float = 2.0,
    baseline_s: float = 2.0,
    settle_s: float | None = None,
    seed: int = 0,
    record_path: str | Path | None = None,
    progress: bool = False,
    fs_internal_hz: float | None = None,
    ramp_s: float = 0.0,
) -> VreResult:
    """Simulate the sine method (IEEE Std 1293-1998; SPEC 4) and fit VRC at each frequency.

    At each frequency in ``freqs_hz`` every level of ``levels_rms_g`` [g rms] runs for
    ``seconds`` (rounded to whole periods of the drive after the settling trim), bracketed by
    vibration-off baselines. ``VRE = VRC·vib_rms²`` is fitted by weighted least squares
    through the origin at each frequency (:func:`vrelab.fits.fit_vrc`): ``VRC(f)`` shows the
    resonance (``VRC·|H(f)|²``, SPEC 1.3). Other parameters (``ramp_s`` too) as in
    :func:`run_random_test`; with a ramp the sine's amplitude rises and falls, its phase runs on.
    """
    record = plan_sine_test(
        sensor, freqs_hz, levels_rms_g, static_g, seconds, baseline_s, settle_s, seed, fs_internal_hz, progress,
        ramp_s=ramp_s,
    )
    settle = record.meta["simulation"]["settle_s"]
    levels, fits, warnings = _reduce_and_fit(record, "sine", _sine_band(record), settle, record_path, progress)
    freqs_text = ", ".join(f"{f:g}" for f in dict.fromkeys(float(x) for x in freqs_hz))
    return VreResult(
        method="sine",
        conditions=_conditions(sensor, f"sine {freqs_text} Hz", static_g, record.meta["simulation"]),
        levels=tuple(levels),
        fits=tuple(fits),
        warnings=tuple(warnings),
        provenance=_provenance("vrelab.shaker.run_sine_test", sensor),
        kind="simulation",
    )


# --- a production lot -------------------------------------------------------------------------


@dataclass(frozen=True)
class LotResult:
    """VRE across a production lot: one row per unit, and per-level statistics.

    ``params[i]`` holds the drawn parameters of unit ``i``; ``vre_g[i, j]`` its VRE at level
    ``j`` [g]; ``u_vre_g`` the simulation's standard uncertainty (0 for predictions).
    """

    levels_g: tuple[float, ...]
    params: tuple[Mapping[str, float], ...]
    vre_g: NDArray[np.float64]
    u_vre_g: NDArray[np.float64]
    mode: str
    conditions: Conditions
    seed: int

    @property
    def mean_g(self) -> NDArray[np.float64]:
        return self.vre_g.mean(axis=0)

    @property
    def std_g(self) -> NDArray[np.float64]:
        return self.vre_g.std(axis=0, ddof=1) if len(self.vre_g) > 1 else np.zeros(len(self.levels_g))

    def percentile_g(self, q: float) -> NDArray[np.float64]:
        return np.percentile(self.vre_g, q, axis=0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "mode": self.mode,
            "seed": self.seed,
            "conditions": self.conditions.to_dict(),
            "levels_g": list(self.levels_g),
            "units": [
                {"params": dict(p), "vre_g": [float(x) for x in v], "u_vre_g": [float(x) for x in u]}
                for p, v, u in zip(self.params, self.vre_g, self.u_vre_g)
            ],
            "summary": [
                {"rms_g": lv, "mean_vre_g": float(m), "std_vre_g": float(s),
                 "p05_vre_g": float(a), "p95_vre_g": float(b)}
                for lv, m, s, a, b in zip(
                    self.levels_g, self.mean_g, self.std_g, self.percentile_g(5), self.percentile_g(95)
                )
            ],
        }


def _lot_unit(
    sensor: Any,
    excitation: RandomProfile | float,
    levels: Sequence[float],
    static_g: float,
    mode: str,
    seed: np.random.SeedSequence,
    seconds: float,
) -> tuple[list[float], list[float]]:
    if mode == "predict":
        from vrelab.predict import predict

        pred = predict(sensor, excitation, levels, static_g=static_g)
        return [lv.vre_g for lv in pred.levels], [0.0] * len(levels)
    sim_seed = int(seed.generate_state(1)[0])
    if isinstance(excitation, RandomProfile):
        res = run_random_test(sensor, excitation, levels, static_g, seconds=seconds, seed=sim_seed)
    else:
        res = run_sine_test(sensor, [float(excitation)], levels, static_g, seconds=seconds, seed=sim_seed)
    return [lv.vre.value for lv in res.levels], [lv.vre.u for lv in res.levels]


def monte_carlo_lot(
    sensor: "Sensor",
    profile_or_freq: RandomProfile | float,
    levels: Sequence[float],
    n_units: int,
    spreads: Mapping[str, tuple[float, float]],
    seed: int = 0,
    static_g: float = 1.0,
    mode: Literal["predict", "simulate"] = "predict",
    seconds: float = 2.0,
    executor: Executor | None = None,
) -> LotResult:
    """Spread of VRE across a production lot of ``n_units`` sensors.

    Each unit is ``dataclasses.replace(sensor, **params)`` with every parameter named in
    ``spreads`` drawn from a normal distribution ``(mean, standard deviation)`` in the
    parameter's own units (e.g. ``{"fn_hz": (2400, 100), "q": (1.5, 0.2)}``); draws that
    leave the parameter's physical domain (a negative Q) are redrawn. Unit ``i`` uses the
    ``i``-th child of ``SeedSequence(seed)`` both for its parameters and, with
    ``mode="simulate"``, for its simulated test, so results do not depend on the executor.
    ``mode="predict"`` uses :func:`vrelab.predict.predict` (fast); ``"simulate"`` runs the
    virtual shaker test for each unit.
    """
    n_units = int(n_units)
    if n_units < 1:
        raise ValueError(f"n_units must be >= 1, got {n_units}")
    V.one_of("mode", mode, ("predict", "simulate"))
    lv = _validate_levels("levels", levels)
    fields = {f.name for f in dataclasses.fields(sensor)}
    for name, spec in spreads.items():
        if name not in fields:
            raise ValueError(f"spreads: sensor has no parameter {name!r}")
        if len(spec) != 2 or not (np.isfinite(spec[0]) and np.isfinite(spec[1]) and spec[1] >= 0):
            raise ValueError(f"spreads[{name!r}] must be (mean, std >= 0), got {spec!r}")
    children = np.random.SeedSequence(int(seed)).spawn(n_units)
    units: list[Any] = []
    params: list[dict[str, float]] = []
    for child in children:
        rng = np.random.default_rng(child)
        drawn: dict[str, float] = {}
        for name, (mean, sd) in spreads.items():
            x = rng.normal(mean, sd)
            # Keep strictly positive parameters (fn, Q, rail, ...) physical: redraw, bounded.
            for _ in range(100):
                if mean <= 0 or x > 0:
                    break
                x = rng.normal(mean, sd)
            drawn[name] = float(x)
        params.append(drawn)
        units.append(dataclasses.replace(sensor, **drawn))
    args = [(u, profile_or_freq, lv, static_g, mode, c, seconds) for u, c in zip(units, children)]
    if executor is None:
        rows = [_lot_unit(*a) for a in args]
    else:
        rows = list(executor.map(_lot_unit, *zip(*args)))
    excitation_text = (
        profile_or_freq.describe() if isinstance(profile_or_freq, RandomProfile) else f"sine {float(profile_or_freq):g} Hz"
    )
    return LotResult(
        levels_g=tuple(lv),
        params=tuple(params),
        vre_g=np.array([r[0] for r in rows], dtype=np.float64),
        u_vre_g=np.array([r[1] for r in rows], dtype=np.float64),
        mode=mode,
        conditions=_conditions(sensor, excitation_text, static_g, {"seed": int(seed), "n_units": n_units,
                                                                  "spreads": {k: list(v) for k, v in spreads.items()}}),
        seed=int(seed),
    )
