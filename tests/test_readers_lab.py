"""Lab formats through the reader registry, each against its own library's writer (or, for LVM,
NI's documented layout written by hand): values, rates, names, bad files."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from vrelab.analysis.readers import open_record

FS = 1000.0
N = 3000


def _signals(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    return 0.5 * np.sin(2 * np.pi * 80 * t) + 1e-3 * rng.standard_normal(N), 1.0 + 1e-3 * rng.standard_normal(N)


def _read(path: Path, dut: str, ref: str, **kw) -> tuple[float, np.ndarray, np.ndarray]:
    with open_record(path, dut, ref, **kw) as rec:
        blk = next(rec.blocks(N, ["dut", "reference"]))
        assert rec.n_samples == N
        return rec.fs_hz, blk["dut"], blk["reference"]


# ----------------------------------------------------------------------------- LVM


def write_lvm(path: Path, ref: np.ndarray, dut: np.ndarray, dec: str = ".", sep: str = "\t",
              comment_cells: bool = False, delta_x: tuple[float, float] = (1 / FS, 1 / FS)) -> None:
    """An LVM file with NI's layout (file header, segment header, X_Value column, Comment)."""
    name = {"\t": "Tab", ",": "Comma"}[sep]

    def num(x: float, fmt: str) -> str:
        return format(x, fmt).replace(".", dec)

    head = [
        f"LabVIEW Measurement{sep}", f"Writer_Version{sep}2", f"Reader_Version{sep}2", f"Separator{sep}{name}",
        f"Decimal_Separator{sep}{dec}", f"Multi_Headings{sep}No", f"X_Columns{sep}One", f"Time_Pref{sep}Relative",
        f"Operator{sep}lab", f"Date{sep}2026/11/24", f"Time{sep}10:00:00", f"***End_of_Header***{sep}", sep,
        f"Channels{sep}2{sep}{sep}", f"Samples{sep}{len(ref)}{sep}{len(ref)}{sep}",
        f"Date{sep}2026/11/24{sep}2026/11/24{sep}", f"X_Dimension{sep}Time{sep}Time{sep}", f"X0{sep}0{sep}0{sep}",
        f"Delta_X{sep}{num(delta_x[0], '.9g')}{sep}{num(delta_x[1], '.9g')}{sep}", f"***End_of_Header***{sep}{sep}{sep}",
        f"X_Value{sep}ref{sep}dut{sep}Comment",
    ]
    tail = sep if comment_cells else ""
    rows = [f"{num(i / FS, '.6f')}{sep}{num(r, '.12g')}{sep}{num(d, '.12g')}{tail}" for i, (r, d) in enumerate(zip(ref, dut))]
    path.write_text("\n".join(head + rows) + "\n")


@pytest.mark.parametrize("dec, sep, comment", [(".", "\t", False), (",", "\t", True), (".", ",", False)])
def test_lvm_values_and_rate(tmp_path: Path, dec: str, sep: str, comment: bool) -> None:
    ref, dut = _signals()
    p = tmp_path / "run.lvm"
    write_lvm(p, ref, dut, dec, sep, comment)
    fs, d, r = _read(p, "dut", "ref")
    assert fs == pytest.approx(FS)
    np.testing.assert_allclose(d, dut, rtol=1e-11)
    np.testing.assert_allclose(r, ref, rtol=1e-11, atol=1e-15)


def test_lvm_bad_files(tmp_path: Path) -> None:
    ref, dut = _signals()
    p = tmp_path / "rates.lvm"
    write_lvm(p, ref, dut, delta_x=(1e-3, 2e-3))
    # the two channels a record reads must share a rate (the file may hold others: see
    # test_lvm_only_the_chosen_channels_share_a_rate)
    with pytest.raises(ValueError, match=r"rates.lvm: channels 'dut' \(500 Hz\) and 'ref' \(1000 Hz\) have different"):
        open_record(p, "dut", "ref")
    q = tmp_path / "cut.lvm"
    q.write_text("\n".join(p.read_text().splitlines()[:15]))
    with pytest.raises(ValueError, match="cut.lvm: LVM header incomplete"):
        open_record(q, "dut", "ref")
    m = tmp_path / "missing.lvm"
    write_lvm(m, ref, dut)
    with pytest.raises(ValueError, match="channel 'dut2' not found in missing.lvm"):
        open_record(m, "dut2", "ref")


