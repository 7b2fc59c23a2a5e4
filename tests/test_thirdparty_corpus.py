"""Real third-party files (issue 19): every sample file in ``tests/data/thirdparty`` read by vrelab
and by the format's own library, which must agree on the samples, the rate and the unit.

The files were written by instruments and other software (enDAQ / Slam Stick recorders, Simcenter
Testlab, REAPER, Audacity, MATLAB 4.2c-8, asammdf, ...) and come from the public test data of the
format libraries; ``MANIFEST.toml`` beside them gives each one's source, commit, licence and writer.

The reference for each format is its own library, never vrelab's reader: soundfile (libsndfile)
for WAV, pyuff for UFF58, idelib for IDE, asammdf for MDF4, scipy.io.loadmat for MAT v4/v5 and
h5py for HDF5 (MAT v7.3 included). For every channel the library gives:

* ``vrelab channels`` (:func:`~vrelab.analysis.readers.list_channels`) lists it under the name
  given below, with the library's number of samples, rate and the unit the file states;
* ``open_record`` reads it as the user would, and its samples are the library's samples in g:
  bit-identical where the file holds g or a unitless float, within float rounding of the stated
  conversion (m/s², mg) otherwise; integer samples without a unit are counts, refused unless
  the user names them (``Scale("lsb", 1)`` then gives the counts back exactly);
* a unit that is not an acceleration (Pa, degC, Nm, ns, a quaternion's q, ...) is refused as a DUT;
* the rate agrees within what the file states: exactly for WAV, within the rounding of the
  written increment for UFF58 (E13.5: six significant digits), and for time-stamped formats
  (MDF4, IDE: recorders stamp blocks, loggers stamp samples, with jitter) with the slope of a line
  through the library's stamps, within the tilt their scatter about it allows.

A file with an ``expected`` entry is one vrelab rightly refuses (truncated, no time record, no
real-valued channel, a lossy audio codec): its message must match.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
from numpy.typing import NDArray

from vrelab.analysis.readers import Scale, list_channels, open_record

DATA = Path(__file__).parent / "data" / "thirdparty"
MANIFEST: list[dict[str, Any]] = tomllib.loads((DATA / "MANIFEST.toml").read_text(encoding="utf-8"))["file"]
G0 = 9.80665  # standard gravity [m/s²] (3rd CGPM, 1901)
GIVEN_FS_HZ = 1000.0  # the rate given with --fs to a file that states none
# a step between stamps this many samples beyond the usual one is a gap rather than jitter: vrelab
# may then list no rate and refuse the channel (issue 19: stamps jittering by about a sample and a
# clock drifting 1-10 samples over the record are read at the fitted rate; a gap of many samples
# is refused, saying where)
GAP_SAMPLES = 5.0
# stamps further than this many samples from the line through them (the library's own) hold no one
# rate: vrelab may then list none and refuse the channel, saying so (issue 19 reads a clock that
# drifts 1-10 samples at the fitted rate; a GNSS receiver's NMEA characters, stamped as they
# arrive in bursts, stray thousands of samples from any line)
DRIFT_SAMPLES = 10.0

# The units the corpus's files state, read by this test's own table (not vrelab's): an
# acceleration's divisor to g; "" or "-" is no unit; anything else is not an acceleration.
ACCEL_PER_G = {"g": 1.0, "mg": 1000.0, "m/s²": G0, "m/s^2": G0, "m/s2": G0}
NO_UNIT = {"", "-"}


@dataclass
class LibChannel:
    """One channel as the format's own library reads it."""

    samples: NDArray[Any]
    rate_hz: float | None  # None: the file states no rate
    rate_rtol: float  # how closely the file pins the rate (relative)
    unit: str  # as the file states it ("" for none)
    gap: float = 0.0  # time-stamped formats: the largest step between stamps beyond the usual one [samples]
    drift: float = 0.0  # time-stamped formats: the stamps' largest distance from the line through them [samples]

    @property
    def integer(self) -> bool:
        return self.samples.dtype.kind in "biu"


