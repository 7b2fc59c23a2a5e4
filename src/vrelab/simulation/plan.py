"""The plan of a simulated shaker test: every choice made once, validated once, passed whole.

A :class:`TestPlan` holds what a lab's test plan holds (method, levels, frequencies or profile,
static field, durations, seed, drive options) and makes the :class:`SimulatedRecord` that runs
it (:meth:`TestPlan.record`). :mod:`vrelab.shaker` runs a plan and reduces its record; nothing
is handed on by position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence, TypedDict, Unpack

import numpy as np

from vrelab import _budget
from vrelab import _validate as V
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.rates import NYQUIST_MARGIN, simulation_rate_hz
from vrelab.record import DEFAULT_SETTLE_S, WINDOW_S, window_length, window_seconds
from vrelab.results import Method
from vrelab.simulation.durations import DEFAULT_BASELINE_S, DEFAULT_LEVEL_S
from vrelab.simulation.record import (
    MIN_WINDOWS,
    RandomDrive,
    Rates,
    SimulatedRecord,
    Stretch,
    choose_rates,
    round_up,
)
from vrelab.synthesis import Method as DriveMethod

if TYPE_CHECKING:
    from vrelab.sensor import Sensor

# What the reduction keeps per 0.1 s analysis window of a record (a dozen float64/int64 arrays,
# vrelab.analysis.segmentation.WindowStats): sized against the memory budget up front.
_WINDOW_STATS_BYTES = 12 * 8


def default_settle_s(settle_s: float | None = None) -> float:
    """The settling time trimmed at each segment edge: by default the reduction's own default
    (its DUT low-pass must settle after every level change)."""
    if settle_s is None:
        return float(DEFAULT_SETTLE_S)
    return float(V.non_negative("settle_s", settle_s))


def min_segment_seconds(settle_s: float | None = None, window_s: float = WINDOW_S) -> float:
    """Shortest baseline or level [s] the simulated test accepts for a settling time ``settle_s``
    and the reduction's averaging window ``window_s`` (:func:`vrelab.record.window_seconds`:
    0.1 s, longer for a band from below 20 Hz).

    The reduction ignores a segment with fewer than 3 whole averaging windows after the trim
    (4 windows of length guarantee 3 whole ones), and trims at most a quarter of a segment
    per edge, so a segment shorter than 4·settle_s would be trimmed less than asked.

    Examples
    --------
    The shortest level the simulated test accepts with a 0.5 s settling trim:

    >>> from vrelab.shaker import min_segment_seconds
    >>> print(f"{min_segment_seconds(0.5):.1f} s")
    2.0 s
    """
    settle_s = default_settle_s(settle_s)
    return max(2 * settle_s + MIN_WINDOWS * window_s, 4 * settle_s)


def measurement_band(profile: RandomProfile | SineOnRandom) -> tuple[float, float]:
    """Band in which the reduction measures the reference rms: the profile's band (its tones
    included) widened by an octave on each side. The drive has no power outside the profile's band (it is
    synthesised that way), so the wider band measures the same rms, but the band-pass edges
    (a Butterworth is 3 dB down at its corners) no longer eat into the profile's edges."""
    f_lo, f_hi = profile.band
    return f_lo / 2, f_hi * 2


