"""The dynoNet comparison script: its message without dynoNet, its two records."""

import importlib.util
import re
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "compare_dynonet_emps.py"


def _script():
    spec = importlib.util.spec_from_file_location("compare_dynonet", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_without_dynonet_it_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "dynonet", None)
    with pytest.raises(SystemExit, match=re.escape("pip install --no-deps dynonet")):
        _script().main(["--data", "anywhere"])


def test_it_scores_the_estimation_record_whole_and_the_test_after_n_init(
    shared_data_dir,
):
    pytest.importorskip("dynonet", reason="dynoNet is an optional peer")
    row = _script().run_seed(shared_data_dir, 0, {"iterations": 2, "lr": 1e-4})
    assert set(row) == {"seed", "published", "test", "seconds"}
    # Two Adam steps leave the model far from the data on both records.
    assert np.isfinite(row["published"]) and row["published"] > 10.0
    assert row["test"] != row["published"]
