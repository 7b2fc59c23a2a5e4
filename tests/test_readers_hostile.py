"""Hostile and loggers' files (issue 30): what a file other software wrote may point at, print or
hide, each made with the format's own writer (h5py, npTDMS) and shown to be what it claims
through that library alone before vrelab reads it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vrelab.analysis.readers import list_channels, open_record
from vrelab.cli import main

FS = 1000.0
N = 4000


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


def _sine(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    return 0.5 * np.sin(2 * np.pi * 80 * t) + 1e-3 * rng.standard_normal(N)


# ----------------------------------------------------------------------------- data in other files


def _external(tmp_path: Path, target: Path, dtype: str) -> Path:
    """An HDF5 file whose ``dut`` keeps its samples in ``target``'s raw bytes (h5py's
    ``external=``: HDF5 external storage), beside an ordinary ``ref``."""
    import h5py

    n = target.stat().st_size // np.dtype(dtype).itemsize
    p = tmp_path / "ext.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs_hz"] = FS
        f.create_dataset("ref", data=_sine()[:n] if n <= N else np.resize(_sine(), n))
        f.create_dataset("dut", shape=(n,), dtype=dtype, external=[(str(target), 0, n * np.dtype(dtype).itemsize)])
    return p


@pytest.mark.parametrize("target", ["secret", "elsewhere"])
def test_hdf5_external_storage_is_refused_by_name(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  target: str) -> None:
    import h5py

    if target == "secret":
        t = tmp_path / "secret.bin"
        _sine(1).tofile(t)
        dtype = "<f8"
    else:
        # another local file by its absolute path, outside the HDF5 file's folder (as /etc/passwd
        # would be): numpy's own __init__.py, which every machine running this test has
        t = Path(np.__file__).resolve()
        dtype = "u1"
    p = _external(tmp_path, t, dtype)
    # the file is what it claims: h5py alone reads the other file's bytes as the dataset
    with h5py.File(p, "r") as f:
        assert f["dut"][:].tobytes() == t.read_bytes()[: f["dut"].size * np.dtype(dtype).itemsize]
    listing = {c["name"]: c for c in list_channels(p)["channels"]}
    assert listing["dut"]["data"] == {"kind": "external", "files": [str(t)]}
    assert listing["ref"]["data"] == {"kind": "file", "files": []}
    assert any("outside this file" in n and str(t) in n for n in listing["dut"]["notes"])
    with pytest.raises(ValueError, match=r"'dut' keeps its samples outside this file \(external storage in '.*"
                                         + t.name):
        open_record(p, "dut", "ref", dut_scale=1.0 if dtype == "u1" else None)
    # the reference's role is refused the same way
    with pytest.raises(ValueError, match="reference channel 'dut' keeps its samples outside"):
        open_record(p, "ref", "dut")
    assert main(["analyze", str(p), "--dut", "dut", "--reference", "ref"]) == 2
    err = _one_line(capsys)
    assert p.name in err and "'dut'" in err and str(t) in err


def test_hdf5_virtual_dataset_mapping_another_file_is_refused(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    import h5py

    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.create_dataset("x", data=_sine(1))
    p = tmp_path / "vds.h5"
    layout = h5py.VirtualLayout(shape=(N,), dtype="f8")
    layout[:] = h5py.VirtualSource(str(other), "x", shape=(N,))
    inner = h5py.VirtualLayout(shape=(N,), dtype="f8")
    with h5py.File(p, "w") as f:
        f.attrs["fs_hz"] = FS
        f.create_dataset("ref", data=_sine())
        f.create_virtual_dataset("dut", layout)
        inner[:] = h5py.VirtualSource(".", "ref", shape=(N,))  # a virtual view of this file's own data
        f.create_virtual_dataset("view", inner)
    with h5py.File(p, "r") as f:  # h5py alone reads the other file's samples through the mapping
        np.testing.assert_array_equal(f["dut"][:], _sine(1))
    listing = {c["name"]: c for c in list_channels(p)["channels"]}
    assert listing["dut"]["data"] == {"kind": "virtual", "files": [str(other)]}
    assert listing["view"]["data"] == {"kind": "virtual", "files": ["."]}
    with pytest.raises(ValueError, match=r"'dut' keeps its samples outside this file \(a virtual dataset mapping"):
        open_record(p, "dut", "ref")
    # a virtual dataset over this file's own data reads as the data
    with open_record(p, "view", "ref") as rec:
        np.testing.assert_array_equal(next(rec.blocks(N, ["dut"]))["dut"], _sine())
    m = tmp_path / "campaign.toml"
    m.write_text(f'name = "t"\n[[run]]\nfile = "{p.name}"\nreference = "ref"\ndut = {{a = "dut"}}\nstatic_g = 1\n')
    assert main(["campaign", str(m), "--out", str(tmp_path / "out"), "--json"]) != 0
    assert "keeps its samples outside this file" in capsys.readouterr().err


# ----------------------------------------------------------------------------- names that are escapes

TITLE = "\x1b]0;pwned\x07"  # xterm's "set window title", ended by BEL
CLEAR = "\x1b[2J\x1b[H"  # clear the screen, cursor home


@pytest.mark.parametrize("fmt", ["hdf5", "csv"])
def test_control_characters_in_channel_names_are_printed_escaped(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                  fmt: str) -> None:
    bad = f"acc{TITLE}x{CLEAR}"
    if fmt == "hdf5":
        import h5py

        p = tmp_path / "names.h5"
        with h5py.File(p, "w") as f:
            f.attrs["fs_hz"] = FS
            f.create_dataset(bad, data=_sine())
            f[bad].attrs["unit"] = f"g{CLEAR}"
        with h5py.File(p, "r") as f:  # the name is stored as written
            assert bad in f
    else:
        p = tmp_path / "names.csv"
        p.write_text(f"time,{bad}\n" + "".join(f"{i / FS},{v}\n" for i, v in enumerate(_sine())))
    assert bad in [c["name"] for c in list_channels(p)["channels"]]  # the API gives the name as it is
    assert main(["channels", str(p)]) == 0
    out, err = capsys.readouterr()
    assert "\x1b" not in out + err and "\x07" not in out + err
    assert "acc\\x1b]0;pwned\\x07x\\x1b[2J" in out
    # a refusal naming the channel is escaped too (its repr already is; the whole line is)
    assert main(["analyze", str(p), "--dut", bad, "--reference", "nope"]) == 2
    out, err = capsys.readouterr()
    assert "\x1b" not in out + err and "\x07" not in out + err and "nope" in err
    # JSON escapes them its own way (\u001b) and stays valid JSON with the name intact
    import json

    assert main(["channels", str(p), "--json"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and bad in [c["name"] for c in json.loads(out)["channels"]]


# ----------------------------------------------------------------------------- many channels, big chunks


def test_a_file_of_many_datasets_is_listed_first_n_and_a_count(tmp_path: Path) -> None:
    """1050 datasets (h5py) and 1050 TDMS channels (npTDMS): the first MAX_CHANNELS listed, the
    rest counted, and one beyond them still read by its exact name."""
    import h5py
    from nptdms import ChannelObject, TdmsFile, TdmsWriter

    from vrelab.analysis.readers._base import MAX_CHANNELS

    n = MAX_CHANNELS + 50
    x = _sine()
    h5 = tmp_path / "many.h5"
    with h5py.File(h5, "w") as f:
        f.attrs["fs_hz"] = FS
        for i in range(n):
            f.create_dataset(f"c{i:05d}", data=x if i in (3, n - 1) else np.zeros(2))
    td = tmp_path / "many.tdms"
    with TdmsWriter(td) as w:
        w.write_segment([ChannelObject("g", f"c{i:05d}", x if i in (3, n - 1) else np.zeros(2),
                                       properties={"wf_increment": 1 / FS}) for i in range(n)])
    with h5py.File(h5, "r") as f:
        assert len(f) == n
    assert len(TdmsFile.read_metadata(td)["g"].channels()) == n
    for p, last in ((h5, f"c{n - 1:05d}"), (td, f"g/c{n - 1:05d}")):
        listing = list_channels(p)
        assert len(listing["channels"]) == MAX_CHANNELS and listing["unlisted"] == 50
        assert any(f"{n}" in note and "50 more not listed" in note for note in listing["notes"]), listing["notes"]
        with open_record(p, last, last.replace(f"{n - 1:05d}", "00003")) as rec:
            blk = next(rec.blocks(N, ["dut", "reference"]))
            np.testing.assert_array_equal(blk["dut"], x)
            assert rec.fs_hz == FS
        with pytest.raises(ValueError, match="50 more not listed"):
            open_record(p, "nope")


def test_a_chunk_that_would_inflate_beyond_the_budget_is_refused_before_reading(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A dataset of one gzip chunk of 2^21 float64 (16.8 MB inflated, a few kB on disk) under a
    budget of 0.064 GB (a chunk may take 1/64 of it: 1 MB): refused naming both sizes; the
    same samples in 65536-sample chunks (0.5 MB) read. The default budget (4 GB: 62.5 MB a
    chunk) refuses the 1 GiB chunk of the issue's 2 MB file the same way."""
    import h5py

    monkeypatch.setenv("VRELAB_MEMORY_BUDGET_GB", "0.064")
    m = 1 << 21
    p = tmp_path / "bomb.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs_hz"] = FS
        f.create_dataset("dut", shape=(m,), dtype="f8", chunks=(m,), compression="gzip")
        f["dut"][:N] = _sine()
        f.create_dataset("ok", data=np.resize(_sine(), m), chunks=(1 << 16,), compression="gzip")
    assert p.stat().st_size < 2e6
    with h5py.File(p, "r") as f:  # what the file asks: one chunk of 2^21 samples, 16.8 MB inflated
        assert f["dut"].chunks == (m,) and f["dut"].compression == "gzip"
    listing = {c["name"]: c for c in list_channels(p)["channels"]}
    assert any("16.8 MB" in n and "1 MB" in n for n in listing["dut"]["notes"]), listing["dut"]["notes"]
    with pytest.raises(ValueError, match=r"'dut' is stored in compressed chunks of 16.8 MB each.*beyond the 1 MB"):
        open_record(p, "dut", "ok")
    with open_record(p, "ok") as rec:
        assert rec.n_samples == m