# ----------------------------------------------------------------------------- MDF4


def test_mdf4_physical_values_and_record_ranges(tmp_path: Path) -> None:
    from asammdf import MDF, Signal

    ref, dut = _signals(1)
    t = np.arange(N) / FS
    counts = np.round(dut * 256000).astype(np.int32)
    mdf = MDF(version="4.10")
    mdf.append([Signal(ref, t, name="ref", unit="g"),
                Signal(counts, t, name="dut", unit="g", conversion={"a": 1 / 256000, "b": 0.0})])
    p = tmp_path / "log.mf4"
    mdf.save(str(p), overwrite=True)
    fs, d, r = _read(p, "dut", "ref")
    assert fs == pytest.approx(FS)
    np.testing.assert_allclose(d, counts / 256000, rtol=1e-12)  # the conversion applied
    np.testing.assert_array_equal(r, ref)
    with open_record(p, "dut", "ref") as rec:  # a stretch read by record range
        blk = next(rec.blocks(100, ["dut"], 1234, 1334))
        np.testing.assert_allclose(blk["dut"], counts[1234:1334] / 256000, rtol=1e-12)


# asammdf's MDF4.__del__ trips on the object its constructor abandoned on the truncated file
# (an AttributeError during garbage collection, after our one-line ValueError): its noise, not ours
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_mdf4_different_rates_and_bad_file(tmp_path: Path) -> None:
    from asammdf import MDF, Signal

    ref, dut = _signals(2)
    mdf = MDF(version="4.10")
    mdf.append([Signal(ref, np.arange(N) / FS, name="ref")])
    mdf.append([Signal(dut, np.arange(N) / (2 * FS), name="dut")])
    p = tmp_path / "two.mf4"
    mdf.save(str(p), overwrite=True)
    with pytest.raises(ValueError, match="two.mf4: channels .* have different sample rates"):
        open_record(p, "dut", "ref")
    bad = tmp_path / "bad.mf4"
    bad.write_bytes(p.read_bytes()[:200])
    with pytest.raises(ValueError, match="bad.mf4"):
        open_record(bad, "dut", "ref")


# ----------------------------------------------------------------------------- TDMS from DAQmx


def test_tdms_scaled_channel_gives_scaled_values(tmp_path: Path) -> None:
    """A channel stored raw (int16 counts) with an NI linear scale, as DAQmx logs it: the reader
    returns the scaled values (npTDMS applies ``NI_Scale``)."""
    from nptdms import ChannelObject, TdmsWriter

    ref, dut = _signals(3)
    raw = np.round(dut / 1e-4).astype(np.int16)
    scale = {"NI_Scaling_Status": "unscaled", "NI_Number_Of_Scales": 1, "NI_Scale[0]_Scale_Type": "Linear",
             "NI_Scale[0]_Linear_Slope": 1e-4, "NI_Scale[0]_Linear_Y_Intercept": 0.0, "wf_increment": 1 / FS}
    p = tmp_path / "daq.tdms"
    with TdmsWriter(str(p)) as w:
        w.write_segment([ChannelObject("Dev1", "ai0", ref, {"wf_increment": 1 / FS}),
                         ChannelObject("Dev1", "ai1", raw, scale)])
    fs, d, r = _read(p, "Dev1/ai1", "Dev1/ai0")
    assert fs == pytest.approx(FS)
    np.testing.assert_allclose(d, raw * 1e-4, rtol=1e-12)
    np.testing.assert_array_equal(r, ref)


