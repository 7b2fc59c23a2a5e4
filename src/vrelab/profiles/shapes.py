"""Sine levels, random breakpoint tables and sine on random (physics §3): the profile
classes, their grms and scaling (the equations in :mod:`vrelab.profiles`)."""

from __future__ import annotations

import functools
import math
from collections import Counter
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as v

#: dB/octave per unit of log-log exponent n: slope = 10·log10(2)·n.
DB_PER_OCT_PER_N = 10.0 * math.log10(2.0)

# Below this |x| the series 1 + x/2 + x²/6 replaces expm1(x)/x; both agree to double precision
# there, and the series never divides by a tiny number.
_SMALL_X = 1e-8


@dataclass(frozen=True)
class SineProfile:
    """A sinusoidal vibration: frequency and level in g rms.

    Parameters
    ----------
    freq_hz : float
        Frequency [Hz], > 0.
    rms_g : float
        Level [g rms], >= 0. The peak is ``rms_g·√2``; use :meth:`from_peak` for a level
        stated in g peak.

    Examples
    --------
    1 g rms at 100 Hz is a sine of 1.414 g peak:

    >>> from vrelab import SineProfile
    >>> sine = SineProfile(100.0, 1.0)
    >>> print(f"{sine.peak_g:.3f} g peak")
    1.414 g peak
    >>> print(sine.describe())
    sine 100 Hz, 1 g rms (1.41 g pk)
    """

    freq_hz: float
    rms_g: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "freq_hz", v.positive_scalar("freq_hz", self.freq_hz))
        rms = v.finite_scalar("rms_g", self.rms_g)
        if rms < 0:
            raise ValueError(f"rms_g must be >= 0, got {self.rms_g!r}")
        object.__setattr__(self, "rms_g", rms)

    @classmethod
    def from_peak(cls, freq_hz: float, peak_g: float) -> SineProfile:
        """A sine given by its peak level [g pk]."""
        peak = v.finite_scalar("peak_g", peak_g)
        if peak < 0:
            raise ValueError(f"peak_g must be >= 0, got {peak_g!r}")
        return cls(freq_hz, peak / math.sqrt(2.0))

    @property
    def peak_g(self) -> float:
        """Peak level [g]: rms·√2."""
        return self.rms_g * math.sqrt(2.0)

    def describe(self) -> str:
        return f"sine {self.freq_hz:g} Hz, {self.rms_g:.3g} g rms ({self.peak_g:.3g} g pk)"

    def describe_shape(self) -> str:
        """The tone without its level (see :meth:`RandomProfile.describe_shape`): ``"sine 80 Hz"``."""
        return f"sine {self.freq_hz:g} Hz"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "sine", "freq_hz": self.freq_hz, "rms_g": self.rms_g, "peak_g": self.peak_g}


def _expm1_over_x(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """(e^x - 1)/x, stable as x -> 0 (the n = -1 limit of the segment area)."""
    x = np.asarray(x, dtype=np.float64)
    small = np.abs(x) < _SMALL_X
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 + x / 2.0 + x * x / 6.0, np.expm1(safe) / safe)


def segment_areas(freq_hz: ArrayLike, psd_g2_per_hz: ArrayLike) -> NDArray[np.float64]:
    """Area [g²] under each log-log segment of a breakpoint table.

    Notes
    -----
    With r = f2/f1, L = ln r and m = n + 1, the closed form ``P1·f1/m·(r^m - 1)`` is written
    ``P1·f1·L·(e^(mL) - 1)/(mL)``, which tends to ``P1·f1·L`` (the n = -1 case) continuously,
    so a slope of exactly -3.0103 dB/oct and one of -3 dB/oct give nearly equal areas instead
    of a division by a tiny number (physics §3).

    Examples
    --------
    A flat 0.01 g²/Hz from 20 to 2000 Hz: one segment of 19.8 g².

    >>> from vrelab.profiles import segment_areas
    >>> print(segment_areas([20.0, 2000.0], [0.01, 0.01]))
    [19.8]
    """
    f = np.asarray(freq_hz, dtype=np.float64)
    p = np.asarray(psd_g2_per_hz, dtype=np.float64)
    f1, f2, p1, p2 = f[:-1], f[1:], p[:-1], p[1:]
    # differences of logs, not logs of ratios: a ratio of two valid values can overflow
    # (1e200/1e-200) where the difference of their logs cannot
    log_r = np.log(f2) - np.log(f1)
    n = (np.log(p2) - np.log(p1)) / log_r
    return np.asarray(p1 * f1 * log_r * _expm1_over_x((n + 1.0) * log_r), dtype=np.float64)  # numpy's log: Any


