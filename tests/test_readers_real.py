"""Files as real instruments and other software write them (issue 19): WAV chunk layouts and
sample formats (hand-built bytes: the truth is the integers written), jittered stamps (IDE, MDF),
files at several rates (TDMS, LVM), the units a file states, time columns by header, ambiguous
names, rates written rounded, a missing reader library, and ``vrelab channels``. Each file is
written by its format's own library where one exists (npTDMS, asammdf, pyuff, soundfile, h5py)."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from test_readers_lab import FS, N, _signals, write_ide, write_lvm
from vrelab.analysis.readers import Scale, open_record
from vrelab.analysis.readers._base import G0

# ----------------------------------------------------------------------------- WAV bytes


def _chunk(cid: bytes, data: bytes, big: bool = False) -> bytes:
    out = cid + struct.pack(">I" if big else "<I", len(data)) + data
    return out + (b"\0" if len(data) % 2 else b"")  # RIFF pads a chunk to an even size


def _riff(chunks: list[bytes], big: bool = False) -> bytes:
    body = b"WAVE" + b"".join(chunks)
    return (b"RIFX" if big else b"RIFF") + struct.pack(">I" if big else "<I", len(body)) + body


def _fmt(channels: int, fs: int, bits: int, big: bool = False, tag: int = 1) -> bytes:
    block = channels * ((bits + 7) // 8)
    return _chunk(b"fmt ", struct.pack((">" if big else "<") + "HHIIHH", tag, channels, fs, fs * block, block, bits), big)


# what recorder and audio software put around the samples (Broadcast Wave's bext, a LIST INFO,
# fact and PEAK, JUNK padding, cue points, an ACID loop header), each with its own payload
_EXTRA = [
    _chunk(b"bext", b"shaker run 12".ljust(256, b"\0") + bytes(346)),
    _chunk(b"LIST", b"INFO" + _chunk(b"ISFT", b"recorder 1.0\0")),
    _chunk(b"fact", struct.pack("<I", 64)),
    _chunk(b"PEAK", struct.pack("<II", 1, 0) + struct.pack("<fI", 0.5, 3) * 2),
    _chunk(b"junk", bytes(27)),
    _chunk(b"cue ", struct.pack("<I", 1) + struct.pack("<II4sIII", 1, 0, b"data", 0, 0, 10)),
    _chunk(b"acid", struct.pack("<IHHfIHHf", 0, 60, 0, 0.0, 4, 4, 4, 120.0)),
]


@pytest.fixture
def counts() -> np.ndarray:
    return np.random.default_rng(19).integers(-30000, 30000, size=(64, 2)).astype("<i2")


def test_wav_with_recorder_chunks_is_read(tmp_path: Path, counts: np.ndarray) -> None:
    """Chunks before and after the data (a LIST after the samples, as many editors write it)
    are skipped; the samples are the integers written."""
    import soundfile as sf

    data = _chunk(b"data", counts.tobytes())
    p = tmp_path / "chunks.wav"
    p.write_bytes(_riff([_fmt(2, 4000, 16)] + _EXTRA[:5] + [data] + _EXTRA[5:]))
    own = sf.read(p, dtype="int16")[0]  # the format's own library: the independent check
    np.testing.assert_array_equal(own, counts)
    with open_record(p, "1", "0", dut_scale=Scale("lsb", 1000.0), reference_scale=Scale("lsb", 1000.0)) as rec:
        assert rec.fs_hz == 4000.0 and rec.n_samples == 64
        blk = next(rec.blocks(64, ["dut", "reference"]))
    np.testing.assert_array_equal(blk["dut"], counts[:, 1] / 1000.0)
    np.testing.assert_array_equal(blk["reference"], counts[:, 0] / 1000.0)


def test_truncated_wav_data_chunk_is_refused(tmp_path: Path, counts: np.ndarray) -> None:
    whole = _riff([_fmt(2, 4000, 16), _chunk(b"data", counts.tobytes())] + _EXTRA[1:2])
    p = tmp_path / "cut.wav"
    p.write_bytes(whole[: 44 + 100])  # the data chunk says 256 bytes, 100 follow
    with pytest.raises(ValueError, match="cut.wav: WAV data chunk is truncated: the header says 256 bytes"):
        open_record(p, "0", dut_scale=Scale("lsb", 1.0))
    # a file cut after its samples (a LIST lost) still holds every sample: read
    q = tmp_path / "tail.wav"
    q.write_bytes(whole[:-10])
    with open_record(q, "0", dut_scale=Scale("lsb", 1.0)) as rec:
        assert rec.n_samples == 64


def _read_counts(p: Path, n: int) -> np.ndarray:
    with open_record(p, "0", dut_scale=Scale("lsb", 1.0)) as rec:
        assert rec.n_samples == n
        return next(rec.blocks(n, ["dut"]))["dut"]


def test_wav_sample_formats_are_counts_at_their_bit_depth(tmp_path: Path) -> None:
    """8-bit unsigned (offset 128), 24-bit packed, 27 valid bits in 32-bit words
    (WAVE_FORMAT_EXTENSIBLE), big-endian RIFX, RF64: the integers written come back as counts,
    and agree with soundfile's normalised floats times 2^(bits-1)."""
    import soundfile as sf

    rng = np.random.default_rng(7)
    c8 = rng.integers(-128, 128, 50)
    p8 = tmp_path / "u8.wav"
    p8.write_bytes(_riff([_fmt(1, 1000, 8), _chunk(b"data", (c8 + 128).astype(np.uint8).tobytes())]))
    np.testing.assert_array_equal(_read_counts(p8, 50), c8)
    np.testing.assert_array_equal(sf.read(p8)[0] * 128, c8)

    c24 = rng.integers(-(2**23), 2**23, 50)
    raw = b"".join(int(v).to_bytes(3, "little", signed=True) for v in c24)
    p24 = tmp_path / "s24.wav"
    p24.write_bytes(_riff([_fmt(1, 1000, 24), _chunk(b"data", raw)]))
    np.testing.assert_array_equal(_read_counts(p24, 50), c24)
    np.testing.assert_array_equal(sf.read(p24)[0] * 2**23, c24)

    c27 = rng.integers(-(2**26), 2**26, 50)
    guid = struct.pack("<IHH", 1, 0, 0x10) + b"\x80\x00\x00\xaa\x00\x38\x9b\x71"
    fmt_ext = _chunk(b"fmt ", struct.pack("<HHIIHHHHI", 0xFFFE, 1, 1000, 4000, 4, 32, 22, 27, 0x4) + guid)
    p27 = tmp_path / "s27in32.wav"
    p27.write_bytes(_riff([fmt_ext, _chunk(b"data", (c27 << 5).astype("<i4").tobytes())]))
    np.testing.assert_array_equal(_read_counts(p27, 50), c27 << 5)  # the 32-bit word: left-justified
    np.testing.assert_array_equal(sf.read(p27)[0] * 2**31, c27 << 5)

    c16 = rng.integers(-(2**15), 2**15, 50)
    px = tmp_path / "rifx.wav"
    px.write_bytes(_riff([_fmt(1, 1000, 16, big=True), _chunk(b"data", c16.astype(">i2").tobytes(), big=True)], big=True))
    np.testing.assert_array_equal(_read_counts(px, 50), c16)

    p64 = tmp_path / "rf64.wav"
    sf.write(p64, c16.astype(np.int16), 1000, format="RF64", subtype="PCM_16")
    assert p64.read_bytes()[:4] == b"RF64"
    np.testing.assert_array_equal(_read_counts(p64, 50), c16)
    f64 = rng.standard_normal(50)
    pf = tmp_path / "f64.wav"
    sf.write(pf, f64, 1000, subtype="DOUBLE")
    with open_record(pf, "0") as rec:
        np.testing.assert_array_equal(next(rec.blocks(50, ["dut"]))["dut"], f64)