# ----------------------------------------------------------------------------- units by channel

LVM_READ = Path(__file__).parent / "data" / "thirdparty" / "lvm_read"


def test_lvm_with_an_x_column_per_channel_matches_units_to_their_channels() -> None:
    """lvm_read's ``multi_time_column.lvm`` (LabVIEW, ``X_Columns Multi``): columns ``X_Value,
    Voltage, X_Value, Acceleration``; its ``Y_Unit_Label`` row reads ``Volts<tab><tab>g``, each
    cell over its column (the blank over the second X_Value), as the file's own text shows."""
    p = LVM_READ / "multi_time_column.lvm"
    lines = p.read_text().splitlines()
    cols = next(x for x in lines if x.startswith("X_Value")).split("\t")
    units = next(x for x in lines if x.startswith("Y_Unit_Label")).split("\t")
    stated = {c: units[i] for i, c in enumerate(cols) if c in ("Voltage", "Acceleration")}  # same position
    assert stated == {"Voltage": "Volts", "Acceleration": "g"}
    listing = {c["name"]: c for c in list_channels(p)["channels"]}
    assert {n: c["unit"] for n, c in listing.items()} == stated
    assert {c["rate_hz"] for c in listing.values()} == {51200.0}  # Delta_X 1.953125E-5 over each
    with pytest.raises(ValueError, match="'Voltage' is in 'Volts'.*give the sensitivity"):
        open_record(p, "Voltage", fs_hz=None)
    with open_record(p, "Acceleration") as rec:
        assert rec.meta["units_assumed"] == []
        np.testing.assert_array_equal(next(rec.blocks(3, ["dut"]))["dut"], [0.532608, 0.502991, 0.467541])