def test_tdms_daqmx_raw_data_is_read_scaled(tmp_path: Path) -> None:
    """DAQmx raw data (the "format changing" scaler of NI-DAQmx logging: int16 counts and a
    linear scale), built with npTDMS's own segment generator for its DAQmx tests: the reader
    gives the scaled values, i.e. what npTDMS's ``read_data(scaled=True)`` gives."""
    from nptdms import TdmsFile
    from nptdms.test.util import (
        GeneratedFile,
        group_metadata,
        hex_properties,
        hexlify_value,
        root_metadata,
        segment_objects_metadata,
        string_hexlify,
    )

    # DAQmx metadata as npTDMS's own DAQmx tests build it (nptdms/test/test_daqmx.py: raw data
    # index 0x1269, data type 0xFFFFFFFF, one scaler per channel, raw widths); restated here
    # because importing that pytest module from site-packages is not what it is for
    def scaler(type_id: int, byte_offset: int) -> str:
        return (hexlify_value("<I", type_id) + hexlify_value("<I", 0) + hexlify_value("<I", byte_offset)
                + "00 00 00 00" + hexlify_value("<I", 0))

    def daqmx_channel_metadata(name: str, n: int, widths: list[int], scalers: list[str], properties: dict) -> str:
        path = "/'Group'/'" + name + "'"
        return (hexlify_value("<I", len(path)) + string_hexlify(path) + "69 12 00 00"
                + hexlify_value("<I", 0xFFFFFFFF) + "01 00 00 00" + hexlify_value("<Q", n)
                + hexlify_value("<I", len(scalers)) + "".join(scalers)
                + hexlify_value("<I", len(widths)) + "".join(hexlify_value("<I", w) for w in widths)
                + hex_properties(properties))

    def daqmx_scaler_metadata(scale_id: int, type_id: int, byte_offset: int) -> str:
        return scaler(type_id, byte_offset)

    def segment_toc() -> tuple[str, ...]:
        return ("kTocMetaData", "kTocRawData", "kTocNewObjList", "kTocDAQmxRawData")

    rng = np.random.default_rng(5)
    counts = rng.integers(-3000, 3000, size=(2, 400)).astype(np.int16)
    slope, inc = 2.5e-4, 1e-3

    def prop_str(s: str) -> tuple[int, str]:
        return 0x20, hexlify_value("<I", len(s)) + string_hexlify(s)

    def props(name: str) -> dict:
        # as DAQmx writes it: scale 0 is the raw data's scaler (no properties), scale 1 a linear
        # scale whose input is scale 0
        return {"NI_Number_Of_Scales": (3, hexlify_value("<I", 2)),
                "NI_Scale[1]_Scale_Type": prop_str("Linear"),
                "NI_Scale[1]_Linear_Slope": (10, hexlify_value("<d", slope)),
                "NI_Scale[1]_Linear_Y_Intercept": (10, hexlify_value("<d", 0.0)),
                "NI_Scale[1]_Linear_Input_Source": (3, hexlify_value("<I", 0)),
                "wf_increment": (10, hexlify_value("<d", inc))}

    meta = segment_objects_metadata(
        root_metadata(), group_metadata(),
        daqmx_channel_metadata("ref", 400, [4], [daqmx_scaler_metadata(0, 3, 0)], props("ref")),
        daqmx_channel_metadata("dut", 400, [4], [daqmx_scaler_metadata(0, 3, 2)], props("dut")))
    data = "".join(hexlify_value("<h", int(a)) + hexlify_value("<h", int(b)) for a, b in zip(counts[0], counts[1]))
    f = GeneratedFile()
    f.add_segment(segment_toc(), meta, data)
    p = tmp_path / "daqmx.tdms"
    p.write_bytes(f.get_bytes_io_file().getvalue())
    with TdmsFile.open(p) as tf:
        truth = tf["Group"]["dut"].read_data(scaled=True)
    np.testing.assert_allclose(truth, counts[1] * slope)  # npTDMS scales it: the independent check
    with open_record(p, "Group/dut", "Group/ref") as rec:
        assert rec.fs_hz == pytest.approx(1 / inc)
        blk = next(rec.blocks(400, ["dut", "reference"]))
    np.testing.assert_allclose(blk["dut"], counts[1] * slope, rtol=1e-12)
    np.testing.assert_allclose(blk["reference"], counts[0] * slope, rtol=1e-12)


