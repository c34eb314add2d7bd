"""Training by simulation error: horizon=T rolls the network over T steps."""

import numpy as np
import pytest
import torch

from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor
from skhybrid.neural._modules import RolloutModule
from skhybrid.preprocessing import WindowLayout


def _oscillator(n_exp, n, seed, noise=0.01):
    rng = np.random.default_rng(seed)
    Y, U = [], []
    for _ in range(n_exp):
        u = np.repeat(rng.uniform(-1, 1, n // 25 + 1), 25)[:n, None]
        x = np.zeros((n, 2))
        for t in range(n - 1):
            p, v = x[t]
            v2 = v + 0.05 * (-4 * p - 0.1 * v - p**3 + u[t, 0])
            x[t + 1] = [p + 0.05 * v2, v2]
        Y.append(x[:, :1] + noise * rng.standard_normal((n, 1)))
        U.append(u)
    return Y, U


def test_rollout_equals_free_run_simulation():
    # The training loss of horizon=T compares exactly what simulate produces.
    Y, U = _oscillator(3, 120, 0)
    layout = WindowLayout(1, 1, 3)
    X, y = layout.make_rows(Y, U)
    model = DenseRegressor((16,), horizon=4, max_epochs=3, random_state=0)
    model.fit(X, y)
    assert isinstance(model.net_.module_, RolloutModule)
    start = 10  # row 10 of experiment 0 starts at time 10
    Z = np.concatenate(
        [(X[start] - model.x_mean_) / model.x_scale_, U[0][start + 3 : start + 6, 0]]
    )
    rollout = model.net_.module_.double()
    with torch.no_grad():
        out = rollout(torch.as_tensor(Z[None, :])).numpy().ravel()
    sim = model.simulate(U[0][: start + 7], Y[0][: start + 3])
    expected = (sim[start + 3 : start + 7, 0] - model.y_mean_) / model.y_scale_
    np.testing.assert_allclose(out, expected, rtol=1e-6, atol=1e-6)


def test_horizon_needs_rows_that_continue_each_other():
    Y, U = _oscillator(1, 80, 1)
    X, y = WindowLayout(1, 1, 2).make_rows(Y, U)
    perm = np.random.default_rng(0).permutation(len(X))
    model = RNNRegressor(n_steps=2, horizon=5, max_epochs=2)
    with pytest.raises(ValueError, match="horizon=5: no 5 consecutive rows"):
        model.fit(X[perm], y[perm])
    with pytest.raises(ValueError, match="objective='mse' only"):
        RNNRegressor(n_steps=2, horizon=5, objective="ljung_box").fit(X, y)
    with pytest.raises(ValueError, match="CyclicRegressor trains one step ahead"):
        CyclicRegressor((8,), horizon=3, max_epochs=2).fit(X[:, -2:], y)


@pytest.mark.slow
def test_horizon_training_lowers_the_free_run_error():
    # A lightly damped oscillator measured with noise: trained one step ahead the
    # network drifts in free run; trained over 10 simulated steps it drifts less.
    Y, U = _oscillator(8, 600, 0)
    Y_test, U_test = _oscillator(4, 600, 1)
    X, y = WindowLayout(1, 1, 3).make_rows(Y, U)
    errors = {}
    for horizon in (1, 10):
        model = RNNRegressor(
            hidden_size=32,
            num_layers=1,
            n_steps=3,
            horizon=horizon,
            max_epochs=60,
            batch_size=128,
            lr=0.003,
            random_state=0,
        ).fit(X, y)
        sim = model.simulate(np.stack(U_test), np.stack(Y_test)[:, :3])
        errors[horizon] = np.sqrt(np.mean((sim[:, 3:] - np.stack(Y_test)[:, 3:]) ** 2))
    assert errors[10] < 0.85 * errors[1], errors
