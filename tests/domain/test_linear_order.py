"""LinearStateSpaceModel with an order independent of the number of outputs."""

import numpy as np
import pytest

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.preprocessing import make_windows

NOISE = 0.05


def _oscillator(u):
    """A lightly damped oscillator: poles 0.95 exp(+-0.4i), output std about 3."""
    r, theta = 0.95, 0.4
    a1, a2 = 2 * r * np.cos(theta), -(r**2)
    y = np.zeros(len(u))
    for t in range(2, len(u)):
        y[t] = a1 * y[t - 1] + a2 * y[t - 2] + 0.3 * u[t - 1] + 0.2 * u[t - 2]
    return y


def _held(rng, n, hold=10):
    return np.repeat(rng.uniform(-1, 1, n // hold + 1), hold)[:n]


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    u = _held(rng, 2000)
    y = _oscillator(u) + NOISE * rng.standard_normal(2000)  # output noise only
    u_test = _held(rng, 500)
    y_test = _oscillator(u_test)
    y_test_measured = y_test + NOISE * rng.standard_normal(500)
    return u, y, u_test, y_test, y_test_measured


def _free_run_rmse(model, n_steps, u_test, y_test, y_test_measured):
    # The initial window is measured (noisy); the rest is simulated and compared
    # with the noise-free output.
    sim = model.simulate(u_test[:, None], y_test_measured[:n_steps, None])[:, 0]
    return float(np.sqrt(np.mean((sim[n_steps:] - y_test[n_steps:]) ** 2)))


def test_order_two_recovers_oscillator(data):
    # Measured (output noise std 0.05, output std about 3.2), free-run RMSE
    # against the noise-free held-out output:
    #   default first-order model (n_steps=1)                 about 2.5
    #   order=2, n_steps=2 (ARX closed form)                  about 0.18
    #   order=2, n_steps=10, refine="simulation"              about 0.03
    u, y, u_test, y_test, y_test_measured = data
    X1, Y1 = make_windows(y[:, None], u[:, None], n_steps=1)
    first = LinearStateSpaceModel().fit(X1, Y1)
    rmse_first = _free_run_rmse(first, 1, u_test, y_test, y_test_measured)

    X2, Y2 = make_windows(y[:, None], u[:, None], n_steps=2)
    arx = LinearStateSpaceModel(order=2, n_steps=2).fit(X2, Y2)
    rmse_arx = _free_run_rmse(arx, 2, u_test, y_test, y_test_measured)
    assert arx.A_.shape == (2, 2) and arx.B_.shape == (2, 1)
    assert arx.C_.shape == (1, 2) and arx.n_states_ == 2
    np.testing.assert_allclose(np.abs(arx.eigenvalues_), 0.95, atol=0.01)

    X10, Y10 = make_windows(y[:, None], u[:, None], n_steps=10)
    refined = LinearStateSpaceModel(order=2, n_steps=10, refine="simulation")
    refined.fit(X10, Y10)
    rmse_refined = _free_run_rmse(refined, 10, u_test, y_test, y_test_measured)
    np.testing.assert_allclose(np.abs(refined.eigenvalues_), 0.95, atol=0.003)
    np.testing.assert_allclose(np.angle(refined.eigenvalues_).max(), 0.4, atol=0.01)

    assert rmse_first > 1.0
    assert rmse_arx < 0.1 * rmse_first
    assert rmse_arx < 5 * NOISE
    assert rmse_refined < NOISE  # better than the noise level
    assert rmse_refined < 0.02 * rmse_first


def test_order_predict_matches_state_space(data):
    # One-step predict on windows equals C (A x + B u + c) with x realised from
    # the newest steps of the window, and order=n_outputs equals the default.
    u, y, *_ = data
    X, Y = make_windows(y[:, None], u[:, None], n_steps=3)
    model = LinearStateSpaceModel(order=2, n_steps=3).fit(X, Y)
    A, B, C, c = model.A_, model.B_, model.C_, model.c_
    # Observer form: x1(t) = y(t), x2(t) = A_2 y(t-1) + B_2 u(t-1).
    x = np.stack([X[:, 4], A[1, 0] * X[:, 2] + B[1, 0] * X[:, 3]], axis=1)
    expected = (x @ A.T + X[:, 5:6] @ B.T + c) @ C.T
    np.testing.assert_allclose(np.ravel(model.predict(X)), expected[:, 0], rtol=1e-10)
    default = LinearStateSpaceModel(n_steps=3).fit(X, Y)
    same = LinearStateSpaceModel(order=1, n_steps=3).fit(X, Y)
    np.testing.assert_allclose(same.predict(X), default.predict(X))


def test_order_multi_output():
    rng = np.random.default_rng(1)
    X, Y = make_windows(
        rng.standard_normal((300, 2)), rng.standard_normal((300, 1)), n_steps=2
    )
    model = LinearStateSpaceModel(order=4, n_steps=2).fit(X, Y)
    assert model.A_.shape == (4, 4) and model.C_.shape == (2, 4)
    assert model.predict(X).shape == (len(X), 2)
    with pytest.raises(ValueError, match="order=3 must be a multiple"):
        LinearStateSpaceModel(order=3, n_steps=2).fit(X, Y)


@pytest.mark.parametrize("order", [0, -1, 1.5, "2"])
def test_bad_order(order):
    X, Y = np.ones((10, 2)), np.ones(10)
    with pytest.raises(ValueError, match=f"'order'.*{order!r}|order.*{order}"):
        LinearStateSpaceModel(order=order).fit(X, Y)


def test_order_needs_enough_steps():
    rng = np.random.default_rng(0)
    X, Y = make_windows(rng.standard_normal((50, 1)), rng.standard_normal((50, 1)))
    with pytest.raises(ValueError, match=r"order=2 .*n_steps=1"):
        LinearStateSpaceModel(order=2).fit(X, Y)


def test_refine_needs_mse():
    rng = np.random.default_rng(0)
    X, Y = make_windows(rng.standard_normal((80, 1)), n_steps=3)
    with pytest.raises(ValueError, match=r"refine='simulation'.*objective"):
        LinearStateSpaceModel(
            order=1, n_steps=3, refine="simulation", objective="ljung_box"
        ).fit(X, Y)
