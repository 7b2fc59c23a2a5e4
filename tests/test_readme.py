"""Every shell command of README.md runs as written, in README order, on a fresh copy of the
shipped examples: what a new user types works.

Each fenced ``sh`` block is read the way a shell reads it (continuation lines joined, comments
stripped by shlex); ``vrelab ...`` runs as ``python -m vrelab ...`` in a temporary folder that
holds a copy of ``examples/`` and nothing the commands did not write, so a command that names a
file nobody ships or generates fails here. Later commands find what earlier ones wrote
(``analyze sim/record.h5`` after ``simulate --out sim``). Each must exit 0.

Three kinds of line are not run verbatim, each for a stated reason:
- ``make demo`` / ``make test``: ``make test`` runs this suite (it would recurse) and both build a
  virtual environment; ``make -n TARGET`` checks that the Makefile has the target and that its
  recipe is well formed, and the recipe of ``make demo`` (``vrelab demo``) is run by the tour.
- ``--scheduler tcp://scheduler:8786``: the README's placeholder host; the command runs against a
  dask.distributed LocalCluster's address instead (marker ``dask``).
- ``chromium``: whichever Chromium the browser tests find (marker ``browser``).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
PLACEHOLDER_SCHEDULER = "tcp://scheduler:8786"

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]


def readme_commands(text: str) -> list[list[str]]:
    """The commands of every fenced ``sh`` block, in order, as argument lists."""
    commands: list[list[str]] = []
    for block in re.findall(r"^```sh\n(.*?)^```", text, flags=re.S | re.M):
        logical = ""
        for line in block.splitlines():
            logical += line
            if line.rstrip().endswith("\\"):
                logical = logical.rstrip()[:-1] + " "
                continue
            argv = shlex.split(logical, comments=True)
            logical = ""
            if argv:
                commands.append(argv)
        assert not logical, f"a README command ends in a line continuation: {logical!r}"
    return commands


COMMANDS = readme_commands(README.read_text(encoding="utf-8"))


def _id(argv: list[str]) -> str:
    return " ".join(argv)[:90]


def _marks(argv: list[str]) -> list:
    if PLACEHOLDER_SCHEDULER in argv:
        return [pytest.mark.dask]
    if argv[0] == "chromium":
        return [pytest.mark.browser]
    return []


def test_readme_has_its_tour():
    """The parser finds the README's commands (a change of fence or layout would silently test
    nothing): the CLI tour's subcommands are all there."""
    subcommands = {a[1] for a in COMMANDS if a[0] == "vrelab"}
    assert {"model", "profile", "environment", "predict", "simulate", "channels", "analyze", "campaign",
            "identify", "report", "demo", "sweep"} <= subcommands
    assert len(COMMANDS) >= 30
    assert {a[0] for a in COMMANDS} <= {"vrelab", "make", "chromium"}, "a README command this test cannot run"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    """A fresh folder holding a copy of the shipped examples and the Makefile, nothing else."""
    work = tmp_path_factory.mktemp("readme")
    shutil.copytree(ROOT / "examples", work / "examples", ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("Makefile", "pyproject.toml"):
        shutil.copy2(ROOT / name, work / name)
    return work


@pytest.fixture(scope="module")
def local_scheduler():
    import distributed

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc:
        yield lc.scheduler_address


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    src = str(ROOT / "src")
    env["PYTHONPATH"] = os.pathsep.join([src, env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


@pytest.mark.parametrize("argv", [pytest.param(a, id=_id(a), marks=_marks(a)) for a in COMMANDS])
def test_readme_command_runs(argv: list[str], workspace: Path, request) -> None:
    if argv[0] == "make":
        run = [shutil.which("make") or "make", "-n", *argv[1:]]
    elif argv[0] == "chromium":
        from test_report_browser import _chromium

        run = [_chromium(), *argv[1:]]
    else:
        run = [sys.executable, "-m", "vrelab", *argv[1:]]
    if PLACEHOLDER_SCHEDULER in run:
        address = request.getfixturevalue("local_scheduler")
        run = [address if a == PLACEHOLDER_SCHEDULER else a for a in run]
    proc = subprocess.run(run, cwd=workspace, env=_environment(), capture_output=True, text=True, timeout=240,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, (
        f"README command `{' '.join(argv)}` exited {proc.returncode}\n"
        f"stderr: {proc.stderr[-2000:]}\nstdout: {proc.stdout[-1000:]}")
    if argv[0] == "chromium":
        out = next(a.split("=", 1)[1] for a in argv if a.startswith("--print-to-pdf="))
        assert (workspace / out).read_bytes()[:5] == b"%PDF-"


def test_the_sweep_file_the_readme_shows_is_the_one_it_runs():
    """The README prints examples/sweep.toml and runs it: the two say the same."""
    import tomllib

    text = README.read_text(encoding="utf-8")
    block = re.search(r"`examples/sweep\.toml`:\n\n```toml\n(.*?)^```", text, flags=re.S | re.M)
    assert block, "the README no longer shows examples/sweep.toml"
    assert tomllib.loads(block.group(1)) == tomllib.loads((ROOT / "examples" / "sweep.toml").read_text(encoding="utf-8"))