def _ms2_record(tmp_path: Path) -> Path:
    """A shaker record whose DUT is in m/s² (9.81 at rest in a 1 g field), in a CSV without units."""
    rng = np.random.default_rng(3)
    n = 4000
    ref = np.concatenate([np.zeros(n), rng.normal(0, 1, n), np.zeros(n)])
    dut = 9.80665 * (1 + ref) + 1e-3 * rng.standard_normal(3 * n)
    p = tmp_path / "ms2.csv"
    p.write_text("reference,dut\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(ref, dut)))
    return p


def test_a_unitless_float_channel_is_said_taken_as_g_and_an_ms2_baseline_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = _ms2_record(tmp_path)
    with open_record(p, "dut", "reference", fs_hz=4000.0) as rec:
        assert rec.meta["units_assumed"] == ["dut", "reference"]
        assert any("'dut': the file states no unit: taken as g" in n for n in rec.meta["reader_notes"])
    argv = ["analyze", str(p), "--dut", "dut", "--reference", "reference", "--fs", "4000", "--json"]
    assert main(argv) == 2
    err = _one_line(capsys)
    assert "DUT 'dut' reads +9.8" in err and "taken as g because the file states no unit" in err and "m/s2" in err
    # said so, it is read: m/s² converted, or g if the user insists it is g
    assert main(argv + ["--dut-units", "m/s2"]) == 0
    capsys.readouterr()


# ----------------------------------------------------------------------------- what a header states


def test_a_loggers_comment_header_gives_the_rate_and_the_units(tmp_path: Path) -> None:
    """A PicoQuake export as its documentation lays it out (PLab-SI/PicoQuake, docs "Acquisition
    CSV File": five comment lines, then count,a_x..g_z; a_* in g, g_* gyro in degrees per
    second): the header's 2000 Hz used and said, a_x in g from acc_range, g_x refused as a gyro."""
    x = _sine()
    p = tmp_path / "picoquake.csv"
    head = ("# PLab PicoQuake Data\n# Time: 2024-04-21 15:54:46.333682, Device: D4E9 (E6632891E36F2029)\n"
            f"# Num. samples: {N}, Duration: {N / 2000.0} s\n"
            "# Config: data_rate = 2000.0 Hz, filter = 488 Hz, acc_range = 4 g, gyro_range = 250.0 dps\n"
            "# Integrity: True, Skipped samples: 0\ncount,a_x,a_y,a_z,g_x,g_y,g_z\n")
    p.write_text(head + "".join(f"{i},{v:.6f},0.0,1.0,{100 * v:.4f},0.0,0.0\n" for i, v in enumerate(x)))
    listing = list_channels(p)
    by = {c["name"]: c for c in listing["channels"]}
    assert by["a_x"]["rate_hz"] == 2000.0 and by["a_x"]["unit"] == "g" and by["g_x"]["unit"] == "dps"
    assert any("2000 Hz from the file's comment header" in n and "data_rate = 2000.0 Hz" in n for n in listing["notes"])
    with open_record(p, "a_x") as rec:
        assert rec.fs_hz == 2000.0 and rec.meta["units_assumed"] == []
        np.testing.assert_allclose(next(rec.blocks(N, ["dut"]))["dut"], np.round(x, 6), rtol=0, atol=0)
    with pytest.raises(ValueError, match=r"'g_x' is in 'dps' .*not an acceleration"):
        open_record(p, "g_x")


def test_a_pandas_frame_in_hdf5_lists_its_column_names(tmp_path: Path) -> None:
    """``DataFrame.to_hdf(path, key="run1")`` (fixed format) as pandas/io/pytables.py lays it out:
    group ``run1`` with ``pandas_type = 'frame'``, ``axis0`` (column names), ``axis1`` (the
    index), ``block0_items`` and ``block0_values`` stored transposed (one column per item).
    Written with h5py here (pandas is not a test dependency)."""
    import h5py

    ax, ay = _sine(), _sine(1)
    p = tmp_path / "frame.h5"
    with h5py.File(p, "w") as f:
        g = f.create_group("run1")
        g.attrs.update({"pandas_type": b"frame", "pandas_version": b"0.15.2", "encoding": b"UTF-8",
                        "ndim": 2, "nblocks": 1})
        g.attrs["fs_hz"] = FS
        g["axis0"] = np.array([b"ax", b"ay"])
        g["axis1"] = np.arange(N)
        g["block0_items"] = np.array([b"ax", b"ay"])
        g["block0_values"] = np.column_stack([ax, ay])
        g["block0_values"].attrs["transposed"] = 1
    names = [c["name"] for c in list_channels(p)["channels"]]
    assert names == ["run1/ax", "run1/ay"]
    with open_record(p, "ax", "ay") as rec:
        blk = next(rec.blocks(N, ["dut", "reference"]))
        np.testing.assert_array_equal(blk["dut"], ax)
        np.testing.assert_array_equal(blk["reference"], ay)


# ----------------------------------------------------------------------------- reader plugins

_PLUGINS = '''
import sys

import numpy as np

from vrelab.analysis.readers import Source

print("hello from a plugin")  # at import: must not reach stdout (--json)


class Greedy(Source):
    """can_open says yes to every file."""

    fmt = "greedy"
    extensions = (".grd",)

    @classmethod
    def can_open(cls, head):
        return not head.startswith(b"BAD1")

    def __init__(self, path):
        super().__init__(path)
        self.lengths = {"dut": 10}

    def read(self, name, start, stop):
        return np.full(stop - start, 7.0)


class Bad(Source):
    """Magic 'BAD1'; channel 'c' complex, 'n' None, 'o' objects, 's' short, 'ok' real."""

    fmt = "bad"
    extensions = (".bad",)

    @classmethod
    def can_open(cls, head):
        return head.startswith(b"BAD1")

    def __init__(self, path):
        super().__init__(path)
        self.fs_hz = 1000.0
        self.lengths = {k: 4000 for k in ("c", "n", "o", "s", "ok")}

    def read(self, name, start, stop):
        t = np.arange(start, stop) / 1000.0
        x = 0.5 * np.sin(2 * np.pi * 80 * t)
        return {"c": x + 1j * x, "n": None, "o": x.astype(object), "s": x[:-1], "ok": x}[name]
'''

_PLUGIN_EPS = """
[vrelab.readers]
greedy = hostile_plugins:Greedy
bad = hostile_plugins:Bad
exits = exits_plugin:X
"""


def _plugin_site(tmp_path: Path) -> Path:
    site = tmp_path / "site"
    site.mkdir()
    (site / "hostile_plugins.py").write_text(_PLUGINS)
    (site / "exits_plugin.py").write_text("import sys\nsys.exit(0)\n")
    info = site / "hostile_plugins-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: hostile-plugins\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(_PLUGIN_EPS)
    return site


def _run(site: Path, *args: str) -> tuple[int, str, str]:
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(root / "src")]))
    r = subprocess.run([sys.executable, "-m", "vrelab", *args], capture_output=True, text=True, env=env, timeout=120)
    return r.returncode, r.stdout, r.stderr


