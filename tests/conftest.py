"""Shared fixtures: seeds, the Agg backend and the real-data folder."""

import os
from pathlib import Path

import numpy as np
import pytest

DATA_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture
def global_random_seed():
    """Seed for randomised tests; set SKHYBRID_TESTS_GLOBAL_RANDOM_SEED to sweep."""
    return int(os.environ.get("SKHYBRID_TESTS_GLOBAL_RANDOM_SEED", "42"))


@pytest.fixture
def rng(global_random_seed):
    return np.random.default_rng(global_random_seed)


@pytest.fixture
def pyplot():
    """matplotlib.pyplot on the Agg backend; closes every figure afterwards."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    yield plt
    plt.close("all")


@pytest.fixture(scope="session")
def shared_data_dir():
    """The measured benchmark data beside the clone; skip where it is absent."""
    if not DATA_DIR.is_dir():
        pytest.skip(f"the shared benchmark data is not present at {DATA_DIR}")
    return DATA_DIR
