"""The whole command surface under bad input (SPEC 5): exit status 2, exactly one line on stderr,
no traceback, and nothing left half-written.

Commands are discovered from ``vrelab.cli.build_parser()``: the bad-value cases of a command are
generated only when the command exists (so each helper's command is checked as soon as it lands),
and every command that exists, known here or not, gets the generic usage cases (unknown option,
missing required argument). ``test_every_known_command_has_bad_value_cases`` fails when a command
of the SPEC contract is in the parser without its cases here.

Runs in-process through ``vrelab.cli.main`` (a subprocess per case would cost seconds each);
Python warnings are counted as stderr lines, since the real command line prints them there. Two
cases also run as real subprocesses to hold the in-process view against the real one.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from vrelab.cli import build_parser, main
from vrelab.record import Schedule, Segment, write_record_hdf5


def _commands() -> dict[str, argparse.ArgumentParser]:
    """Leaf commands as 'model clip', 'simulate', ... -> their parser."""
    found: dict[str, argparse.ArgumentParser] = {}

    def walk(parser: argparse.ArgumentParser, prefix: tuple[str, ...]) -> None:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            found[" ".join(prefix)] = parser
            return
        for name, child in subs[0].choices.items():
            walk(child, prefix + (name,))

    walk(build_parser(), ())
    return found


COMMANDS = _commands()

# Bad-value cases per command: (case id, argv after the command words, a token the one-line message
# must contain, case-insensitive: the option or the value at fault). "{d}" is a folder with the
# fixture files (see `files`). Each argv is otherwise valid, so the one bad value is the cause.
SIM = ["--sensor", "ideal", "--range", "2", "--profile", "flat:50-2000", "--seconds", "2"]
PRED = ["--sensor", "adxl355", "--profile", "flat:50-2000"]
CMP = ["--environment", "flat:50-2000", "--levels", "1"]
CASES: dict[str, list[tuple[str, list[str], str]]] = {
    "model clip": [
        ("negative-level", ["--mean", "1", "--rail", "2", "--rms", "-1"], 'rms'),
        ("nan-level", ["--mean", "1", "--rail", "2", "--rms", "nan"], 'rms'),
        ("malformed-list", ["--mean", "1", "--rail", "2", "--rms", "0.5,,1"], 'rms'),
        ("empty-range", ["--mean", "1", "--rail", "2", "--rms", "2:1:0.5"], 'rms'),
        ("nan-mean", ["--mean", "nan", "--rail", "2", "--rms", "1"], 'mean'),
        ("negative-rail", ["--mean", "1", "--rail", "-2", "--rms", "1"], 'rail'),
        ("unknown-kind", ["--mean", "1", "--rail", "2", "--rms", "1", "--kind", "chopped"], 'kind'),
        ("unknown-shape", ["--mean", "1", "--rail", "2", "--rms", "1", "--shape", "square"], 'shape'),
    ],
    "model poly": [
        ("negative-level", ["--k2", "20", "--rms", "-1"], 'rms'),
        ("nan-level", ["--k2", "20", "--rms", "nan"], 'rms'),
        ("malformed-list", ["--k2", "20", "--rms", "1;2"], 'rms'),
        ("nan-k2", ["--k2", "nan", "--rms", "1"], 'k2'),
        ("unknown-shape", ["--k2", "20", "--rms", "1", "--shape", "square"], 'shape'),
    ],
    "profile": [
        ("non-monotonic", ["100:0.01,50:0.02,2000:0.01"], 'monotonic'),
        ("negative-psd", ["20:0.01,80:-0.04"], 'psd'),
        ("nan-psd", ["20:nan,80:0.04"], 'nan'),
        ("malformed-list", ["20:0.01,,80:0.04"], '20:0.01,,80:0.04'),
        ("negative-grms", ["flat:50-2000", "--grms", "-1"], 'grms'),
        ("nan-grms", ["flat:50-2000", "--grms", "nan"], 'grms'),
        ("huge-grms", ["flat:50-2000", "--grms", "1e200"], 'grms'),
        ("missing-file", ["{d}/no-such-profile.csv"], 'no-such-profile.csv'),
        ("non-monotonic-file", ["{d}/backwards.csv"], 'backwards.csv'),
        ("unknown-named", ["no-such-profile-name"], 'no-such-profile-name'),
        ("negative-tone", ["navmat-p9492+sine:120:-0.5"], 'amplitude'),
        ("zero-tone-frequency", ["navmat-p9492+sine:0:0.5"], 'tone frequency'),
        ("malformed-tones", ["navmat-p9492+sine:120:0.5,240"], '240'),
    ],
    "environment show": [
        ("unknown-name", ["no-such-environment"], 'no-such-environment'),
        ("no-name", [], 'NAME'),
    ],
    "environment list": [
        ("extra-name", ["navmat-p9492"], 'navmat-p9492'),
    ],
    "sensor show": [
        ("unknown-name", ["no-such-part"], 'no-such-part'),
        ("unknown-range", ["adxl355", "--range", "3"], 'range'),
        ("unknown-axis", ["adxl355", "--axis", "w"], 'axis'),
        ("nan-odr", ["adxl355", "--odr", "nan"], 'odr'),
    ],
    "sensor list": [
        ("extra-name", ["adxl355"], 'adxl355'),
    ],
    "compare": [
        ("unknown-part", [*CMP, "--budget-vre", "1mg", "--candidates", "no-such-part:2g"], 'no-such-part'),
        ("negative-level", ["--environment", "flat:50-2000", "--levels", "-1", "--budget-vre", "1mg",
                            "--candidates", "ideal:8"], 'levels'),
        ("nan-level", ["--environment", "flat:50-2000", "--levels", "nan", "--budget-vre", "1mg",
                       "--candidates", "ideal:8"], 'levels'),
        ("unitless-budget", [*CMP, "--budget-vre", "1", "--candidates", "ideal:8"], 'budget-vre'),
        ("non-monotonic-profile", ["--environment", "100:0.01,50:0.02", "--levels", "1", "--budget-vre", "1mg",
                                   "--candidates", "ideal:8"], 'monotonic'),
    ],
    "predict": [
        ("negative-level", [*PRED, "--levels", "-1"], 'levels'),
        ("nan-level", [*PRED, "--levels", "nan"], 'levels'),
        ("huge-level", [*PRED, "--levels", "1e200"], 'levels'),
        ("malformed-list", [*PRED, "--levels", "1,x"], 'levels'),
        ("unknown-sensor", ["--sensor", "no-such-sensor", "--profile", "flat:50-2000", "--levels", "1"], 'no-such-sensor'),
        ("missing-sensor-file", ["--sensor", "{d}/missing.toml", "--profile", "flat:50-2000", "--levels", "1"], 'missing.toml'),
        ("non-monotonic-profile", ["--sensor", "adxl355", "--profile", "100:0.01,50:0.02", "--levels", "1"], 'monotonic'),
        ("missing-profile-file", ["--sensor", "adxl355", "--profile", "{d}/none.csv", "--levels", "1"], 'none.csv'),
        ("negative-freq", ["--sensor", "adxl355", "--freq", "-100", "--levels", "1"], 'freq'),
        ("nan-static", [*PRED, "--levels", "1", "--static", "nan"], 'static'),
        ("unknown-range", [*PRED, "--levels", "1", "--range", "3"], 'range'),
        ("unknown-odr", [*PRED, "--levels", "1", "--odr", "1234"], 'odr'),
        ("negative-tone", ["--sensor", "adxl355", "--profile", "flat:50-2000+sine:120:-1", "--levels", "1"], 'amplitude'),
        ("malformed-tones", ["--sensor", "adxl355", "--profile", "flat:50-2000+sine:120", "--levels", "1"], '120'),
        ("unknown-environment", ["--sensor", "adxl355", "--profile", "no-such-env+sine:120:1", "--levels", "1"], 'no-such-env'),
    ],
    "simulate": [
        ("negative-level", [*SIM, "--levels", "-1"], 'levels'),
        ("nan-level", [*SIM, "--levels", "nan"], 'levels'),
        ("malformed-list", [*SIM, "--levels", "0.5,,1"], 'levels'),
        ("negative-seconds", [*SIM, "--levels", "1", "--seconds", "-1"], 'seconds'),
        ("nan-seconds", [*SIM, "--levels", "1", "--seconds", "nan"], 'seconds'),
        ("huge-seconds", [*SIM, "--levels", "1", "--seconds", "1e9"], 'would take about'),
        ("unknown-sensor", ["--sensor", "no-such-sensor", "--profile", "flat:50-2000", "--levels", "1"], 'no-such-sensor'),
        ("non-monotonic-profile", ["--sensor", "ideal", "--profile", "100:0.01,50:0.02", "--levels", "1"], 'monotonic'),
        ("nan-freq", ["--sensor", "ideal", "--freq", "nan", "--levels", "1", "--seconds", "2"], 'freq'),
        ("out-is-a-file", [*SIM, "--levels", "1", "--out", "{d}/a-file.txt"], 'a-file.txt'),
        ("negative-tone", ["--sensor", "ideal", "--profile", "flat:50-2000+sine:120:-1", "--levels", "1"], 'amplitude'),
        ("zero-tone-frequency", ["--sensor", "ideal", "--profile", "flat:50-2000+sine:0:1", "--levels", "1"], 'tone frequency'),
    ],
    "analyze": [
        ("missing-file", ["{d}/no-such-record.h5", "--dut", "dut"], 'no-such-record.h5'),
        ("missing-channel", ["{d}/record.h5", "--dut", "no_such_channel"], 'no_such_channel'),
        ("missing-reference", ["{d}/record.h5", "--dut", "dut", "--reference", "no_such_channel"], 'no_such_channel'),
        ("negative-fs", ["{d}/record.csv", "--dut", "dut", "--fs", "-1000"], 'fs'),
        ("nan-fs", ["{d}/record.csv", "--dut", "dut", "--fs", "nan"], 'fs'),
        ("unknown-method", ["{d}/record.h5", "--dut", "dut", "--method", "chirp"], 'method'),
        ("not-a-record", ["{d}/a-file.txt", "--dut", "dut"], 'a-file.txt'),
    ],
    "channels": [
        ("missing-file", ["{d}/no-such-record.h5"], 'no-such-record.h5'),
        ("not-a-record", ["{d}/a-file.txt"], 'a-file.txt'),
        ("truncated-tdms", ["{d}/cut.tdms"], 'cut.tdms'),
    ],
    "campaign": [
        ("missing-manifest", ["{d}/no-such-campaign.toml"], 'no-such-campaign.toml'),
        ("malformed-toml", ["{d}/malformed.toml"], 'malformed.toml'),
        ("missing-run-file", ["{d}/campaign-missing-file.toml"], 'nope.h5'),
        ("zero-workers", ["{d}/campaign.toml", "--workers", "0"], 'workers'),
    ],
    "identify": [
        ("missing-source", ["{d}/no-such-campaign.toml", "--out", "{d}/id-out"], 'no-such-campaign.toml'),
        ("not-a-campaign-folder", ["{d}/empty", "--out", "{d}/id-out"], 'results.json'),
        ("unknown-base-sensor", ["{d}/campaign-profile.toml", "--base-sensor", "no-such-sensor", "--out", "{d}/id-out"],
         'no-such-sensor'),
        ("zero-workers", ["{d}/campaign-profile.toml", "--workers", "0", "--out", "{d}/id-out"], 'workers'),
        ("negative-budget", ["{d}/campaign-profile.toml", "--u-dut-pct", "-1", "--out", "{d}/id-out"], 'u_dut_pct'),
        ("random-run-without-profile", ["{d}/campaign.toml", "--out", "{d}/id-out"], 'profile'),
        ("out-is-a-file", ["{d}/campaign-profile.toml", "--out", "{d}/a-file.txt"], 'a-file.txt'),
    ],
    "report": [
        ("missing-folder", ["{d}/no-such-folder"], 'no-such-folder'),
        ("no-results", ["{d}/empty"], 'results.json'),
        ("malformed-results", ["{d}/malformed"], 'results.json'),
        ("metadata-unknown-key", ["{d}/valid-results", "--metadata", "{d}/meta-unknown-key.toml"], "colour"),
        ("metadata-wrong-type", ["{d}/valid-results", "--metadata", "{d}/meta-wrong-type.toml"], "serial"),
        ("metadata-not-toml", ["{d}/valid-results", "--metadata", "{d}/malformed.toml"], "malformed.toml"),
        ("metadata-missing", ["{d}/valid-results", "--metadata", "{d}/no-such-meta.toml"], "no-such-meta.toml"),
    ],
    "demo": [
        ("out-is-a-file", ["--quick", "--out", "{d}/a-file.txt"], 'a-file.txt'),
        ("negative-seconds", ["--seconds", "-1", "--out", "{d}/demo-out"], 'seconds'),
        ("nan-seconds", ["--seconds", "nan", "--out", "{d}/demo-out"], 'seconds'),
    ],
    "sweep": [
        ("missing-file", ["{d}/no-such-sweep.toml"], 'no-such-sweep.toml'),
        ("malformed-toml", ["{d}/malformed.toml"], 'malformed.toml'),
        ("negative-workers", ["{d}/sweep.toml", "--workers", "-1", "--out", "{d}/sweep-out"], 'workers'),
        ("negative-level-in-file", ["{d}/sweep-bad-level.toml", "--out", "{d}/sweep-out"], 'rms_g'),
        ("negative-tone-in-file", ["{d}/sweep-bad-tone.toml", "--out", "{d}/sweep-out"], 'amplitude'),
    ],
}


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("cli-surface")
    (d / "a-file.txt").write_text("not a folder, not a record\n")
    (d / "backwards.csv").write_text("freq_hz,psd_g2_per_hz\n100,0.01\n50,0.02\n2000,0.01\n")
    (d / "malformed.toml").write_text("this is = = not toml [\n")
    sweep = 'kind = "predict"\nseed = 1\n[fixed]\nsensor = "adxl355"\nprofile = "flat:50-2000"\n[grid]\nrms_g = "0.5:1:0.5"\n'
    (d / "sweep.toml").write_text(sweep)  # valid: the example of `vrelab sweep --help`, one axis
    (d / "sweep-bad-level.toml").write_text(sweep.replace('"0.5:1:0.5"', '"-1,1"'))
    (d / "sweep-bad-tone.toml").write_text(sweep.replace('"flat:50-2000"', '"flat:50-2000+sine:120:-1"'))
    camp = 'name = "c"\n[[run]]\nfile = "record.h5"\ndut = ["dut"]\nreference = "reference"\nstatic_g = 1\n'
    (d / "campaign.toml").write_text(camp)
    (d / "campaign-missing-file.toml").write_text(camp.replace("record.h5", "nope.h5"))
    (d / "campaign-profile.toml").write_text(camp + 'profile = "flat:20-1990"\n')
    (d / "empty").mkdir()
    (d / "cut.tdms").write_bytes(b"TDSm" + bytes(20))
    (d / "malformed").mkdir()
    (d / "malformed" / "results.json").write_text("{\"method\": ")
    from vrelab.results import Conditions, Estimate, LevelResult, VreResult

    (d / "valid-results").mkdir()
    res = VreResult("random", Conditions(static_g=1.0), (LevelResult(1.0, Estimate(-0.083, 0.001)),))
    (d / "valid-results" / "results.json").write_text(json.dumps(res.to_dict()))
    (d / "meta-unknown-key.toml").write_text('[item]\nmodel = "ADXL355"\ncolour = "blue"\n')
    (d / "meta-wrong-type.toml").write_text('[item]\nserial = 1234\n')
    rng = np.random.default_rng(11)
    n = 4000
    ref = np.concatenate([np.zeros(n), rng.normal(0, 1, n), np.zeros(n)])
    sched = Schedule((Segment(0, 1, 0), Segment(1, 2, 1.0), Segment(2, 3, 0)))
    write_record_hdf5(d / "record.h5", float(n), [{"reference": ref, "dut": np.clip(1 + ref, -2, 2)}], sched)
    with open(d / "record.csv", "w") as fh:
        fh.write("reference,dut\n")
        for a, b in zip(ref[::10], np.clip(1 + ref, -2, 2)[::10]):
            fh.write(f"{a:.6f},{b:.6f}\n")
    return d


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rc = main(argv)
    out, err = capsys.readouterr()
    shown = [f"{w.category.__name__}: {w.message}" for w in caught if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning))]
    return rc, out, err, shown


def _assert_one_line_exit_2(rc: int, out: str, err: str, shown: list[str], argv: list[str]) -> None:
    assert rc == 2, f"{argv}: exit {rc}, stderr {err!r}"
    lines = err.splitlines()
    assert len(lines) == 1 and err.endswith("\n") and lines[0].strip(), f"{argv}: stderr must be one line, got {err!r}"
    assert not shown, f"{argv}: warnings would add stderr lines: {shown}"
    assert "Traceback" not in err + out


def _params() -> list:
    out = []
    for cmd in COMMANDS:
        for case_id, argv, token in CASES.get(cmd, []):
            out.append(pytest.param(cmd, argv, token, id=f"{cmd.replace(' ', '-')}:{case_id}"))
    return out


@pytest.mark.parametrize("cmd, argv, token", _params())
def test_bad_value_exits_2_with_one_line(cmd: str, argv: list[str], token: str, files: Path, capsys: pytest.CaptureFixture[str]) -> None:
    full = cmd.split() + [a.replace("{d}", str(files)) for a in argv]
    rc, out, err, shown = _run(full, capsys)
    _assert_one_line_exit_2(rc, out, err, shown, full)
    assert token.lower() in err.lower(), f"{full}: the message should name {token!r}: {err!r}"
    if "--out" in full:  # outputs complete or not at all
        out_dir = Path(full[full.index("--out") + 1])
        assert not out_dir.is_dir() or not any(out_dir.iterdir())


# The valid argv the bad-value cases are variations of: each must run (exit 0), or a case could
# pass for a reason other than its one bad value.
VALID: dict[str, list[str]] = {
    "model clip": ["--mean", "1", "--rail", "2", "--rms", "0.5,1", "--json"],
    "model poly": ["--k2", "20", "--rms", "1", "--json"],
    "profile": ["20:0.01,80:0.04,2000:0.01", "--grms", "2", "--json"],
    "environment list": ["--json"],
    "environment show": ["navmat-p9492", "--json"],
    "sensor list": ["--json"],
    "sensor show": ["adxl355", "--json"],
    "compare": [*CMP, "--budget-vre", "1mg", "--candidates", "ideal:8", "--json"],
    "predict": [*PRED, "--levels", "1", "--json"],
    "simulate": [*SIM, "--levels", "1", "--json"],
    "analyze": ["{d}/record.h5", "--dut", "dut", "--reference", "reference", "--json"],
    "campaign": ["{d}/campaign.toml", "--json"],
    "identify": ["{d}/campaign-profile.toml", "--out", "{d}/id-valid", "--json"],
    "report": ["{d}/valid-results", "--json"],
}


@pytest.mark.parametrize("cmd", [c for c in VALID if c in COMMANDS])
def test_the_valid_base_of_the_cases_runs(cmd: str, files: Path, capsys: pytest.CaptureFixture[str]) -> None:
    full = cmd.split() + [a.replace("{d}", str(files)) for a in VALID[cmd]]
    rc, out, err, _ = _run(full, capsys)
    assert rc == 0, f"{full}: {err}"
    json.loads(out)  # --json: one object


def _required(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if a.required]


@pytest.mark.parametrize("cmd", list(COMMANDS))
def test_unknown_option_exits_2_with_one_line(cmd: str, capsys: pytest.CaptureFixture[str]) -> None:
    full = cmd.split() + ["--no-such-option-xyz"]
    _assert_one_line_exit_2(*_run(full, capsys), full)


@pytest.mark.parametrize("cmd", [c for c, p in COMMANDS.items() if _required(p)])
def test_missing_required_argument_exits_2_with_one_line(cmd: str, capsys: pytest.CaptureFixture[str]) -> None:
    full = cmd.split()
    rc, out, err, shown = _run(full, capsys)
    _assert_one_line_exit_2(rc, out, err, shown, full)
    assert "required" in err


def test_every_command_in_the_parser_has_bad_value_cases() -> None:
    """A command in the parser must not go untested: a new command needs its cases in CASES
    (the generic unknown-option / missing-argument cases are not enough)."""
    missing = [c for c in COMMANDS if not CASES.get(c)]
    assert not missing, f"commands without bad-value cases in tests/test_cli_surface.py: {missing}"
    assert {"report", "demo"} <= set(COMMANDS)  # this file's own commands always exist


@pytest.mark.parametrize(
    "argv",
    [
        pytest.param(["report", "{d}/malformed"], id="report-malformed"),
        pytest.param(["simulate", *SIM, "--levels", "-1"], id="simulate-negative-level"),
    ],
)
def test_real_subprocess_agrees(argv: list[str], files: Path) -> None:
    if argv[0] not in COMMANDS:
        argv = ["report", "{d}/malformed"]  # the command has not landed: hold the rule on report
    full = [sys.executable, "-m", "vrelab", *[a.replace("{d}", str(files)) for a in argv]]
    p = subprocess.run(full, capture_output=True, text=True, timeout=60)
    assert p.returncode == 2, p.stderr
    assert len(p.stderr.splitlines()) == 1 and "Traceback" not in p.stderr, p.stderr


def test_json_output_of_report_is_one_object(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from vrelab.results import Conditions, Estimate, LevelResult, VreResult

    res = VreResult("random", Conditions(static_g=1.0), (LevelResult(1.0, Estimate(-0.083, 0.001)),))
    (tmp_path / "results.json").write_text(json.dumps(res.to_dict()))
    rc, out, err, _ = _run(["report", str(tmp_path), "--json"], capsys)
    assert rc == 0 and err == ""
    assert len(out.splitlines()) == 1 and json.loads(out)["report"].endswith("report.html")


def test_an_unexpected_error_is_one_line_exit_1_and_debug_shows_the_traceback(monkeypatch, capsys):
    """Issue 9: only ValueError/OSError were caught, any other exception printed a traceback.
    Bad input stays exit 2; a bug is exit 1 with one line, and --debug gives the traceback."""
    import vrelab.prediction

    def broken(*a, **k):
        raise RuntimeError("the model blew up\nsecond line")

    monkeypatch.setattr(vrelab.prediction, "predict", broken)
    argv = ["predict", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "1"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "internal error: RuntimeError: the model blew up" in err and "--debug" in err
    assert main(["--debug", *argv]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "RuntimeError" in err
    assert main(["predict", "--sensor", "ideal", "--profile", "flat:50-2000", "--levels", "-1"]) == 2


def test_every_bad_value_case_under_a_memory_cap(files: Path, tmp_path: Path) -> None:
    """Issue 9's fuzz table: every case above, run again in one child process under RLIMIT_AS
    (3 GiB) with an alarm per case, so a case that sizes memory from its input or hangs fails
    here instead of taking the machine (the in-process runs above have no such cap)."""
    import textwrap

    cases = [cmd.split() + [a.replace("{d}", str(files)) for a in argv] for cmd in COMMANDS for _, argv, _ in CASES.get(cmd, [])]
    driver = tmp_path / "driver.py"
    driver.write_text(textwrap.dedent("""
        import contextlib, io, json, resource, signal, sys
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
        from vrelab.cli import main
        def hang(*_):
            raise TimeoutError("case took over 60 s")
        signal.signal(signal.SIGALRM, hang)
        out = []
        for argv in json.load(open(sys.argv[1])):
            err = io.StringIO()
            signal.alarm(60)
            try:
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    rc = main(argv)
            except BaseException as exc:
                rc = f"escaped {type(exc).__name__}: {exc}"
            finally:
                signal.alarm(0)
            out.append([argv, rc, err.getvalue()])
        json.dump(out, open(sys.argv[2], "w"))
    """))
    (tmp_path / "cases.json").write_text(json.dumps(cases))
    p = subprocess.run([sys.executable, str(driver), str(tmp_path / "cases.json"), str(tmp_path / "out.json")],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    results = json.loads((tmp_path / "out.json").read_text())
    assert len(results) == len(cases) > 60
    bad = [(argv, rc, err) for argv, rc, err in results if rc != 2 or len(err.splitlines()) != 1 or "Traceback" in err]
    assert not bad, bad[:5]


def test_a_channel_name_with_terminal_escapes_reaches_stderr_as_text(tmp_path):
    """A recording's channel name is the file's text: an ESC/OSC sequence in it (clear the
    screen, retitle the window) is printed as escapes in the one error line, never executed."""
    import subprocess
    import sys

    rec = tmp_path / "rec.csv"
    evil = "acc\x1b]0;owned\x07\x1b[2J"
    rec.write_text("time,ref," + evil + "\n" + "".join(f"{i / 1000},{(-1) ** i},{0.5}\n" for i in range(50)),
                   encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "vrelab", "analyze", str(rec), "--dut", "nope", "--reference", "ref"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert "\x1b" not in out.stderr and "\x07" not in out.stderr
    assert out.stderr.count("\n") == 1 and "\\x1b]0;owned\\x07\\x1b[2J" in out.stderr, out.stderr
