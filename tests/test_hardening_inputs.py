"""Input validation rows of issue 23: each case is refused by the CLI with exit status 2 and
exactly one line on stderr (no traceback, no NumPy warning printed first), in seconds.

The campaign cases use the simulated example campaign (vrelab.example_campaign): two parts
z along the shaker, runs at +1 g and -1 g, DUTs with a DC response (their baselines read the
static field), so each case's truth is known: which runs share a file, which orientation each
record was taken at.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
import shutil
import subprocess
import sys
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from vrelab.campaigns import ManifestContradiction, check_static, read_manifest
from vrelab.cli import main
from vrelab.example_campaign import write_campaign

RUN1 = """
[[run]]
file = "runs/01_z_up_80hz.tdms"
label = "again"
reference = "shaker/ref"
dut = {sn1 = "shaker/sn1_z", sn2 = "shaker/sn2_z"}
static_g = 1
"""


@pytest.fixture(scope="module")
def example(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_campaign(tmp_path_factory.mktemp("campaign"))


def _vrelab(*args: str, real: bool = False, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    """The CLI on ``args``: in this process (``vrelab.cli.main``, the code ``python -m vrelab``
    runs, every RuntimeWarning recorded and appended to stderr as Python would print it), or with
    ``real`` in a fresh interpreter (Python's default warning filters: a RuntimeWarning prints)."""
    if real:
        env = dict(os.environ)
        env.pop("PYTHONWARNINGS", None)
        return subprocess.run([sys.executable, "-m", "vrelab", *args], capture_output=True, text=True, env=env,
                              timeout=timeout)
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught, redirect_stdout(out), redirect_stderr(err):
        warnings.simplefilter("always", RuntimeWarning)
        rc = main(list(args))
    shown = "".join(f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}\n"
                    for w in caught if issubclass(w.category, RuntimeWarning))
    return subprocess.CompletedProcess(list(args), rc, out.getvalue(), shown + err.getvalue())


def _refused(p: subprocess.CompletedProcess[str], *words: str) -> str:
    """Exit 2, nothing on stdout, one line on stderr holding ``words``, no traceback, no warning."""
    err = p.stderr
    assert p.returncode == 2, (p.returncode, err)
    assert p.stdout == ""
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err and "Warning" not in err and "internal error" not in err, err
    for w in words:
        assert w in err, (w, err)
    return err


def _campaign_copy(example: Path, tmp: Path, name: str, text: str) -> Path:
    (tmp / "runs").symlink_to(example.parent / "runs")
    m = tmp / name
    m.write_text(text)
    return m


# ----------------------------------------------------------------------------- campaign consistency


def test_the_same_file_twice_is_refused_naming_both_runs(example: Path, tmp_path: Path) -> None:
    m = _campaign_copy(example, tmp_path, "dup.toml", example.read_text() + RUN1)
    _refused(_vrelab("campaign", str(m)), "run 1 ('Z up, 80 Hz')", "run 8 ('again')", "01_z_up_80hz.tdms",
             "counted twice")


