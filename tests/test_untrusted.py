"""Untrusted files (issue 23): a format library never evaluates a file's expression for vrelab.

Each crafted file is first shown to be what it claims, through the format library alone: asammdf
runs an MDF formula conversion as code (sympy importable, as wherever torch is), idelib evaluates
an IDE channel's sample-rate text. Then vrelab refuses it with one line naming the channel and
the expression, in ``analyze`` and in ``campaign`` validation, and the code never runs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vrelab.analysis.readers import open_record
from vrelab.cli import main

FS = 1000.0
N = 2000
# a file's formula that leaves a marker file in the working directory when evaluated (no
# lowercase x: asammdf upper-cases it, the variable of an MDF formula being X)
PAYLOAD = "__import__('os').system('touch ran')"


def _mdf(path: Path, version: str, formula: str) -> None:
    """Two channels with asammdf's own writer; ``dut``'s conversion is ``formula``."""
    from asammdf import MDF, Signal

    t = np.arange(N) / FS
    x = 0.5 * np.sin(2 * np.pi * 80 * t)
    mdf = MDF(version=version)
    mdf.append([Signal(x, t, name="ref"), Signal(x, t, name="dut", conversion={"formula": formula})])
    mdf.save(path, overwrite=True)


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


@pytest.mark.timeout(15)
@pytest.mark.parametrize("version, variable", [("4.10", "X"), ("3.30", "X1")])
def test_mdf_formula_conversion_is_refused_not_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str], version: str,
                                                   variable: str) -> None:
    import sympy  # noqa: F401  (importable: asammdf's fallback that runs the formula's code)
    from asammdf import MDF

    monkeypatch.chdir(tmp_path)
    p = tmp_path / f"evil{'.mf4' if version.startswith('4') else '.mdf'}"
    _mdf(p, version, f"{variable} + 0*{PAYLOAD}")
    marker = tmp_path / "ran"
    # the crafted file is what it claims: asammdf alone runs its formula
    mdf = MDF(str(p))
    try:
        mdf.get("dut")
    except Exception:  # sympy's lambdify may fail after the payload ran (the payload is the point)
        pass
    mdf.close()
    assert marker.exists()
    marker.unlink()

    with pytest.raises(ValueError, match=r"channel 'dut' has an algebraic conversion \(formula .*system.*refused"):
        open_record(p, "dut", "ref")
    assert main(["analyze", str(p), "--dut", "dut", "--reference", "ref"]) == 2
    err = _one_line(capsys)
    assert p.name in err and "'dut'" in err and "algebraic conversion" in err
    # a campaign refuses it at validation, before any run
    m = tmp_path / "campaign.toml"
    m.write_text(f'name = "t"\n[[run]]\nfile = "{p.name}"\nreference = "ref"\ndut = {{a = "dut"}}\nstatic_g = 1\n')
    assert main(["campaign", str(m), "--out", str(tmp_path / "out"), "--json"]) == 2
    err = _one_line(capsys)
    assert "run 1" in err and "'dut'" in err and "algebraic conversion" in err
    assert not (tmp_path / "out").exists()
    assert not marker.exists()


def test_mdf_formula_inside_a_value_to_text_table_is_refused(tmp_path: Path) -> None:
    """A value-to-text table (cc_type 7) may hold conversions as entries, asammdf converting
    through them: a formula there is refused as well, naming the channel."""
    from asammdf import MDF, Signal

    t = np.arange(N) / FS
    conv = {"val_0": 1, "text_0": b"one", "val_1": 2, "text_1": {"formula": f"X + 0*{PAYLOAD}"}, "default_addr": b"?"}
    p = tmp_path / "status.mf4"
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.arange(N) % 3, t, name="status", conversion=conv), Signal(np.zeros(N), t, name="ref"),
                Signal(np.zeros(N), t, name="dut")])
    mdf.save(p, overwrite=True)
    with pytest.raises(ValueError, match=r"status.mf4: channel 'status' has an algebraic conversion"):
        open_record(p, "dut", "ref")


def test_mdf_linear_and_rational_conversions_still_apply(tmp_path: Path) -> None:
    """The refusal is of formulas only: arithmetic conversions are applied, as the file's
    writer meant them (values checked against the conversion's definition, ASAM MDF 4.1
    cc_type 1: phys = a·raw + b; cc_type 2: (P1·x² + P2·x + P3)/(P4·x² + P5·x + P6))."""
    from asammdf import MDF, Signal

    t = np.arange(N) / FS
    raw = np.arange(N, dtype=np.int32) - N // 2
    p = tmp_path / "ok.mf4"
    mdf = MDF(version="4.10")
    mdf.append([Signal(raw, t, name="ref", conversion={"a": 0.25, "b": -3.0}),
                Signal(raw, t, name="dut", conversion={"P1": 0.0, "P2": 2.0, "P3": 1.0, "P4": 0.0, "P5": 0.0,
                                                         "P6": 4.0})])
    mdf.save(p, overwrite=True)
    with open_record(p, "dut", "ref") as rec:
        blk = next(rec.blocks(N, ["dut", "reference"]))
    np.testing.assert_allclose(blk["reference"], 0.25 * raw - 3.0, rtol=1e-12)
    np.testing.assert_allclose(blk["dut"], (2.0 * raw + 1.0) / 4.0, rtol=1e-12)


def _ide(path: Path, **channel: str) -> None:
    """An IDE file (ebmlite against idelib's schema, as tests/test_readers_lab.py writes one)
    whose channel 8 carries ``channel``'s extra fields (``SampleRate``, ``TimeCodeScale``)."""
    import ebmlite

    schema = ebmlite.loadSchema("mide_ide.xml")
    t = np.arange(N) / 1024.0
    data = np.column_stack([np.sin(2 * np.pi * 80 * t), 1.0 + 0 * t]).astype("<f4")
    subs = [{"SubChannelID": i, "SubChannelName": nm} for i, nm in enumerate(("ref", "dut"))]
    ch = {"ChannelID": 8, "ChannelName": "Accel", "ChannelFormat": "<ff", "SubChannel": subs, **channel}
    tick = 32768 / 1024.0
    blocks = [{"ChannelDataBlock": {"ChannelIDRef": 8, "StartTimeCodeAbs": int(round(i * tick)),
                                    "EndTimeCodeAbs": int(round((min(i + 250, N) - 1) * tick)),
                                    "ChannelDataPayload": data[i:i + 250].tobytes()}} for i in range(0, N, 250)]
    path.write_bytes(schema.encodes([{"RecordingProperties": {"ChannelList": {"Channel": [ch]}}}] + blocks,
                                    headers=True))


def test_idelib_evaluates_the_sample_rate_text(tmp_path: Path) -> None:
    """Why the field is checked: idelib gives ``2*512`` to Python's eval (1024 back), so
    ``9**9**9**9`` (a number of 3.7e8 digits' exponent) would never return."""
    import idelib

    p = tmp_path / "expr.ide"
    _ide(p, SampleRate="2*512")
    doc = idelib.importFile(str(p), quiet=True)
    assert doc.channels[8].sampleRate == 1024
    doc.close()


@pytest.mark.timeout(10)
@pytest.mark.parametrize("field, text", [("SampleRate", "9**9**9**9"), ("TimeCodeScale", "9**9**9**9"),
                                         ("SampleRate", "(lambda: 1)()"), ("SampleRate", "1" * 5000)])
def test_ide_expression_fields_are_refused_at_once(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  field: str, text: str) -> None:
    p = tmp_path / "bomb.ide"
    _ide(p, **{field: text})
    what = {"SampleRate": "sample-rate", "TimeCodeScale": "time-code-scale"}[field]
    with pytest.raises(ValueError, match=rf"bomb.ide: IDE channel 8 \(Accel\): its {what} field .* refused"):
        open_record(p, "8.1", "8.0")
    assert main(["analyze", str(p), "--dut", "8.1", "--reference", "8.0"]) == 2
    assert what in _one_line(capsys)
    m = tmp_path / "campaign.toml"
    m.write_text(f'name = "t"\n[[run]]\nfile = "{p.name}"\nreference = "8.0"\ndut = {{a = "8.1"}}\nstatic_g = 1\n')
    assert main(["campaign", str(m), "--out", str(tmp_path / "out"), "--json"]) == 2
    err = _one_line(capsys)
    assert "run 1" in err and what in err


@pytest.mark.parametrize("field, text", [("SampleRate", "1024"), ("SampleRate", " 32768/32 "),
                                         ("TimeCodeScale", "1/32768"), ("SampleRate", "1024.0")])
def test_ide_numbers_and_ratios_as_the_schema_writes_them_are_read(tmp_path: Path, field: str, text: str) -> None:
    """mide_ide.xml: SampleRate and TimeCodeScale are "an integer, decimal or ratio"."""
    p = tmp_path / "ok.ide"
    _ide(p, **{field: text})
    with open_record(p, "8.1", "8.0") as rec:
        assert rec.fs_hz == pytest.approx(1024.0, rel=1e-3)


def test_no_eval_in_vrelab_itself() -> None:
    """vrelab's own code holds no eval/exec (a string from a file or manifest is never code): every
    call of ``eval``/``exec``/``compile`` by name, or of a ``sympify``/``lambdify``/``parse_expr``
    attribute, found in the syntax tree (a text search would flag numpy's ``hermeval(``)."""
    import ast

    src = Path(__file__).resolve().parents[1] / "src" / "vrelab"
    named, attributes = {"eval", "exec", "compile"}, {"sympify", "lambdify", "parse_expr"}
    found = []
    for f in src.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text(), filename=str(f))):
            if not isinstance(node, ast.Call):
                continue
            fn = node.func
            if (isinstance(fn, ast.Name) and fn.id in named | attributes) or (
                    isinstance(fn, ast.Attribute) and fn.attr in attributes):
                found.append(f"{f.relative_to(src)}:{node.lineno}")
    assert found == [], found
