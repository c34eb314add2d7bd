"""A booster stage reading earlier residuals models coloured noise (innovations form).

The numbers behind docs/losses.md ("When the Ljung-Box objective helps") come from
benchmarks/bench_innovations.py; this test checks the claim the guide makes on a
smaller budget: with the residual inputs the stage's held-out residual is white at
the innovation level, and the physics alone is far from it.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from skhybrid.diagnostics import ljung_box_test
from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.preprocessing import make_windows

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from bench_innovations import INNOVATION_STD, simulate


@pytest.mark.slow
def test_residual_inputs_reach_white_innovations():
    rng = np.random.default_rng(0)
    X, y = make_windows(*simulate(6, 1000, rng), n_steps=3)
    X_test, y_test = make_windows(*simulate(3, 1000, rng), n_steps=3)
    model = HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel(n_steps=3)),
            ("nn", DenseRegressor((32, 32), max_epochs=80, batch_size=256)),
        ],
        stage_input="window+prediction+residuals",
        n_steps=3,
        random_state=0,
    ).fit(X, y)
    physics = model.decompose(X_test).physics
    residual = (y_test - model.predict(X_test)).ravel()
    assert np.std(y_test.ravel() - physics) > 2 * INNOVATION_STD
    assert np.std(residual) < 1.1 * INNOVATION_STD
    assert ljung_box_test(residual, lags=20).pvalue[0] > 0.01