# ----------------------------------------------------------------------------- the libraries


def _wav(path: Path) -> dict[str, LibChannel]:
    """soundfile (libsndfile). Integer PCM as counts at the file's own bit depth (a 24-bit file's
    LSB is 2^-23 of full scale, an 8-bit file's samples are offset by 128); codecs (mu-law, A-law,
    ADPCM) decoded to 16-bit counts as libsndfile does."""
    import soundfile as sf

    info = sf.info(str(path))
    bits = {"PCM_S8": 8, "PCM_U8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32}.get(info.subtype)
    if bits is not None:
        x = sf.read(str(path), dtype="int32", always_2d=True)[0] >> (32 - bits)
    elif info.subtype in ("FLOAT", "DOUBLE"):
        x = sf.read(str(path), dtype="float32" if info.subtype == "FLOAT" else "float64", always_2d=True)[0]
    else:
        x = sf.read(str(path), dtype="int16", always_2d=True)[0]
    return {str(i): LibChannel(x[:, i], float(info.samplerate), 0.0, "") for i in range(x.shape[1])}


def _uff(path: Path) -> dict[str, LibChannel]:
    """pyuff: every UFF58 record of function type 1 (time response) with even abscissa spacing,
    named by its id1; the increment is written E13.5 (six significant digits)."""
    import pyuff

    uff = pyuff.UFF(str(path))
    out: dict[str, LibChannel] = {}
    for i in np.flatnonzero(np.asarray(uff.get_set_types()).astype(int) == 58):
        d = uff.read_sets(int(i))
        if int(d["func_type"]) != 1 or int(d.get("abscissa_spacing", 1)) != 1:
            continue
        inc = float(d["abscissa_inc"])
        half_digit = 0.5 * 10.0 ** (math.floor(math.log10(inc)) - 5)
        out[str(d["id1"]).strip()] = LibChannel(np.asarray(d["data"]), 1.0 / inc, half_digit / inc * (1 + 1e-9),
                                               str(d.get("ordinate_axis_units_lab", "")).strip())
    return out


def _stamped_rate(t: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """The rate [Hz] that time stamps [s] give (the slope of a least-squares line through them:
    numpy's polyfit, not vrelab's code), how closely they pin it (a line that stays within the
    stamps' scatter r about it can tilt by 2r over the record, a relative 2r / span), the
    largest step between stamps beyond the median step, in samples (idelib and asammdf give a
    stamp per sample, idelib's spread over each block), and r in samples."""
    i = np.arange(len(t), dtype=np.float64)
    slope, icept = np.polyfit(i, t, 1)
    r = float(np.max(np.abs(t - (slope * i + icept))))
    d = np.diff(t)
    return (1.0 / float(slope), 2.0 * r / float(t[-1] - t[0]) + 1e-9, float(d.max() - np.median(d)) / float(slope),
            r / float(slope))


def _ide(path: Path) -> dict[str, LibChannel]:
    """idelib: every sub-channel with samples, named ``<channel id>.<sub-channel id>``; the rate
    from the library's time stamps (µs; recorders stamp blocks, which jitter)."""
    import idelib

    out: dict[str, LibChannel] = {}
    doc = idelib.importFile(str(path), quiet=True)
    try:
        for cid, ch in sorted(doc.channels.items()):
            for sc in ch.subchannels:
                ev = sc.getSession()
                n = len(ev)
                if n < 2:
                    continue
                t, v = ev.arraySlice(0, n)
                rate, rtol, r, drift = _stamped_rate(np.asarray(t, dtype=np.float64) * 1e-6)
                units = sc.units if isinstance(sc.units, tuple) else ("", sc.units)
                out[f"{cid}.{sc.id}"] = LibChannel(np.asarray(v), rate, rtol, str(units[1] or "").strip(), r, drift)
    finally:
        doc.close()
    return out


def _mdf(path: Path) -> dict[str, LibChannel]:
    """asammdf: every numeric 1-D channel but the masters, its conversion applied (``MDF.get``),
    named as in the file (``<group>/<name>`` where the name is in several groups)."""
    from asammdf import MDF

    out: dict[str, LibChannel] = {}
    mdf = MDF(str(path))
    try:
        for gi, grp in enumerate(mdf.groups):
            master = mdf.masters_db.get(gi)
            for ci, ch in enumerate(grp.channels):
                if ci == master:
                    continue
                s = mdf.get(group=gi, index=ci)
                x = np.asarray(s.samples)
                if x.ndim != 1 or x.dtype.kind not in "biuf" or len(x) < 2:
                    continue  # (a logger's bus with no frames holds no record: no rate to compare)
                rate, rtol, r, drift = _stamped_rate(np.asarray(s.timestamps, dtype=np.float64))
                name = ch.name if len(mdf.channels_db[ch.name]) == 1 else f"{gi}/{ch.name}"
                out[name] = LibChannel(x, rate, rtol, str(s.unit or "").strip(), r, drift)
    finally:
        mdf.close()
    return out


def _columns(name: str, v: NDArray[Any]) -> dict[str, NDArray[Any]]:
    """A 2-D variable's channels as the readers document them: a vector is one channel; a matrix
    gives its columns ``name/i`` (its rows when it is short and wide: (channels, samples))."""
    if v.ndim == 1 or (v.ndim == 2 and 1 in v.shape):
        return {name: v.ravel()}
    if v.ndim != 2:
        return {}
    rows = v.shape[0] <= 64 < v.shape[1]
    return {f"{name}/{i}": (v[i, :] if rows else v[:, i]) for i in range(v.shape[0] if rows else v.shape[1])}


def _mat(path: Path) -> dict[str, LibChannel]:
    """scipy.io.loadmat (MAT v4 and v5): every real numeric variable of two samples or more, of the
    class MATLAB gives it (``mat_dtype``: a double matrix that MATLAB stored compactly as uint8 is
    still a double)."""
    from scipy.io import loadmat

    out: dict[str, LibChannel] = {}
    data = loadmat(str(path), squeeze_me=False, mat_dtype=True)
    # a 1x1 struct's fields, named struct.field as the readers document (loaded without mat_dtype,
    # which casts a complex field to its real part)
    for k, v in loadmat(str(path), squeeze_me=False).items():
        if not k.startswith("__") and isinstance(v, np.ndarray) and v.dtype.names and v.size == 1:
            data.update({f"{k}.{f}": v[f].item() for f in v.dtype.names})
    for k, v in data.items():
        if k.startswith("__") or not isinstance(v, np.ndarray) or v.dtype.kind not in "biuf" or v.size < 2:
            continue
        out.update({n: LibChannel(x, None, 0.0, "") for n, x in _columns(k, v).items()})
    return out


def _hdf5(path: Path) -> dict[str, LibChannel]:
    """h5py: every real numeric dataset of two samples or more, by its path."""
    import h5py

    out: dict[str, LibChannel] = {}
    with h5py.File(path, "r") as f:
        dsets: list[Any] = []
        f.visititems(lambda n, o: dsets.append(o) if isinstance(o, h5py.Dataset) else None)
        for d in dsets:
            if d.dtype.kind not in "biuf" or d.size < 2:
                continue
            out.update({n: LibChannel(x, None, 0.0, "") for n, x in _columns(d.name.lstrip("/"), d[()]).items()})
    return out


LIBRARY: dict[str, Callable[[Path], dict[str, LibChannel]]] = {
    "wav": _wav, "uff": _uff, "ide": _ide, "mdf": _mdf, "mat": _mat, "hdf5": _hdf5,
}


# ----------------------------------------------------------------------------- the checks


def _listing(path: Path) -> dict[str, dict[str, Any]]:
    """What ``vrelab channels --json`` lists, by every name a channel answers to (its own, and
    those its notes give as "also named 'a', 'b'")."""
    out: dict[str, dict[str, Any]] = {}
    for c in list_channels(path)["channels"]:
        out[c["name"]] = c
        for note in c["notes"]:
            if note.startswith("also named "):
                out.update({a: c for a in re.findall(r"'([^']*)'", note)})
    return out


def _samples(rec: Any) -> NDArray[np.float64]:
    return np.concatenate([b["dut"] for b in rec.blocks(1 << 16, ["dut"])] or [np.empty(0)])


def _open(path: Path, name: str, lib: LibChannel, scale: Scale | None = None) -> Any:
    fs = GIVEN_FS_HZ if lib.rate_hz is None else None
    return open_record(path, dut=name, dut_scale=scale, fs_hz=fs)


def _refused(path: Path, name: str, lib: LibChannel, scale: Scale | None = None) -> str | None:
    """vrelab's one-line refusal of channel ``name`` read as the user would, or None if it reads it."""
    try:
        with _open(path, name, lib, scale) as rec:
            _samples(rec)
    except ValueError as exc:
        return str(exc)
    return None


def _check_channel(path: Path, name: str, lib: LibChannel) -> list[str]:
    """What vrelab gets wrong about channel ``name``: one line per problem (none: it agrees)."""
    unit = lib.unit
    problems: list[str] = []
    if unit in NO_UNIT and lib.integer:
        # counts: refused as g, read back exactly as counts when the user says so
        if _refused(path, name, lib) is None:
            problems.append(f"{name}: integer samples without a unit read as g (counts: should be refused)")
        scale, divisor = Scale("lsb", 1.0), 1.0
    elif unit in NO_UNIT:
        scale, divisor = None, 1.0
    elif unit in ACCEL_PER_G:
        scale, divisor = None, ACCEL_PER_G[unit]
    else:
        # refused (vrelab says "not an acceleration"; a channel it cannot read for another
        # reason, an uneven one, is refused all the same): never read as g
        if _refused(path, name, lib) is None:
            problems.append(f"{name}: unit {unit!r} is not an acceleration, yet read as g")
        return problems
    try:
        with _open(path, name, lib, scale) as rec:
            got = _samples(rec)
            n, fs = rec.n_samples, rec.fs_hz
    except ValueError as exc:
        if lib.gap > GAP_SAMPLES and "gap" in str(exc):
            return problems  # refused, and rightly: the library's own stamps hold a gap
        if lib.drift > DRIFT_SAMPLES and "not one sample rate" in str(exc):
            return problems  # refused, and rightly: the library's own stamps follow no one rate
        return problems + [f"{name}: refused: {exc}"]
    want = np.asarray(lib.samples, dtype=np.float64) / divisor
    if n != len(want) or len(got) != len(want):
        problems.append(f"{name}: {n} samples ({len(got)} read), the library reads {len(want)}")
    elif divisor == 1.0 and not np.array_equal(got, want):
        i = int(np.flatnonzero(got != want)[0])
        problems.append(f"{name}: samples differ from the library's (first at {i}: {got[i]!r} vs {want[i]!r})")
    elif not np.allclose(got, want, rtol=4e-16, atol=0):
        i = int(np.flatnonzero(~np.isclose(got, want, rtol=4e-16, atol=0))[0])
        problems.append(f"{name}: samples in g differ from the library's / {divisor:g} "
                        f"(first at {i}: {got[i]!r} vs {want[i]!r})")
    if lib.rate_hz is None:
        if fs != GIVEN_FS_HZ:
            problems.append(f"{name}: rate {fs!r} Hz, but the file states none and --fs {GIVEN_FS_HZ:g} was given")
    elif abs(fs - lib.rate_hz) > lib.rate_rtol * lib.rate_hz:
        problems.append(f"{name}: rate {fs!r} Hz, the file states {lib.rate_hz!r} Hz (rtol {lib.rate_rtol:.3g})")
    return problems


def check_file(entry: dict[str, Any]) -> list[str]:
    """Every disagreement between vrelab and the format's library on one manifest entry."""
    path = DATA / entry["file"]
    if "expected" in entry:
        # a file vrelab rightly refuses: each channel's refusal is one line that says why
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                names = list(LIBRARY[entry["format"]](path)) or ["0"]
        except Exception:  # the library refuses it too (a truncated file)
            names = ["0"]
        problems = []
        for name in names:
            try:
                with open_record(path, dut=name) as rec:
                    _samples(rec)
                problems.append(f"{name}: read, but expected a refusal matching {entry['expected']!r}")
            except ValueError as exc:
                if not re.search(entry["expected"], str(exc)):
                    problems.append(f"{name}: refused with {str(exc)!r}, expected {entry['expected']!r}")
        return problems
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lib = LIBRARY[entry["format"]](path)
    if not lib:
        return ["the library reads no channel (give the file an `expected` entry)"]
    try:
        listing = _listing(path)
    except ValueError as exc:
        return [f"refused: {exc}"]
    problems = []
    for name, ch in lib.items():
        if name not in listing:
            problems.append(f"{name}: not listed by `vrelab channels` (it lists {sorted(listing)})")
            continue
        c = listing[name]
        said = (c["unit"] or "").strip()
        if said != ch.unit and not (said in NO_UNIT and ch.unit in NO_UNIT):
            problems.append(f"{name}: `vrelab channels` says the file states unit {said!r}, the library reads {ch.unit!r}")
        if c["n_samples"] != len(ch.samples):
            problems.append(f"{name}: `vrelab channels` lists {c['n_samples']} samples, the library reads {len(ch.samples)}")
        if ch.rate_hz is None:
            if c["rate_hz"] is not None:
                problems.append(f"{name}: `vrelab channels` lists rate {c['rate_hz']!r} Hz, the file states none")
        elif c["rate_hz"] is None and ((ch.gap > GAP_SAMPLES and any("gap" in n for n in c["notes"]))
                                       or (ch.drift > DRIFT_SAMPLES and any("not one sample rate" in n for n in c["notes"]))):
            pass  # stamps with a gap, or straying from any line, pin no one rate: none listed, saying why, is right
        elif c["rate_hz"] is None or abs(c["rate_hz"] - ch.rate_hz) > ch.rate_rtol * ch.rate_hz:
            problems.append(f"{name}: `vrelab channels` lists rate {c['rate_hz']!r} Hz, the file states "
                            f"{ch.rate_hz!r} Hz (rtol {ch.rate_rtol:.3g})")
        problems += _check_channel(path, name, ch)
    return problems


@pytest.mark.parametrize("entry", [e for e in MANIFEST if "checked_by" not in e],
                         ids=[e["file"] for e in MANIFEST if "checked_by" not in e])
def test_thirdparty_file_reads_as_its_library_reads_it(entry: dict[str, Any]) -> None:
    problems = check_file(entry)
    assert not problems, f"{entry['file']} ({entry['writer']}):\n" + "\n".join(problems)


def test_corpus_spans_thirty_files_over_six_formats() -> None:
    """Issue 19's bar, and the manifest's own record of every file (source, commit, licence)."""
    formats = {e["format"] for e in MANIFEST}
    read = [e for e in MANIFEST if "expected" not in e]
    assert len(read) >= 30 and len(formats) >= 6, (len(read), formats)
    for e in MANIFEST:
        data = (DATA / e["file"]).read_bytes()
        assert len(data) == e["bytes"] and hashlib.sha256(data).hexdigest() == e["sha256"], e["file"]
        assert e["license"] in ("MIT", "BSD-3-Clause"), e["file"]
        assert len(e["commit"]) == 40 and e["source"].startswith("https://github.com/"), e["file"]
        assert (DATA / e["file"]).parent.joinpath("LICENSE").is_file(), e["file"]
