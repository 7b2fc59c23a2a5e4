"""Start-up of the command line (issue 29): each run imports what its command needs, no more.

What is checked is *which modules a run imports*, never a time (``bench/bench_startup.py``
times it): ``python -X importtime`` in a fresh interpreter lists every module a run imports,
nested under the module that imported it, so a failure names the chain that brought a heavy
library in (``scipy.special <- vrelab.models.clipping <- vrelab.cli.model``).

* ``vrelab --help`` imports no command module, no numpy, scipy, reader library (h5py, npTDMS,
  asammdf, idelib, pyuff, soundfile, pyarrow), plotting library or xarray/Dask;
* ``vrelab COMMAND --help`` imports no scipy and none of those libraries (the help of
  ``analyze``, ``channels`` and ``campaign`` lists the reader registry's formats, which reads
  no file and imports no reader library);
* ``vrelab model clip`` (a closed form) imports no reader, plotting library or report;
* ``vrelab model poly`` (a polynomial closed form: numpy's arithmetic) imports no scipy either
  (the clipping and memoryless models import ``scipy.special`` where they evaluate ``ndtr`` /
  ``erfcx``, not at their top).

And the list ``vrelab --help`` prints without importing the commands (:data:`vrelab.cli.COMMANDS`)
is the one the commands' modules register.

* ``vrelab analyze`` (random, ``--json``, no ``--out`` or ``--profile``) imports neither the
  profiles package, the output folder's module nor threadpoolctl;
* the BLAS of a ``vrelab`` run has one thread unless the user's ``OPENBLAS_NUM_THREADS`` /
  ``OMP_NUM_THREADS`` says otherwise (OpenBLAS's own count, read with threadpoolctl after the
  run), and the variables are gone from the environment when :func:`vrelab.cli.main` returns;
  a program that imported numpy before calling it gets no variable set.
"""

from __future__ import annotations

import argparse
import json
import os
import pkgutil
import re
import subprocess
import sys

import numpy as np
import pytest

import vrelab.cli
from vrelab.cli import COMMANDS, build_parser, command_named

READERS = ("h5py", "nptdms", "asammdf", "idelib", "pyuff", "soundfile", "pyarrow")
PLOTS_AND_ARRAYS = ("matplotlib", "plotly", "xarray", "dask")
_LINE = re.compile(r"^import time:\s+\d+ \|\s+\d+ \|( *)(\S+)$")
# Runs the command as `python -m vrelab` does, then writes sys.modules: -X importtime misses
# what importlib.import_module loads (the command modules, the lazy packages' names).
_RUN = """import json, sys
from vrelab.cli import main
try:
    code = main(sys.argv[1:])
except SystemExit as stop:
    code = stop.code
sys.stderr.write("\\nMODULES " + json.dumps(sorted(sys.modules)) + "\\n")
sys.exit(code)
"""


def imports_of(*argv: str) -> dict[str, list[str]]:
    """Every module ``vrelab ARGV`` imports (a fresh interpreter's ``sys.modules`` after the
    run), each with its chain of importers, innermost first, where ``-X importtime`` shows it
    (it prints a module after those it imports, these indented one level deeper)."""
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", _RUN, *argv], capture_output=True,
                          text=True, env=dict(os.environ, COLUMNS="100"), timeout=120)
    assert done.returncode == 0 and "\nMODULES " in done.stderr, done.stderr[-2000:]
    trace, modules = done.stderr.rsplit("\nMODULES ", 1)
    parent: dict[str, str] = {}
    pending: list[tuple[int, str]] = []  # (depth, module) whose importer is not printed yet
    for line in trace.splitlines():
        m = _LINE.match(line)
        if not m:
            continue
        depth, name = len(m.group(1)), m.group(2)
        for d, child in pending:
            if d > depth:  # printed before it, one level deeper: imported by it
                parent.setdefault(child, name)
        pending = [(d, c) for d, c in pending if d <= depth] + [(depth, name)]
    chains: dict[str, list[str]] = {}
    for name in json.loads(modules):
        chain, at = [], name
        while at in parent and parent[at] not in chain:  # a module printed twice (a failed optional
            at = parent[at]                                # import tried again) must not loop
            chain.append(at)
        chains[name] = chain
    return chains


def offenders(chains: dict[str, list[str]], roots: tuple[str, ...]) -> list[str]:
    """Per package of ``roots`` imported: its module that was reached from outside it, with
    the chain of importers (the module alone where the chain is unknown)."""
    found = []
    for root in sorted({m.split(".")[0] for m in chains} & set(roots)):
        mods = [m for m in chains if m.split(".")[0] == root]
        entry = [m for m in mods if chains[m] and chains[m][0].split(".")[0] != root] or mods
        m = min(entry, key=lambda m: (m != root, len(chains[m]), m))  # the package itself, else the nearest
        found.append(" <- ".join([m, *chains[m]]))
    return found


def test_help_imports_no_command_and_nothing_heavy():
    chains = imports_of("--help")
    assert offenders(chains, ("numpy", "scipy", *READERS, *PLOTS_AND_ARRAYS)) == []
    commands = sorted(m for m in chains if m.startswith("vrelab.cli.") and not m.startswith("vrelab.cli._"))
    assert commands == []
    assert "importlib.metadata" not in chains  # the version is read by --version only


@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_command_help_imports_no_scipy_nor_a_reader(command):
    chains = imports_of(command, "--help")
    assert offenders(chains, ("scipy", *READERS, *PLOTS_AND_ARRAYS)) == []
    others = sorted(m for m in chains if m.startswith("vrelab.cli.") and m.split(".")[2] in COMMANDS
                    and m != f"vrelab.cli.{command}")
    assert others == []  # only its own module


