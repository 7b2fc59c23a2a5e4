"""Vibration profiles: sine levels and random breakpoint tables (SPEC section 3).

A random profile is a table of (frequency Hz, PSD g²/Hz) breakpoints joined by straight lines
on a log-log plot, the way vibration test specifications (NAVMAT P-9492, GSFC-STD-7000,
MIL-STD-810) write them: a flat level, or a slope in dB/octave between breakpoints.

Between breakpoints (f1, P1) and (f2, P2) the PSD is ``P(f) = P1·(f/f1)^n`` with
``n = ln(P2/P1)/ln(f2/f1)``; the slope is ``10·log10(2)·n`` dB/oct (≈ 3.0103·n), and the
segment's area is

    A = P1·f1/(n+1)·((f2/f1)^(n+1) - 1),     or  P1·f1·ln(f2/f1)  when n = -1.

The overall level is ``grms = sqrt(Σ A)``. Scaling a profile to a target grms multiplies every
PSD value by the square of the ratio (the shape, hence every slope, is kept).

Files: CSV (two columns ``f_hz, psd_g2_per_hz``; optional header; ``#`` comments) and TOML::

    [profile]
    name = "navmat-p9492"
    source = "NAVMAT P-9492 (1979)"
    breakpoints = [[20, 0.01], [80, 0.04], [350, 0.04], [2000, 0.007]]
    # or: start = [20, 0.01] and slopes = [[80, 3.0], [350, 0.0], [2000, -3.0]]
    # optional: grms = 2.5   (scales the shape to this overall level)

References
----------
.. [1] NAVMAT P-9492, "Navy Manufacturing Screening Program", Department of the Navy,
   May 1979: 20-80 Hz +3 dB/oct to 0.04 g²/Hz, 0.04 g²/Hz 80-350 Hz, -3 dB/oct 350-2000 Hz.
.. [2] NASA GSFC-STD-7000 (GEVS), General Environmental Verification Standard, component
   minimum workmanship random vibration levels.
.. [3] Analog Devices, "Vibration rectification error in MEMS accelerometers" (the seed
   article): flat profile 50 Hz - 2 kHz; ADXL354/ADXL355 datasheet Rev. D, VRE at 2.5 g rms.
"""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
import tomllib
from collections import Counter
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import tomli_w
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as v
from vrelab._load import toml_load

__all__ = [
    "DB_PER_OCT_PER_N",
    "SineProfile",
    "RandomProfile",
    "Tone",
    "SineOnRandom",
    "Profile",
    "Environment",
    "environments",
    "load_environment",
    "parse_tones",
    "split_tones",
    "with_tones",
    "read_profile",
    "write_profile",
    "named_profiles",
    "load_named_profile",
    "parse_profile",
    "segment_areas",
]

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
    of a division by a tiny number (SPEC section 3).
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
    """A random-vibration PSD given by breakpoints, interpolated log-log (SPEC section 3).

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

    @property
    def mean_square_g2(self) -> float:
        """Total area under the PSD [g²] (closed form, see :func:`segment_areas`)."""
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
    """Random vibration plus sine tones (sine-on-random, SPEC 6.2).

    Parameters
    ----------
    random : RandomProfile
        The broadband part, a log-log breakpoint PSD (SPEC 3).
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


# --- files ------------------------------------------------------------------------------------