def test_an_identical_copy_is_the_same_record(example: Path, tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()
    for f in (example.parent / "runs").iterdir():
        (runs / f.name).symlink_to(f)
    shutil.copyfile(example.parent / "runs" / "01_z_up_80hz.tdms", runs / "copy.tdms")
    m = tmp_path / "copy.toml"
    m.write_text(example.read_text() + RUN1.replace("01_z_up_80hz", "copy"))
    _refused(_vrelab("campaign", str(m)), "run 1", "run 8", "identical files", "copy.tdms", "counted twice")


def test_one_record_at_two_orientations_is_refused(example: Path, tmp_path: Path) -> None:
    m = _campaign_copy(example, tmp_path, "two.toml", example.read_text() + RUN1.replace("static_g = 1", "static_g = -1"))
    _refused(_vrelab("campaign", str(m)), "run 1", "run 8", "+1 g and -1 g", "one orientation")


def test_one_file_split_into_runs_per_part_is_accepted(example: Path, tmp_path: Path) -> None:
    # the control: one file, each part its own run (even at its own static field), counts
    # nothing twice
    text = example.read_text().replace('dut = {sn1 = "shaker/sn1_z", sn2 = "shaker/sn2_z"}',
                                       'dut = {sn1 = "shaker/sn1_z"}', 1)
    text += RUN1.replace('{sn1 = "shaker/sn1_z", sn2 = "shaker/sn2_z"}', '{sn2 = "shaker/sn2_z"}')
    m = _campaign_copy(example, tmp_path, "split.toml", text)
    runs = read_manifest(m).runs
    assert len(runs) == 8 and runs[0].file == runs[7].file


def test_a_flipped_static_sign_is_refused_from_the_duts_own_baseline(example: Path, tmp_path: Path) -> None:
    # run 2 of the example was recorded at -1 g (its DUTs' baselines read -1 g); declared +1 g it
    # would give k3 of the wrong sign. Only that run, so the check costs one run's reduction.
    head, *runs = example.read_text().split("[[run]]")
    down = [r for r in runs if "02_z_down_80hz" in r][0]
    m = _campaign_copy(example, tmp_path, "sign.toml", head + "[[run]]" + down.replace("static_g = -1", "static_g = 1"))
    out = tmp_path / "out"
    _refused(_vrelab("campaign", str(m), "--out", str(out), real=True), "run 1 ('Z down, 80 Hz')", "static_g", "'sn1'",
             "declared +1 g", "vibration-off reading is -0.99")
    assert not out.exists()  # refused: nothing written


@pytest.mark.parametrize("declared, baseline, refused", [
    (1.0, -1.0, True),    # the flipped sign
    (0.0, 0.98, True),    # declared horizontal, the DUT reads the 1 g field
    (-1.0, -0.97, False),  # agrees (an offset of 30 mg)
    (1.0, 0.02, False),   # no DC response (piezoelectric): not judged
    (1.0, -0.6, False),   # tilted (|reading| < 0.75 g): not judged
    (1.0, None, False),   # no baseline
])
def test_static_check_judges_only_a_clear_1g_reading(declared: float, baseline: float | None, refused: bool,
                                                     example: Path) -> None:
    run = read_manifest(example, check_files=False).runs[0]
    run = dataclasses.replace(run, static_g={c: declared for c in run.dut})
    if refused:
        with pytest.raises(ManifestContradiction, match="vibration-off reading"):
            check_static(run, "sn1", baseline)
    else:
        check_static(run, "sn1", baseline)


def test_a_static_field_beyond_any_test_is_refused_at_validation(example: Path, tmp_path: Path) -> None:
    # 1e300 g passed as "finite" and reached the k2/k3 fit (where the sign check caught it, late)
    m = _campaign_copy(example, tmp_path, "big.toml", example.read_text().replace("static_g = -1\n", "static_g = -1e300\n", 1))
    with pytest.raises(ValueError, match=r"run 2 .*static_g.sn1 must be within ±100000 g"):
        read_manifest(m, check_files=False)
    f = example.parent / "runs" / "01_z_up_80hz.tdms"
    _refused(_vrelab("analyze", str(f), "--dut", "shaker/sn1_z", "--reference", "shaker/ref", "--reference-units", "mv",
                     "--reference-sensitivity", "10", "--dut-units", "lsb", "--dut-sensitivity", "256000",
                     "--static", "1e300"), "--static", "100000 g")


def test_a_dut_that_is_the_reference_is_refused_at_validation(example: Path, tmp_path: Path) -> None:
    text = example.read_text().replace('dut = {sn1 = "shaker/sn1_z", sn2 = "shaker/sn2_z"}',
                                       'dut = {sn1 = "shaker/sn1_z", sn2 = "/shaker/REF"}', 1)
    m = _campaign_copy(example, tmp_path, "ref.toml", text)
    _refused(_vrelab("campaign", str(m)), "run 1", "dut 'sn2'", "reference channel 'shaker/ref'")


@pytest.mark.parametrize("band", ["[10, inf]", "[10, nan]", "[100, 10]"])
def test_a_band_without_finite_increasing_edges_is_refused_at_validation(example: Path, tmp_path: Path,
                                                                         band: str) -> None:
    text = example.read_text().replace('profile = "flat:50-500"', f'profile = "flat:50-500"\nband = {band}')
    m = _campaign_copy(example, tmp_path, "band.toml", text)
    with pytest.raises(ValueError, match=r"run 6 .*band must be \[F1, F2\] in Hz, finite"):
        read_manifest(m)
    if band == "[10, inf]":
        _refused(_vrelab("campaign", str(m)), "run 6", "band", "inf")


# ----------------------------------------------------------------------------- budgets


DEEP = "x = " + "[" * 3000 + "]" * 3000 + "\n"  # 6 kB: RecursionError in tomllib before the budget


@pytest.mark.parametrize("kind", ["manifest", "profile", "sensor", "metadata", "dotted"])
def test_deeply_nested_toml_is_one_line(tmp_path: Path, kind: str) -> None:
    f = tmp_path / "deep.toml"
    if kind == "profile":
        f.write_text("[profile]\nbreakpoints = [[20, 1], [2000, 1]]\n" + DEEP)
        p = _vrelab("profile", str(f))
    elif kind == "sensor":
        f.write_text(DEEP)
        p = _vrelab("predict", "--sensor", str(f), "--freq", "100", "--levels", "1")
    elif kind == "metadata":
        f.write_text(DEEP)
        p = _vrelab("report", str(tmp_path), "--metadata", str(f))
    else:  # a campaign manifest: arrays, or 100 dotted keys (parsed fine, nested beyond the budget)
        f.write_text(DEEP if kind == "manifest" else "a" + ".a" * 100 + " = 1\n")
        p = _vrelab("campaign", str(f))
    _refused(p, "deep.toml", "nested more than 32 levels")


def test_deeply_nested_json_in_a_results_folder_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "results.json").write_text("[" * 100000 + "]" * 100000)
    _refused(_vrelab("report", str(tmp_path)), "results.json", "nested more than 32 levels")