def test_model_clip_imports_no_reader_plot_or_report():
    chains = imports_of("model", "clip", "--mean", "1", "--rail", "2", "--rms", "1")
    assert offenders(chains, (*READERS, *PLOTS_AND_ARRAYS)) == []
    ours = [m for m in chains if m.startswith(("vrelab.report", "vrelab.analysis", "vrelab.shaker", "vrelab.sensor"))]
    assert ours == []


def test_model_poly_imports_no_scipy():
    chains = imports_of("model", "poly", "--k2", "100", "--rms", "1,2")
    assert offenders(chains, ("scipy", *READERS, *PLOTS_AND_ARRAYS)) == []


def test_the_listed_commands_are_those_registered():
    """``vrelab --help`` lists :data:`COMMANDS` without importing them: every command module is
    in it, in the order of the list, with the help line its ``register`` gives."""
    modules = {m.name for m in pkgutil.iter_modules(vrelab.cli.__path__) if not m.name.startswith("_")}
    assert set(COMMANDS) == modules
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert {a.dest: a.help for a in sub._choices_actions} == COMMANDS
    assert list(sub.choices) == list(COMMANDS)


@pytest.mark.parametrize("argv", [
    ["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1"],
    ["--debug", "model", "poly", "--k2", "100", "--rms", "1,2"],
    ["environment", "show", "navmat-p9492"],
    ["--debug", "channels", "run.csv", "--json"],
    ["--deb", "report", "some-folder", "--json"],
])
def test_the_command_is_found_as_argparse_finds_it(argv):
    """Parsing with only the named command registered gives what the whole parser gives."""
    name = command_named(argv)
    assert name in COMMANDS
    def parsed(parser: argparse.ArgumentParser) -> dict[str, object]:
        out = vars(parser.parse_args(argv))
        return {**out, "func": out["func"].__code__}  # a lambda is made anew with each parser, from one code

    whole = parsed(build_parser())
    assert parsed(build_parser([name])) == whole
    assert whole["command"] == name


def test_an_unknown_command_is_refused_with_the_list(capsys):
    assert vrelab.cli.main(["nonsense"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vrelab: error: argument COMMAND: invalid choice: 'nonsense'")
    assert all(repr(c) in err for c in COMMANDS)


def test_version_prints_the_installed_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as stop:
        vrelab.cli.main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"vrelab {version('vrelab')}\n"


def test_analyze_imports_no_profile_folder_or_threadpoolctl(tmp_path):
    """A random analysis printed as JSON needs no profile (no --profile), no output folder
    (no --out) and no threadpoolctl (the BLAS thread count is :func:`vrelab.cli.main`'s)."""
    from test_analysis_helpers import make_record

    rec = make_record(3, levels_g=(0.5, 1.0), vre_g=(1e-4, 4e-4), t_off_s=6.0, t_on_s=10.0).record
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([rec.data["reference"], rec.data["dut"]]), delimiter=",", header="ref,dut",
               comments="", fmt="%.9g")
    chains = imports_of("analyze", str(path), "--fs", str(rec.fs_hz), "--dut", "dut", "--reference", "ref",
                        "--method", "random", "--json")  # (imports_of: exit status 0, the analysis done)
    assert "vrelab.analysis.pipeline" in chains
    assert offenders(chains, ("threadpoolctl",)) == []
    assert [m for m in ("vrelab.profiles", "vrelab.folder") if m in chains] == []


BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
# vrelab model clip loads numpy's and SciPy's OpenBLAS (scipy.special); after the run, each one's
# thread count as threadpoolctl reads it from the library, and the BLAS variables left set
_BLAS_RUN = """import json, os, sys
from vrelab.cli import main
main(["model", "clip", "--mean", "1", "--rail", "2", "--rms", "1"])
from threadpoolctl import threadpool_info
sys.stderr.write("\\nBLAS " + json.dumps({
    "threads": [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"],
    "env": {k: os.environ[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
            if k in os.environ}}) + "\\n")
"""


def blas_after_run(**env: str) -> dict[str, object]:
    clean = {k: v for k, v in os.environ.items() if k not in BLAS_VARIABLES}
    done = subprocess.run([sys.executable, "-c", _BLAS_RUN], capture_output=True, text=True, env={**clean, **env},
                          timeout=120)
    assert done.returncode == 0 and "\nBLAS " in done.stderr, done.stderr[-2000:]
    return json.loads(done.stderr.rsplit("\nBLAS ", 1)[1])


# OpenBLAS starts a thread per core by default and caps any count at the cores: on one core
# every case below reads 1, and nothing tells the default from the user's choice
many_cores = pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one core: OpenBLAS runs one thread anyway")


@many_cores
def test_a_run_uses_one_blas_thread_by_default():
    found = blas_after_run()
    assert len(found["threads"]) >= 1 and set(found["threads"]) == {1}  # numpy's and SciPy's OpenBLAS
    assert found["env"] == {}  # main() removed what it set: the caller's later children see none


@many_cores
@pytest.mark.parametrize("name", ["OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"])
def test_the_users_blas_threads_win(name):
    found = blas_after_run(**{name: "2"})
    assert set(found["threads"]) == {2}
    assert found["env"] == {name: "2"}


def test_main_sets_no_blas_variable_once_numpy_is_imported(monkeypatch):
    """This process imported numpy (its BLAS is loaded, its thread count the caller's): main()
    leaves the environment alone, for the command and for its child processes."""
    assert "numpy" in sys.modules
    for name in BLAS_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    seen = {}
    monkeypatch.setattr(vrelab.cli, "_run", lambda argv, debug: seen.update(
        {k: os.environ.get(k) for k in BLAS_VARIABLES}) or 0)
    assert vrelab.cli.main(["--help"]) == 0
    assert seen == dict.fromkeys(BLAS_VARIABLES)
