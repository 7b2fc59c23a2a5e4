"""Readers fed mutated files (truncated, bit-flipped, wrong extension), each reduced by the CLI
under a memory cap: every case ends in exit 2 with one line on stderr, or a clean result.

Issue "never a confident wrong number": a WAV whose header claimed 4.29 GHz once ran 1 min 46 s
and asked for 23.5 GB before failing. The cases run in one child process (one interpreter start)
under ``RLIMIT_AS``, each with an alarm, so a case that sizes memory from a corrupt header or
hangs fails the test instead of the machine.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from test_analysis_readers import FS, write_all

# Address-space cap of the child [bytes]: numpy, scipy, h5py and pyarrow loaded take ~1 GiB of
# address space; a reader that sizes an allocation from a corrupt header asks for far more.
MEMORY_CAP = 3 << 30
# Seconds one case may take: the files hold 16 s at 500 Hz; any honest path takes well under 5 s.
CASE_SECONDS = 30

DRIVER = textwrap.dedent(
    """
    import contextlib, io, json, resource, signal, sys
    resource.setrlimit(resource.RLIMIT_AS, ({cap}, {cap}))
    from vrelab.cli import main

    class Hang(Exception):
        pass

    def alarm(*_):
        raise Hang()

    signal.signal(signal.SIGALRM, alarm)
    out = []
    for case in json.load(open(sys.argv[1])):
        err, std = io.StringIO(), io.StringIO()
        signal.alarm({seconds})
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
                code = main(case["argv"])
        except Hang:
            code = "hang"
        except BaseException as exc:  # the test reports what escaped the CLI
            code = f"escaped {{type(exc).__name__}}: {{exc}}"
        finally:
            signal.alarm(0)
        out.append({{"name": case["name"], "code": code, "stderr": err.getvalue(), "stdout": std.getvalue()}})
    json.dump(out, open(sys.argv[2], "w"))
    """
)


def _mutations(path: Path, rng: np.random.Generator, tmp: Path) -> list[tuple[str, Path]]:
    data = path.read_bytes()
    cases: list[tuple[str, Path]] = []

    def put(tag: str, blob: bytes, suffix: str | None = None) -> None:
        p = tmp / f"{path.stem}.{tag}{suffix or path.suffix}"
        p.write_bytes(blob)
        cases.append((f"{path.name}:{tag}", p))

    put("half", data[: len(data) // 2])
    put("head100", data[:100])
    put("empty", b"")
    for k in range(3):  # bit flips in the header region, where sizes and rates live
        blob = bytearray(data)
        for pos in rng.integers(0, min(len(blob), 512), size=4):
            blob[pos] ^= 1 << int(rng.integers(0, 8))
        put(f"flip{k}", bytes(blob))
    for other in (".csv", ".wav", ".h5", ".tdms", ".npy", ".mat"):
        if other != path.suffix:
            put(f"as{other[1:]}", data, other)
            break
    return cases


def _header_claiming(path: Path, fs_hz: int, tmp: Path) -> Path:
    """A float WAV whose header claims ``fs_hz`` (and the byte rate to match)."""
    blob = bytearray(path.read_bytes())
    i = blob.find(b"fmt ")
    blob[i + 12 : i + 16] = int(fs_hz).to_bytes(4, "little")
    p = tmp / f"rate{fs_hz}.wav"
    p.write_bytes(bytes(blob))
    return p


@pytest.fixture(scope="module")
def fuzz_results(tmp_path_factory):
    from scipy.io import wavfile

    from test_analysis_helpers import make_record

    tmp = tmp_path_factory.mktemp("fuzz")
    truth = make_record(21, t_off_s=3.0, t_on_s=4.0)
    ref = np.asarray(truth.record.data["reference"])
    dut = np.asarray(truth.record.data["dut"])
    files = write_all(tmp, ref, dut)
    rng = np.random.default_rng(20261124)
    cases = []
    for path_s, kw in files.items():
        path = Path(path_s)
        argv = ["analyze", "PATH", "--dut", kw["dut"], "--json"]
        if kw.get("reference") is not None:
            argv += ["--reference", kw["reference"]]
        if kw.get("fs_hz") is not None:
            argv += ["--fs", str(kw["fs_hz"])]
        for name, p in [(path.name + ":as-written", path), *_mutations(path, rng, tmp)]:
            cases.append({"name": name, "argv": [str(p) if a == "PATH" else a for a in argv]})
    wav = tmp / "claims.wav"
    wavfile.write(wav, int(FS), np.column_stack([ref, dut]).astype(np.float32))
    for rate in (4_294_967_295, 2_000_000_000, 1):
        p = _header_claiming(wav, rate, tmp)
        cases.append({"name": f"wav header says {rate} Hz", "argv": ["analyze", str(p), "--dut", "1", "--reference", "0", "--json"]})
    spec = tmp / "cases.json"
    spec.write_text(json.dumps(cases))
    driver = tmp / "driver.py"
    driver.write_text(DRIVER.format(cap=MEMORY_CAP, seconds=CASE_SECONDS))
    result = tmp / "result.json"
    proc = subprocess.run([sys.executable, str(driver), str(spec), str(result)], capture_output=True, text=True,
                          timeout=CASE_SECONDS * len(cases) + 60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    shutil.rmtree(tmp / "__pycache__", ignore_errors=True)
    return json.loads(result.read_text())


def test_every_mutated_file_gives_one_line_and_exit_2_or_a_result(fuzz_results):
    bad = []
    for r in fuzz_results:
        if r["code"] == 0:
            try:
                json.loads(r["stdout"])
            except ValueError:
                bad.append((r["name"], "exit 0 without a JSON result"))
            continue
        lines = [ln for ln in r["stderr"].splitlines() if ln.strip()]
        if r["code"] != 2 or len(lines) != 1 or "Traceback" in r["stderr"]:
            bad.append((r["name"], r["code"], r["stderr"][-300:]))
    assert not bad, "\n".join(map(str, bad))
    assert len(fuzz_results) > 60


def test_unmutated_files_all_reduce(fuzz_results):
    """The control: every as-written file gives a result, so the refusals above are the mutations'."""
    ok = [r for r in fuzz_results if r["name"].endswith(":as-written")]
    assert len(ok) >= 8 and all(r["code"] == 0 for r in ok), [(r["name"], r["stderr"]) for r in ok if r["code"]]