# ----------------------------------------------------------------------------- enDAQ IDE


def write_ide(path: Path, cols: dict[str, np.ndarray], fs: float, per: int = 250, jitter: float = 0.0,
              seed: int = 0, gap_after: int | None = None, drift: float = 0.0, gap_blocks: int = 1,
              early_first: float = 0.0, boundary: float = 0.0) -> None:
    """An IDE file as enDAQ recorders write it, encoded with ebmlite (the EBML library idelib
    reads with) against idelib's own schema (mide_ide.xml): recording properties declaring one
    channel (ID 8, float32 sub-channels), then data blocks stamped with their start and end
    time codes (1/32768 s); ``jitter`` moves each block's stamps by up to that many ticks;
    ``gap_after`` blocks, the stamps jump ``gap_blocks`` blocks ahead (samples lost); ``drift``
    bends the recorder's clock: block b is stamped ``drift`` samples late at the record's end,
    quadratically in between (a clock slowing down as the recorder warms); ``early_first``: the
    first block's start stamp that many samples early (its end stamp kept), ``boundary``: each
    block after the first that many samples late, one step more at each (an enDAQ gyro's stamps)."""
    import ebmlite

    schema = ebmlite.loadSchema("mide_ide.xml")
    names = list(cols)
    subs = [{"SubChannelID": i, "SubChannelName": nm, "SubChannelAxisName": nm,
             "SubChannelLabel": "Acceleration", "SubChannelUnits": "g"}
            for i, nm in enumerate(names)]
    props = {"RecordingProperties": {"ChannelList": {"Channel": [
        {"ChannelID": 8, "ChannelName": "Accel", "ChannelFormat": "<" + "f" * len(names), "SubChannel": subs}]}}}
    rng = np.random.default_rng(seed)
    tick = 32768 / fs
    data = np.column_stack([cols[n] for n in names]).astype("<f4")
    blocks = []
    for b, i in enumerate(range(0, len(data), per)):
        j = min(i + per, len(data))
        dj = (rng.uniform(-jitter, jitter) + (gap_blocks * per * tick if gap_after is not None and b >= gap_after else 0.0)
              + drift * tick * (i / len(data)) ** 2 + boundary * tick * b)
        t0 = np.ceil(jitter) + early_first * tick  # stamps are unsigned
        early = early_first * tick if b == 0 else 0.0
        blocks.append({"ChannelDataBlock": {"ChannelIDRef": 8, "StartTimeCodeAbs": int(round(t0 + i * tick + dj - early)),
                                            "EndTimeCodeAbs": int(round(t0 + (j - 1) * tick + dj)),
                                            "ChannelDataPayload": data[i:j].tobytes()}})
    path.write_bytes(schema.encodes([props] + blocks, headers=True))