def _read_csv(path: Path) -> RandomProfile:
    freqs: list[float] = []
    psds: list[float] = []
    name: str | None = None
    source: str | None = None
    with open(path, newline="") as fh:
        text = fh.read()
    seen_data = False
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line.startswith("#"):
            # "# name: ..." / "# source: ..." comments carry the metadata write_profile writes.
            body = line.lstrip("#").strip()
            key, sep, val = body.partition(":")
            if sep and key.strip().lower() == "name" and name is None:
                name = val.strip() or None
            elif sep and key.strip().lower() == "source" and source is None:
                source = val.strip() or None
            continue
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        cells = next(csv.reader([line.replace(";", ",").replace("\t", ",")]))
        cells = [c.strip() for c in cells if c.strip()]
        if len(cells) == 1 and " " in cells[0]:
            cells = cells[0].split()
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not seen_data and not freqs:
                seen_data = True  # the header line: column names, allowed once, before the data
                continue
            raise ValueError(f"{path}: line {lineno}: not a number pair: {raw.strip()!r}") from None
        seen_data = True
        if len(values) != 2:
            raise ValueError(
                f"{path}: line {lineno}: expected 2 columns (f_hz, psd_g2_per_hz), "
                f"got {len(values)}: {raw.strip()!r}"
            )
        freqs.append(values[0])
        psds.append(values[1])
    try:
        return RandomProfile(np.array(freqs), np.array(psds), name=name, source=source or str(path))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _toml_pair(path: Path, field: str, item: Any) -> tuple[float, float]:
    if not isinstance(item, (list, tuple)) or len(item) != 2:
        raise ValueError(f"{path}: {field} must be a pair [a, b], got {item!r}")
    try:
        return float(item[0]), float(item[1])
    except (TypeError, ValueError):
        raise ValueError(f"{path}: {field} must hold numbers, got {item!r}") from None


def profile_from_table(path: Path, table: dict[str, Any]) -> RandomProfile:
    """Build a profile from a TOML ``[profile]`` table (SPEC section 3 file format)."""
    name = table.get("name")
    source = table.get("source")
    for key in ("name", "source"):
        if table.get(key) is not None and not isinstance(table[key], str):
            raise ValueError(f"{path}: profile.{key} must be a string, got {table[key]!r}")
    has_bp = "breakpoints" in table
    has_slopes = "start" in table or "slopes" in table
    try:
        if has_bp and has_slopes:
            raise ValueError(f"{path}: give profile.breakpoints or profile.start+slopes, not both")
        if has_bp:
            rows = table["breakpoints"]
            if not isinstance(rows, list):
                raise ValueError(f"{path}: profile.breakpoints must be a list of [f_hz, psd] pairs")
            pairs = [_toml_pair(path, f"profile.breakpoints[{i}]", r) for i, r in enumerate(rows)]
            prof = RandomProfile(
                np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]), name, source
            )
        elif has_slopes:
            if "start" not in table or "slopes" not in table:
                raise ValueError(f"{path}: profile.start and profile.slopes go together")
            f0, p0 = _toml_pair(path, "profile.start", table["start"])
            rows = table["slopes"]
            if not isinstance(rows, list):
                raise ValueError(f"{path}: profile.slopes must be a list of [f_end_hz, db_per_oct]")
            segs = [_toml_pair(path, f"profile.slopes[{i}]", r) for i, r in enumerate(rows)]
            prof = RandomProfile.from_slopes(f0, p0, segs, name=name, source=source)
        else:
            raise ValueError(f"{path}: [profile] needs breakpoints, or start and slopes")
        if "grms" in table:
            prof = prof.scaled_to(v.positive_scalar("profile.grms", table["grms"]))
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
    return prof


_TONE_KEYS = ("freq_hz", "peak_g")


def _tones_from_tables(path: Path, rows: Any) -> tuple[Tone, ...]:
    """The ``[[tone]]`` tables of a profile file (each ``freq_hz`` [Hz], ``peak_g`` [g peak])."""
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise ValueError(f"{path}: tone must be [[tone]] tables with freq_hz and peak_g")
    try:
        check_tone_count(len(rows))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    tones = []
    for i, row in enumerate(rows):
        unknown = sorted(set(row) - set(_TONE_KEYS))
        if unknown:
            raise ValueError(f"{path}: tone[{i}]: unknown key {unknown[0]!r} (known: freq_hz, peak_g)")
        missing = [k for k in _TONE_KEYS if k not in row]
        if missing:
            raise ValueError(f"{path}: tone[{i}]: {missing[0]} is missing (a tone needs freq_hz and peak_g)")
        try:
            tones.append(Tone(row["freq_hz"], row["peak_g"]))
        except ValueError as exc:
            raise ValueError(f"{path}: tone[{i}]: {exc}") from None
    return tuple(tones)


