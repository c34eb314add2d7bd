"""Networks that predict the increment of the state (target="increment")."""

import numpy as np
import pytest

from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor
from skhybrid.preprocessing import make_windows


def _positions(rng, n, dt=0.01):
    """A position integrated from a held speed: x(t+1) = x(t) + dt v(t)."""
    v = np.repeat(rng.uniform(-1, 1, n // 20 + 1), 20)[:n]
    x = rng.uniform(-2, 2) + np.concatenate([[0.0], np.cumsum(dt * v)])[:n]
    return x, v


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    x, v = _positions(rng, 3000)
    X, y = make_windows(x[:, None], v[:, None], n_steps=1)
    x_test, v_test = _positions(rng, 1000)
    X_test, y_test = make_windows(x_test[:, None], v_test[:, None], n_steps=1)
    return X, y.ravel(), X_test, y_test.ravel(), x_test, v_test


def _rmse(model, X, y):
    return float(np.sqrt(np.mean((model.predict(X) - y) ** 2)))


@pytest.mark.parametrize(
    "cls, kwargs",
    [
        (DenseRegressor, {"hidden_layer_sizes": (32, 32)}),
        (RNNRegressor, {"hidden_size": 16, "num_layers": 1}),
    ],
)
def test_increment_beats_state_on_slow_system(data, cls, kwargs):
    # Increments are about 0.006 against positions spanning about 2.7.
    # Measured one-step RMSE on held-out rows (30 epochs, same seed):
    #   DenseRegressor(32, 32): state 0.029, increment 0.00015
    #   RNNRegressor(16, 1 layer): state 0.12, increment 0.0003
    X, y, X_test, y_test, *_ = data
    common = {"max_epochs": 30, "batch_size": 64, "random_state": 0, **kwargs}
    state = cls(**common).fit(X, y)
    increment = cls(**common, target="increment").fit(X, y)
    rmse_state, rmse_increment = (
        _rmse(state, X_test, y_test),
        _rmse(increment, X_test, y_test),
    )
    assert rmse_increment < 0.1 * rmse_state
    assert rmse_increment < 0.002
    # target="state" is the default and unchanged.
    explicit = cls(**common, target="state").fit(X, y)
    np.testing.assert_array_equal(explicit.predict(X_test), state.predict(X_test))


def test_increment_horizon_and_simulate(data):
    X, y, X_test, y_test, x_test, v_test = data
    model = RNNRegressor(
        hidden_size=16,
        num_layers=1,
        target="increment",
        horizon=3,
        max_epochs=10,
        batch_size=64,
        random_state=0,
    ).fit(X, y)
    assert _rmse(model, X_test, y_test) < 0.002
    sim = model.simulate(v_test[:, None], x_test[:1, None])
    assert sim.shape == (1000, 1) and np.all(np.isfinite(sim))
    assert sim[0, 0] == x_test[0]
    # Simulation drifts slowly: well within the positions' span.
    assert np.sqrt(np.mean((sim[:, 0] - x_test) ** 2)) < 0.5


def test_increment_reads_newest_step_of_windows():
    # With windows of 3 steps, the state added back is that of the newest step.
    rng = np.random.default_rng(1)
    x, v = _positions(rng, 400)
    X, y = make_windows(x[:, None], v[:, None], n_steps=3)
    dense = DenseRegressor(
        hidden_layer_sizes=(8,), target="increment", max_epochs=3, random_state=0
    ).fit(X, y)
    assert dense._increment_layout.n_steps == 3
    rnn = RNNRegressor(
        hidden_size=4, num_layers=1, n_steps=3, target="increment", max_epochs=3
    ).fit(X, y)
    # Predictions stay close to the newest state even barely trained.
    assert np.max(np.abs(rnn.predict(X)[:, 0] - X[:, 4])) < 0.5


def test_increment_needs_state_columns():
    rng = np.random.default_rng(0)
    X, y = rng.standard_normal((50, 1)), rng.standard_normal((50, 2))
    with pytest.raises(ValueError, match=r"target='increment'.*n_features=1"):
        DenseRegressor(hidden_layer_sizes=(4,), target="increment").fit(X, y)


def test_cyclic_refuses_increment():
    rng = np.random.default_rng(0)
    X, y = rng.standard_normal((50, 2)), rng.standard_normal(50)
    with pytest.raises(ValueError, match="target='increment'"):
        CyclicRegressor(target="increment", max_epochs=1).fit(X, y)


def test_bad_target():
    rng = np.random.default_rng(0)
    X, y = rng.standard_normal((50, 2)), rng.standard_normal(50)
    with pytest.raises(ValueError, match=r"'target'.*'delta'"):
        DenseRegressor(hidden_layer_sizes=(4,), target="delta").fit(X, y)


def test_ensemble_refuses_increment():
    from skhybrid.domain import LinearStateSpaceModel
    from skhybrid.hybrid import HybridEnsembleRegressor

    rng = np.random.default_rng(0)
    X, y = rng.standard_normal((50, 2)), rng.standard_normal(50)
    model = HybridEnsembleRegressor(
        domain=LinearStateSpaceModel(),
        neural=DenseRegressor(hidden_layer_sizes=(4,), target="increment"),
    )
    with pytest.raises(ValueError, match="target='increment'"):
        model.fit(X, y)