@dataclass(frozen=True, eq=False)
class RandomProfile:
    """A random-vibration PSD given by breakpoints, interpolated log-log (physics §3).

    Parameters
    ----------
    freq_hz : array_like
        Breakpoint frequencies [Hz]: at least 2, positive, finite, strictly increasing.
    psd_g2_per_hz : array_like
        PSD at each breakpoint [g²/Hz]: positive and finite (a log-log line cannot reach 0).
    name, source : str, optional
        Name of the profile and where it comes from (a standard, a file).

    Notes
    -----
    The arrays are stored as read-only copies, so the caller's arrays are never modified and
    the profile cannot be changed after validation. Between breakpoints
    ``P(f) = P1·(f/f1)^n``, ``n = ln(P2/P1)/ln(f2/f1)``; outside the band the PSD is 0.

    Examples
    --------
    The flat 50-2000 Hz profile scaled to 2 g rms, its PSD level and its breakpoints:

    >>> from vrelab import RandomProfile
    >>> profile = RandomProfile.flat(50.0, 2000.0).scaled_to(2.0)
    >>> print(f"{profile.grms:.3f} g rms, {profile.psd(100.0):.6f} g²/Hz")
    2.000 g rms, 0.002051 g²/Hz
    >>> print(profile.describe())
    random 50–2000 Hz, 2.00 g rms
    """

    freq_hz: NDArray[np.float64]
    psd_g2_per_hz: NDArray[np.float64]
    name: str | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        f = np.array(v.as_float_array("freq_hz", self.freq_hz), dtype=np.float64, copy=True).ravel()
        p = np.array(
            v.as_float_array("psd_g2_per_hz", self.psd_g2_per_hz), dtype=np.float64, copy=True
        ).ravel()
        if f.size != p.size:
            raise ValueError(
                f"freq_hz and psd_g2_per_hz must have the same length, got {f.size} and {p.size}"
            )
        if f.size < 2:
            raise ValueError(f"a random profile needs at least 2 breakpoints, got {f.size}")
        v.frequency("freq_hz", f)
        v.positive("psd_g2_per_hz", p)
        out = (p < MIN_PSD_G2_PER_HZ) | (p > MAX_PSD_G2_PER_HZ)
        if out.any():
            raise ValueError(f"psd_g2_per_hz must be within {MIN_PSD_G2_PER_HZ:g}..{MAX_PSD_G2_PER_HZ:g} g²/Hz, "
                             f"got {float(p[out][0])!r}")
        step = np.diff(f)
        if (step <= 0).any():
            i = int(np.argmax(step <= 0)) + 1
            raise ValueError(
                f"non-monotonic profile: freq_hz must be strictly increasing, but breakpoint {i} "
                f"({f[i]:g} Hz) follows breakpoint {i - 1} ({f[i - 1]:g} Hz)"
            )
        f.setflags(write=False)
        p.setflags(write=False)
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "psd_g2_per_hz", p)

    # --- constructors -------------------------------------------------------------------------

    @classmethod
    def from_breakpoints(
        cls,
        freq_hz: ArrayLike,
        psd_g2_per_hz: ArrayLike,
        name: str | None = None,
        source: str | None = None,
    ) -> RandomProfile:
        """A profile from its breakpoint table (Hz, g²/Hz)."""
        return cls(np.asarray(freq_hz), np.asarray(psd_g2_per_hz), name=name, source=source)

    @classmethod
    def from_slopes(
        cls,
        f0_hz: float,
        psd0_g2_per_hz: float,
        segments: Sequence[tuple[float, float]],
        name: str | None = None,
        source: str | None = None,
    ) -> RandomProfile:
        """A profile from a start point and segments ``(f_end_hz, slope_db_per_oct)``.

        Each segment runs from the previous breakpoint to ``f_end_hz`` with exponent
        ``n = slope/(10·log10 2)``, so its end PSD is ``P_start·(f_end/f_start)^n``.
        """
        f0 = v.positive_scalar("f0_hz", f0_hz)
        p0 = v.positive_scalar("psd0_g2_per_hz", psd0_g2_per_hz)
        if len(segments) < 1:
            raise ValueError("segments must hold at least one (f_end_hz, db_per_oct) pair, got none")
        freqs, psds = [f0], [p0]
        for i, seg in enumerate(segments):
            try:
                f_end, slope = seg
            except (TypeError, ValueError):
                raise ValueError(
                    f"segments[{i}] must be a pair (f_end_hz, db_per_oct), got {seg!r}"
                ) from None
            f_end = v.positive_scalar(f"segments[{i}] f_end_hz", f_end)
            slope = v.finite_scalar(f"segments[{i}] db_per_oct", slope)
            if f_end <= freqs[-1]:
                raise ValueError(
                    f"non-monotonic profile: segments[{i}] ends at {f_end:g} Hz, not above "
                    f"the previous breakpoint {freqs[-1]:g} Hz"
                )
            n = slope / DB_PER_OCT_PER_N
            psds.append(psds[-1] * (f_end / freqs[-1]) ** n)
            freqs.append(f_end)
        return cls(np.asarray(freqs), np.asarray(psds), name=name, source=source)

    @classmethod
    def flat(
        cls,
        f_lo_hz: float,
        f_hi_hz: float,
        grms: float | None = None,
        psd: float | None = None,
        name: str | None = None,
        source: str | None = None,
    ) -> RandomProfile:
        """A flat PSD from ``f_lo_hz`` to ``f_hi_hz``, given by its grms or its PSD [g²/Hz].

        With neither, the PSD is 1 g²/Hz: a shape to be scaled with :meth:`scaled_to`.
        """
        lo = v.positive_scalar("f_lo_hz", f_lo_hz)
        hi = v.positive_scalar("f_hi_hz", f_hi_hz)
        if hi <= lo:
            raise ValueError(f"f_hi_hz must be above f_lo_hz, got {f_lo_hz!r}-{f_hi_hz!r} Hz")
        if grms is not None and psd is not None:
            raise ValueError(f"give grms or psd, not both (got grms={grms!r}, psd={psd!r})")
        if grms is not None:
            level = v.positive_scalar("grms", grms) ** 2 / (hi - lo)
        elif psd is not None:
            level = v.positive_scalar("psd", psd)
        else:
            level = 1.0
        return cls(np.array([lo, hi]), np.array([level, level]), name=name, source=source)

    # --- properties ---------------------------------------------------------------------------

    @property
    def band(self) -> tuple[float, float]:
        """(lowest, highest) breakpoint frequency [Hz]."""
        return (float(self.freq_hz[0]), float(self.freq_hz[-1]))

    @property
    def exponents(self) -> NDArray[np.float64]:
        """Log-log exponent n of each segment: ``ln(P2/P1)/ln(f2/f1)``."""
        lf, lp = np.log(self.freq_hz), np.log(self.psd_g2_per_hz)  # differences of logs, as segment_areas
        return np.diff(lp) / np.diff(lf)

    @property
    def slopes_db_per_oct(self) -> NDArray[np.float64]:
        """Slope of each segment [dB/oct]: ``10·log10(2)·n``."""
        return DB_PER_OCT_PER_N * self.exponents

    @functools.cached_property
    def mean_square_g2(self) -> float:
        """Total area under the PSD [g²] (closed form, see :func:`segment_areas`).

        Computed once per profile (its arrays are read-only): every prediction of a comparison
        or a propagation reads it, and the same profile is predicted hundreds of times."""
        return float(np.sum(segment_areas(self.freq_hz, self.psd_g2_per_hz)))

    @property
    def grms(self) -> float:
        """Overall level [g rms]: sqrt of the area under the log-log PSD (closed form)."""
        return math.sqrt(self.mean_square_g2)

    @property
    def breakpoints(self) -> list[list[float]]:
        """The table as ``[[f_hz, psd_g2_per_hz], ...]`` (plain floats, JSON-ready)."""
        return [[float(f), float(p)] for f, p in zip(self.freq_hz, self.psd_g2_per_hz)]

    # --- evaluation ---------------------------------------------------------------------------

    def psd(self, f_hz: ArrayLike) -> NDArray[np.float64] | float:
        """PSD [g²/Hz] at ``f_hz``: log-log interpolation inside the band, 0 outside it."""
        f = np.asarray(f_hz, dtype=np.float64)
        out = np.zeros(f.shape)
        lo, hi = self.band
        inside = (f >= lo) & (f <= hi)
        if inside.any():
            out[inside] = np.exp(
                np.interp(np.log(f[inside]), np.log(self.freq_hz), np.log(self.psd_g2_per_hz))
            )
        return float(out) if out.ndim == 0 else out

    def cumulative_mean_square(self, f_hz: ArrayLike) -> NDArray[np.float64] | float:
        """Area [g²] of the PSD from the band's lower edge up to ``f_hz`` (closed form, vectorized).

        0 below the band, the total mean square above it; inside segment i it adds the partial
        segment area from f_i to f, with the same stable closed form as :func:`segment_areas`.
        """
        f = np.clip(np.asarray(f_hz, dtype=np.float64), *self.band)
        fb, pb = self.freq_hz, self.psd_g2_per_hz
        cum = np.concatenate(([0.0], np.cumsum(segment_areas(fb, pb))))
        i = np.clip(np.searchsorted(fb, f, side="right") - 1, 0, fb.size - 2)
        n = self.exponents[i]
        log_r = np.log(f / fb[i])
        out = cum[i] + pb[i] * fb[i] * log_r * _expm1_over_x((n + 1.0) * log_r)
        return float(out) if out.ndim == 0 else out

    def mean_square_between(self, f_lo_hz: ArrayLike, f_hi_hz: ArrayLike) -> NDArray[np.float64] | float:
        """Area [g²] of the PSD between two frequencies (0 where they do not overlap the band)."""
        lo = np.asarray(self.cumulative_mean_square(f_lo_hz))
        hi = np.asarray(self.cumulative_mean_square(f_hi_hz))
        out = np.maximum(hi - lo, 0.0)
        return float(out) if out.ndim == 0 else out

    def scaled_to(self, grms: float) -> RandomProfile:
        """The same shape at overall level ``grms`` [g rms]: every PSD value × (grms/self.grms)²."""
        target = float(v.vibration_level("grms", v.positive_scalar("grms", grms)))
        ratio2 = (target / self.grms) ** 2
        return RandomProfile(self.freq_hz, self.psd_g2_per_hz * ratio2, self.name, self.source)

    # --- presentation -------------------------------------------------------------------------

    def describe(self) -> str:
        """One line, e.g. ``"random 50–2000 Hz, 2.50 g rms"`` (with the name when there is one)."""
        lo, hi = self.band
        text = f"random {lo:g}–{hi:g} Hz, {self.grms:.2f} g rms"
        return f"{text} ({self.name})" if self.name else text

    def describe_shape(self) -> str:
        """The shape without a level, e.g. ``"random 50–500 Hz (flat-50-500)"``: what a test that
        steps this shape through several levels states (the levels are its results')."""
        lo, hi = self.band
        return f"random {lo:g}–{hi:g} Hz" + (f" ({self.name})" if self.name else "")

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": "random",
            "name": self.name,
            "source": self.source,
            "grms": self.grms,
            "band_hz": list(self.band),
            "breakpoints": self.breakpoints,
            "slopes_db_per_oct": [float(s) for s in self.slopes_db_per_oct],
        }

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RandomProfile):
            return NotImplemented
        return (
            np.array_equal(self.freq_hz, other.freq_hz)
            and np.array_equal(self.psd_g2_per_hz, other.psd_g2_per_hz)
            and self.name == other.name
            and self.source == other.source
        )

    def __hash__(self) -> int:
        return hash((self.freq_hz.tobytes(), self.psd_g2_per_hz.tobytes(), self.name, self.source))

    def __repr__(self) -> str:
        return f"RandomProfile(breakpoints={self.breakpoints!r}, name={self.name!r})"


