"""PendulumModel against gymnasium, parameter recovery and standard errors."""

import pickle

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import FunctionTransformer

from skhybrid.domain import PendulumModel, pendulum_step


def _random_transitions(rng, n, torque=1.0, noise=0.0):
    theta = rng.uniform(-np.pi, np.pi, n)
    theta_dot = rng.uniform(-8, 8, n)
    u = rng.uniform(-torque, torque, n)
    X = np.column_stack([np.cos(theta), np.sin(theta), theta_dot, u])
    y = np.column_stack(pendulum_step(*X.T, mass=1.0, length=1.0, g=10.0, dt=0.05))
    return X, y + noise * rng.standard_normal(y.shape)


def test_matches_gymnasium_env_step(rng):
    gym = pytest.importorskip("gymnasium")
    env = gym.make("Pendulum-v1")
    env.reset(seed=0)
    rows, targets = [], []
    for _ in range(1000):
        theta, theta_dot = rng.uniform(-np.pi, np.pi), rng.uniform(-8, 8)
        torque = rng.uniform(-2.5, 2.5)  # beyond max_torque: the clip is tested too
        env.unwrapped.state = np.array([theta, theta_dot])
        obs, *_ = env.step(np.array([torque], dtype=np.float32))
        torque32 = float(np.float32(torque))
        rows.append([np.cos(theta), np.sin(theta), theta_dot, torque32])
        targets.append(obs)
    X, y = np.array(rows), np.array(targets, dtype=np.float64)
    model = PendulumModel(fixed=("mass", "length")).fit(X, y)
    np.testing.assert_allclose(model.predict(X), y, atol=1e-6, rtol=0)


@pytest.mark.parametrize("jac", ["2-point", "autograd"])
def test_recovers_mass_and_length_from_wrong_start(rng, jac):
    X, y = _random_transitions(rng, 2000)
    model = PendulumModel(mass=5.0, length=10.0, jac=jac).fit(X, y)
    assert abs(model.params_["mass"] - 1.0) < 1e-6
    assert abs(model.params_["length"] - 1.0) < 1e-6


def test_fixed_parameters_are_held(rng):
    X, y = _random_transitions(rng, 500)
    model = PendulumModel(mass=5.0, length=10.0, fixed=("mass", "length")).fit(X, y)
    assert model.params_ == {"mass": 5.0, "length": 10.0}
    assert model.params_std_ == {"mass": 0.0, "length": 0.0}
    assert model.result_ is None
    partly = PendulumModel(mass=5.0, length=10.0, fixed=("mass",)).fit(X, y)
    assert partly.params_["mass"] == 5.0
    assert partly.params_["length"] != 10.0


def test_params_std_matches_spread_over_noisy_redraws():
    """Standard errors agree within 25 % with the spread of 50 re-fits."""
    base = np.random.default_rng(0)
    X, y_clean = _random_transitions(base, 400)
    estimates, stds = [], []
    for seed in range(50):
        noise = np.random.default_rng(1000 + seed).standard_normal(y_clean.shape)
        model = PendulumModel().fit(X, y_clean + 0.05 * noise)
        estimates.append([model.params_["mass"], model.params_["length"]])
        stds.append([model.params_std_["mass"], model.params_std_["length"]])
    spread = np.std(estimates, axis=0, ddof=1)
    reported = np.mean(stds, axis=0)
    np.testing.assert_array_less(np.abs(reported / spread - 1), 0.25)