def _vrelab(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vrelab", *args], capture_output=True, text=True, timeout=60)


def test_integer_samples_without_a_unit_are_refused_as_counts(tmp_path: Path, counts: np.ndarray) -> None:
    p = tmp_path / "pcm.wav"
    p.write_bytes(_riff([_fmt(2, 4000, 16), _chunk(b"data", counts.tobytes())]))
    with pytest.raises(ValueError, match="DUT channel '1' holds integer samples with no unit: they are ADC counts, "
                                         "not g; give --dut-units lsb --dut-sensitivity"):
        open_record(p, "1", "0", reference_scale=Scale("lsb", 1.0))
    r = _vrelab("analyze", str(p), "--dut", "1", "--reference", "0", "--reference-units", "lsb",
                "--reference-sensitivity", "100")
    assert r.returncode == 2 and "--dut-units lsb --dut-sensitivity" in r.stderr and "Traceback" not in r.stderr


# ----------------------------------------------------------------------------- jittered stamps


def test_ide_stamps_jittering_a_sample_and_drifting_give_the_fitted_rate(tmp_path: Path) -> None:
    ref, dut = _signals(8)
    p = tmp_path / "jit.ide"
    # 1024 Hz: 32 ticks of the 32768 Hz clock a sample; 1 sample of jitter peak to peak (more
    # and a block may start before the last ends: idelib then reads a clock rollover), 6 samples
    # of drift
    write_ide(p, {"ref": ref, "dut": dut}, 1024.0, jitter=15.0, drift=6.0, seed=3)
    with open_record(p, "8.1", "8.0") as rec:
        # 6 samples late at the end, quadratically: the line through the stamps has a slope
        # between 1024 (no drift) and 1024·N/(N+6) (all of it)
        assert 1024.0 * N / (N + 6.5) < rec.fs_hz < 1024.0 * 1.0005
        assert any("fitted to the recorder's block time stamps" in n for n in rec.meta["reader_notes"])
        assert any("scatter up to" in n for n in rec.meta["reader_notes"])
    g = tmp_path / "gap.ide"
    write_ide(g, {"ref": ref, "dut": dut}, 1024.0, jitter=15.0, gap_after=6, seed=3)  # block 6 lost
    with pytest.raises(ValueError, match=r"gap.ide: IDE channel '[^']+': not evenly sampled: \+25\d samples between "
                                         r"1.2\d* s and 1.7\d* s \(sample 1500\).*a gap in the recording"):
        open_record(g, "8.1", "8.0")


def test_ide_block_stamps_a_few_samples_off_at_each_block_give_the_fitted_rate(tmp_path: Path) -> None:
    """An enDAQ gyro's stamps (endaq-python's test4.IDE, issue 19): the first block's start stamp
    14 samples early, each later block about 2 samples later than the one before ends: no step
    of more than a few samples between a block's last sample and the next one's first, a drift
    of ~10 samples about one line: read at the rate of the line through idelib's own per-sample
    stamps, within the tilt their scatter allows (as tests/test_thirdparty_corpus.py judges it);
    a lost block among such stamps is still a gap, refused saying where."""
    import idelib

    ref, dut = _signals(10)
    p = tmp_path / "gyro.ide"
    write_ide(p, {"ref": ref, "dut": dut}, 1024.0, early_first=14.0, boundary=1.9)
    doc = idelib.importFile(str(p), quiet=True)
    t = np.asarray(doc.channels[8].subchannels[1].getSession().arraySlice(0, N)[0], dtype=np.float64) * 1e-6
    doc.close()
    k = np.arange(N, dtype=np.float64)
    slope, icept = np.polyfit(k, t, 1)
    scatter = float(np.max(np.abs(t - (slope * k + icept))))
    assert 5.0 < scatter / slope < 25.0  # the drift is the point of the test
    with open_record(p, "8.1", "8.0") as rec:
        assert rec.fs_hz == pytest.approx(1.0 / slope, rel=2.0 * scatter / (t[-1] - t[0]))
    g = tmp_path / "gap.ide"
    write_ide(g, {"ref": ref, "dut": dut}, 1024.0, early_first=14.0, boundary=1.9, gap_after=6)
    with pytest.raises(ValueError, match=r"not evenly sampled: \+25\d samples .*\(sample 1500\).*a gap"):
        open_record(g, "8.1", "8.0")


def test_mdf_ns_jitter_on_1ms_steps_is_accepted_and_fs_overrides(tmp_path: Path) -> None:
    from asammdf import MDF, Signal

    ref, dut = _signals(9)
    rng = np.random.default_rng(4)
    t = np.arange(N) / FS + rng.uniform(-50e-9, 50e-9, N)  # a logger's ns on 1 ms steps
    mdf = MDF(version="4.10")
    mdf.append([Signal(ref, t, name="ref", unit="g"), Signal(dut, t, name="dut", unit="g")])
    p = tmp_path / "jit.mf4"
    mdf.save(str(p), overwrite=True)
    with open_record(p, "dut", "ref") as rec:
        assert rec.fs_hz == pytest.approx(FS, rel=1e-6)
        assert any("scatter up to" in n and "constant rate" in n for n in rec.meta["reader_notes"])
    t2 = np.arange(N) / FS
    t2[1500:] += 5e-3  # five records lost
    mdf = MDF(version="4.10")
    mdf.append([Signal(ref, t2, name="ref"), Signal(dut, t2, name="dut")])
    q = tmp_path / "gap.mf4"
    mdf.save(str(q), overwrite=True)
    with pytest.raises(ValueError, match=r"gap.mf4: group 0: not evenly sampled: \+5 samples .*\(sample 1500\)"):
        open_record(q, "dut", "ref")
    with open_record(q, "dut", "ref", fs_hz=1000.0) as rec:  # the user's rate overrides the stamps
        assert rec.fs_hz == 1000.0 and any("--fs 1000 Hz used" in n for n in rec.meta["reader_notes"])


# ----------------------------------------------------------------------------- several rates, rounded rates


def test_tdms_several_rates_only_the_chosen_share_one_and_unit_string(tmp_path: Path) -> None:
    from nptdms import ChannelObject, TdmsWriter

    ref, dut = _signals(10)
    p = tmp_path / "rates.tdms"
    with TdmsWriter(p) as w:
        w.write_segment([
            ChannelObject("g", "ref", ref, properties={"wf_increment": 1 / FS, "unit_string": "g"}),
            ChannelObject("g", "dut", dut * G0, properties={"wf_increment": 1 / FS, "unit_string": "m/s^2"}),
            ChannelObject("g", "temp", np.full(30, 21.5), properties={"wf_increment": 0.1, "unit_string": "°C"}),
        ])
    with open_record(p, "dut", "ref") as rec:
        assert rec.fs_hz == FS
        blk = next(rec.blocks(N, ["dut"]))
        assert any("unit 'm/s^2' from the file, converted to g" in n for n in rec.meta["reader_notes"])
    np.testing.assert_allclose(blk["dut"], dut, rtol=1e-12)  # m/s² -> g
    with pytest.raises(ValueError, match="rates.tdms: channels 'g/temp' .* have different sample rates"):
        open_record(p, "temp", "ref")
    with pytest.raises(ValueError, match=r"DUT channel 'g/temp' is in '°C' \(the file says\), not an acceleration"):
        open_record(p, "temp", fs_hz=10.0)


def test_lvm_rounded_delta_x_several_rates_and_y_unit_label(tmp_path: Path) -> None:
    ref, dut = _signals(11)
    p = tmp_path / "r.lvm"
    write_lvm(p, ref, dut * G0, delta_x=(1 / FS, 1 / FS))
    text = p.read_text().replace("Delta_X\t0.001\t0.001\t", "Delta_X\t0.000977\t0.000977\t0.01\t")
    text = text.replace("X_Dimension\tTime", "Y_Unit_Label\tg\tm/s^2\t\nX_Dimension\tTime", 1)
    p.write_text(text)
    with open_record(p, "dut", "ref") as rec:
        assert rec.fs_hz == 1024.0  # 0.000977 s is 1/1024 s written with 3 digits (1/0.000977 = 1023.54)
        notes = rec.meta["reader_notes"]
        assert any("Delta_X 0.000977 s is the rounded inverse of 1024 Hz" in n for n in notes)
        blk = next(rec.blocks(N, ["dut"]))
    np.testing.assert_allclose(blk["dut"], dut, rtol=1e-9)
    # a third channel at another rate (a 100 Hz temperature beside two 1 kHz accelerometers):
    # the two read share one, and that is all a record needs
    q = tmp_path / "three.lvm"
    write_lvm(q, ref, dut)
    lines = q.read_text().splitlines()
    head_end = lines.index("X_Value\tref\tdut\tComment")
    lines = [ln.replace("Delta_X\t0.001\t0.001\t", "Delta_X\t0.001\t0.001\t0.01\t") for ln in lines[:head_end]] + [
        "X_Value\tref\tdut\tslow\tComment"] + [ln + "\t21.5" for ln in lines[head_end + 1:]]
    q.write_text("\n".join(lines) + "\n")
    with open_record(q, "dut", "ref") as rec:
        assert rec.fs_hz == FS
        np.testing.assert_allclose(next(rec.blocks(N, ["dut"]))["dut"], dut, rtol=1e-11)
    with pytest.raises(ValueError, match=r"three.lvm: channels 'slow' \(100 Hz\) and 'ref' \(1000 Hz\) have different"):
        open_record(q, "slow", "ref")


def test_uff_rate_written_rounded_and_ordinate_units(tmp_path: Path) -> None:
    import pyuff

    ref, dut = _signals(12)
    p = tmp_path / "r.uff"
    sets = []
    for name, x, unit, node in [("ref", ref, "g", 1), ("dut", dut * G0, "m/s^2", 2), ("dut2", dut, "g", 2)]:
        d = pyuff.prepare_58(
            binary=0, id1=name, func_type=1, rsp_node=node, rsp_dir=3, ref_node=0, ref_dir=0, ord_data_type=2,
            abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1 / 51200, abscissa_spec_data_type=17,
            ordinate_spec_data_type=12, orddenom_spec_data_type=0, z_axis_spec_data_type=0,
            data=x, x=np.arange(N) / 51200, return_full_dict=True)
        fill = {"id2": "NONE", "id3": "NONE", "id4": "NONE", "id5": "NONE", "func_id": 1, "ver_num": 0,
                "load_case_id": 0, "rsp_ent_name": name, "ref_ent_name": "NONE", "z_axis_value": 0.0,
                "abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": unit, "orddenom_axis_units_lab": "NONE",
                "z_axis_axis_units_lab": "NONE"}
        sets.append({k: (fill.get(k, 0) if v is None else v) for k, v in d.items()})
    pyuff.UFF(str(p)).write_sets(sets, mode="add")
    assert "1.95313e-05" in p.read_text().lower()  # E13.5: 1/51200 s rounded (1/it = 51199.9 Hz)
    with open_record(p, "dut", "ref") as rec:
        assert rec.fs_hz == 51200.0
        blk = next(rec.blocks(N, ["dut"]))
    np.testing.assert_allclose(blk["dut"], dut, rtol=1e-5)  # m/s² -> g (E13.5 values: 6 digits)
    with pytest.raises(ValueError, match=r"DUT channel '2:\+Z' is ambiguous in r.uff: it names 'dut', 'dut2'"):
        open_record(p, "2:+Z", "ref")


# ----------------------------------------------------------------------------- units, time headers, names


def test_units_the_file_states_meet_the_users(tmp_path: Path) -> None:
    ref, dut = _signals(13)
    p = tmp_path / "phyphox.csv"
    t = np.arange(N) / FS
    rows = "\n".join(f"{a:.9g},{b:.12g},{c:.12g}" for a, b, c in zip(t, dut * G0, ref * G0))
    p.write_text('"Time (s)","Acceleration x (m/s^2)","Acceleration y (m/s^2)"\n' + rows + "\n")
    with open_record(p, "Acceleration x (m/s^2)", "Acceleration y (m/s^2)") as rec:
        assert rec.fs_hz == pytest.approx(FS, rel=1e-9) and rec.meta["fs_from"] == "time column 'Time (s)'"
        blk = next(rec.blocks(N, ["dut", "reference"]))
    np.testing.assert_allclose(blk["dut"], dut, rtol=1e-9)
    with pytest.raises(ValueError, match=r"is in 'm/s\^2' \(the file says\), but --dut-units says 'g'.*--accept-file-units"):
        open_record(p, "Acceleration x (m/s^2)", dut_scale=Scale("g"))
    with open_record(p, "Acceleration x (m/s^2)", dut_scale=Scale("g"), accept_file_units=True) as rec:
        np.testing.assert_allclose(next(rec.blocks(N, ["dut"]))["dut"], dut * G0, rtol=1e-9)
    with open_record(p, "Acceleration x (m/s^2)", dut_scale=Scale("m/s2")) as rec:  # agrees with the file
        np.testing.assert_allclose(next(rec.blocks(N, ["dut"]))["dut"], dut, rtol=1e-9)
    v = tmp_path / "volts.csv"
    v.write_text("time_s,acc [mV],p [hPa]\n" + "\n".join(f"{a:.9g},{b * 10:.12g},1013" for a, b in zip(t, dut)))
    with pytest.raises(ValueError, match=r"'acc \[mV\]' is in 'mV' \(the file says\): give the sensitivity, "
                                         r"--dut-units mv --dut-sensitivity S"):
        open_record(v, "acc [mV]")
    with open_record(v, "acc [mV]", dut_scale=Scale("mv", 10.0)) as rec:
        np.testing.assert_allclose(next(rec.blocks(N, ["dut"]))["dut"], dut, rtol=1e-9)
    with pytest.raises(ValueError, match=r"reference channel 'p \[hPa\]' is in 'hPa' .*not an acceleration"):
        open_record(v, "acc [mV]", "p [hPa]", dut_scale=Scale("mv", 10.0))
    r = _vrelab("analyze", str(p), "--dut", "Acceleration x (m/s^2)", "--dut-units", "g")
    assert r.returncode == 2 and "--accept-file-units" in r.stderr


def _write_ide_two_x(path: Path, fs: float, n: int) -> None:
    """An IDE file with an accelerometer (channel 8: X, Y) and a quaternion (channel 65: X, W),
    as enDAQ recorders name them: 'X' is two sub-channels."""
    import ebmlite

    schema = ebmlite.loadSchema("mide_ide.xml")
    chans = {8: ("Acceleration", ["X", "Y"], "g"), 65: ("Quaternion", ["X", "W"], "q")}
    props = {"RecordingProperties": {"ChannelList": {"Channel": [
        {"ChannelID": cid, "ChannelName": cname, "ChannelFormat": "<ff", "SubChannel": [
            {"SubChannelID": i, "SubChannelName": s, "SubChannelAxisName": s, "SubChannelLabel": cname,
             "SubChannelUnits": unit} for i, s in enumerate(subs)]}
        for cid, (cname, subs, unit) in chans.items()]}}}
    x = np.random.default_rng(2).standard_normal((n, 2)).astype("<f4")
    tick = 32768 / fs
    blocks = [{"ChannelDataBlock": {"ChannelIDRef": cid, "StartTimeCodeAbs": int(round(i * tick)),
                                    "EndTimeCodeAbs": int(round((i + 99) * tick)),
                                    "ChannelDataPayload": x[i:i + 100].tobytes()}}
              for i in range(0, n, 100) for cid in chans]
    path.write_bytes(schema.encodes([props] + blocks, headers=True))


def test_a_name_several_channels_answer_to_is_ambiguous(tmp_path: Path) -> None:
    p = tmp_path / "two_x.ide"
    _write_ide_two_x(p, 1024.0, 1000)
    with pytest.raises(ValueError, match=r"DUT channel 'X' is ambiguous in two_x.ide: it names 'Acceleration/X', "
                                         r"'Quaternion/X'"):
        open_record(p, "X")
    with open_record(p, "Acceleration/X", "Acceleration/Y") as rec:
        assert rec.fs_hz == pytest.approx(1024.0, rel=1e-3)
    with pytest.raises(ValueError, match=r"'Quaternion/X' is in 'q' \(the file says\), not an acceleration"):
        open_record(p, "Quaternion/X")


def test_missing_reader_library_names_its_install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    mdf.append([Signal(np.zeros(10), np.arange(10) / FS, name="a")])
    p = tmp_path / "x.mf4"
    mdf.save(str(p), overwrite=True)
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "asammdf" else real(name, *a))
    with pytest.raises(ValueError, match=r"x.mf4: reading MDF needs asammdf: pip install 'vrelab\[formats\]'"):
        open_record(p, "a")