# --- sine on random ---------------------------------------------------------------------------


# Breakpoint PSDs [g²/Hz] a profile may hold. A vibration of 1e5 g rms (the largest level, see
# vrelab._validate.MAX_LEVEL_G_RMS) over 1 Hz is 1e10 g²/Hz and a 1 µg rms floor over 10 MHz is
# 1e-19 g²/Hz; the bounds leave decades around both and keep every area and level ratio
# (PSD × level², scaled to a level) far from float64's overflow and underflow.
MIN_PSD_G2_PER_HZ = 1e-100
MAX_PSD_G2_PER_HZ = 1e100

# Sine tones a sine-on-random profile may hold. Rotating machinery, propellers and gunfire give
# a fundamental and a few harmonics per source (the helicopter and propeller profiles of
# MIL-STD-810H Method 514.8): tens of tones at most. Synthesis costs a sine per tone per sample
# of every simulated level, and a table of many thousands (a spectrum pasted as lines, a swept
# sine written as tones) is a slip; it is refused before any tone is built or any work sized.
MAX_TONES = 1000


def check_tone_count(n: int) -> None:
    """Refuse more than :data:`MAX_TONES` tones (checked before the tones are built)."""
    if n > MAX_TONES:
        raise ValueError(f"{n} sine tones: at most {MAX_TONES} (a machine's harmonics are tens; "
                         "a spectrum is a random profile, not tones)")


