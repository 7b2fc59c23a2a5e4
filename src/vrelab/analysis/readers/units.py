"""The unit a file states for a channel, and how it meets the unit the user gives.

One owner for the rule (:func:`channel_scale`): every reader only reports the unit text its file
states (LVM ``Y_Unit_Label``, TDMS ``unit_string``, UFF58 ordinate units, MDF channel unit, IDE
sub-channel units, a CSV header ``Acceleration x (m/s^2)``); this module says what it means.

* an acceleration (g, mg, m/s², mm/s², ...): converted to g;
* a voltage (mV, V) or counts (LSB): needs the sensitivity (``--dut-units mv --dut-sensitivity``);
* anything else (a temperature, a pressure, a quaternion, an angle, a text vrelab does not know):
  not an acceleration, refused as DUT or reference;
* no unit stated: integer samples are counts and need ``--dut-units lsb --dut-sensitivity``;
  floating samples are taken as g unless the user says otherwise, and the record says so (a
  note, and ``meta["units_assumed"]``: the analysis refuses a baseline reading 9.8 "g", which
  is 1 g in m/s², :func:`vrelab.analysis.plausibility.check_assumed_g`).

A unit the user gives that contradicts the file's is refused unless ``accept`` (the user says it
is meant: ``--accept-file-units``).
"""

from __future__ import annotations

import re

from vrelab.analysis.readers._base import Scale

# spelled-out units as files write them -> vrelab's Scale units (lower case, no spaces)
_SPELLINGS = {
    "g": "g", "gn": "g", "g0": "g", "gs": "g", "g's": "g", "gee": "g", "g(9.80665m/s2)": "g",
    "mg": "mg", "milli-g": "mg", "millig": "mg",
    "m/s2": "m/s2", "m/s^2": "m/s2", "m/s²": "m/s2", "m/s/s": "m/s2", "ms^-2": "m/s2", "m*s^-2": "m/s2",
    "m·s^-2": "m/s2", "m.s-2": "m/s2", "ms-2": "m/s2", "ms2": "m/s2", "mps2": "m/s2", "m/sec^2": "m/s2",
    "m/sec2": "m/s2", "m/sec/sec": "m/s2",
    "mm/s2": "mm/s2", "mm/s^2": "mm/s2", "mm/s²": "mm/s2", "mm/sec^2": "mm/s2",
    "mv": "mv", "millivolt": "mv", "millivolts": "mv",
    "v": "v", "volt": "v", "volts": "v",
    "lsb": "lsb", "count": "lsb", "counts": "lsb", "cnt": "lsb", "digits": "lsb", "adc": "lsb",
}
_NONE = {"", "-", "none", "n/a", "na", "null", "unitless", "(none)"}
_ACCEL = ("g", "mg", "m/s2", "mm/s2")


# units a column header may carry that are not accelerations (a header's bracket is read as a
# unit only when it is a unit: "Accel (front)" is a name)
_OTHER = {"s", "ms", "us", "µs", "ns", "min", "h", "hz", "khz", "pa", "kpa", "hpa", "mpa", "bar", "mbar", "psi",
          "°c", "degc", "c", "k", "°f", "degf", "%", "m/s", "mm/s", "m", "mm", "cm", "µm", "um", "in", "rad", "deg",
          "°", "rad/s", "deg/s", "°/s", "dps", "n", "kn", "nm", "µt", "ut", "t", "mt", "gauss", "lx", "lux", "a",
          "ma", "ohm", "db", "rpm", "1"}
_HEADER_UNIT = re.compile(r"^(.*?\S)\s*[\(\[]([^()\[\]]+)[\)\]]\s*$")


def header_unit(header: str) -> str | None:
    """The unit in a column header's trailing brackets (``Acceleration x (m/s^2)`` -> ``m/s^2``,
    ``Pressure [hPa]`` -> ``hPa``), None when the brackets hold no unit (``Accel (front)``)."""
    m = _HEADER_UNIT.match(header.strip())
    if not m:
        return None
    unit = m.group(2).strip()
    key = re.sub(r"\s+", "", unit.lower())
    if normalize(unit) or key in _OTHER:
        return unit
    return None


def normalize(unit: str | None) -> str | None:
    """vrelab's name for a unit text (``'m/s^2'`` -> ``'m/s2'``), ``''`` for none stated, or
    None for a text that is not a unit vrelab knows (not an acceleration, a voltage or counts)."""
    if unit is None:
        return ""
    u = str(unit).strip().strip("[]()").strip()
    key = re.sub(r"\s+", "", u.lower())
    if key in _NONE:
        return ""
    if key in _SPELLINGS:
        return _SPELLINGS[key]
    return None


def channel_scale(role: str, channel: str, given: Scale | None, stated: str | None, integer: bool,
                  accept: bool = False, units_option: str = "--dut-units") -> tuple[Scale, str | None]:
    """The scale to g of one channel, and a note for the record (or None).

    Parameters
    ----------
    role : "DUT" or "reference" (for the messages); channel : the file's channel name.
    given : the user's scale, None when the user stated no unit.
    stated : the unit text the file states for the channel (None or blank: none).
    integer : whether the channel holds integer samples.
    accept : use ``given`` even where it contradicts the file's unit.
    units_option : the option that names the unit, for the messages.
    """
    sens = units_option.replace("-units", "-sensitivity")
    norm = normalize(stated)
    said = f"{role} channel {channel!r} is in {stated!r} (the file says)"
    if norm == "":  # the file states none
        if given is not None:
            return given, None
        if integer:
            raise ValueError(f"{role} channel {channel!r} holds integer samples with no unit: they are ADC counts, "
                             f"not g; give {units_option} lsb {sens} S (LSB per g)")
        return Scale(), f"{role} channel {channel!r}: the file states no unit: taken as g (give {units_option} if not)"
    if given is not None:
        if norm == given.units or accept:
            note = None if norm == given.units else f"{said}; read as {given.units} as given ({units_option})"
            return given, note
        raise ValueError(f"{said}, but {units_option} says {given.units!r}: drop {units_option} to use the "
                         "file's unit, or add --accept-file-units if the file's unit is wrong")
    if norm in _ACCEL:
        note = None if norm == "g" else f"{role} channel {channel!r}: unit {stated!r} from the file, converted to g"
        return Scale(norm), note  # type: ignore[arg-type]
    if norm in ("mv", "v", "lsb"):
        raise ValueError(f"{said}: give the sensitivity, {units_option} {norm} {sens} S ({norm} per g)")
    raise ValueError(f"{said}, not an acceleration: choose an accelerometer channel (vrelab channels "
                     f"FILE lists them), or if it is one, give {units_option} and --accept-file-units")


ASSUMED_NOTE = "the file states no unit: taken as g"


__all__ = ["normalize", "channel_scale", "header_unit", "ASSUMED_NOTE"]