def _read_toml(path: Path) -> Profile:
    try:
        with open(path, "rb") as fh:
            doc = toml_load(fh, str(path))
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    table = doc.get("profile")
    if not isinstance(table, dict):
        raise ValueError(f"{path}: no [profile] table")
    prof = profile_from_table(path, table)
    if "tone" not in doc:
        return prof
    try:
        return SineOnRandom(prof, _tones_from_tables(path, doc["tone"]))
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


def read_profile(path: str | os.PathLike[str]) -> Profile:
    """Read a profile from a CSV (``f_hz, psd_g2_per_hz``) or TOML file.

    A TOML file with ``[[tone]]`` tables (``freq_hz``, ``peak_g``) beside its ``[profile]``
    gives a :class:`SineOnRandom`; ``profile.grms`` there sets the random part's level, the
    tones being given in g peak as they are.

    Raises
    ------
    ValueError
        Unknown extension, or a malformed file; the message names the file and the line
        (CSV) or field (TOML).
    FileNotFoundError
        The file does not exist.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".toml", ".txt"):
        raise ValueError(f"profile file must be .csv or .toml, got {str(path)!r}")
    if not p.is_file():
        raise FileNotFoundError(2, "profile file not found", str(p))
    return _read_toml(p) if suffix == ".toml" else _read_csv(p)


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` completely or not at all (temporary file + rename)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_profile(profile: Profile, path: str | os.PathLike[str]) -> Path:
    """Write ``profile`` to ``path`` (.csv or .toml), atomically (temporary file + rename).

    Values are written with ``repr`` precision so that ``read_profile`` gives back the same
    breakpoints exactly. A sine-on-random profile needs .toml (its tones as ``[[tone]]``).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if isinstance(profile, SineOnRandom) and suffix == ".csv":
        raise ValueError(f"a profile with sine tones is written as .toml ([[tone]] tables), not .csv: {str(path)!r}")
    if suffix == ".toml":
        table: dict[str, Any] = {}
        if profile.name:
            table["name"] = profile.name
        if profile.source:
            table["source"] = profile.source
        table["breakpoints"] = profile.breakpoints
        doc: dict[str, Any] = {"profile": table}
        if isinstance(profile, SineOnRandom):
            doc["tone"] = [{"freq_hz": t.freq_hz, "peak_g": t.peak_g} for t in profile.tones]
        data = tomli_w.dumps(doc).encode()
    elif suffix == ".csv":
        buf = io.StringIO()
        if profile.name:
            buf.write(f"# name: {profile.name}\n")
        if profile.source:
            buf.write(f"# source: {profile.source}\n")
        buf.write(f"# {profile.describe()}\n")
        buf.write("f_hz,psd_g2_per_hz\n")
        for f, psd in profile.breakpoints:
            buf.write(f"{f!r},{psd!r}\n")
        data = buf.getvalue().encode()
    else:
        raise ValueError(f"profile file must be .csv or .toml, got {str(path)!r}")
    atomic_write(p, data)
    return p


# --- named profiles ---------------------------------------------------------------------------


def named_profiles() -> dict[str, str]:
    """Named profiles shipped in ``vrelab/data``: name -> path of its TOML file."""
    folder = resources.files("vrelab") / "data"
    out: dict[str, str] = {}
    for item in sorted(folder.iterdir(), key=lambda x: x.name):
        if item.name.endswith(".toml"):
            out[item.name[: -len(".toml")]] = str(item)
    return out


# The [environment] table of a named profile's file: what the standard says about it.
_ENV_TEXT_KEYS = ("title", "document", "table", "figure", "reproduced_from", "note")
_ENV_KEYS = (*_ENV_TEXT_KEYS, "stated_grms")


@dataclass(frozen=True)
class Environment:
    """A named vibration environment: a profile with where it comes from (SPEC 6.2).

    ``source`` names the document and its table or figure; ``stated_grms`` is the overall level
    the standard (or the public reproduction named in ``reproduced_from``) states, which may
    differ from the log-log area of the breakpoints (:attr:`grms`); ``note`` says why when it does.
    """

    name: str
    title: str
    source: str
    profile: Profile
    stated_grms: float | None = None
    reproduced_from: str | None = None
    note: str | None = None

    @property
    def grms(self) -> float:
        """Overall level of the breakpoints (and tones) by the log-log area formula [g rms]."""
        return self.profile.grms

    @property
    def band_hz(self) -> tuple[float, float]:
        return self.profile.band

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "title": self.title,
            "source": self.source,
            "grms": self.grms,
            "band_hz": list(self.band_hz),
            "stated_grms": self.stated_grms,
            "reproduced_from": self.reproduced_from,
            "note": self.note,
        }


