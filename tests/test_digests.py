"""The provenance digest's cache (vrelab._digests, issue 29): a second analysis of an unchanged
file does not hash it again, and a changed file never carries an old digest.

Reference digests come from hashlib.sha256 over the file's bytes read here, not from the code
under test."""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import pytest

from vrelab import _digests
from vrelab.cli import main

sys.path.insert(0, str(Path(__file__).parent))
from test_analysis_helpers import make_record  # noqa: E402


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """The cache in a temporary folder, the racy delay at zero (a file written by the test is
    otherwise too fresh to be remembered), and a count of the files actually hashed."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("VRELAB_NO_DIGEST_CACHE", raising=False)
    monkeypatch.setattr(_digests, "RACY_S", 0.0)
    hashed = {"n": 0}
    real = _digests.sha256_file

    def counting(path: str | Path) -> str:
        hashed["n"] += 1
        return real(path)

    monkeypatch.setattr(_digests, "sha256_file", counting)
    return hashed


def _rewrite_same_size_same_mtime(path: Path) -> None:
    """Change one byte in place, keep the size and put the modification time back (as a copy
    tool preserving times would): only the status-change time tells."""
    st = path.stat()
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    with open(path, "r+b") as fh:
        fh.write(data)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert path.stat().st_mtime_ns == st.st_mtime_ns and path.stat().st_size == st.st_size


def test_an_unchanged_file_is_hashed_once(tmp_path: Path, cache: dict[str, int]) -> None:
    f = tmp_path / "a.bin"
    f.write_bytes(os.urandom(100_000))
    assert _digests.file_sha256(f) == _sha256(f)
    assert _digests.file_sha256(f) == _sha256(f)
    assert cache["n"] == 1


def test_a_changed_file_gets_its_new_digest(tmp_path: Path, cache: dict[str, int]) -> None:
    f = tmp_path / "a.bin"
    f.write_bytes(os.urandom(100_000))
    old = _digests.file_sha256(f)
    _rewrite_same_size_same_mtime(f)
    new = _digests.file_sha256(f)
    assert new == _sha256(f) != old
    assert cache["n"] == 2


def test_a_fresh_file_is_not_remembered(tmp_path: Path, cache: dict[str, int],
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Git's racy rule: a file written within RACY_S of its hashing is hashed every time."""
    monkeypatch.setattr(_digests, "RACY_S", 3600.0)
    f = tmp_path / "a.bin"
    f.write_bytes(b"x" * 1000)
    _digests.file_sha256(f)
    _digests.file_sha256(f)
    assert cache["n"] == 2


def test_the_cache_can_be_turned_off_and_can_fail(tmp_path: Path, cache: dict[str, int],
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    f = tmp_path / "a.bin"
    f.write_bytes(b"y" * 1000)
    monkeypatch.setenv("VRELAB_NO_DIGEST_CACHE", "1")
    assert _digests.file_sha256(f) == _digests.file_sha256(f) == _sha256(f)
    assert cache["n"] == 2
    monkeypatch.delenv("VRELAB_NO_DIGEST_CACHE")
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))  # the cache cannot be made: no error
    assert _digests.file_sha256(f) == _sha256(f)


def test_analyze_again_after_a_change_states_the_new_digest(tmp_path: Path, cache: dict[str, int],
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """Modify a record, re-analyse it: the result's input_sha256 is the new file's."""
    from vrelab.record import write_record_hdf5

    rec = make_record(seed=11).record
    path = tmp_path / "run.h5"
    write_record_hdf5(path, rec.fs_hz, [dict(rec.data)])
    argv = ["analyze", str(path), "--dut", "dut", "--reference", "reference", "--method", "random", "--json"]

    def digest() -> str:
        assert main(argv) == 0
        return str(json.loads(capsys.readouterr().out)["provenance"]["input_sha256"])

    first = digest()
    assert first == _sha256(path) and digest() == first
    assert cache["n"] == 1  # the second analysis took it from the cache
    _rewrite_same_size_same_mtime(path)
    assert digest() == _sha256(path) != first