def test_nesting_budget_holds_every_real_file(example: Path) -> None:
    from vrelab import _load

    # the manifests, sensors, profiles and environments vrelab ships and writes
    root = Path(__file__).resolve().parent.parent
    files = [example, example.parent / "sensor.toml", *root.glob("examples/**/*.toml"), *root.glob("src/**/*.toml")]
    assert len(files) > 10
    for f in files:
        _load.toml_loads(f.read_text(encoding="utf-8"), str(f))


def test_a_profile_with_100000_tones_is_refused_in_seconds(tmp_path: Path) -> None:
    f = tmp_path / "tones.toml"
    f.write_text("[profile]\nbreakpoints = [[20, 0.01], [2000, 0.01]]\n"
                 + "".join(f"[[tone]]\nfreq_hz = {100 + i * 0.01:.2f}\npeak_g = 0.1\n" for i in range(100_000)))
    _refused(_vrelab("profile", str(f)), "100000 sine tones", "at most 1000")
    spec = "flat:20-2000+sine:" + ",".join(f"{100 + i}:0.1" for i in range(1001))
    _refused(_vrelab("profile", spec), "1001 sine tones")


@pytest.mark.parametrize("spec, words", [
    ("flat:50-500+sine:1e300:1", ["tone frequency", "1e+300"]),     # the case (OverflowError)
    ("flat:50-500+sine:100:1e300", ["amplitude", "at most 100000 g peak"]),  # peak² overflowed
])
def test_profile_overflow_is_one_line(spec: str, words: list[str]) -> None:
    _refused(_vrelab("profile", spec), *words)


