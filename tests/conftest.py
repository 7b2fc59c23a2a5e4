import os

import numpy as np
import pytest
from hypothesis import settings

# Hypothesis draws from a fixed seed (derandomize) and keeps no example database: a run is the
# same on every machine, and a clean clone in CI draws what the developer's run drew.
settings.register_profile("vrelab", derandomize=True, database=None)
settings.load_profile("vrelab")

# The suite writes nothing into the user's home: `vrelab analyze` remembers a file's SHA-256 under
# ~/.cache (vrelab._digests); here it computes every digest afresh. Set before any test runs, so the
# CLI subprocesses inherit it; tests/test_digests.py exercises the cache with its own folder.
os.environ["VRELAB_NO_DIGEST_CACHE"] = "1"


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random test is reproducible."""
    return np.random.default_rng(20161121)


# The hardening suite (issue 23: a crafted file, a bomb, a runaway input) runs under a memory cap,
# so a case that would allocate without bound fails here with MemoryError instead of taking the
# machine (24 GiB, shared with the rest of the suite) down with it; pytest-timeout bounds its time.
# The cap is the soft address-space limit, inherited by the CLI subprocesses these tests start,
# and restored after each test. 6 GiB: numpy, scipy, h5py and their thread pools map ~1-2 GiB of
# address space at import; a healthy run of any hardening case stays well below the cap.
HARDENING_MODULES = ("test_hardening_folders", "test_hardening_inputs", "test_untrusted")
HARDENING_CAP_BYTES = 6 * 1024**3


# The heaviest test files, heaviest first (one worker's seconds at 3dfc271 on a 2-core CI clone,
# `--durations`: the tour's page ~150 s, identify's recovery 86 s, campaign 71 s, sweep 69 s, mypy
# 55 s, the docs' build 47 s...). `make test` runs `--dist loadfile --no-loadscope-reorder`: each
# worker takes the next whole file in collection order, so these go first and the light files fill
# in behind them (longest first: no worker left alone on a heavy file at the end, as when xdist
# orders the files by their number of tests and the one-test heavy files came last).
HEAVY_FIRST = ("test_readme_tour", "test_identify_recovery", "test_campaign", "test_sweep", "test_lint",
               "test_readme_tutorials", "test_readme", "test_docs", "test_imports", "test_triaxial_identify_sim",
               "test_demo", "test_coverage", "test_report_layout", "test_predict", "test_identify_honest",
               "test_gum", "test_one_predict", "test_report_browser")


def _file_order(items) -> list:
    """``items`` grouped by file: the HEAVY_FIRST files in that order, then the others by their
    number of tests, most first (xdist's own order for --dist loadfile), each file's tests in
    their order."""
    by_file: dict[str, list] = {}
    for item in items:
        by_file.setdefault(item.nodeid.split("::", 1)[0], []).append(item)

    def rank(path: str) -> tuple[int, int]:
        stem = path.rsplit("/", 1)[-1].removesuffix(".py")
        return (HEAVY_FIRST.index(stem) if stem in HEAVY_FIRST else len(HEAVY_FIRST), -len(by_file[path]))

    return [item for path in sorted(by_file, key=rank) for item in by_file[path]]


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.module is not None and item.module.__name__.rsplit(".", 1)[-1] in HARDENING_MODULES:
            item.add_marker(pytest.mark.hardening)
    items[:] = _file_order(items)


@pytest.fixture(autouse=True)
def _memory_cap_for_hardening(request):
    if request.node.get_closest_marker("hardening") is None:
        yield
        return
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = HARDENING_CAP_BYTES if hard == resource.RLIM_INFINITY else min(HARDENING_CAP_BYTES, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


# The example campaign's recordings (examples/campaign/runs/) are not committed: `make examples`
# generates them, and so does this fixture when pytest runs without make. One file lock, so that
# the pytest-xdist workers generate them once; the one function does it (vrelab.example_campaign).
@pytest.fixture(scope="session", autouse=True)
def _example_campaign() -> None:
    import fcntl
    from pathlib import Path

    from vrelab.example_campaign import ensure_campaign

    folder = Path(__file__).resolve().parent.parent / "examples" / "campaign"
    (folder / "runs").mkdir(exist_ok=True)
    with open(folder / "runs" / ".generate.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        ensure_campaign(folder)


# Outputs that several test files only read (the example campaign reduced and reported, the quick
# demo, the README's sweep and its report) are built once per run, not once per file: ~55 s of CPU
# each time (most of it the reports' matplotlib figures), and the report-layout file built all of
# them in one fixture, which reached pytest-timeout's 300 s on a loaded machine. With
# pytest-xdist the workers share one folder (the parent of each worker's basetemp) and a file
# lock: the first worker to ask builds, the others wait and read. Readers never write into these
# folders (a test that writes copies first: see copy_shared).
def session_folder(tmp_path_factory: pytest.TempPathFactory, worker_id: str):
    """The folder every worker of this session shares: the parent of each worker's basetemp."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if worker_id != "master" else base


def _shared_root(tmp_path_factory: pytest.TempPathFactory, worker_id: str):
    return session_folder(tmp_path_factory, worker_id) / "shared-outputs"


def _built(root, name: str, build):
    """``build(folder)`` once into ``root/name`` across workers; ``folder/.done`` marks it whole."""
    import fcntl

    root.mkdir(parents=True, exist_ok=True)
    folder = root / name
    with open(root / f".{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / ".done").is_file():
            import shutil

            shutil.rmtree(folder, ignore_errors=True)  # a build that failed half-way
            folder.mkdir()
            build(folder)
            (folder / ".done").write_text("")
    return folder


def _cli(argv: list[str]) -> tuple[int, str, str]:
    """``vrelab argv`` in this process (the import is paid once): exit code, stdout, stderr."""
    import contextlib
    import io

    from vrelab.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(argv)
    return rc, out.getvalue(), err.getvalue()


def _checked(argv: list[str]) -> str:
    rc, out, err = _cli(argv)
    assert rc == 0, f"vrelab {' '.join(argv)}: {err[-1500:]}"
    return out


# The example campaign, its report and the README's sweep are the pages' own command lines
# (docs/tour.md and README.md run them; tests/test_readme.py checks that they still do), run the way
# the pages run them, in a folder like a page's: test_readme.run_once_per_inputs runs each line once
# per session for these fixtures and the pages' steps alike (~30 s of CPU: the campaign, its report's
# figures, the sweep), so these outputs are the very ones the pages' later steps read.
CAMPAIGN_LINE = ["vrelab", "campaign", "examples/campaign/campaign.toml", "--workers", "2", "--out", "camp"]
CAMPAIGN_REPORT_LINE = ["vrelab", "report", "camp", "--metadata", "examples/report-metadata.toml"]
SWEEP_LINE = ["vrelab", "sweep", "examples/sweep.toml", "--workers", "2", "--out", "sweep-out"]


def _page_line(argv: list[str], folder, tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> str:
    """``argv`` (a page's command line) run in ``folder`` as the pages run it; its stdout."""
    from test_readme import run_page_command

    rc, out, err = run_page_command(argv, folder, session_folder(tmp_path_factory, worker_id))
    assert rc == 0, f"{' '.join(argv)}: {err[-1500:]}"
    return out


@pytest.fixture(scope="session")
def example_campaign_out(tmp_path_factory: pytest.TempPathFactory, worker_id: str, _example_campaign: None):
    """`vrelab campaign examples/campaign/campaign.toml --workers 2 --out camp` (CAMPAIGN_LINE; read
    only): a page's folder holding its output folder ``camp`` and the command's stdout,
    ``cli-stdout.txt``."""
    from test_readme import fill_page_folder

    def build(folder) -> None:
        fill_page_folder(folder)
        (folder / "cli-stdout.txt").write_text(_page_line(CAMPAIGN_LINE, folder, tmp_path_factory, worker_id))

    return _built(_shared_root(tmp_path_factory, worker_id), "example-campaign", build)


@pytest.fixture(scope="session")
def example_campaign_report(tmp_path_factory: pytest.TempPathFactory, worker_id: str, example_campaign_out):
    """`vrelab report camp --metadata examples/report-metadata.toml` (CAMPAIGN_REPORT_LINE) on a copy
    of example_campaign_out (read only; the report is its own fixture, so that a test that needs the
    campaign only does not wait for the report's figures)."""
    import shutil

    def build(folder) -> None:
        shutil.copytree(example_campaign_out, folder, dirs_exist_ok=True, ignore=shutil.ignore_patterns(".done"))
        _page_line(CAMPAIGN_REPORT_LINE, folder, tmp_path_factory, worker_id)

    return _built(_shared_root(tmp_path_factory, worker_id), "example-campaign-report", build)


@pytest.fixture(scope="session")
def quick_demo_out(tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> dict:
    """`vrelab demo --quick --json --metadata` (tests/test_report_browser.METADATA), read only: the
    folder ``out``, the exit code, stdout and stderr."""
    import json

    def build(folder) -> None:
        from test_report_browser import METADATA

        (folder / "meta.toml").write_text(METADATA)
        rc, out, err = _cli(["demo", "--quick", "--out", str(folder / "demo-out"), "--json", "--metadata",
                             str(folder / "meta.toml")])
        (folder / "cli.json").write_text(json.dumps({"rc": rc, "stdout": out, "stderr": err}))

    folder = _built(_shared_root(tmp_path_factory, worker_id), "quick-demo", build)
    return {"out": folder / "demo-out"} | json.loads((folder / "cli.json").read_text())


@pytest.fixture(scope="session")
def readme_sweep_out(tmp_path_factory: pytest.TempPathFactory, worker_id: str):
    """`vrelab sweep examples/sweep.toml --workers 2 --out sweep-out` (SWEEP_LINE, the tour's), then
    `vrelab report` on its folder (read only): the folder ``sweep-out``."""

    def build(folder) -> None:
        from test_readme import fill_page_folder

        fill_page_folder(folder)
        _page_line(SWEEP_LINE, folder, tmp_path_factory, worker_id)
        _checked(["report", str(folder / "sweep-out")])

    return _built(_shared_root(tmp_path_factory, worker_id), "readme-sweep", build) / "sweep-out"


# The demo's and the campaign's reports in headless Chromium, once per run: one launch and one
# load of the page (6-7 MB, 11 and 30 interactive figures) serves tests/test_report_layout.py's
# measurements (taken first, before the mouse moves an axis) and then the render of
# tests/test_demo.py and tests/test_campaign.py (the demo's figures hovered and zoomed), the
# screenshot and the A4 print, which two launches did before. Read only: {"state", "events"} of render_in_chromium, "pdf" and "screenshot".
def _visit(tmp_path_factory: pytest.TempPathFactory, worker_id: str, report, screenshot: str, exercise: bool) -> dict:
    import json
    import shutil

    from test_report_browser import SCREENSHOT_DIR

    name = screenshot.rsplit(".", 1)[0]

    def build(folder) -> None:
        from test_report_browser import render_in_chromium
        from test_report_layout import measure_layout

        state, events = render_in_chromium(report, folder, SCREENSHOT_DIR / screenshot, pdf=folder / "report.pdf",
                                           exercise=exercise, measure=measure_layout)
        shutil.rmtree(folder / "chromium-profile", ignore_errors=True)
        (folder / "visit.json").write_text(json.dumps({"state": state, "events": events}))
        shutil.copy2(folder / "report.pdf", SCREENSHOT_DIR / f"{name}.pdf")  # beside the screenshot, for a person

    folder = _built(_shared_root(tmp_path_factory, worker_id), f"chromium-{name}", build)
    return json.loads((folder / "visit.json").read_text()) | {"pdf": folder / "report.pdf",
                                                              "screenshot": SCREENSHOT_DIR / screenshot}


@pytest.fixture(scope="session")
def demo_visit(tmp_path_factory: pytest.TempPathFactory, worker_id: str, quick_demo_out: dict) -> dict:
    """quick_demo_out's report visited (see _visit), its figures hovered and zoomed."""
    return _visit(tmp_path_factory, worker_id, quick_demo_out["out"] / "report.html", "demo-report.jpg", exercise=True)


@pytest.fixture(scope="session")
def campaign_visit(tmp_path_factory: pytest.TempPathFactory, worker_id: str, example_campaign_report) -> dict:
    """example_campaign_report's report visited (see _visit): the paper only, its 30 figures not
    hovered (minutes of waits on a loaded machine; the demo's are, on the same page code)."""
    return _visit(tmp_path_factory, worker_id, example_campaign_report / "camp" / "report.html", "campaign-report.jpg",
                  exercise=False)

