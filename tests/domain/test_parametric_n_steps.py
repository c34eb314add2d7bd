"""ParametricModel checks n_steps against the rows at fit (issue 26)."""

import numpy as np
import pytest

from skhybrid.domain import ParametricModel
from skhybrid.preprocessing import make_windows


def second_order(X, *, a, b, xp=np):
    # Reads the newest step of a 2-step window [x(t-1), u(t-1), x(t), u(t)].
    return a * X[:, 2] + b * X[:, 3]


def _ar_windows(n_steps, shuffle=False):
    rng = np.random.default_rng(0)
    u = rng.normal(size=300)
    x = np.zeros(300)
    for t in range(299):
        x[t + 1] = 0.8 * x[t] + u[t]
    X, y = make_windows(x, u, n_steps=n_steps)
    if shuffle:
        perm = rng.permutation(len(X))
        X, y = X[perm], y[perm]
    return X, y


def test_fit_says_which_n_steps_to_set():
    """4-column windows of 2 steps fitted with the default n_steps=1.

    They used to fit without complaint and fail only at simulate, without saying
    "set n_steps=2".
    """
    X, y = _ar_windows(2)
    model = ParametricModel(second_order, {"a": 1.0, "b": 1.0})
    with pytest.raises(
        ValueError,
        match=r"has n_steps=1, .*windows of 2 time steps.*"
        r"Set n_steps=2",
    ):
        model.fit(X, y)
    with pytest.raises(ValueError, match="Set n_steps=2"):
        model.initialize(X, y)
    fitted = model.set_params(n_steps=2).fit(X, y)
    np.testing.assert_allclose(
        [fitted.params_["a"], fitted.params_["b"]], [0.8, 1.0], rtol=1e-6
    )


def test_rows_that_do_not_tell_fit_as_before():
    # Shuffled rows carry no order to read; the given n_steps stands.
    X, y = _ar_windows(2, shuffle=True)
    model = ParametricModel(second_order, {"a": 1.0, "b": 1.0}).fit(X, y)
    assert model.n_features_in_ == 4


def test_simulate_says_which_n_steps_to_set_where_fit_could_not_tell():
    from skhybrid.simulation import simulate

    X, y = _ar_windows(2, shuffle=True)
    model = ParametricModel(second_order, {"a": 1.0, "b": 1.0}).fit(X, y)
    u = np.zeros((20, 1))
    with pytest.raises(
        ValueError,
        match=r"estimator has n_steps=1: its rows of 4 columns are 2 steps .*"
        r"Set n_steps=2 on the estimator and fit it again",
    ):
        simulate(model, u, np.zeros((2, 1)))