@dataclass(frozen=True)
class Tone:
    """A sine tone on top of random vibration, as rotating machinery and propellers make.

    Parameters
    ----------
    freq_hz : float
        Frequency [Hz], > 0.
    peak_g : float
        Amplitude [g peak], >= 0; its rms is ``peak_g/√2``.

    Examples
    --------
    >>> from vrelab.profiles import Tone
    >>> tone = Tone(120.0, 0.5)
    >>> print(f"{tone.rms_g:.4f} g rms")
    0.3536 g rms
    """

    freq_hz: float
    peak_g: float

    def __post_init__(self) -> None:
        f = self.freq_hz
        try:
            f = float(v.frequency("tone freq_hz", v.positive_scalar("tone freq_hz", f)))
        except ValueError:
            raise ValueError(f"tone frequency must be a finite number > 0 Hz, within {v.MIN_FREQ_HZ:g}.."
                             f"{v.MAX_FREQ_HZ:g} Hz, got {self.freq_hz!r}") from None
        peak = v.finite_scalar(f"tone at {f:g} Hz: peak_g", self.peak_g)
        if peak < 0:
            raise ValueError(f"tone at {f:g} Hz: amplitude must be >= 0 g peak, got {self.peak_g!r}")
        if peak > v.MAX_ACCELERATION_G:
            raise ValueError(f"tone at {f:g} Hz: amplitude must be at most {v.MAX_ACCELERATION_G:g} g peak "
                             f"(beyond any shaker or shock test), got {self.peak_g!r}")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "peak_g", peak)

    @property
    def rms_g(self) -> float:
        """rms of the tone [g]: peak/√2."""
        return self.peak_g / math.sqrt(2.0)

    def to_dict(self) -> dict[str, Any]:
        return {"freq_hz": self.freq_hz, "peak_g": self.peak_g, "rms_g": self.rms_g}