def test_implausible_header_rates_are_refused_naming_the_rate(fuzz_results):
    """SPEC 4.2: a sample rate the file's size makes implausible is refused before memory is
    sized from it (4.29 GHz; 2 GHz); 1 Hz is plausible for the file but too slow for the band."""
    by_name = {r["name"]: r for r in fuzz_results}
    for rate in (4_294_967_295, 2_000_000_000):
        r = by_name[f"wav header says {rate} Hz"]
        assert r["code"] == 2 and "rate" in r["stderr"], r


def test_a_corrupt_header_rate_can_be_overridden_with_fs(tmp_path):
    """The refusal says 'give the true rate with --fs': that must then work, and say so."""
    from scipy.io import wavfile

    from vrelab.analysis.readers import open_record

    x = np.random.default_rng(5).standard_normal((4000, 2)).astype(np.float32)
    wav = tmp_path / "ok.wav"
    wavfile.write(wav, 500, x)
    bad = _header_claiming(wav, 4_294_967_295, tmp_path)
    with pytest.raises(ValueError, match="implausible"):
        open_record(bad, dut="1", reference="0")
    rec = open_record(bad, dut="1", reference="0", fs_hz=500.0)
    assert rec.fs_hz == 500.0 and any("implausible" in n for n in rec.meta["reader_notes"])
    with pytest.raises(ValueError, match="disagrees"):
        open_record(wav, dut="1", reference="0", fs_hz=400.0)  # a plausible header still wins over a slip