@pytest.mark.slow
def test_hostile_plugins_cannot_take_built_in_files_exit_or_print(tmp_path: Path) -> None:
    import json

    site = _plugin_site(tmp_path)
    csv = tmp_path / "rec.csv"
    csv.write_text("time,dut\n" + "".join(f"{i / FS},{v}\n" for i, v in enumerate(_sine())))
    # built-in CSV read by the built-in reader (the plugins not even imported: nothing to wait on)
    rc, out, err = _run(site, "channels", str(csv), "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["format"] == "csv" and [c["name"] for c in d["channels"]] == ["time", "dut"]
    assert "plugin" not in err
    # a file no built-in format claims: the plugins load; --json is still exactly one object,
    # the exiting plugin is skipped in one line, the printing one's text kept off stdout
    grd = tmp_path / "rec.grd"
    grd.write_bytes(b"GRD" + bytes(100))
    rc, out, err = _run(site, "channels", str(grd), "--json")
    assert rc == 0, err
    assert json.loads(out)["format"] == "greedy" and "hello from a plugin" not in out
    lines = err.strip().splitlines()
    assert any("exits_plugin:X" in ln and "sys.exit(0)" in ln and "skipped" in ln for ln in lines), err
    assert any("printed at import" in ln and "hello from a plugin" in ln for ln in lines), err

def test_a_plugins_samples_are_held_to_a_readers_contract(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """Real, 1-D, the length asked for: complex samples, None, objects and a short read are one
    line naming the plugin and the channel (the plugin registered in this process as
    load_plugins registers an entry point's class)."""
    from vrelab.analysis.readers import _base

    ns: dict[str, object] = {}
    exec(compile(_PLUGINS.replace('print("hello from a plugin")', ""), "hostile_plugins.py", "exec"), ns)
    bad_cls = ns["Bad"]
    monkeypatch.setattr(_base, "READERS", [*_base.READERS, bad_cls])
    monkeypatch.setitem(_base.PLUGINS, bad_cls, "bad = hostile_plugins:Bad")
    bad = tmp_path / "rec.bad"
    bad.write_bytes(b"BAD1" + bytes(100))
    with open_record(bad, "ok") as rec:  # a good channel reads
        assert len(next(rec.blocks(N, ["dut"]))["dut"]) == N
    for ch, words in (("c", "complex128 samples"), ("n", "None"), ("o", "object samples"), ("s", "shape (3999,)")):
        with pytest.raises(ValueError, match=r"reader plugin bad = hostile_plugins:Bad gave .*") as exc:
            with open_record(bad, ch, "ok") as rec:
                list(rec.blocks(N, ["dut", "reference"]))
        assert words in str(exc.value) and f"channel {ch!r}" in str(exc.value)
    assert main(["analyze", str(bad), "--dut", "c", "--reference", "ok"]) == 2
    assert "complex128 samples for channel 'c'" in _one_line(capsys)


# ----------------------------------------------------------------------------- where units and data come from


def test_channels_json_says_where_each_unit_and_each_channels_data_come_from(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One HDF5 file (h5py) with a unit attribute, a float dataset without one, integer counts and
    a dataset in another file; one CSV whose header brackets state a unit."""
    import json

    import h5py

    other = tmp_path / "other.bin"
    _sine(1).tofile(other)
    p = tmp_path / "units.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs_hz"] = FS
        f.create_dataset("acc", data=_sine())
        f["acc"].attrs["unit"] = "m/s^2"
        f.create_dataset("bare", data=_sine())
        f.create_dataset("counts", data=(_sine() * 1000).astype("i4"))
        f.create_dataset("away", shape=(N,), dtype="<f8", external=[(str(other), 0, N * 8)])
    assert main(["channels", str(p), "--json"]) == 0
    by = {c["name"]: c for c in json.loads(capsys.readouterr().out)["channels"]}
    assert {n: c["unit_source"] for n, c in by.items()} == {"acc": "file", "bare": "assumed", "counts": "none",
                                                           "away": "assumed"}
    assert {n: c["data"]["kind"] for n, c in by.items()} == {"acc": "file", "bare": "file", "counts": "file",
                                                            "away": "external"}
    assert by["away"]["data"]["files"] == [str(other)]
    csv = tmp_path / "h.csv"
    csv.write_text("time,Acceleration x (m/s^2)\n" + "".join(f"{i / FS},{v}\n" for i, v in enumerate(_sine())))
    assert main(["channels", str(csv), "--json"]) == 0
    by = {c["name"]: c for c in json.loads(capsys.readouterr().out)["channels"]}
    assert by["Acceleration x (m/s^2)"]["unit_source"] == "header" and by["time"]["unit_source"] == "assumed"
    assert main(["channels", str(p)]) == 0  # the table says it too
    out = capsys.readouterr().out
    assert "g (assumed)" in out and "- (counts)" in out


def test_a_truncated_tdms_says_so_in_notes_not_in_npTDMS_log_lines(tmp_path: Path, capfd: pytest.CaptureFixture[str],
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """npTDMS's writer, two segments, the file cut 30000 bytes short: npTDMS alone logs two
    WARNING lines on stderr; vrelab keeps them as notes, and a refusal is its one line."""
    import json

    from nptdms import ChannelObject, TdmsFile, TdmsWriter

    full = tmp_path / "full.tdms"
    with TdmsWriter(full) as w:
        w.write_segment([ChannelObject("g", "a", np.arange(10000.0), properties={"wf_increment": 1 / FS})])
        w.write_segment([ChannelObject("g", "a", np.arange(10000.0))])
    p = tmp_path / "cut.tdms"
    p.write_bytes(full.read_bytes()[:-30000])
    import io

    from nptdms.log import log_manager

    # npTDMS's own console handler holds the stderr of its import: point it at a buffer to see
    # what it prints, whichever test imported it first
    printed = io.StringIO()
    monkeypatch.setattr(log_manager.console_handler, "stream", printed)
    with TdmsFile.open(p) as f:  # npTDMS alone: its own log lines
        f["g"]["a"][:]
    assert "Last segment of file has less data than expected" in printed.getvalue()
    printed.truncate(0)
    printed.seek(0)
    assert main(["channels", str(p), "--json"]) == 0
    out, err = capfd.readouterr()
    assert any("npTDMS: Last segment of file has less data than expected" in n for n in json.loads(out)["notes"])
    assert main(["analyze", str(p), "--dut", "g/a"]) == 2
    err = capfd.readouterr().err
    assert printed.getvalue() == "" and "[nptdms" not in err and len(err.strip().splitlines()) == 1, err


def test_a_400_character_run_label_makes_a_folder_the_file_system_takes(tmp_path: Path) -> None:
    """A campaign's run folder is NN-<label>: a 400-character label was a name the file system
    refuses (NAME_MAX, 255 bytes on Linux); two labels alike in their first 100 characters stay apart."""
    from vrelab.folder import channel_folder_names

    long = "Z up, 80 Hz, " + "x" * 387
    names = channel_folder_names([f"01-{long}", f"02-{long}", f"03-{long}"[:120], f"03-{long}"[:130]])
    assert len(set(names.values())) == 4
    for n in names.values():
        (tmp_path / n).mkdir()  # ENAMETOOLONG before
        assert len(n.encode()) <= 255


def test_a_python_sweep_runs_only_with_allow_python(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A sweep file of kind 'python' names a module of the environment to import and call: not
    without --allow-python (the module, which leaves a marker when imported, is never imported)."""
    import sys

    (tmp_path / "hf_sweep_mod.py").write_text("import pathlib\npathlib.Path('imported').touch()\n"
                                              "def f(params, seed):\n    return {'a': float(params['x'])}\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "python"\nfunction = "hf_sweep_mod:f"\nseed = 1\n[grid]\nx = [1, 2]\n')
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = _one_line(capsys)
    assert "hf_sweep_mod:f" in err and "--allow-python" in err
    assert not (tmp_path / "imported").exists() and "hf_sweep_mod" not in sys.modules
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o"), "--no-progress", "--allow-python"]) == 0
    assert (tmp_path / "imported").exists()
    sys.modules.pop("hf_sweep_mod", None)
