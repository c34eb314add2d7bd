"""What the networks learn: smooth maps, windows, whiter residuals, inverse maps."""

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.metrics import r2_score
from statsmodels.stats.diagnostic import acorr_ljungbox

from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor


def _x_sin_3x(n_samples, seed, noise=0.05):
    """``y = x sin(3x) + noise`` on [-2, 2]; 2,000 held-out rows after the first n."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, size=(n_samples + 2000, 1))
    y = x[:, 0] * np.sin(3 * x[:, 0]) + noise * rng.standard_normal(len(x))
    return x[:n_samples], y[:n_samples], x[n_samples:], y[n_samples:]


QUICK = {
    DenseRegressor: dict(hidden_layer_sizes=(32, 32)),
    RNNRegressor: dict(hidden_size=16, num_layers=1),
    CyclicRegressor: dict(hidden_layer_sizes=(32, 32)),
}


@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_smooth_regression_quick(cls, global_random_seed):
    X, y, X_test, y_test = _x_sin_3x(1500, global_random_seed)
    model = cls(
        **QUICK[cls], batch_size=64, max_epochs=60, random_state=global_random_seed
    )
    model.fit(X, y)
    # 60 epochs of a small network: well above a linear fit (R^2 ~ 0), short of
    # the 0.99 that the full-size test below reaches.
    assert r2_score(y_test, model.predict(X_test)) >= 0.9


FULL = {
    DenseRegressor: dict(hidden_layer_sizes=(64, 64, 64)),
    RNNRegressor: dict(),  # defaults: GRU, 2 layers of 50
    CyclicRegressor: dict(hidden_layer_sizes=(64, 64, 64)),
}


@pytest.mark.slow
@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_smooth_regression_r2_099(cls, global_random_seed):
    X, y, X_test, y_test = _x_sin_3x(5000, global_random_seed)
    model = cls(**FULL[cls], random_state=global_random_seed).fit(X, y)
    # the noise alone caps R^2 at about 0.996
    assert r2_score(y_test, model.predict(X_test)) >= 0.99


def test_rnn_learns_from_the_window(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    n_steps = 5
    X = rng.uniform(-1, 1, size=(3000, n_steps * 2))  # steps of [a, b]
    y = X[:, 0::2].sum(axis=1)  # the sum of the window's first column
    train, test = slice(0, 2500), slice(2500, None)
    newest_only = LinearRegression().fit(X[train, -2:], y[train])
    assert newest_only.score(X[test, -2:], y[test]) < 0.3  # the window is needed
    model = RNNRegressor(
        hidden_size=16,
        num_layers=1,
        n_steps=n_steps,
        batch_size=64,
        max_epochs=40,
        random_state=global_random_seed,
    ).fit(X[train], y[train])
    assert model.score(X[test], y[test]) >= 0.98


def _ar1_noise_system(seed, n_samples=3500, phi=0.9):
    """Rows ``[y(t-1), u(t)]``, target ``y(t) = sin(3 u(t)) + e(t)``, AR(1) ``e``.

    ``y(t-1)`` carries the noise history ``e(t-1)`` buried under ``sin(3 u(t-1))``
    (u is not in the row). Predicting ``phi * y(t-1)`` on top of ``sin(3 u(t))``
    would whiten the residuals, but it adds the variance of ``phi sin(3 u(t-1))``,
    so a least-squares fit all but ignores ``y(t-1)`` and keeps AR(1) residuals. A
    Ljung-Box term rewards the whitening: the trade-off the paper describes.
    """
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n_samples + 1)
    w = 0.1 * rng.standard_normal(n_samples + 1)
    e = np.zeros(n_samples + 1)
    for t in range(1, n_samples + 1):
        e[t] = phi * e[t - 1] + w[t]
    y = np.sin(3 * u) + e
    return np.column_stack([y[:-1], u[1:]]), y[1:]


def test_ljung_box_objective_whitens_held_out_residuals(global_random_seed):
    X, y = _ar1_noise_system(global_random_seed)
    train, test = slice(0, 2500), slice(2500, None)  # time order kept
    stats = {}
    for objective, weight in [("mse", 1.0), ("mse+ljung_box", 10.0), ("ljung_box", 1)]:
        model = DenseRegressor(
            (16, 16),
            objective=objective,
            ljung_box_lags=10,
            ljung_box_weight=weight,
            batch_size=256,
            max_epochs=20,
            random_state=global_random_seed,
        ).fit(X[train], y[train])
        residuals = y[test] - model.predict(X[test])
        stats[objective] = acorr_ljungbox(residuals, lags=[10]).iloc[0]
    assert stats["mse"]["lb_pvalue"] < 1e-6  # least squares leaves AR residuals
    for objective in ("mse+ljung_box", "ljung_box"):
        assert stats[objective]["lb_pvalue"] > stats["mse"]["lb_pvalue"]
        assert stats[objective]["lb_stat"] < stats["mse"]["lb_stat"] / 2


def test_cyclic_inverse_predict_reconstructs_inputs(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    X = rng.uniform(0, 2, size=(1500, 1))
    Y = np.column_stack([np.exp(X[:, 0]), np.sin(X[:, 0])])  # invertible map
    model = CyclicRegressor(
        (32, 32), batch_size=64, max_epochs=60, random_state=global_random_seed
    ).fit(X[:1000], Y[:1000])
    assert model.score(X[1000:], Y[1000:]) >= 0.95
    X_rec = model.inverse_predict(Y[1000:])
    assert X_rec.shape == (500, 1) and X_rec.dtype == np.float64
    assert r2_score(X[1000:], X_rec) >= 0.95
    # the decoder reads outputs in the units of y; one column per output
    with pytest.raises(ValueError, match="n_outputs_=2"):
        model.inverse_predict(Y[:5, :1])
    one = CyclicRegressor((8,), max_epochs=2, random_state=0).fit(X, Y[:, 0])
    assert one.inverse_predict(Y[:5, 0]).shape == (5, 1)
