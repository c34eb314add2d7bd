"""Every gallery example runs (under the Agg backend) and draws a figure."""

import runpy
from pathlib import Path

import matplotlib
import pytest

EXAMPLES = sorted(
    (Path(__file__).resolve().parent.parent / "examples").glob("plot_*.py")
)


def test_there_are_at_least_eight_examples():
    assert len(EXAMPLES) >= 8, [p.name for p in EXAMPLES]


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_and_draws(path, monkeypatch, request):
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if path.stem.startswith("plot_measured"):  # reads the measured data
        monkeypatch.setenv(
            "SKHYBRID_DATA", str(request.getfixturevalue("shared_data_dir"))
        )
    monkeypatch.setattr(plt, "show", lambda *a, **k: None)
    plt.close("all")
    runpy.run_path(str(path), run_name="__main__")
    assert plt.get_fignums(), f"{path.name} drew no figure"
    plt.close("all")