def test_channels_lists_names_rates_units_and_notes(tmp_path: Path) -> None:
    from nptdms import ChannelObject, TdmsWriter

    p = tmp_path / "mixed.tdms"
    with TdmsWriter(p) as w:
        w.write_segment([
            ChannelObject("g", "acc", np.zeros(2000), properties={"wf_increment": 1 / 51200, "unit_string": "m/s^2"}),
            ChannelObject("g", "counts", np.zeros(2000, np.int32), properties={"wf_increment": 1 / 51200}),
            ChannelObject("g", "temp", np.zeros(20), properties={"wf_increment": 0.5, "unit_string": "degC"}),
        ])
    r = _vrelab("channels", str(p), "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["format"] == "tdms" and d["file"] == str(p)
    by = {c["name"]: c for c in d["channels"]}
    assert set(by) == {"g/acc", "g/counts", "g/temp"}
    assert by["g/acc"] == {"name": "g/acc", "rate_hz": 51200.0, "n_samples": 2000, "duration_s": 2000 / 51200,
                           "unit": "m/s^2", "unit_source": "file", "notes": [], "data": {"kind": "file", "files": []}}
    assert by["g/temp"]["rate_hz"] == 2.0 and by["g/temp"]["duration_s"] == 10.0 and by["g/temp"]["unit"] == "degC"
    assert by["g/counts"]["unit"] is None and any("ADC counts" in n for n in by["g/counts"]["notes"])
    text = _vrelab("channels", str(p))
    assert text.returncode == 0 and "g/acc" in text.stdout and "51200" in text.stdout
    miss = _vrelab("analyze", str(p), "--dut", "nope")
    assert miss.returncode == 2 and "vrelab channels mixed.tdms" in miss.stderr
