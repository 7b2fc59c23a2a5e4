"""Readers: the same recording written as CSV, NPY, NPZ, HDF5, TDMS, WAV (float32, RF64),
MAT v7.3 and MAT v5 reduces to the same VRE per level; scaling from LSB and mV; lazy reads."""

from __future__ import annotations

import struct
from pathlib import Path

import h5py
import numpy as np
import pytest

from test_analysis_helpers import make_record
from vrelab._io import sha256_file
from vrelab.analysis import ReductionOptions, reduce_record
from vrelab.analysis.readers import Scale, detect_format, open_record
from vrelab.record import write_record_hdf5

FS = 500.0


@pytest.fixture(scope="module")
def truth():
    return make_record(21, t_off_s=6.0, t_on_s=10.0)


@pytest.fixture(scope="module")
def reference_levels(truth):
    levels, _ = reduce_record(truth.record)
    assert len(levels) == 3
    return levels


def _write_rf64(path: Path, data: np.ndarray, fs: int) -> None:
    """RF64 (EBU Tech 3306) IEEE-float WAV written by hand: 'RF64' + ds64 chunk + data size -1."""
    data = np.ascontiguousarray(data, dtype="<f4")
    n, ch = data.shape
    payload = data.tobytes()
    fmt = struct.pack("<HHIIHH", 3, ch, fs, fs * ch * 4, ch * 4, 32)
    ds64 = struct.pack("<QQQI", 0, len(payload), n, 0)
    body = b"WAVE" + b"ds64" + struct.pack("<I", len(ds64)) + ds64 + b"fmt " + struct.pack("<I", len(fmt)) + fmt
    body += b"data" + struct.pack("<I", 0xFFFFFFFF) + payload
    riff_size = len(body)
    ds64 = struct.pack("<QQQI", riff_size, len(payload), n, 0)
    body = body.replace(b"ds64" + struct.pack("<I", len(ds64)) + struct.pack("<QQQI", 0, len(payload), n, 0),
                        b"ds64" + struct.pack("<I", len(ds64)) + ds64, 1)  # fmt: skip
    path.write_bytes(b"RF64" + struct.pack("<I", 0xFFFFFFFF) + body)


