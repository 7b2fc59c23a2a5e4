"""Every shell command and Python block of README.md and of the manual's pages runs as written,
in page order, on a fresh copy of the shipped examples: what a new user types works.

Each page gets its own folder (a reader starts from any page), holding a copy of ``examples/``
and nothing its own commands did not write, so a command that names a file nobody ships or
generates, or that leans on another page's output, fails here. Within a page later blocks find
what earlier ones wrote (``analyze sim/record.h5`` after ``simulate --out sim``) and Python blocks
share one namespace (a reader pasting them in order). Each command must exit 0, each block run.

Each fenced ``sh`` block is read the way a shell reads it (continuation lines joined, comments
stripped by shlex); ``vrelab ...`` runs as ``python -m vrelab ...``. README's Python blocks run in
tests/test_front_door.py (the front door's own test); the pages' here.

Three kinds of line are not run verbatim, each for a stated reason:
- ``make demo`` / ``make test`` / ``make examples``: ``make test`` runs this suite (it would
  recurse) and both build a virtual environment; ``make -n TARGET`` checks that the Makefile has
  the target and that its recipe is well formed (the shipped examples are copied in already).
- ``--scheduler tcp://scheduler:8786``: the page's placeholder host; the command runs against a
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
# README first; the manual's pages with commands a reader types (the physics page has none; the
# gallery's examples run at the docs' build)
PAGES = ("README.md", "docs/tour.md", "docs/environments.md", "docs/designer-path.md",
         "docs/tutorial-test-engineer.md", "docs/tutorial-designer.md", "docs/index.md")
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


def page_steps(page: str) -> list[tuple[str, object]]:
    """A page's steps in order: ("sh", argv) per command, ("python", source) per Python block
    (README's Python runs in test_front_door)."""
    text = (ROOT / page).read_text(encoding="utf-8")
    steps: list[tuple[str, object]] = []
    for m in re.finditer(r"^```(sh|python)\n(.*?)^```", text, flags=re.S | re.M):
        if m.group(1) == "sh":
            steps += [("sh", argv) for argv in readme_commands(f"```sh\n{m.group(2)}```\n")]
        elif page != "README.md":
            steps.append(("python", m.group(2)))
    return steps


STEPS = [(page, k, kind, what) for page in PAGES for k, (kind, what) in enumerate(page_steps(page))]
# Where each page's steps run: a page is one worker's (its steps share a folder, in order), and
# pytest-xdist's --dist loadfile gives a worker whole files, so the heavy pages (each runs a
# campaign and a report) are files of their own, run beside each other rather than one after
# another on one worker. Every page is in exactly one (test_every_page_runs_in_one_file).
PAGE_FILES = {
    "test_readme": ("README.md", "docs/environments.md", "docs/index.md"),
    "test_readme_tour": ("docs/tour.md",),
    "test_readme_tutorials": ("docs/designer-path.md", "docs/tutorial-test-engineer.md", "docs/tutorial-designer.md"),
}


def page_step_params(pages: tuple[str, ...]) -> list:
    """The steps of ``pages``, as pytest params of :func:`test_page_step_runs`."""
    return [pytest.param(*s, id=_step_id(*s), marks=_marks(s[3])) for s in STEPS if s[0] in pages]


def _id(argv: list[str]) -> str:
    return " ".join(argv)[:90]


def _step_id(page: str, k: int, kind: str, what: object) -> str:
    label = _id(what) if kind == "sh" else "python: " + " ".join(str(what).split())[:70]
    return f"{Path(page).stem}-{k}: {label}"


def _marks(argv: object) -> list:
    if not isinstance(argv, list):
        return []
    if PLACEHOLDER_SCHEDULER in argv:
        return [pytest.mark.dask]
    if argv[0] == "chromium":
        return [pytest.mark.browser]
    return []


def test_readme_and_the_tour_have_their_commands():
    """The parser finds the commands (a change of fence or layout would silently test nothing):
    README's five-command tour, and every subcommand in the manual's tour."""
    assert {a[1] for a in COMMANDS if a[0] == "vrelab"} >= {"model", "predict", "simulate", "campaign", "report"}
    tour = [what for kind, what in page_steps("docs/tour.md") if kind == "sh"]
    assert {"model", "profile", "environment", "predict", "simulate", "channels", "analyze", "campaign",
            "identify", "report", "demo", "sweep"} <= {a[1] for a in tour if a[0] == "vrelab"}
    assert len(tour) >= 30
    every = [what for s in STEPS if s[2] == "sh" for what in [s[3]]]
    assert {a[0] for a in every} <= {"vrelab", "make", "chromium"}, "a command this test cannot run"


def test_every_page_with_commands_has_some():
    """The parser finds each page's blocks (a change of fence would silently test nothing)."""
    for page in PAGES:
        assert page_steps(page) or page == "README.md" and COMMANDS, f"{page}: no sh or python block found"


@pytest.fixture(scope="module")
def workspaces(tmp_path_factory) -> dict[str, tuple[Path, dict]]:
    """Per page, made on its first step: a fresh folder holding a copy of the shipped examples
    and the Makefile, nothing else, and the namespace its Python blocks share."""
    made: dict[str, tuple[Path, dict]] = {}
    return made


def _workspace(workspaces: dict[str, tuple[Path, dict]], page: str, tmp_path_factory) -> tuple[Path, dict]:
    if page not in workspaces:
        work = tmp_path_factory.mktemp(Path(page).stem)
        fill_page_folder(work)
        workspaces[page] = (work, {"__name__": f"page_{Path(page).stem}"})
    return workspaces[page]


def fill_page_folder(work: Path) -> None:
    """What a page's folder holds before its first step: a copy of the shipped examples, the
    Makefile and pyproject.toml (SHIPPED)."""
    shutil.copytree(ROOT / "examples", work / "examples", ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("Makefile", "pyproject.toml"):
        shutil.copy2(ROOT / name, work / name)


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


def test_every_page_runs_in_one_file():
    """Each page's steps run in exactly one test file (PAGE_FILES), and each of those files runs
    its pages' steps: splitting the pages across files drops none."""
    import importlib

    listed = [page for pages in PAGE_FILES.values() for page in pages]
    assert sorted(listed) == sorted(PAGES), "a page in no file, or in two"
    for name, pages in PAGE_FILES.items():
        module = importlib.import_module(name)
        marks = [m for m in module.test_page_step_runs.pytestmark if m.name == "parametrize"]
        assert [p.values[0] for p in marks[0].args[1]] == [s[0] for s in STEPS if s[0] in pages], name


@pytest.mark.parametrize(("page", "k", "kind", "what"), page_step_params(PAGE_FILES["test_readme"]))
def test_page_step_runs(page: str, k: int, kind: str, what: object, workspaces, tmp_path_factory,
                        request, monkeypatch) -> None:
    run_page_step(page, k, kind, what, workspaces, tmp_path_factory, request, monkeypatch)


def run_page_step(page: str, k: int, kind: str, what: object, workspaces, tmp_path_factory,
                  request, monkeypatch) -> None:
    """One step of a page, in the page's folder: a Python block in its namespace, a command as a
    subprocess that must exit 0."""
    workspace, namespace = _workspace(workspaces, page, tmp_path_factory)
    if kind == "python":
        monkeypatch.chdir(workspace)
        exec(compile(str(what), f"{page} (block {k})", "exec"), namespace)
        return
    assert isinstance(what, list)
    _run_command(what, workspace, request)


def _run_command(argv: list[str], workspace: Path, request) -> None:
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
        rc, out, err = _run(run, workspace)  # the cluster's address is this run's own: nothing to share
    else:
        rc, out, err = run_once_per_inputs(argv, run, workspace, _shared_commands(request))
    assert rc == 0, (
        f"command `{' '.join(argv)}` exited {rc}\n"
        f"stderr: {err[-2000:]}\nstdout: {out[-1000:]}")
    if argv[0] == "chromium":
        out = next(a.split("=", 1)[1] for a in argv if a.startswith("--print-to-pdf="))
        assert (workspace / out).read_bytes()[:5] == b"%PDF-"


def _run(run: list[str], workspace: Path) -> tuple[int, str, str]:
    proc = subprocess.run(run, cwd=workspace, env=_environment(), capture_output=True, text=True, timeout=240,
                          stdin=subprocess.DEVNULL)
    return proc.returncode, proc.stdout, proc.stderr


# The same command on the same inputs, once per session. Several pages quote the same command line
# (the example campaign `--out camp` on five pages, `report camp --metadata ...` on three, `identify
# camp` on three...): ~20 s of CPU each (the report's figures, the campaign's reductions), 40 % of
# the pages' time. Each page still runs in its own folder and each of its steps is the page's text:
# a step whose command line and inputs (below) equal a step run earlier in this session, by any
# page on any worker, gets that run's exit status and output and the files it wrote, copied into
# its own folder; any other step runs. A run that failed is not shared (the next page runs it
# again, and fails in its own right), nor one whose files name the folder it ran in (the printed
# PDF's metadata: a copy would point at another page's folder).
#
# The inputs of a command: the shipped examples (`examples/`, the Makefile, pyproject.toml: the same
# copy in every folder, hashed all the same) and every top-level entry of the page's folder its
# command line names (`camp` of `report camp`, `ident` of `ident/sensor.toml`, `camp-report.pdf`
# of `--print-to-pdf=camp-report.pdf`), each by its whole content, or its absence. A vrelab command
# reads only the files its arguments name (the manifests it reads name files of examples/ only), so
# two folders equal on these give the same run. A page whose earlier step wrote `camp` differently
# (tutorial-test-engineer's second campaign, `--limit 0.4`), or never wrote it, has other inputs.
SHIPPED = ("examples", "Makefile", "pyproject.toml")


def _shared_commands(request) -> Path:
    """In the folder every worker of this session shares (tests/conftest.py's session_folder)."""
    from conftest import session_folder

    return shared_commands(session_folder(request.getfixturevalue("tmp_path_factory"), request.getfixturevalue("worker_id")))


def shared_commands(session: Path) -> Path:
    """Where run_once_per_inputs keeps the runs it shares, in the session's shared folder."""
    return session / "page-commands"


def run_page_command(argv: list[str], workspace: Path, session: Path) -> tuple[int, str, str]:
    """A page's ``vrelab ...`` command line run in ``workspace`` (a page's folder: see
    fill_page_folder) as the pages run it, sharing its run with every page step of this session
    that runs the same line on the same inputs (tests/conftest.py's fixtures of the example
    campaign, its report and the README's sweep run the pages' own lines: one run serves both)."""
    assert argv[0] == "vrelab", argv
    return run_once_per_inputs(argv, [sys.executable, "-m", "vrelab", *argv[1:]], workspace, shared_commands(session))


def _named_entries(argv: list[str]) -> set[str] | None:
    """The top-level names of the folder that ``argv`` may read or write, the shipped examples
    included; None when an argument reaches outside the folder (not shared)."""
    names = set(SHIPPED)
    for token in argv[1:]:
        value = token.split("=", 1)[1] if token.startswith("-") and "=" in token else token
        if not value or value.startswith("-"):
            continue
        path = Path(value)
        if path.is_absolute() or ".." in path.parts:
            return None
        names.add(path.parts[0])
    return names


def _digest(argv: list[str], workspace: Path) -> str | None:
    """The command line and the content of every entry it names (see above), as one sha256."""
    import hashlib

    names = _named_entries(argv)
    if names is None:
        return None
    h = hashlib.sha256(repr(argv).encode())
    for name in sorted(names):
        top = workspace / name
        h.update(b"\0entry " + name.encode())
        files = sorted(p for p in top.rglob("*") if p.is_file()) if top.is_dir() else [top] if top.is_file() else []
        if not top.exists():
            h.update(b"\0absent")
        for f in files:
            h.update(b"\0file " + f.relative_to(workspace).as_posix().encode() + b"\0")
            h.update(hashlib.sha256(f.read_bytes()).digest())
    return h.hexdigest()


def _state(workspace: Path) -> tuple[dict[str, tuple[int, int]], set[str]]:
    """Every file of the folder (size, mtime) and every directory, by relative path."""
    files, dirs = {}, set()
    for p in workspace.rglob("*"):
        rel = p.relative_to(workspace).as_posix()
        if p.is_dir():
            dirs.add(rel)
        elif p.is_file():
            st = p.stat()
            files[rel] = (st.st_size, st.st_mtime_ns)
    return files, dirs


def run_once_per_inputs(argv: list[str], run: list[str], workspace: Path, shared: Path) -> tuple[int, str, str]:
    """``run`` (the page's ``argv`` as it runs here) in ``workspace``, or, when a step with the same
    command line and inputs ran before in this session, its result and the files it wrote copied
    into ``workspace``: the exit status, stdout and stderr."""
    import fcntl
    import json

    key = _digest(argv, workspace)
    if key is None:
        return _run(run, workspace)
    shared.mkdir(parents=True, exist_ok=True)
    entry = shared / key
    with open(shared / f".{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if (entry / "result.json").is_file():
            result = json.loads((entry / "result.json").read_text())
            for rel in result["deleted"]:
                target = workspace / rel
                shutil.rmtree(target) if target.is_dir() else target.unlink(missing_ok=True)
            for rel in result["dirs"]:
                (workspace / rel).mkdir(parents=True, exist_ok=True)
            for rel in result["written"]:
                shutil.copy2(entry / "files" / rel, workspace / rel)
            return result["rc"], result["stdout"], result["stderr"]
        files, dirs = _state(workspace)
        rc, out, err = _run(run, workspace)
        after, after_dirs = _state(workspace)
        written = sorted(rel for rel, stat in after.items() if files.get(rel) != stat)
        own = str(workspace.resolve()).encode()
        if rc == 0 and not any(own in (workspace / rel).read_bytes() for rel in written):
            shutil.rmtree(entry, ignore_errors=True)
            for rel in written:
                (entry / "files" / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(workspace / rel, entry / "files" / rel)
            deleted = sorted(set(files) - set(after)) + sorted(dirs - after_dirs)
            entry.mkdir(parents=True, exist_ok=True)  # a command that prints only wrote no file
            (entry / "result.json").write_text(json.dumps(
                {"rc": rc, "stdout": out, "stderr": err, "written": written, "deleted": deleted,
                 "dirs": sorted(after_dirs - dirs)}))
        return rc, out, err


def test_the_shared_outputs_are_the_pages_own_command_lines():
    """tests/conftest.py builds the example campaign, its report and the README's sweep by the
    pages' own command lines, so that one run serves the fixtures and the pages' steps: each line
    is still a step of a page (a page that changes its line would leave both running, twice)."""
    from conftest import CAMPAIGN_LINE, CAMPAIGN_REPORT_LINE, SWEEP_LINE

    lines = [what for s in STEPS if s[2] == "sh" for what in [s[3]]]
    for line in (CAMPAIGN_LINE, CAMPAIGN_REPORT_LINE, SWEEP_LINE):
        assert line in lines, f"no page runs `{' '.join(line)}`: update tests/conftest.py to a line a page runs"


def test_the_sweep_file_the_readme_shows_is_the_one_it_runs():
    """The README prints examples/sweep.toml and runs it: the two say the same."""
    import tomllib

    text = (ROOT / "docs" / "tour.md").read_text(encoding="utf-8")
    block = re.search(r"`examples/sweep\.toml`:\n\n```toml\n(.*?)^```", text, flags=re.S | re.M)
    assert block, "the tour no longer shows examples/sweep.toml"
    assert tomllib.loads(block.group(1)) == tomllib.loads((ROOT / "examples" / "sweep.toml").read_text(encoding="utf-8"))


def test_a_step_shares_a_run_only_with_the_same_command_on_the_same_inputs(tmp_path):
    """run_once_per_inputs: a second folder with the same command line, the same shipped examples
    and the same named entries gets the first run's status, output and files without a run; a
    different named input, shipped file or command line runs; a failed run, or one whose files
    name its folder, is not shared."""
    runs = tmp_path / "runs.txt"
    runs.write_text("")
    # `tool IN OUT [--name-folder]`: OUT/copy holds IN (or the folder's path), each run counted
    counted = "import pathlib, sys; runs = pathlib.Path(sys.argv[1]); runs.write_text(runs.read_text() + 'x');"
    tool = (counted + " text = pathlib.Path(sys.argv[2]).read_text(); out = pathlib.Path(sys.argv[3]); out.mkdir();"
            " (out / 'copy').write_text(str(pathlib.Path.cwd().resolve()) if sys.argv[4:] else text); print('ran', text)")
    printer = counted + " print('ran', pathlib.Path(sys.argv[2]).read_text())"  # `printer IN`: writes no file

    def step(name: str, argv: list[str], text: str | None, shipped: str = "shipped", script: str = tool,
             ) -> tuple[int, str, Path]:
        work = tmp_path / name
        (work / "examples").mkdir(parents=True)
        (work / "examples" / "data.txt").write_text(shipped)
        if text is not None:
            (work / "in.txt").write_text(text)
        rc, out, _ = run_once_per_inputs(argv, [sys.executable, "-c", script, str(runs), *argv[1:]], work, tmp_path / "shared")
        copy = work / "out" / "copy"
        return rc, out, copy

    argv = ["tool", "in.txt", "out"]
    assert step("a", argv, "1")[:2] == (0, "ran 1\n") and len(runs.read_text()) == 1
    rc, out, copy = step("b", argv, "1")  # same command, same inputs: a's run, copied
    assert (rc, out, copy.read_text(), len(runs.read_text())) == (0, "ran 1\n", "1", 1)
    rc, out, copy = step("c", argv, "2")  # the named input differs
    assert (rc, copy.read_text(), len(runs.read_text())) == (0, "2", 2)
    assert step("d", argv, "1", shipped="other")[0] == 0 and len(runs.read_text()) == 3  # other examples
    assert step("e", ["tool", "in.txt", "out", "-v"], "1")[0] == 0 and len(runs.read_text()) == 4  # other line
    printing = ["printer", "in.txt"]  # writes no file: its output alone is shared
    assert step("j", printing, "1", script=printer)[:2] == (0, "ran 1\n") == step("k", printing, "1", script=printer)[:2]
    assert len(runs.read_text()) == 5
    assert step("f", argv, None)[0] != 0 and step("g", argv, None)[0] != 0  # no input: fails, each time
    assert len(runs.read_text()) == 7
    named = ["tool", "in.txt", "out", "--name-folder"]
    assert step("h", named, "1")[0] == 0 and step("i", named, "1")[2].read_text() == str((tmp_path / "i").resolve())
    assert len(runs.read_text()) == 9  # each wrote its own folder's path: not shared
