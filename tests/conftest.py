"""Shared fixtures: seeds, the Agg backend, the real-data folder, headless Chromium."""

import os
import shutil
import subprocess
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


@pytest.fixture
def rendered_dom(tmp_path):
    """A function that opens an HTML page in headless Chromium and returns its DOM.

    Skips the test where no Chromium is installed (``apt-get install chromium``).
    The page is loaded from disk with a fresh profile and 5 s of virtual time, so
    scripts that run on ``load`` have run when the DOM is dumped.
    """
    browser = next(
        (
            path
            for name in ("chromium", "chromium-browser", "google-chrome")
            if (path := shutil.which(name))
        ),
        None,
    )
    if browser is None:
        pytest.skip("no Chromium on this machine (apt-get install chromium)")

    def render(page):
        out = subprocess.run(
            [
                browser,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--no-first-run",
                f"--user-data-dir={tmp_path / 'profile'}",
                "--virtual-time-budget=5000",
                "--dump-dom",
                page.as_uri(),
            ],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        return out.stdout, out.stderr

    return render