def _write_mat73(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """MATLAB v7.3 layout: 512-byte user block with the text header, HDF5 after it; a column
    vector of length N is stored transposed, as an HDF5 dataset of shape (1, N)."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for k, v in arrays.items():
            d = f.create_dataset(k, data=np.atleast_2d(np.asarray(v, dtype=np.float64)))
            d.attrs["MATLAB_class"] = np.bytes_("double")
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sat Nov 21 12:00:00 2026 HDF5 schema 1.00 ."
    head = head.ljust(116, b" ") + b"\x00" * 8 + struct.pack("<H", 0x0200) + b"IM"
    with open(path, "r+b") as fh:
        fh.write(head.ljust(512, b"\x00"))


def write_all(tmp: Path, ref: np.ndarray, dut: np.ndarray) -> dict[str, dict]:
    """Every format: path -> open_record keyword arguments."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    from nptdms import ChannelObject, GroupObject, TdmsWriter
    from scipy.io import savemat, wavfile

    out: dict[str, dict] = {}
    t = np.arange(len(ref)) / FS
    p = tmp / "rec.csv"
    pacsv.write_csv(pa.table({"time": t, "reference": ref, "dut": dut}), p)
    out[str(p)] = dict(dut="dut", reference="reference")
    p = tmp / "noheader.txt"
    np.savetxt(p, np.column_stack([ref, dut]), delimiter="\t", fmt="%.17g")
    out[str(p)] = dict(dut="ch1", reference="0", fs_hz=FS)
    p = tmp / "rec.npy"
    np.save(p, np.column_stack([ref, dut]))
    out[str(p)] = dict(dut="1", reference="0", fs_hz=FS)
    p = tmp / "rec_struct.npy"
    arr = np.zeros(len(ref), dtype=[("reference", "f8"), ("dut", "f8")])
    arr["reference"], arr["dut"] = ref, dut
    np.save(p, arr)
    out[str(p)] = dict(dut="dut", reference="reference", fs_hz=FS)
    p = tmp / "rec.npz"
    np.savez(p, reference=ref, dut=dut, fs_hz=np.float64(FS))
    out[str(p)] = dict(dut="dut", reference="reference")
    p = tmp / "rec_c.npz"
    np.savez_compressed(p, reference=ref, dut=dut)
    out[str(p)] = dict(dut="dut", reference="reference", fs_hz=FS)
    p = tmp / "rec.h5"
    write_record_hdf5(p, FS, [{"reference": ref, "dut": dut}])
    out[str(p)] = dict(dut="dut", reference="reference")
    p = tmp / "nested.hdf5"
    with h5py.File(p, "w") as f:
        g = f.create_group("acq/run1")
        g.attrs["sample_rate"] = FS
        g.create_dataset("ref", data=ref, chunks=(4096,))
        g.create_dataset("adxl", data=dut, chunks=(4096,))
    out[str(p)] = dict(dut="acq/run1/adxl", reference="ref")
    p = tmp / "rec.tdms"
    with TdmsWriter(p) as w:
        props = {"wf_increment": 1.0 / FS, "wf_start_offset": 0.0}
        # two segments, as a DAQ writes in chunks
        h = len(ref) // 2
        for a, b in ((0, h), (h, len(ref))):
            w.write_segment([
                GroupObject("shaker"),
                ChannelObject("shaker", "reference", ref[a:b], properties=props),
                ChannelObject("shaker", "dut", dut[a:b], properties=props),
            ])  # fmt: skip
    out[str(p)] = dict(dut="shaker/dut", reference="reference")
    p = tmp / "rec.wav"
    wavfile.write(p, int(FS), np.column_stack([ref, dut]).astype(np.float32))
    out[str(p)] = dict(dut="1", reference="ch0")
    p = tmp / "rf64.wav"
    _write_rf64(p, np.column_stack([ref, dut]), int(FS))
    out[str(p)] = dict(dut="1", reference="0")
    p = tmp / "rec73.mat"
    _write_mat73(p, {"reference": ref, "dut": dut, "fs": np.array([[FS]])})
    out[str(p)] = dict(dut="dut", reference="reference")
    p = tmp / "rec5.mat"
    savemat(p, {"reference": ref[:, None], "dut": dut[:, None], "fs": FS})
    out[str(p)] = dict(dut="dut", reference="reference")
    return out


def test_every_format_gives_the_same_levels(tmp_path, truth, reference_levels):
    d = truth.record.data
    files = write_all(tmp_path, d["reference"], d["dut"])
    expected_fmt = {".csv": "csv", ".txt": "csv", ".npy": "npy", ".npz": "npz", ".h5": "hdf5", ".hdf5": "hdf5",
                    ".tdms": "tdms", ".wav": "wav", ".mat": "mat"}  # fmt: skip
    for path, kw in files.items():
        before = sha256_file(path)
        with open_record(path, **kw) as rec:
            assert rec.fs_hz == pytest.approx(FS, rel=1e-9), path
            assert rec.n_samples == len(d["dut"])
            assert detect_format(Path(path)) == expected_fmt[Path(path).suffix]
            levels, _ = reduce_record(rec, options=ReductionOptions(block_size=4096))
        assert len(levels) == 3, path
        float32 = path.endswith(".wav")
        for a, b in zip(levels, reference_levels):
            tol = 0.05 * b.vre.u if float32 else 1e-9 * max(abs(b.vre.value), 1e-6)
            assert a.vre.value == pytest.approx(b.vre.value, abs=tol), path
            assert a.rms_g == pytest.approx(b.rms_g, rel=1e-5 if float32 else 1e-10), path
        assert sha256_file(path) == before  # read-only


def test_reader_notes_say_what_is_not_memory_mapped(tmp_path, truth):
    d = truth.record.data
    files = write_all(tmp_path, d["reference"], d["dut"])
    notes = {}
    for p, kw in files.items():
        with open_record(p, **kw) as rec:
            notes[Path(p).name] = rec.meta["reader_notes"]
    assert any("compressed NPZ" in n for n in notes["rec_c.npz"])
    assert any("MAT v5" in n for n in notes["rec5.mat"])
    mapped = {k: [n for n in v if "the file states no unit" not in n] for k, v in notes.items()}  # (issue 30's unit note)
    assert mapped["rec.npz"] == [] and mapped["rec.h5"] == [] and mapped["rf64.wav"] == []


def test_mat_reads_the_class_matlab_states_v4_and_v5(tmp_path):
    """A double of whole numbers, which MATLAB (and scipy's savemat) stores compactly as uint8, is
    read as the double it is; an int16 variable stays counts; a complex double is no channel (not
    its real part); MAT v4 (no text header, MATLAB's "MAT-File Format" v4 matrix header) reads the
    same way. The samples are compared with what was saved, not with vrelab's reading."""
    from scipy.io import savemat

    whole = np.arange(40.0) % 5  # whole numbers: stored as miUINT8 (MAT-File Format, v5 "compression")
    p5 = tmp_path / "v5.mat"
    savemat(p5, {"whole": whole, "counts": np.arange(40, dtype=np.int16), "z": whole * 1j, "fs": 100.0})
    with open_record(p5, "whole") as rec:
        got = np.concatenate([b["dut"] for b in rec.blocks(16, ["dut"])])
    assert got.dtype == np.float64 and np.array_equal(got, whole) and rec.fs_hz == 100.0
    with pytest.raises(ValueError, match="counts"):
        open_record(p5, "counts")
    with pytest.raises(ValueError, match="'z' not found"):
        open_record(p5, "z")
    p4 = tmp_path / "v4.mat"
    savemat(p4, {"whole": whole, "fs": 100.0}, format="4")
    assert detect_format(p4) == "mat"
    with open_record(p4, "whole") as rec:
        assert rec.source.fmt == "mat-v4" and np.array_equal(np.concatenate([b["dut"] for b in rec.blocks(16, ["dut"])]), whole)
    bad = tmp_path / "bad.mat"
    bad.write_bytes(b"\x00" * 64)  # no text header and no valid v4 matrix header
    with pytest.raises(ValueError, match="wrong header bytes"):
        open_record(bad, "whole", fs_hz=100.0)


def test_uncompressed_npz_and_npy_are_memory_mapped(tmp_path):
    x = np.arange(10.0)
    np.savez(tmp_path / "a.npz", dut=x, reference=2 * x)
    np.save(tmp_path / "a.npy", np.column_stack([x, 2 * x]))
    rec = open_record(tmp_path / "a.npz", "dut", "reference", fs_hz=10)
    assert isinstance(rec.source.specs["dut"][0], np.memmap)
    assert np.array_equal(next(rec.blocks(4, ["reference"], 3, 9))["reference"], 2 * x[3:7])
    rec2 = open_record(tmp_path / "a.npy", "1", fs_hz=10)
    assert isinstance(rec2.source.specs["1"][0], np.memmap)


def test_embedded_schedule_and_meta_from_vrelab_hdf5(tmp_path, truth):
    d = truth.record.data
    p = tmp_path / "sim.h5"
    write_record_hdf5(p, FS, [d], schedule=truth.schedule, meta={"conditions": {"sensor": "adxl355"}})
    rec = open_record(p, "dut", "reference")
    assert rec.schedule == truth.schedule
    assert rec.meta["conditions"]["sensor"] == "adxl355"
    levels, warnings = reduce_record(rec)
    assert any("embedded" in w for w in warnings)
    assert len(levels) == 3


def test_scaling_from_lsb_and_mv(tmp_path, truth, reference_levels):
    """DUT as 20-bit-like counts (256000 LSB/g), reference in mV at 10 mV/g."""
    d = truth.record.data
    counts = np.round(d["dut"] * 256000).astype(np.int32)
    mv = d["reference"] * 10.0
    np.savez(tmp_path / "raw.npz", dut=counts, ref=mv)
    rec = open_record(
        tmp_path / "raw.npz", "dut", "ref", fs_hz=FS,
        dut_scale=Scale.parse("lsb", 256000), reference_scale=Scale.parse("mV", 10),
    )  # fmt: skip
    levels, _ = reduce_record(rec)
    for a, b in zip(levels, reference_levels):
        # quantisation to 3.9 µg adds far less than u
        assert a.vre.value == pytest.approx(b.vre.value, abs=0.05 * b.vre.u)
        assert a.rms_g == pytest.approx(b.rms_g, rel=1e-9)


def test_scale_parse_errors():
    with pytest.raises(ValueError, match="sensitivity"):
        Scale.parse("lsb", None, "--dut")
    with pytest.raises(ValueError, match="units"):
        Scale.parse("furlongs", 3.0, "--dut")
    assert Scale.parse("m/s2", None).to_g(np.array([9.80665]))[0] == pytest.approx(1.0)


def test_time_column_gives_rate_and_fs_conflict_is_error(tmp_path):
    t = 1000.0 + np.arange(2000) / 250.0
    p = tmp_path / "t.csv"
    np.savetxt(p, np.column_stack([t, np.zeros(2000), np.ones(2000)]), delimiter=",", header="t,reference,dut", comments="")
    assert open_record(p, "dut").fs_hz == pytest.approx(250.0, rel=1e-9)
    with pytest.raises(ValueError, match="disagrees"):
        open_record(p, "dut", fs_hz=500.0)


def test_tdms_channel_name_must_be_unique(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    p = tmp_path / "two.tdms"
    with TdmsWriter(p) as w:
        w.write_segment([ChannelObject("a", "x", np.zeros(10)), ChannelObject("b", "x", np.zeros(10))])
    with pytest.raises(ValueError, match="ambiguous"):
        open_record(p, "x", fs_hz=10)
    assert open_record(p, "b/x", fs_hz=10).n_samples == 10


def test_blocks_are_bounded_by_block_size(tmp_path, truth):
    d = truth.record.data
    files = write_all(tmp_path, d["reference"], d["dut"])
    for path, kw in files.items():
        with open_record(path, **kw) as rec:
            blocks = list(rec.blocks(1000, ["dut", "reference"], 10, 5010))
        sizes = [len(b["dut"]) for b in blocks]
        assert max(sizes) <= 1000 and sum(sizes) == 5000, path
        tol = 1e-6 if path.endswith(".wav") else 0.0  # float32 WAV
        assert np.allclose(np.concatenate([b["dut"] for b in blocks]), d["dut"][10:5010], rtol=tol, atol=0), path


def test_csv_quirks_bom_comments_semicolons(tmp_path):
    """A lab export: UTF-8 BOM, comment lines, ';' separator, a time column named by --time."""
    t = np.arange(1000) / 200.0
    body = "\n".join(f"{a:.6f};{b:.6f};{c:.6f}" for a, b, c in zip(t, np.sin(t), np.cos(t)))
    p = tmp_path / "lab.csv"
    p.write_bytes(("\ufeff# exported by DAQ\n# 2026-11-21\ntime [s];acc_ref;acc_dut\n" + body + "\n").encode())
    rec = open_record(p, "acc_dut", "acc_ref", time_channel="time [s]")
    assert rec.fs_hz == pytest.approx(200.0, rel=1e-6)
    assert rec.n_samples == 1000
    x = np.concatenate([b["dut"] for b in rec.blocks(300, ["dut"])])
    assert np.allclose(x, np.round(np.cos(t), 6))


def test_npz_structured_member_and_channel_listing(tmp_path):
    arr = np.zeros(100, dtype=[("reference", "f8"), ("dut", "f8")])
    arr["dut"] = 1.0
    np.savez(tmp_path / "s.npz", data=arr, fs_hz=np.float64(50.0))
    rec = open_record(tmp_path / "s.npz", "dut", "reference")
    assert rec.channels == ("dut", "reference") and rec.fs_hz == 50.0
    assert rec.mapping == {"dut": "data/dut", "reference": "data/reference"}
    assert np.all(next(rec.blocks(10, ["dut"]))["dut"] == 1.0)
    with pytest.raises(ValueError, match=r"channels: data/reference, data/dut"):
        open_record(tmp_path / "s.npz", "nope")


def test_a_new_format_is_one_registered_class(tmp_path, truth, reference_levels):
    """The reader registry (xarray's backend shape): a format declares its magic bytes,
    extensions and how it reads; open_record finds it by content, whatever the file's name."""
    from vrelab.analysis.readers import READERS, Source, register

    class Toy(Source):
        """'TOY1' + float64 fs + uint32 n + two little-endian float64 columns (ref, dut)."""

        fmt = "toy"
        extensions = (".toy",)

        @classmethod
        def can_open(cls, head: bytes) -> bool:
            return head.startswith(b"TOY1")

        def __init__(self, path):
            super().__init__(path)
            raw = path.read_bytes()
            self.fs_hz, n = struct.unpack("<dI", raw[4:16])
            self.cols = np.frombuffer(raw, "<f8", offset=16).reshape(2, n)
            self.lengths = {"ref": n, "dut": n}

        def read(self, name, start, stop):
            return self.cols[0 if name == "ref" else 1, start:stop]

    ref = truth.record.data["reference"]
    dut = truth.record.data["dut"]
    path = tmp_path / "run.bin"  # an extension no reader claims: the magic bytes decide
    path.write_bytes(b"TOY1" + struct.pack("<dI", FS, len(ref)) + np.concatenate([ref, dut]).astype("<f8").tobytes())
    register(Toy)
    try:
        assert detect_format(path) == "toy"
        rec = open_record(path, dut="dut", reference="ref")
        levels, _ = reduce_record(rec)
    finally:
        READERS.remove(Toy)
    assert [lv.vre.value for lv in levels] == pytest.approx([lv.vre.value for lv in reference_levels], rel=1e-9)
    with pytest.raises(ValueError, match="unknown file format"):
        detect_format(path)
