"""Epoch counting across joblib workers for the progress bar."""

import numpy as np
from joblib import Parallel, delayed

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.experiments._progress import attach_epoch_logger
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor


def test_epoch_logger_counts_epochs_of_nested_networks_in_workers(tmp_path, rng):
    X = rng.standard_normal((120, 3))
    y = X[:, :1] * 0.5 + np.sin(X[:, 1:2])
    path = tmp_path / "epochs.log"
    path.touch()
    models = [
        HybridBoostingRegressor(
            [
                ("linear", LinearStateSpaceModel()),
                ("dense", DenseRegressor((8,), max_epochs=e, random_state=0)),
            ],
            stage_input="window",
        )
        for e in (2, 3)
    ]
    for i, model in enumerate(models):
        attach_epoch_logger(model, path, f"model{i}")
    # A package method, not a test-module function: workers must import it.
    fitted = Parallel(n_jobs=2)(
        delayed(HybridBoostingRegressor.fit)(m, X, y) for m in models
    )
    epochs = [f.stages_[1][1].n_epochs_ for f in fitted]
    lines = path.read_text().splitlines()
    assert sorted(lines) == ["model0"] * epochs[0] + ["model1"] * epochs[1]
    assert epochs == [2, 3]