def _environment_table(path: str) -> dict[str, Any]:
    """The checked ``[environment]`` table of a named profile's file (empty when it has none)."""
    with open(path, "rb") as fh:
        table = tomllib.load(fh).get("environment", {})
    if not isinstance(table, dict):
        raise ValueError(f"{path}: environment must be a table")
    unknown = sorted(set(table) - set(_ENV_KEYS))
    if unknown:
        raise ValueError(f"{path}: environment.{unknown[0]}: unknown key (known: {', '.join(_ENV_KEYS)})")
    for key in _ENV_TEXT_KEYS:
        if key in table and not isinstance(table[key], str):
            raise ValueError(f"{path}: environment.{key} must be a string, got {table[key]!r}")
    if "stated_grms" in table:
        table["stated_grms"] = v.positive_scalar(f"{path}: environment.stated_grms", table["stated_grms"])
    return table


def _citation(table: dict[str, Any]) -> str | None:
    """'document, table, figure' of an [environment] table (None without a document)."""
    parts = [table[k] for k in ("document", "table", "figure") if table.get(k)]
    return ", ".join(parts) if table.get("document") else None


def load_named_profile(name: str) -> Profile:
    """The named profile ``name`` (see :func:`named_profiles`)."""
    return load_environment(name, what="profile").profile


def load_environment(name: str, what: str = "environment") -> Environment:
    """The named environment ``name``: its profile, title, source and stated grms.

    Every named profile is an environment; its file's ``[environment]`` table (``title``,
    ``document``, ``table``, ``figure``, ``stated_grms``, ``reproduced_from``, ``note``) says
    where it comes from. A profile without its own ``source`` takes the citation built from
    ``document``, ``table`` and ``figure``.
    """
    known = named_profiles()
    if name not in known:
        raise ValueError(f"unknown {what} name {name!r}; known: {', '.join(known)}")
    path = known[name]
    table = _environment_table(path)
    prof = read_profile(path)
    cited = _citation(table)
    rnd = prof.random if isinstance(prof, SineOnRandom) else prof
    if rnd.name is None or rnd.source is None:
        rnd = RandomProfile(rnd.freq_hz, rnd.psd_g2_per_hz, rnd.name or name, rnd.source or cited)
        prof = SineOnRandom(rnd, prof.tones) if isinstance(prof, SineOnRandom) else rnd
    return Environment(
        name=name,
        title=table.get("title", name),
        source=cited or prof.source or "",
        profile=prof,
        stated_grms=table.get("stated_grms"),
        reproduced_from=table.get("reproduced_from"),
        note=table.get("note"),
    )


def environments() -> list[Environment]:
    """Every named environment (:func:`load_environment`), by name."""
    return [load_environment(name) for name in named_profiles()]


_FORMS = (
    "a .csv/.toml file, an inline list F:P,F:P,... (Hz:g²/Hz), flat:F1-F2, "
    "or a named profile ({names}), optionally +sine:F:PEAK,... (Hz:g peak)"
)


def _number_pairs(text: str, what: str, form: str, units: str) -> list[tuple[float, float]]:
    """``A:B,A:B,...`` as number pairs; a bad item is named in the error, e.g.
    ``profile '20:x': item 0 '20:x' is not F:P numbers`` (``what`` = "profile", ``form`` = "F:P")."""
    pairs = []
    for i, token in enumerate(text.split(",")):
        parts = token.strip().split(":")
        if len(parts) != 2:
            raise ValueError(f"{what} {text!r}: item {i} {token.strip()!r} is not {form} ({units})")
        try:
            pairs.append((float(parts[0]), float(parts[1])))
        except ValueError:
            raise ValueError(f"{what} {text!r}: item {i} {token.strip()!r} is not {form} numbers") from None
    return pairs