def _ending_on(pos: int, n: int, window: int, multiple: int) -> int:
    """``n`` internal samples from ``pos``, lengthened so that they end on a multiple of ``window``
    (0: as they are), in whole ``multiple``s (the DUT's output samples: one at most past the edge)."""
    if window <= 0:
        return n
    end = -(-(pos + n) // window) * window
    return round_up(end - pos, multiple)


def _levels(name: str, levels: Sequence[float]) -> tuple[float, ...]:
    arr = V.vibration_level(name, np.atleast_1d(np.asarray(levels, dtype=np.float64)))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty list of levels, got {levels!r}")
    return tuple(float(x) for x in arr)


def _freqs(name: str, freqs: Sequence[float]) -> tuple[float, ...]:
    arr = V.positive(name, np.atleast_1d(np.asarray(freqs, dtype=np.float64)))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty list of frequencies, got {freqs!r}")
    return tuple(float(x) for x in arr)


class PlanOptions(TypedDict, total=False):
    """:class:`TestPlan`'s fields a caller sets by keyword beyond the method, sensor, levels,
    static field, profile and frequencies (each its default when left out; their meaning there):
    the ``**plan`` of :func:`vrelab.shaker.run_random_test` and its siblings."""

    seconds: float
    baseline_s: float
    settle_s: float | None
    seed: int
    drive_method: DriveMethod
    clip_sigma: float | None
    kurtosis: float | None
    fs_internal_hz: float | None
    ramp_s: float


class PlanFields(PlanOptions, total=False):
    """:class:`PlanOptions` and the static field: the keywords of :meth:`TestPlan.random`, :meth:`TestPlan.sine`."""

    static_g: float


@dataclass(frozen=True)
class TestPlan:
    """A shaker test to simulate (physics §4), validated on construction.

    ``method`` "random": every level of ``levels_g`` [g rms] runs the ``profile`` scaled to it;
    "sine": at each of ``freqs_hz`` every level runs as a sine. Each level lasts ``seconds``
    (sine: rounded to whole periods after the settling trim) between vibration-off baselines of
    ``baseline_s``; ``settle_s`` (default: the reduction's) is what the analysis trims at each
    edge; ``ramp_s`` raises and lowers each level (raised cosine, outside ``seconds``). ``seed``
    is the root of every random draw. ``drive_method``, ``clip_sigma``, ``kurtosis`` shape a
    random drive (:func:`vrelab.synthesis.random_blocks`); ``fs_internal_hz`` overrides the rate
    rule (:func:`vrelab.rates.simulation_rate_hz`).

    Examples
    --------
    A sine test of two levels at 100 Hz on the ADXL355, checked when it is made (a level too
    short for its settling trim is refused):

    >>> import vrelab
    >>> from vrelab.shaker import TestPlan
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> plan = TestPlan.sine(sensor, [100.0], [0.5, 1.0], static_g=1.0, seconds=2.0, seed=1)
    >>> plan.method, plan.levels_g
    ('sine', (0.5, 1.0))
    >>> TestPlan.sine(sensor, [100.0], [0.5], seconds=0.5)
    Traceback (most recent call last):
        ...
    ValueError: seconds must be >= 2 s with settle_s=0.5 s (...), got seconds=0.5
    """

    __test__ = False  # a pytest collection hint: this is not a test class

    method: Method
    sensor: Sensor
    levels_g: tuple[float, ...]
    static_g: float = 1.0
    seconds: float = DEFAULT_LEVEL_S
    baseline_s: float = DEFAULT_BASELINE_S
    settle_s: float | None = None  # None: the reduction's default (a float once constructed)
    seed: int = 0
    profile: RandomProfile | SineOnRandom | None = None
    freqs_hz: tuple[float, ...] = ()
    drive_method: DriveMethod = "gaussian"
    clip_sigma: float | None = None
    kurtosis: float | None = None
    fs_internal_hz: float | None = None
    ramp_s: float = 0.0
    # the baseline_s asked when a low band's analysis windows made it longer (_fit_band_windows)
    baseline_s_asked: float | None = None

    def __post_init__(self) -> None:
        V.one_of("method", self.method, ("random", "sine"))
        name = "levels_grms" if self.method == "random" else "levels_rms_g"
        put = object.__setattr__
        put(self, "levels_g", _levels(name, self.levels_g))
        put(self, "static_g", V.finite_scalar("static_g", self.static_g))
        put(self, "seconds", V.positive_scalar("seconds", self.seconds))
        put(self, "baseline_s", V.positive_scalar("baseline_s", self.baseline_s))
        put(self, "settle_s", default_settle_s(self.settle_s))
        put(self, "ramp_s", float(V.non_negative("ramp_s", self.ramp_s)))
        put(self, "seed", int(self.seed))
        if self.method == "random":
            if not isinstance(self.profile, (RandomProfile, SineOnRandom)):
                raise ValueError(f"profile must be a RandomProfile or SineOnRandom, got {type(self.profile).__name__}")
            V.one_of("drive_method", self.drive_method, ("gaussian", "multisine"))
        else:
            put(self, "freqs_hz", _freqs("freqs_hz", self.freqs_hz))
        if self.fs_internal_hz is not None:
            put(self, "fs_internal_hz", V.positive_scalar("fs_internal_hz", self.fs_internal_hz))
        need = min_segment_seconds(self.settle_s)
        for key in ("seconds", "baseline_s"):
            value = getattr(self, key)
            if value < need - 1e-9:
                raise ValueError(
                    f"{key} must be >= {need:g} s with settle_s={self.settle_s:g} s (the settling trim at both "
                    f"edges, at most a quarter of the segment each, plus {MIN_WINDOWS} averaging windows of "
                    f"{WINDOW_S:g} s), got {key}={value:g}"
                )
        self._fit_band_windows()

    def _fit_band_windows(self) -> None:
        """A measurement band (:func:`measurement_band`) from below 20 Hz makes the reduction's
        windows longer than 0.1 s (2/f1: 0.8 s for a profile from 5 Hz, its band from 2.5 Hz),
        and a segment holding fewer than 3 of them after the trims is not averaged: a 2 s baseline
        of a profile from 10 Hz or below kept 1 s, one window or two, and the record had no
        baseline. A baseline (no vibration: the lab's housekeeping) is lengthened to hold
        MIN_WINDOWS of them, the length used in the conditions (``baseline_s``; the one asked in
        ``baseline_s_asked``). A level keeps its length (the measurement's): one that cannot hold
        3 windows is refused."""
        if self.method != "random" or self.profile is None:
            return  # a sine test is reduced with 0.1 s windows
        assert self.settle_s is not None  # __post_init__ sets the default
        window = window_seconds(measurement_band(self.profile))
        need = min_segment_seconds(self.settle_s, window)
        fits = 2 * self.settle_s + (MIN_WINDOWS - 1) * window  # 3 whole windows at best below it
        if self.seconds < fits - 1e-9:
            raise ValueError(
                f"seconds must be >= {fits:g} s for a profile from {self.profile.band[0]:g} Hz: its analysis averages "
                f"windows of {window:g} s (2 FFT bins below its measurement band's lower edge, an octave under the "
                f"profile's) and a level must hold {MIN_WINDOWS - 1} of them after the settling trims of "
                f"{self.settle_s:g} s; got seconds={self.seconds:g}"
            )
        if self.baseline_s < need - 1e-9:
            object.__setattr__(self, "baseline_s_asked", self.baseline_s)
            object.__setattr__(self, "baseline_s", need)

    @classmethod
    def random(cls, sensor: Sensor, profile: RandomProfile | SineOnRandom, levels_grms: Sequence[float],
               **kw: Unpack[PlanFields]) -> TestPlan:
        """The random method (physics §4): ``profile`` scaled to each of ``levels_grms`` (a
        sine-on-random profile too: its tones scale with it and count in the level)."""
        return cls("random", sensor, tuple(np.atleast_1d(levels_grms)), profile=profile, **kw)

    @classmethod
    def sine(cls, sensor: Sensor, freqs_hz: Sequence[float], levels_rms_g: Sequence[float], **kw: Unpack[PlanFields]) -> TestPlan:
        """The sine method (IEEE 1293): each level at each frequency."""
        return cls("sine", sensor, tuple(np.atleast_1d(levels_rms_g)), freqs_hz=tuple(np.atleast_1d(freqs_hz)), **kw)

    @property
    def _random_profile(self) -> RandomProfile | SineOnRandom:
        """The random method's profile (__post_init__ refuses a random plan without one)."""
        if self.profile is None:
            raise ValueError("the random method needs a profile")
        return self.profile

    @property
    def f_max_hz(self) -> float:
        """The drive's highest frequency [Hz]."""
        return float(self._random_profile.band[1]) if self.method == "random" else max(self.freqs_hz)

    @property
    def profile_text(self) -> str:
        """The vibration, as the result's conditions state it."""
        if self.method == "random":
            p = self.profile
            if isinstance(p, SineOnRandom):
                lo, hi = p.random.band
                tones = ", ".join(f"{t.freq_hz:g}" for t in p.tones)
                return f"random {lo:g}-{hi:g} Hz + sine {tones} Hz" + (f" ({p.name})" if p.name else "")
            return f"random {p.band[0]:g}-{p.band[1]:g} Hz" + (f" ({p.name})" if p.name else "")  # type: ignore[union-attr]
        return "sine " + ", ".join(f"{f:g}" for f in dict.fromkeys(self.freqs_hz)) + " Hz"

    def _layout(self) -> tuple[float, Rates, list[Stretch], np.random.SeedSequence]:
        """(internal rate [Hz], rates, the record's stretches, the chain's seed): what the record
        will be, nothing generated yet."""
        fs_int = self.fs_internal_hz if self.fs_internal_hz is not None else simulation_rate_hz(self.sensor, self.f_max_hz)
        if self.method == "sine" and self.f_max_hz >= fs_int / (2 * NYQUIST_MARGIN):
            raise ValueError(f"freqs_hz: {self.f_max_hz:g} Hz is too high for the internal rate {fs_int:g} Hz")
        if self.method == "sine" and self.fs_internal_hz is None:
            needed = [f for f in self.freqs_hz if self._needs_lattice(f, fs_int)]
            if needed:
                fs_int = _lattice_rate(self.sensor, fs_int, needed)
        rates = choose_rates(self.sensor.chain(fs_int), fs_int, self.f_max_hz)
        segs, chain_seed = (self._random_stretches if self.method == "random" else self._sine_stretches)(rates)
        return fs_int, rates, segs, chain_seed

    def internal_samples(self) -> float:
        """Samples this test computes at the internal rate: what its compute time grows with
        (:func:`vrelab._budget.check_simulation`), known before anything runs."""
        return float(sum(s.n_internal for s in self._layout()[2]))

    def record(self, progress: bool = False) -> SimulatedRecord:
        """The record of this test, not yet run (its blocks are generated on demand)."""
        fs_int, rates, segs, chain_seed = self._layout()
        self._check_budget(segs, rates)
        extra: dict[str, Any] = {
            "seed": self.seed,
            "seconds": self.seconds,
            "baseline_s": self.baseline_s,
            **({} if self.baseline_s_asked is None else {"baseline_s_asked": self.baseline_s_asked}),
            "settle_s": self.settle_s,
            "fs_internal_hz": fs_int,
            "fs_record_hz": rates.fs_record_hz,
        }
        n_ramp = _ramp_samples(self.ramp_s, fs_int, rates)
        if self.method == "random":
            extra.update(drive_method=self.drive_method, clip_sigma=self.clip_sigma, kurtosis=self.kurtosis,
                         band_hz=list(self._random_profile.band))
            meta_more: dict[str, Any] = {"profile": self._random_profile.to_dict()}
        else:
            extra["drive_method"] = "sine"
            extra["sine_drive_hz"] = list(dict.fromkeys(s.drive_hz for s in segs if s.drive_hz is not None))
            meta_more = {"freqs_hz": list(self.freqs_hz)}
        if n_ramp:
            extra["ramp_s"] = n_ramp / fs_int
        return SimulatedRecord(
            self.sensor,
            segs,
            rates,
            self.static_g,
            drive=RandomDrive(self.profile, self.drive_method, self.clip_sigma, self.kurtosis)
            if self.method == "random" else RandomDrive(self.profile),
            chain_seed=chain_seed,
            meta={"simulation": extra, "sensor": str(getattr(self.sensor, "name", type(self.sensor).__name__)),
                  "static_g": self.static_g, **meta_more},
            progress=progress,
        )

    def _random_stretches(self, rates: Rates) -> tuple[list[Stretch], np.random.SeedSequence]:
        fs_int = rates.fs_internal_hz
        chain_seed, *level_seeds = np.random.SeedSequence(self.seed).spawn(len(self.levels_g) + 1)
        n_base = round_up(self.baseline_s * fs_int, rates.decimation)
        n_level = round_up(self.seconds * fs_int, rates.decimation)
        n_ramp = _ramp_samples(self.ramp_s, fs_int, rates)
        window = self._window_internal(rates)
        segs = [Stretch(_ending_on(0, n_base, window, rates.decimation), 0.0)]
        pos = segs[0].n_internal
        for g, s in zip(self.levels_g, level_seeds):
            seed_g = int(s.generate_state(1, np.uint32)[0])
            level = Stretch(n_level + 2 * n_ramp, g, None, seed_g, n_ramp)
            base = Stretch(_ending_on(pos + level.n_internal, n_base, window, rates.decimation), 0.0)
            segs += [level, base]
            pos += level.n_internal + base.n_internal
        return segs, chain_seed

    def _window_internal(self, rates: Rates) -> int:
        """Internal samples per analysis window when the baselines were lengthened for a low band
        (:meth:`_fit_band_windows`), else 0. Each such baseline then ends on a window edge, so the
        level after it starts on one: a level holds the same whole windows wherever it falls in
        the record (a 4 s level of 0.8 s windows, trimmed to 3 s: 3 windows, not 2 or 3)."""
        if self.baseline_s_asked is None or self.profile is None:
            return 0
        return window_length(rates.fs_record_hz, measurement_band(self.profile)) * rates.step

    def _sine_stretches(self, rates: Rates) -> tuple[list[Stretch], np.random.SeedSequence]:
        fs_int = rates.fs_internal_hz
        assert self.settle_s is not None  # __post_init__ sets the default
        # the chain's seed is the first child, as before the sine phases were drawn (a plan's
        # sensor noise does not change with them); each level's phase from the second
        chain_seed, phase_seed = np.random.SeedSequence(self.seed).spawn(2)
        rng = np.random.default_rng(phase_seed)
        n_base = round_up(self.baseline_s * fs_int, rates.decimation)
        n_ramp = _ramp_samples(self.ramp_s, fs_int, rates)
        segs = [Stretch(n_base, 0.0)]
        for f in self.freqs_hz:
            # IEEE 1293: average over whole periods; the window left after trimming settle_s at
            # each edge holds a whole number of periods. Where the output may reach a rail or
            # the over-range threshold (not a polynomial of the input: its cycle mean needs
            # many phases) or the drive meets fewer than 5 phases of the output, each batch
            # of m periods samples L phases (sine_drive) and the window holds whole batches.
            fs_out = fs_int / rates.decimation
            window: float
            if self._needs_lattice(f, fs_out):
                drive_hz, m, n_out = sine_drive(f, fs_out)
                batches = max(3, round((self.seconds - 2 * self.settle_s) * drive_hz / m))
                window, lattice = batches * n_out * rates.decimation, n_out
            else:
                periods = max(1, round((self.seconds - 2 * self.settle_s) * f))
                drive_hz, window, lattice = f, periods / f * fs_int, 0
            n_level = round_up(window + 2 * self.settle_s * fs_int, rates.decimation)
            for g in self.levels_g:
                # a random phase per level (a lab's drive starts where it starts); with a
                # lattice, every batch of L samples falls on the same L phases, whose error
                # the shaker adds to u (vrelab.shaker.with_lattice_u). Phase
                # steps between batches would shift the lattice at random instead, but a step
                # rings a resonance and moves the mean by more than the lattice's error.
                phase0 = float(rng.uniform(0.0, 2 * np.pi))
                segs += [Stretch(n_level + 2 * n_ramp, g, f, None, n_ramp, drive_hz, phase0, lattice),
                         Stretch(n_base, 0.0)]
        return segs, chain_seed

    def _needs_lattice(self, freq_hz: float, fs_out_hz: float) -> bool:
        """Whether a sine at ``freq_hz`` needs every phase sampled (:func:`sine_drive`): the
        output may reach a rail or the over-range threshold, or meets fewer than 5 phases."""
        return _few_phases(freq_hz, fs_out_hz) or any(
            _may_saturate(self.sensor, self.static_g, g, freq_hz) for g in self.levels_g)

    def _check_budget(self, segs: Sequence[Stretch], rates: Rates) -> None:
        """Refuse, before anything runs, a test beyond the time or memory budget (vrelab._budget):
        its compute grows with the internal samples, the reduction's window table with the record."""
        n_internal = float(sum(s.n_internal for s in segs))
        duration_s = n_internal / rates.fs_internal_hz
        window_bytes = duration_s / WINDOW_S * _WINDOW_STATS_BYTES
        what = (f"simulate: {len(self.levels_g) * max(1, len(self.freqs_hz))} level(s) of {self.seconds:g} s "
                f"({duration_s:.4g} s of record at {rates.fs_internal_hz:g} Hz)")
        _budget.check_simulation(what, n_internal, window_bytes)


def sine_drive(freq_hz: float, fs_out_hz: float) -> tuple[float, int, int]:
    """(drive frequency [Hz], periods m, output samples L) of a sine level that samples every
    phase of the cycle in every batch the reduction averages.

    A drive whose frequency divides the sensor's output rate (1000 Hz at 8 kHz) is sampled at
    the same few phases in every period, and the mean of a clipped or nonlinear output over
    those phases is not its mean over the cycle (-51.8 mg against the closed form's
    -68.3 mg at 1 kHz, 1 g rms, +1 g, ±2 g). A lab's shaker and sensor run on independent
    clocks, so the phase at which the sensor samples slides. Here the drive is
    ``f = m·fs_out/L`` with ``gcd(m, L) = 1``: m whole periods take exactly L output samples,
    which fall on all L phases ``j/L`` of the cycle, each once (a rank-1 lattice rule: the
    sampled mean is the cycle mean of any output whose harmonics stay below order L). L is
    near the reduction's batch (``WINDOW_S`` of whole periods,
    :func:`vrelab.analysis.reduction.whole_period_batch`, which then finds m periods in L
    samples exactly), chosen among ``[1, 1.5]×`` that length for the fraction ``m/L`` nearest
    ``freq_hz/fs_out``: a few parts in 10⁵ off for most frequencies, up to ``fs_out/(q·L)`` for
    one that divides the rate in small numbers (q = fs_out/f: 1.0 Hz at 1 kHz on an 8 kHz
    output, 1.6 Hz on a 4 kHz one). The level is reported at the frequency measured from
    the reference, and fitted at the nominal one.
    """
    ratio = freq_hz / fs_out_hz
    l0 = max(2, round(max(WINDOW_S, 1.0 / freq_hz) * fs_out_hz))
    best: tuple[float, int, int] | None = None
    for n in range(l0, int(1.5 * l0) + 1):
        c = max(1, round(n * ratio))
        for m in (c, c - 1, c + 1):
            if m < 1 or math.gcd(m, n) != 1:
                continue
            err = abs(m / n - ratio)
            if best is None or err < best[0]:
                best = (err, m, n)
    if best is None:  # no coprime pair below Nyquist (cannot happen for freq_hz < fs_out/2)
        raise ValueError(f"freqs_hz: no sine drive near {freq_hz:g} Hz at the output rate {fs_out_hz:g} Hz")
    _, m, n = best
    return m * fs_out_hz / n, m, n


def _few_phases(freq_hz: float, fs_out_hz: float) -> bool:
    """Whether the output samples meet fewer than 5 distinct phases of the drive: a polynomial
    output of degree 4 (k2..k4) then does not average to its cycle mean."""
    from fractions import Fraction

    return Fraction(freq_hz / fs_out_hz).limit_denominator(1 << 20).denominator < 5


def _may_saturate(sensor: Sensor, static_g: float, rms_g: float, freq_hz: float) -> bool:
    """Whether a sine of ``rms_g`` at ``freq_hz`` may bring the output within 5 % of a rail or
    of the over-range threshold: its peak through the resonance's gain (physics §1.3; the filters'
    gain is at most 1), on the static field."""
    gain = 1.0
    fn, q = getattr(sensor, "fn_hz", None), getattr(sensor, "q", None)
    if fn and q:
        r = freq_hz / fn
        gain = max(1.0, 1.0 / math.sqrt((1 - r * r) ** 2 + (r / q) ** 2))
    amp = math.sqrt(2.0) * rms_g * gain
    lo, hi = (float(x) for x in sensor.rails_g)
    if static_g + amp >= 0.95 * hi or static_g - amp <= 0.95 * lo:
        return True
    thr = getattr(sensor, "overrange_threshold_g", None)
    if not thr:
        return False
    return abs(static_g) + amp >= 0.95 * float(thr)


# A sine drive this close to its nominal frequency (relative) is taken as at it: the rate
# search below accepts it, and no notice is given (a shaker controller's own accuracy is coarser).
DRIVE_TOLERANCE = 1e-5


def _lattice_rate(sensor: Sensor, fs_hz: float, freqs_hz: Sequence[float]) -> float:
    """A rate at or a little above ``fs_hz`` at which every sine of ``freqs_hz`` runs at its own
    frequency (within ``DRIVE_TOLERANCE``) in :func:`sine_drive` (m periods in L samples,
    gcd(m, L) = 1), for a chain whose
    output rate is the internal rate (no ODR of its own: the rate is the simulation's choice, not
    the sensor's); else ``fs_hz`` (the drives then move a little, see :func:`sine_drive`)."""
    if abs(float(sensor.chain(fs_hz).fs_out_hz(fs_hz)) - fs_hz) > 1e-9 * fs_hz:
        return fs_hz
    start = math.ceil(fs_hz)
    for fs in range(start, start + 500):
        if all(abs(sine_drive(f, float(fs))[0] - f) <= DRIVE_TOLERANCE * f for f in freqs_hz):
            return float(fs)
    return fs_hz


def _ramp_samples(ramp_s: float, fs_internal_hz: float, rates: Rates) -> int:
    """Internal samples of one ramp: whole DUT output samples, so the schedule's level segment
    starts on a record sample (0 for no ramp)."""
    return round_up(ramp_s * fs_internal_hz, rates.decimation) if ramp_s > 0 else 0