def _trajectory(rng, n, noise=0.01):
    """One time-ordered trajectory; torques held for 5 steps; noisy outputs."""
    state = np.array([1.0, 0.0, 0.0])
    torques = np.repeat(rng.uniform(-2, 2, n // 5 + 1), 5)[:n]
    rows, targets = [], []
    for u in torques:
        nxt = pendulum_step(*state, u, mass=1.0, length=1.0, g=10.0, dt=0.05)
        rows.append([*state, u])
        targets.append(nxt)
        state = np.array(nxt)
    y = np.array(targets)
    return np.array(rows), y + noise * rng.standard_normal(y.shape)


def test_ljung_box_objectives_fit(rng):
    X, y = _trajectory(rng, 600)
    for objective in ("mse+ljung_box", "ljung_box"):
        model = PendulumModel(mass=2.0, length=2.0, objective=objective).fit(X, y)
        assert abs(model.params_["mass"] - 1) < 0.1, objective
        assert abs(model.params_["length"] - 1) < 0.1, objective


def test_windows_read_newest_step(rng):
    X, y = _random_transitions(rng, 300)
    older = rng.standard_normal((300, 4))
    model = PendulumModel(n_steps=2).fit(np.hstack([older, X]), y)
    np.testing.assert_allclose(model.params_["mass"], 1.0, atol=1e-6)


@pytest.mark.parametrize(
    "kwargs, X_cols, y_cols, match",
    [
        ({}, 5, 3, "4 columns per time step.*got 5 columns per step"),
        ({}, 4, 2, "3 outputs.*got 4 columns per step \\(n_steps=1\\) and 2 outputs"),
        ({"n_steps": 2}, 7, 3, "not a multiple of n_steps=2"),
        ({"fixed": ("mas",)}, 4, 3, "fixed names \\['mas'\\]"),
        ({"bounds": {"len": (0, 1)}}, 4, 3, "bounds has keys \\['len'\\]"),
        ({"bounds": {"mass": (2, 3)}}, 4, 3, "parameter 'mass' is 1.0, outside"),
        ({"bounds": {"mass": (3, 2)}}, 4, 3, "lower >= upper"),
    ],
)
def test_bad_input_names_parameter_and_value(rng, kwargs, X_cols, y_cols, match):
    X = rng.standard_normal((20, X_cols))
    y = rng.standard_normal((20, y_cols))
    with pytest.raises(ValueError, match=match):
        PendulumModel(**kwargs).fit(X, y)


def test_nan_and_inf_are_rejected(rng):
    X, y = _random_transitions(rng, 20)
    X[3, 2] = np.nan
    with pytest.raises(ValueError, match="X contains NaN"):
        PendulumModel().fit(X, y)
    X[3, 2] = 0.0
    y[1, 0] = np.inf
    with pytest.raises(ValueError, match="y contains infinity"):
        PendulumModel().fit(X, y)


def test_api_contract_on_pendulum_data(rng):
    """What sklearn's common checks verify, on data the model accepts."""
    X, y = _random_transitions(rng, 200, noise=0.01)
    model = PendulumModel(mass=2.0)
    with pytest.raises(NotFittedError):
        model.predict(X)
    params_before = model.get_params()
    fitted = model.fit(X, y)
    assert fitted is model
    assert model.get_params() == params_before  # fit does not touch parameters
    assert model.n_features_in_ == 4 and model.n_outputs_ == 3
    pred = model.predict(X)
    assert pred.dtype == np.float64 and pred.shape == y.shape
    # Row order and subsets do not matter; refits are idempotent.
    perm = rng.permutation(200)
    np.testing.assert_allclose(model.predict(X[perm]), pred[perm], rtol=1e-12)
    np.testing.assert_allclose(model.predict(X[:7]), pred[:7], rtol=1e-12)
    np.testing.assert_allclose(clone(model).fit(X, y).predict(X), pred, rtol=1e-12)
    # float32 and list input, pickling, pipelines.
    np.testing.assert_allclose(model.predict(X.astype(np.float32)), pred, atol=1e-5)
    np.testing.assert_allclose(model.predict(X.tolist()), pred, rtol=1e-12)
    restored = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(restored.predict(X), pred)
    pipe = make_pipeline(FunctionTransformer(), PendulumModel()).fit(X, y)
    assert pipe.score(X, y) > 0.99
    with pytest.raises(ValueError, match="X has 5 features"):
        model.predict(np.hstack([X, X[:, :1]]))


def test_convergence_warning_names_max_nfev(rng):
    from sklearn.exceptions import ConvergenceWarning

    X, y = _random_transitions(rng, 200)
    with pytest.warns(ConvergenceWarning, match="max_nfev.*increase max_nfev"):
        PendulumModel(mass=5.0, length=10.0, max_nfev=2).fit(X, y)
