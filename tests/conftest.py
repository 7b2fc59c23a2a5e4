import numpy as np
import pytest
from hypothesis import settings

# Hypothesis draws from a fixed seed (derandomize) and keeps no example database: a run is the
# same on every machine, and a clean clone in CI draws what the developer's run drew.
settings.register_profile("vrelab", derandomize=True, database=None)
settings.load_profile("vrelab")


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


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.module is not None and item.module.__name__.rsplit(".", 1)[-1] in HARDENING_MODULES:
            item.add_marker(pytest.mark.hardening)


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
