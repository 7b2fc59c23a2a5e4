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
