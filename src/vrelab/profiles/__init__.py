"""Vibration profiles: sine levels and random breakpoint tables (physics §3).

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

The package: :mod:`.shapes` (the profile classes), :mod:`.files` (CSV and TOML files),
:mod:`.named` (the shipped environments and the command line's profile parser); every name is
importable from ``vrelab.profiles``.
"""

from __future__ import annotations

from vrelab.profiles.files import (
    read_profile,
    write_profile,
)
from vrelab.profiles.named import (
    Environment,
    environments,
    load_environment,
    load_named_profile,
    named_profiles,
    parse_profile,
    parse_tones,
    split_tones,
    with_tones,
)
from vrelab.profiles.shapes import (
    DB_PER_OCT_PER_N,
    Profile,
    RandomProfile,
    SineOnRandom,
    SineProfile,
    Tone,
    segment_areas,
)

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

# the rest of what ``vrelab.profiles`` held before it was split, importable from here as before
from vrelab.profiles.files import atomic_write as atomic_write
from vrelab.profiles.files import profile_from_table as profile_from_table
from vrelab.profiles.named import TONES_MARK as TONES_MARK
from vrelab.profiles.shapes import MAX_PSD_G2_PER_HZ as MAX_PSD_G2_PER_HZ
from vrelab.profiles.shapes import MAX_TONES as MAX_TONES
from vrelab.profiles.shapes import MIN_PSD_G2_PER_HZ as MIN_PSD_G2_PER_HZ
from vrelab.profiles.shapes import check_tone_count as check_tone_count