def _parse_inline(spec: str) -> RandomProfile:
    pairs = _number_pairs(spec, "profile", "F:P", "Hz:g²/Hz")
    try:
        return RandomProfile(np.array([f for f, _ in pairs]), np.array([p for _, p in pairs]), source="inline")
    except ValueError as exc:
        raise ValueError(f"profile {spec!r}: {exc}") from None


def _parse_flat(spec: str) -> RandomProfile:
    body = spec.split(":", 1)[1].strip()
    lo_s, sep, hi_s = body.partition("-")
    try:
        if not sep:
            raise ValueError
        lo, hi = float(lo_s), float(hi_s)
    except ValueError:
        raise ValueError(f"profile {spec!r}: expected flat:F1-F2 (Hz), e.g. flat:50-2000") from None
    try:
        return RandomProfile.flat(lo, hi, name=f"flat-{lo:g}-{hi:g}", source="flat (unit PSD shape)")
    except ValueError as exc:
        raise ValueError(f"profile {spec!r}: {exc}") from None


#: Joins a profile and its sine tones on the command line: ``navmat-p9492+sine:120:0.5,240:0.2``.
TONES_MARK = "+sine:"


def split_tones(spec: str) -> tuple[str, str | None]:
    """(profile part, tone list or None) of a profile string: ``"A+sine:T"`` -> ``("A", "T")``."""
    i = spec.lower().rfind(TONES_MARK)
    if i < 0:
        return spec, None
    return spec[:i], spec[i + len(TONES_MARK):]


def parse_tones(text: str) -> tuple[Tone, ...]:
    """Tones from ``F:PEAK,F:PEAK,...`` (Hz : g peak), e.g. ``"120:0.5,240:0.2"``."""
    if not text.strip():
        raise ValueError("sine tones: give F:PEAK pairs after '+sine:' (Hz:g peak), e.g. +sine:120:0.5,240:0.2")
    check_tone_count(text.count(",") + 1)
    return tuple(Tone(f, peak) for f, peak in _number_pairs(text, "sine tones", "F:PEAK", "Hz:g peak"))


def with_tones(profile: Profile, tones: Sequence[Tone]) -> SineOnRandom:
    """``profile`` with ``tones`` added (to those it already has)."""
    if isinstance(profile, SineOnRandom):
        return SineOnRandom(profile.random, profile.tones + tuple(tones), profile.name, profile.source)
    return SineOnRandom(profile, tuple(tones))


def parse_profile(spec: str) -> Profile:
    """A vibration profile from a command-line string (SPEC sections 5 and 6.2).

    Accepted forms, tried in this order: a named profile (``navmat-p9492``), a file path
    (``.csv``/``.toml``; a TOML file with ``[[tone]]`` tables is sine-on-random),
    ``flat:F1-F2`` (a flat 1 g²/Hz shape, to be scaled to a grms), and an inline breakpoint list
    ``F:P,F:P,...`` (Hz:g²/Hz). Any of them followed by ``+sine:F:PEAK,F:PEAK,...`` (Hz : g
    peak) adds sine tones: a :class:`SineOnRandom`.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(f"profile must be {_FORMS.format(names=', '.join(named_profiles()))}; got {spec!r}")
    text = spec.strip()
    base, tones = split_tones(text)
    if tones is not None:
        if not base.strip():
            raise ValueError(f"profile {spec!r}: give a random profile before '+sine:', e.g. navmat-p9492+sine:120:0.5")
        try:
            return with_tones(parse_profile(base), parse_tones(tones))
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(msg if spec in msg else f"profile {spec!r}: {msg}") from None
    names = named_profiles()
    if text in names:
        return load_named_profile(text)
    if Path(text).suffix.lower() in (".csv", ".toml") or Path(text).is_file():
        return read_profile(text)
    if text.lower().startswith("flat:"):
        return _parse_flat(text)
    if ":" in text:
        return _parse_inline(text)
    raise ValueError(f"unknown profile {spec!r}: give {_FORMS.format(names=', '.join(names))}")