# ----------------------------------------------------------------------------- no warning before a refusal

# Each of these printed NumPy RuntimeWarnings (overflow, invalid value, divide by zero) before
# its refusal or, for the last two, before a silent inf/NaN and exit 0.
WARNED = [
    (["model", "poly", "--k2", "1", "--rms", "1e200"], ["--rms", "at most 100000 g rms"]),
    (["model", "poly", "--k2", "1e300", "--k4", "1e300", "--rms", "1e5"], ["overflows float64"]),
    (["predict", "--sensor", "adxl355", "--freq", "1e300", "--levels", "1"], ["--freq", "1e+07 Hz"]),
    (["predict", "--sensor", "adxl355", "--profile", "flat:1-1e300", "--levels", "1"], ["freq_hz", "1e+07 Hz"]),
    (["predict", "--sensor", "adxl355", "--static", "1e300", "--freq", "100", "--levels", "1"],
     ["--static", "100000 g"]),
    (["profile", "20:1e200,2000:1e-200"], ["psd_g2_per_hz", "1e+100"]),
    (["model", "poly", "--k2", "1", "--static", "1e300", "--rms", "1"], ["--static", "100000 g"]),
]


@pytest.mark.parametrize("args, words", WARNED, ids=[" ".join(a[:2]) + f"-{i}" for i, (a, _) in enumerate(WARNED)])
def test_no_numpy_warning_before_a_refusal(args: list[str], words: list[str]) -> None:
    _refused(_vrelab(*args), *words)


def test_in_a_fresh_interpreter(tmp_path: Path) -> None:
    # the in-process runner records warnings; here Python's default filters print them, and the
    # stack is a fresh interpreter's (tomllib's RecursionError as a user meets it)
    _refused(_vrelab("profile", "20:1e200,2000:1e-200", real=True), "psd_g2_per_hz")
    f = tmp_path / "deep.toml"
    f.write_text(DEEP)
    _refused(_vrelab("campaign", str(f), real=True), "nested more than 32 levels")


def test_a_tiny_sensitivity_is_refused_before_the_record_overflows(example: Path) -> None:
    f = example.parent / "runs" / "01_z_up_80hz.tdms"
    _refused(_vrelab("analyze", str(f), "--dut", "shaker/sn1_z", "--reference", "shaker/ref", "--reference-units", "mv",
                     "--reference-sensitivity", "10", "--dut-units", "lsb", "--dut-sensitivity", "1e-300"),
             "sensitivity", "1e-300")


def test_profile_slopes_from_log_differences_are_exact_and_quiet() -> None:
    # 20 Hz at 1e-99 g²/Hz to 2000 Hz at 1e99: n = ln(1e198)/ln(100) = 99 exactly, and the area
    # P1·f1/(n+1)·(r^(n+1) - 1) = (P2·f2 - P1·f1)/(n+1) = (2e102 - 2e-98)/100 (closed form, SPEC 3)
    from vrelab.profiles import DB_PER_OCT_PER_N, RandomProfile

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        prof = RandomProfile([20.0, 2000.0], [1e-99, 1e99])
        assert prof.exponents[0] == pytest.approx(99.0, rel=1e-12)
        assert prof.slopes_db_per_oct[0] == pytest.approx(99.0 * DB_PER_OCT_PER_N, rel=1e-12)
        assert prof.mean_square_g2 == pytest.approx(2e100, rel=1e-9)
        assert math.isfinite(prof.grms)


def test_the_hardening_suite_runs_under_a_memory_cap():
    """The cap of tests/conftest.py is in force here (and so in the CLI subprocesses these cases
    start): an allocation far beyond it fails with MemoryError instead of taking the machine."""
    import resource

    import numpy as np

    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    assert soft != resource.RLIM_INFINITY and soft <= 6 * 1024**3
    with pytest.raises(MemoryError):
        np.ones(soft // 8 + 1)