@dataclass(frozen=True)
class SineOnRandom:
    """Random vibration plus sine tones (sine-on-random, the environments page).

    Parameters
    ----------
    random : RandomProfile
        The broadband part, a log-log breakpoint PSD (physics §3).
    tones : sequence of Tone
        At least one; distinct frequencies (stored sorted by frequency).
    name, source : str, optional
        Name and origin of the whole profile (default: those of ``random``).

    Notes
    -----
    The mean square adds, random and tones being uncorrelated (distinct frequencies, and the
    tones' phases independent of the noise): ``grms² = ∫S df + Σ peak_i²/2``.

    **Scaling rule** (:meth:`scaled_to`): the profile keeps its shape, random part and tones
    together: to reach a target grms every PSD value is multiplied by ``(target/grms)²`` and
    every tone amplitude by ``target/grms``, so the ratio of tone power to random power, and
    hence the crest of the motion, is the same at every level.

    Examples
    --------
    2 g rms of flat random plus a 0.5 g peak tone at 120 Hz:

    >>> import vrelab
    >>> profile = vrelab.parse_profile("flat:50-2000+sine:120:0.5").scaled_to(2.0)
    >>> print(type(profile).__name__, f"{profile.grms:.3f} g rms", [t.freq_hz for t in profile.tones])
    SineOnRandom 2.000 g rms [120.0]
    """

    random: RandomProfile
    tones: tuple[Tone, ...]
    name: str | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.random, RandomProfile):
            raise ValueError(f"random must be a RandomProfile, got {type(self.random).__name__}")
        tones = tuple(self.tones)
        if not tones:
            raise ValueError("a sine-on-random profile needs at least one tone")
        check_tone_count(len(tones))
        for t in tones:
            if not isinstance(t, Tone):
                raise ValueError(f"tones must be Tone(freq_hz, peak_g) values, got {t!r}")
        dup = sorted(f for f, n in Counter(t.freq_hz for t in tones).items() if n > 1)
        if dup:
            raise ValueError(f"tone frequencies must be distinct, got {', '.join(f'{f:g}' for f in dup)} Hz twice")
        object.__setattr__(self, "tones", tuple(sorted(tones, key=lambda t: t.freq_hz)))
        if self.name is None:
            object.__setattr__(self, "name", self.random.name)
        if self.source is None:
            object.__setattr__(self, "source", self.random.source)

    @property
    def tone_mean_square_g2(self) -> float:
        """Mean square of the tones [g²]: Σ peak²/2."""
        return float(sum(t.peak_g**2 for t in self.tones) / 2.0)

    @property
    def mean_square_g2(self) -> float:
        """Total mean square [g²]: the random part's area plus the tones' Σ peak²/2."""
        return self.random.mean_square_g2 + self.tone_mean_square_g2

    @property
    def grms(self) -> float:
        """Overall level [g rms], tones included."""
        return math.sqrt(self.mean_square_g2)

    @property
    def band(self) -> tuple[float, float]:
        """(lowest, highest) frequency of any content [Hz]: the random band widened to the tones."""
        lo, hi = self.random.band
        return (min(lo, self.tones[0].freq_hz), max(hi, self.tones[-1].freq_hz))

    @property
    def breakpoints(self) -> list[list[float]]:
        """The random part's breakpoint table (the tones are in :attr:`tones`)."""
        return self.random.breakpoints

    def psd(self, f_hz: ArrayLike) -> NDArray[np.float64] | float:
        """The random part's PSD [g²/Hz]; a tone is a line, not a density, and is not in it."""
        return self.random.psd(f_hz)

    def scaled_to(self, grms: float) -> SineOnRandom:
        """The same profile at overall level ``grms`` [g rms], tones included: PSD ×
        ``(grms/self.grms)²`` and every tone amplitude × ``grms/self.grms`` (see the class Notes)."""
        target = float(v.vibration_level("grms", v.positive_scalar("grms", grms)))
        ratio = target / self.grms
        random = RandomProfile(self.random.freq_hz, self.random.psd_g2_per_hz * ratio**2, self.random.name,
                               self.random.source)
        return SineOnRandom(random, tuple(Tone(t.freq_hz, t.peak_g * ratio) for t in self.tones),
                            self.name, self.source)

    def describe(self) -> str:
        """One line, e.g. ``"random 20–2000 Hz + sine 120 Hz 0.5 g pk, 6.08 g rms (navmat-p9492)"``."""
        lo, hi = self.random.band
        tones = ", ".join(f"{t.freq_hz:g} Hz {t.peak_g:.3g} g pk" for t in self.tones)
        text = f"random {lo:g}–{hi:g} Hz + sine {tones}, {self.grms:.2f} g rms"
        return f"{text} ({self.name})" if self.name else text

    def describe_shape(self) -> str:
        """The shape without a level (see :meth:`RandomProfile.describe_shape`); the tones by
        frequency, their amplitudes scaling with the level."""
        lo, hi = self.random.band
        text = f"random {lo:g}–{hi:g} Hz + sine " + ", ".join(f"{t.freq_hz:g}" for t in self.tones) + " Hz"
        return f"{text} ({self.name})" if self.name else text

    def to_dict(self) -> dict[str, Any]:
        """The random part's dict (breakpoints, slopes) with this profile's level, band and tones."""
        return {
            **self.random.to_dict(),
            "kind": "sine-on-random",
            "name": self.name,
            "source": self.source,
            "grms": self.grms,
            "band_hz": list(self.band),
            "random_grms": self.random.grms,
            "tones": [t.to_dict() for t in self.tones],
        }


#: What a vibration profile can be: random, or random plus sine tones.
Profile = RandomProfile | SineOnRandom
