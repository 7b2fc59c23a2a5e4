"""Reader plugins: a lab adds its recorder's format as a package with an entry point in the group
``vrelab.readers``. Here a real (tiny) distribution is installed by putting its ``.dist-info``
(METADATA, entry_points.txt) and its module on the path of a fresh ``vrelab`` process, as pip
would leave them in site-packages; the CLI then reads the plugin's format, lists it in its help,
and skips the broken plugins beside it with one line each."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from test_analysis_helpers import make_record
from vrelab.analysis.readers import open_record
from vrelab.analysis.reduction import analyze

ROOT = Path(__file__).resolve().parents[1]

# The plugin's format: 'VRX1', uint32 length of a JSON header {fs_hz, channels, units}, then
# float64 samples, channels interleaved. Written only with vrelab's public reader API.
_VRX = '''
import json
import struct

import numpy as np

from vrelab.analysis.readers import Source


class VrxSource(Source):
    fmt = "vrx"
    extensions = (".vrx",)

    @classmethod
    def can_open(cls, head):
        return head.startswith(b"VRX1")

    def __init__(self, path):
        super().__init__(path)
        with open(path, "rb") as fh:
            (n,) = struct.unpack("<I", fh.read(8)[4:])
            head = json.loads(fh.read(n))
        names = head["channels"]
        self.fs_hz = float(head["fs_hz"])
        self.data = np.memmap(path, "<f8", "r", offset=8 + n).reshape(-1, len(names))
        self.index = {c: i for i, c in enumerate(names)}
        self.lengths = {c: self.data.shape[0] for c in names}
        self.units = dict(zip(names, head["units"]))

    def read(self, name, start, stop):
        return np.asarray(self.data[start:stop, self.index[name]])

    def close(self):
        self.data = None


class NeedsSdk(Source):
    """A format whose vendor library is not installed."""

    fmt = "nsd"
    extensions = (".nsd",)
    has_magic = False
    requires = "vrelab_test_no_such_sdk"
    install = "no-such-sdk>=2"


def not_a_reader():
    return None


class Grabby(Source):
    """A plugin whose magic-bytes check fails on files it does not know."""

    fmt = "grabby"
    extensions = (".grb",)

    @classmethod
    def can_open(cls, head):
        raise RuntimeError("cannot parse this header")
'''

_ENTRY_POINTS = """
[vrelab.readers]
vrx = vrx_reader:VrxSource
nsd = vrx_reader:NeedsSdk
broken = broken_reader:BrokenSource
notaclass = vrx_reader:not_a_reader
grabby = vrx_reader:Grabby
"""


def _install(site: Path) -> None:
    """The distribution 'vrx-reader' as pip leaves it: a module and its dist-info."""
    (site / "vrx_reader.py").write_text(_VRX)
    (site / "broken_reader.py").write_text("raise ImportError('the recorder SDK licence file is missing')\n")
    info = site / "vrx_reader-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: vrx-reader\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent(_ENTRY_POINTS))


def _vrelab(site: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(ROOT / "src")]))
    return subprocess.run([sys.executable, "-m", "vrelab", *args], capture_output=True, text=True, env=env, timeout=120)


def _write_vrx(path: Path, fs_hz: float, channels: dict[str, np.ndarray]) -> None:
    head = json.dumps({"fs_hz": fs_hz, "channels": list(channels), "units": ["g"] * len(channels)}).encode()
    data = np.column_stack(list(channels.values())).astype("<f8")
    path.write_bytes(b"VRX1" + len(head).to_bytes(4, "little") + head + data.tobytes())


@pytest.mark.slow
def test_a_plugin_format_is_read_listed_and_broken_plugins_are_skipped(tmp_path):
    site = tmp_path / "site"
    site.mkdir()
    _install(site)
    truth = make_record(5, t_off_s=6.0, t_on_s=10.0)
    fs = truth.record.fs_hz
    ref, dut = truth.record.data["reference"], truth.record.data["dut"]
    run = tmp_path / "shaker_run.vrx"
    _write_vrx(run, fs, {"ref": ref, "dut": dut})

    # the plugin's file, listed: its channels and rate come from the plugin's reader
    out = _vrelab(site, "channels", str(run), "--json")
    assert out.returncode == 0, out.stderr
    listing = json.loads(out.stdout)
    assert listing["format"] == "vrx"
    assert [(c["name"], c["rate_hz"], c["n_samples"], c["unit"]) for c in listing["channels"]] == [
        ("ref", fs, len(ref), "g"), ("dut", fs, len(dut), "g")]
    assert any("read by reader plugin vrx = vrx_reader:VrxSource (package vrx-reader)" in n for n in listing["notes"])
    # the broken plugins beside it: one line each on stderr, naming it and why; nothing else
    errs = out.stderr.strip().splitlines()
    assert len(errs) == 2, out.stderr
    assert "reader plugin broken = broken_reader:BrokenSource (package vrx-reader) skipped: ImportError: " \
        "the recorder SDK licence file is missing" in errs[0]
    assert "reader plugin notaclass = vrx_reader:not_a_reader (package vrx-reader) skipped: " in errs[1]
    assert "not a subclass of vrelab.analysis.readers.Source" in errs[1]

    # analyze reads it through the plugin: the same numbers as the in-memory record gives (the
    # plugin delivers the samples unchanged), and each level's VRE is the one the record was
    # made with (test_analysis_helpers.make_record's truth) within its uncertainty
    out = _vrelab(site, "analyze", str(run), "--dut", "dut", "--reference", "ref", "--method", "random", "--json")
    assert out.returncode == 0, out.stderr
    levels = json.loads(out.stdout)["levels"]
    direct = analyze(truth.record, "random").levels
    assert [lv["vre_g"] for lv in levels] == pytest.approx([lv.vre.value for lv in direct], rel=1e-12, abs=1e-15)
    assert len(levels) == len(truth.vre_g) == 3
    for lv, want in zip(levels, truth.vre_g):
        assert abs(lv["vre_g"] - want) < 4 * lv["u_vre_g"], (lv, want)

    # the help is made from the registry: every format with its extensions, the plugin's too, and
    # the install hint of a format whose library is missing
    out = _vrelab(site, "analyze", "--help")
    assert out.returncode == 0, out.stderr
    text = " ".join(out.stdout.split())
    for fmt in ("CSV (.csv .tsv .txt .dat)", "HDF5 (.h5", "TDMS (.tdms)", "WAV (.wav .wave)", "MAT (.mat)",
                "UFF (.uff .unv)", "MDF (.mf4 .mdf", "IDE (.ide", "LVM (.lvm)", "NPY (.npy)", "NPZ (.npz)",
                "VRX (.vrx; plugin vrx = vrx_reader:VrxSource (package vrx-reader))",
                "NSD (.nsd; needs vrelab_test_no_such_sdk, not installed: pip install 'no-such-sdk>=2'"):
        assert fmt in text, fmt

    # a file of the format whose library is missing: one line with the install hint, exit 2
    (tmp_path / "x.nsd").write_text("a recorder's file\n")
    out = _vrelab(site, "channels", str(tmp_path / "x.nsd"))
    assert out.returncode == 2
    assert out.stderr.strip().splitlines()[-1] == ("vrelab: error: x.nsd: reading NSD needs vrelab_test_no_such_sdk: "
                                                   "pip install 'no-such-sdk>=2'")
    # a plugin whose can_open raises on a file it is asked about is taken as not its file, said once
    assert "reader plugin grabby = vrx_reader:Grabby (package vrx-reader): can_open raised RuntimeError: cannot " \
        "parse this header (taken as not its file)" in out.stderr

    # and a built-in format is read as before, with every plugin installed
    csv = tmp_path / "run.csv"
    np.savetxt(csv, np.column_stack([np.arange(2000) / 500.0, ref[:2000], dut[:2000]]), delimiter=",",
               header="time,ref,dut", comments="")
    out = _vrelab(site, "channels", str(csv), "--json")
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["format"] == "csv"
    assert [c["rate_hz"] for c in json.loads(out.stdout)["channels"] if c["name"] == "dut"] == [pytest.approx(500.0)]


def test_without_the_plugin_the_format_is_unknown_and_names_the_built_in_ones(tmp_path):
    """The same file in this process, where no plugin is installed: refused as an unknown format,
    the message listing the registered ones."""
    run = tmp_path / "shaker_run.vrx"
    _write_vrx(run, 100.0, {"ref": np.zeros(10), "dut": np.ones(10)})
    with pytest.raises(ValueError, match=r"unknown file format \(extension '\.vrx'\); supported: HDF5, IDE, CSV, LVM"):
        open_record(run, "dut", "ref")