def test_ide_values_names_and_rate(tmp_path: Path) -> None:
    import idelib

    ref, dut = _signals(6)
    p = tmp_path / "rec.ide"
    write_ide(p, {"ref": ref, "dut": dut}, 1024.0)
    doc = idelib.importFile(str(p), quiet=True)  # what idelib itself reads: the independent check
    own = doc.channels[8].subchannels[1].getSession().arraySlice(0, N)[1]
    doc.close()
    np.testing.assert_allclose(own, dut.astype(np.float32))
    with open_record(p, "8.1", "8.0") as rec:
        assert rec.fs_hz == pytest.approx(1024.0, rel=1e-6)
        blk = next(rec.blocks(N, ["dut", "reference"]))
    np.testing.assert_array_equal(blk["dut"], own)
    np.testing.assert_allclose(blk["reference"], ref.astype(np.float32))
    # block stamps jittered by ±10 ticks of the 32768 Hz clock (a third of a sample here), as
    # recorders stamp them: still one rate; a missing block is a gap: refused
    q = tmp_path / "jitter.ide"
    write_ide(q, {"ref": ref, "dut": dut}, 1024.0, jitter=10.0)
    with open_record(q, "8.1", "8.0") as rec:
        assert rec.fs_hz == pytest.approx(1024.0, rel=1e-3)
    g = tmp_path / "gap.ide"
    write_ide(g, {"ref": ref, "dut": dut}, 1024.0, gap_after=4)
    with pytest.raises(ValueError, match="gap.ide: IDE channel .* not evenly sampled"):
        open_record(g, "8.1", "8.0")
    bad = tmp_path / "bad.ide"
    bad.write_bytes(p.read_bytes()[:40])
    with pytest.raises(ValueError, match="bad.ide"):
        with open_record(bad, "8.1", "8.0") as rec:
            next(rec.blocks(N, ["dut"]))


def test_ide_refused_after_opening_closes_idelib_document(tmp_path: Path) -> None:
    """A file idelib opens but vrelab refuses (no channel holds two samples) is closed at once,
    not left open for the garbage collector (it was: a ResourceWarning at exit)."""
    import gc
    import os

    ref, dut = _signals(1)
    p = tmp_path / "one.ide"
    write_ide(p, {"ref": ref[:1], "dut": dut[:1]}, 1024.0, per=1)

    def open_on_p() -> int:
        return sum(1 for fd in os.listdir("/proc/self/fd") if os.path.realpath(f"/proc/self/fd/{fd}") == str(p))

    gc.disable()  # the collector would close a leaked handle and hide the leak
    try:
        with pytest.raises(ValueError, match="one.ide: no IDE channel holds samples"):
            open_record(p, "8.1", "8.0")
        assert open_on_p() == 0
        p.write_bytes(p.read_bytes()[:40])  # truncated: refused by idelib itself, half-way
        with pytest.raises(ValueError, match="one.ide"):
            open_record(p, "8.1", "8.0")
        assert open_on_p() == 0
    finally:
        gc.enable()


