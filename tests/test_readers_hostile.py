"""Hostile and loggers' files (issue 30): what a file other software wrote may point at, print or
hide, each made with the format's own writer (h5py, npTDMS) and shown to be what it claims
through that library alone before vrelab reads it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vrelab.analysis.readers import list_channels
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
