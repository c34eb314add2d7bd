"""A booster stage reading earlier residuals models coloured noise (innovations form).

The numbers behind docs/losses.md ("When the Ljung-Box objective helps") come from
benchmarks/bench_innovations.py; this test checks the claim the guide makes on a
smaller budget: with the residual inputs the stage's held-out residual is white at
the innovation level, and the physics alone is far from it.
"""

import numpy as np
import pytest

from skhybrid.diagnostics import ljung_box_test
from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.preprocessing import make_windows

INNOVATION_STD = 0.05


def _episodes(n_episodes, length, rng):
    states, inputs = [], []
    for _ in range(n_episodes):
        u = np.repeat(rng.uniform(-1, 1, length // 5 + 1), 5)[:length]
        x, w = np.zeros(length), 0.0
        for t in range(length - 1):
            w = 0.8 * w + INNOVATION_STD * rng.standard_normal()
            x[t + 1] = 0.8 * x[t] + 0.5 * u[t] + 0.3 * np.sin(2 * x[t]) + w
        states.append(x[:, None])
        inputs.append(u[:, None])
    return states, inputs


@pytest.mark.slow
def test_residual_inputs_reach_white_innovations():
    rng = np.random.default_rng(0)
    X, y = make_windows(*_episodes(6, 1000, rng), n_steps=3)
    X_test, y_test = make_windows(*_episodes(3, 1000, rng), n_steps=3)
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
