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
"""

from __future__ import annotations

import argparse
import json
import os
import pkgutil
import re
import subprocess
import sys

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
    main(sys.argv[1:])
except SystemExit:
    pass
sys.stderr.write("\\nMODULES " + json.dumps(sorted(sys.modules)) + "\\n")
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