def test_truncated_mdf4_is_one_line_on_stderr(tmp_path: Path) -> None:
    """asammdf's MDF4.__del__ raised on the half-built object of a file it refused ("Exception
    ignored in ... AttributeError" and a traceback after vrelab's one line)."""
    import subprocess
    import sys

    from asammdf import MDF, Signal

    ref, dut = _signals(3)
    mdf = MDF(version="4.10")
    mdf.append([Signal(ref, np.arange(N) / FS, name="ref"), Signal(dut, np.arange(N) / FS, name="dut")])
    p = tmp_path / "whole.mf4"
    mdf.save(str(p), overwrite=True)
    mdf.close()
    bad = tmp_path / "cut.mf4"
    bad.write_bytes(p.read_bytes()[:200])
    out = subprocess.run([sys.executable, "-m", "vrelab", "analyze", str(bad), "--dut", "dut", "--reference", "ref"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and out.stderr.startswith("vrelab: error: cut.mf4: cannot read as MDF"), out.stderr


def _band_noise(rng: np.random.Generator, n: int, fs: float, lo: float, hi: float) -> np.ndarray:
    """Gaussian noise with a flat spectrum between lo and hi Hz and none outside (FFT mask), unit rms."""
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / fs)
    spec[(f < lo) | (f > hi)] = 0.0
    x = np.fft.irfft(spec, n)
    return x / np.sqrt(np.mean(x**2))


def test_ide_rate_of_idelib_stated_and_judged_against_each_level_u(tmp_path: Path) -> None:
    """Issue 30 (rates): vrelab fits an IDE channel's rate to every block's stamps, idelib's
    getSampleRate() takes the first block's alone; both are stated, and the difference is judged
    level by level. Truth by closed form: the reference is flat from 20 to 1900 Hz, the band
    50-1000 Hz lies inside it, so at idelib's rate (q = fs_lib/fs) the band holds P/q, the rms
    reads rms/√q, and a VRE = k2·rms² belongs to a VRC off by q: at
    the level's rms a VRE shift of |VRE·(q - 1)|. (The DUT is ref + k2·ref² + noise.)"""
    import idelib

    from vrelab.analysis.options import ReductionOptions
    from vrelab.analysis.pipeline import analyze

    fs, k2 = 4096.0, 1e-3  # k2: 1000 µg/g²
    rng = np.random.default_rng(30)
    parts, rms = [], []
    for level in (0.0, 1.0, 0.0, 2.0, 0.0):
        n = int((4.0 if level == 0 else 8.0) * fs)
        parts.append(level * _band_noise(rng, n, fs, 20.0, 1900.0) if level else np.zeros(n))
        rms.append(level)
    ref = np.concatenate(parts)
    dut = ref + k2 * ref**2 + 2e-3 * rng.standard_normal(len(ref))
    p = tmp_path / "vib.ide"
    # the first block's start stamped 5 samples early (its end kept): idelib's first-block rate
    # is 5 samples in 250 (2 %) slow, the line through all 450 blocks barely moves
    write_ide(p, {"ref": ref, "dut": dut}, fs, early_first=5.0)
    doc = idelib.importFile(str(p), quiet=True)
    lib = float(doc.channels[8].subchannels[0].getSession().getSampleRate())  # idelib itself
    doc.close()
    with open_record(p, "8.1", "8.0") as rec:
        res = analyze(rec, "random", options=ReductionOptions(band_hz=(50.0, 1000.0), settle_s=0.5))
        fs_used = rec.fs_hz
    q = lib / fs_used
    assert q == pytest.approx(0.98, abs=0.005)  # the 2 % the stamps were built with
    assert res.provenance["fs_library_hz"] == lib
    text = " ".join(res.warnings)
    assert f"idelib's getSampleRate() gives {lib:.9g} Hz" in text and f"{fs_used:.9g} Hz" in text
    rate = next(w for w in res.warnings if getattr(w, "code", "") == "rate")
    rel = [abs(lv.vre.value * (q - 1)) / lv.vre.u for lv in res.levels]
    want = max(rel)
    said = float(re.search(r"up to ([\d.e+-]+) u", rate).group(1))
    # the PSD's scatter in the ~20 Hz edge slivers of an 8 s level (about 20 Welch averages of
    # 1 Hz bins, 5 % for 20 bins) and the 2-digit rounding of the notice: 15 %
    assert said == pytest.approx(want, rel=0.15)
    # the 1 g level's shift (|VRE| 0.5 mg · 2 %) is inside its u, the 2 g level's (2 mg · 2 %) beyond
    assert rel[0] < 0.85 and rel[1] > 1.15  # clear of 1 by more than the 15 % above
    assert f"beyond u at 1 level(s) ({res.levels[1].rms_g:.4g} g rms)" in rate


def test_ide_real_file_states_both_rates() -> None:
    """On an enDAQ recorder's file (SSX70065.IDE, idelib's test data) the record says the rate it
    uses and idelib's, 0.32 % apart, as idelib itself gives it."""
    import idelib

    path = Path(__file__).parent / "data" / "thirdparty" / "idelib" / "SSX70065.IDE"
    doc = idelib.importFile(str(path), quiet=True)
    lib = float(doc.channels[32].subchannels[0].getSession().getSampleRate())
    doc.close()
    with open_record(path, "32.0", "32.1") as rec:
        notes = " ".join(rec.meta["reader_notes"])
        assert rec.meta["fs_library_hz"] == lib
        assert f"getSampleRate() gives {lib:.9g} Hz" in notes and f"{rec.fs_hz:.9g} Hz" in notes
        assert abs(lib / rec.fs_hz - 1) == pytest.approx(0.0032, abs=0.0001)
