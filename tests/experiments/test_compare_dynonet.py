"""The dynoNet comparison script: its message without dynoNet, its two records."""

import re
import sys

import numpy as np
import pytest

SCRIPT = "compare_dynonet_emps.py"


def test_without_dynonet_it_says_how_to_install_it(monkeypatch, benchmark_script):
    monkeypatch.setitem(sys.modules, "dynonet", None)
    with pytest.raises(SystemExit, match=re.escape("pip install --no-deps dynonet")):
        benchmark_script(SCRIPT).main(["--data", "anywhere"])


def test_it_scores_the_estimation_record_whole_and_the_test_after_n_init(
    shared_data_dir, benchmark_script
):
    pytest.importorskip("dynonet", reason="dynoNet is an optional peer")
    row = benchmark_script(SCRIPT).run_seed(
        shared_data_dir, 0, {"iterations": 2, "lr": 1e-4}
    )
    assert set(row) == {"seed", "published", "test", "seconds"}
    # Two Adam steps leave the model far from the data on both records.
    assert np.isfinite(row["published"]) and row["published"] > 10.0
    assert row["test"] != row["published"]
