"""simulate: one step equals predict, batches equal separate calls, the pendulum."""

import inspect

import numpy as np
import pytest
from sklearn.base import clone

from skhybrid.datasets import make_pendulum
from skhybrid.domain import PendulumModel
from skhybrid.exceptions import NonWhiteResidualWarning, SimulationDivergedError
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import SimulatorMixin, simulate
from skhybrid.utils._testing import fast_instances, with_states

N_STATES, N_INPUTS = 2, 1


def _sequences(n_traj=3, n_times=60, seed=0):
    """A stable linear system with a little nonlinearity and random inputs."""
    rng = np.random.default_rng(seed)
    U = rng.normal(size=(n_traj, n_times, N_INPUTS))
    X = np.zeros((n_traj, n_times, N_STATES))
    X[:, 0] = rng.normal(size=(n_traj, N_STATES))
    for t in range(n_times - 1):
        x, u = X[:, t], U[:, t]
        X[:, t + 1, 0] = 0.8 * x[:, 0] + 0.2 * x[:, 1] + 0.3 * u[:, 0]
        X[:, t + 1, 1] = -0.3 * x[:, 0] + 0.7 * x[:, 1] + 0.1 * np.tanh(u[:, 0])
    return X + 0.01 * rng.normal(size=X.shape), U


#: Simulating estimators that compute in float64 only (no torch network).
_FLOAT64_MODELS = {"LinearStateSpaceModel", "ParametricModel", "PendulumModel"}


def _simulators():
    for est in fast_instances():
        if isinstance(est, SimulatorMixin) and not isinstance(est, PendulumModel):
            est = with_states(est, N_STATES)
            yield pytest.param(est, id=type(est).__name__)


@pytest.fixture(scope="module")
def fitted():
    """Every simulating estimator fitted once, with its window length."""
    X_seq, U_seq = _sequences()
    out = {}
    for param in _simulators():
        est = clone(param.values[0])
        n_steps = est.get_params(deep=False).get("n_steps", 1)
        X, y = WindowLayout(N_STATES, N_INPUTS, n_steps).make_rows(
            list(X_seq), list(U_seq)
        )
        out[type(est).__name__] = (est.fit(X, y), n_steps)
    return out


@pytest.mark.parametrize("est", list(_simulators()))
def test_one_step_equals_predict(fitted, est):
    est, n_steps = fitted[type(est).__name__]
    X_seq, U_seq = _sequences(n_traj=4, n_times=n_steps + 1, seed=1)
    sim = est.simulate(U_seq, X_seq[:, :n_steps])
    assert sim.shape == X_seq.shape
    np.testing.assert_array_equal(sim[:, :n_steps], X_seq[:, :n_steps])
    X, _ = WindowLayout(N_STATES, N_INPUTS, n_steps).make_rows(list(X_seq), list(U_seq))
    expected = np.asarray(est.predict(X)).reshape(4, N_STATES)
    np.testing.assert_allclose(sim[:, -1], expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("est", list(_simulators()))
def test_batch_equals_separate_calls(fitted, est):
    est, n_steps = fitted[type(est).__name__]
    X_seq, U_seq = _sequences(n_traj=64, n_times=25, seed=2)
    init = X_seq[:, : n_steps + 2]
    batch = est.simulate(U_seq, init)
    separate = np.stack([est.simulate(U_seq[i], init[i]) for i in range(64)])
    np.testing.assert_allclose(batch, separate, rtol=1e-10, atol=1e-10)
    # A list of experiments of different lengths gives the same paths.
    as_list = est.simulate([U_seq[0][:10], U_seq[1]], [init[0], init[1]])
    np.testing.assert_allclose(as_list[0], batch[0, :10], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(as_list[1], batch[1], rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("est", list(_simulators()))
def test_least_squares_init_for_every_estimator(fitted, est):
    est, n_steps = fitted[type(est).__name__]
    if "init" not in inspect.signature(est.simulate).parameters:
        pytest.skip(f"{type(est).__name__} always estimates its (latent) initial state")
    X_seq, U_seq = _sequences(n_traj=3, n_times=30, seed=4)
    init = X_seq[:, : n_steps + 6]
    batch = est.simulate(U_seq, init, init="least_squares")
    assert np.all(np.isfinite(batch))
    np.testing.assert_array_equal(batch[:, : n_steps + 6], init)
    separate = np.stack(
        [est.simulate(U_seq[i], init[i], init="least_squares") for i in range(3)]
    )
    # One Levenberg-Marquardt iteration per trajectory (fit_initial_states), run
    # to the rounding floor of the model's own evaluations. What is left is the
    # model's rounding: a batched predict (BLAS, torch) rounds differently from
    # a one-row one, by about float64's epsilon for a float64 model and
    # float32's for a network, and the least-squares optimum moves by that
    # times the problem's conditioning (measured at most 5e-11 relative for the
    # physics and 4.5e-9, or 6e-10 absolute, for models with a network).
    if type(est).__name__ in _FLOAT64_MODELS:
        np.testing.assert_allclose(batch, separate, rtol=1e-10, atol=1e-12)
    else:
        np.testing.assert_allclose(batch, separate, rtol=1e-8, atol=1e-8)


def test_true_pendulum_physics_reproduces_the_clean_trajectory():
    data = make_pendulum(n_samples=600, random_state=0)
    model = PendulumModel(mass=1.0, length=1.0, fixed=("mass", "length"))
    model.fit(data.X, data.y)
    clean, inputs = data.states_clean, data.inputs
    sim = model.simulate(inputs, [c[:1] for c in clean])
    for s, c in zip(sim, clean, strict=True):
        np.testing.assert_allclose(s, c, rtol=0, atol=1e-10)
    # From a noisy measured first state the error grows on swings near the
    # upright position (measured 0.127 at most over 20 steps for noise 0.01).
    # From a noisy 10-sample initial window fitted by least squares through the
    # physics (init="least_squares"), the next 20 steps stay within the noise
    # level of the clean trajectory on every episode.
    data = make_pendulum(n_samples=2000, random_state=0)
    keep = [i for i, u in enumerate(data.inputs) if len(u) >= 30]
    assert len(keep) >= 8
    inputs = [data.inputs[i] for i in keep]
    window = [data.states[i][:10] for i in keep]
    sim = model.simulate(inputs, window, init="least_squares")
    measured = model.simulate(inputs, window)
    worst_measured = 0.0
    for i, s, m in zip(keep, sim, measured, strict=True):
        clean = data.states_clean[i]
        np.testing.assert_array_equal(s[:10], data.states[i][:10])
        err = s[10:30] - clean[10:30]
        assert np.sqrt(np.mean(err**2)) <= data.noise.max(), i
        assert np.abs(err).max() <= 1.5 * data.noise.max(), i
        worst_measured = max(worst_measured, np.abs(m[10:30] - clean[10:30]).max())
    # The fit is what makes the difference: from the measured window as it is,
    # some episode leaves the noise level.
    assert worst_measured > 1.5 * data.noise.max()


def test_least_squares_init_is_checked_and_batch_invariant():
    data = make_pendulum(n_samples=600, random_state=1)
    model = PendulumModel(mass=1.0, length=1.0, fixed=("mass", "length"))
    model.fit(data.X, data.y)
    long = [i for i, u in enumerate(data.inputs) if len(u) >= 40]
    U = np.stack([data.inputs[i][:40] for i in long])
    Y0 = np.stack([data.states[i][:8] for i in long])
    batch = model.simulate(U, Y0, init="least_squares")
    separate = np.stack(
        [model.simulate(u, y, init="least_squares") for u, y in zip(U, Y0, strict=True)]
    )
    np.testing.assert_allclose(batch, separate, rtol=1e-10, atol=1e-10)
    # A window of n_steps samples has nothing to average: it is kept as measured.
    one = model.simulate(U, Y0[:, :1], init="least_squares")
    np.testing.assert_array_equal(one, model.simulate(U, Y0[:, :1]))
    with pytest.raises(ValueError, match="init must be one of"):
        model.simulate(U, Y0, init="kalman")


def test_divergence_names_the_step():
    from sklearn.base import BaseEstimator

    class Doubling(SimulatorMixin, BaseEstimator):
        n_features_in_ = 1
        n_outputs_ = 1

        def __sklearn_is_fitted__(self):
            return True

        def fit(self, X, y):
            return self

        def predict(self, X):
            return X * 1e200

    sim = Doubling()
    # The overflow is the point: 1e200 * 1e200 is inf in float64 (numpy warns),
    # and simulate must name the step where the state stopped being finite.
    with (
        pytest.raises(SimulationDivergedError, match="diverged at time step 2"),
        pytest.warns(RuntimeWarning, match="overflow encountered"),
    ):
        sim.simulate(np.zeros((10, 0)), np.ones((1, 1)))


def test_bad_inputs_are_named():
    X_seq, U_seq = _sequences(n_traj=1, n_times=30)
    X, y = WindowLayout(N_STATES, N_INPUTS, 2).make_rows(X_seq[0], U_seq[0])
    est = DenseRegressor((4,), max_epochs=2, random_state=0).fit(X, y)
    with pytest.raises(ValueError, match="at least 2 measured steps"):
        est.simulate(U_seq[0], X_seq[0, :1])
    with pytest.raises(ValueError, match="initial must match inputs"):
        est.simulate(U_seq[0], [X_seq[0, :2]])
    with pytest.raises(ValueError, match="initial has 1 state columns"):
        est.simulate(U_seq[0], X_seq[0, :2, :1])
    with pytest.raises(ValueError, match="need a noise model"):
        est.simulate(U_seq[0], X_seq[0, :2], n_samples=3)
    with pytest.raises(ValueError, match="n_samples must be >= 1"):
        simulate(est, U_seq[0], X_seq[0, :2], n_samples=0)


def test_noise_paths_and_band_widen():
    X_seq, U_seq = _sequences(n_traj=2, n_times=200, seed=3)
    X, y = WindowLayout(N_STATES, N_INPUTS, 1).make_rows(list(X_seq), list(U_seq))
    from skhybrid.domain import LinearStateSpaceModel

    model = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel())], noise_model="gaussian"
    )
    # _sequences measures the states with noise, so the one-step residuals are
    # correlated (MA(1)) and the gaussian noise model rightly says they are not
    # white; the band it draws is what this test checks.
    with pytest.warns(NonWhiteResidualWarning, match="noise_model='gaussian'"):
        model.fit(X, y)
    paths = model.simulate(U_seq, X_seq[:, :1], n_samples=5, random_state=0)
    assert paths.shape == (5, *X_seq.shape)
    again = model.simulate(U_seq, X_seq[:, :1], n_samples=5, random_state=0)
    np.testing.assert_array_equal(paths, again)
    mean, std = model.simulate(U_seq, X_seq[:, :1], return_std=True, random_state=0)
    assert mean.shape == std.shape == X_seq.shape
    np.testing.assert_allclose(std[:, 0], 0.0, atol=1e-12)  # measured initial state
    # The band widens from one step ahead to the stationary spread.
    assert np.all(std[:, 1].mean(axis=0) < std[:, 50:].mean(axis=(0, 1)))


def test_display_from_estimator_draws_band_and_rmse():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from skhybrid.domain import LinearStateSpaceModel
    from skhybrid.simulation import SimulationDisplay

    X_seq, U_seq = _sequences(n_traj=2, n_times=120, seed=4)
    X, y = WindowLayout(N_STATES, N_INPUTS, 1).make_rows(list(X_seq), list(U_seq))
    model = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel())], noise_model="gaussian"
    )
    # Measurement noise makes the one-step residuals correlated (see
    # test_noise_paths_and_band_widen); the display is what is checked here.
    with pytest.warns(NonWhiteResidualWarning, match="noise_model='gaussian'"):
        model.fit(X, y)
    disp = SimulationDisplay.from_estimator(
        model, U_seq[0], X_seq[0], n_init=1, return_std=True, random_state=0
    )
    sim = model.simulate(U_seq[0], X_seq[0, :1], return_std=True, random_state=0)[0]
    expected = np.sqrt(np.mean((sim[1:] - X_seq[0, 1:]) ** 2, axis=0))
    np.testing.assert_allclose(disp.rmse_, expected)
    assert disp.axes_.shape == (2, N_STATES)
    assert len(disp.axes_[0, 0].collections) == 1  # the band
    plt.close(disp.figure_)


def test_every_estimator_can_simulate():
    from skhybrid.utils import all_estimators

    missing = [name for name, cls in all_estimators() if not hasattr(cls, "simulate")]
    assert not missing, f"estimators without simulate: {missing}"


def _arx(X, *, a1, a2, b, xp=np):
    """y(t+1) = a1 y(t) + a2 y(t-1) + b u(t), read through the window layout."""
    outputs, inputs = WindowLayout(n_states=1, n_inputs=1, n_steps=2).split(X)
    return a1 * outputs[:, 1] + a2 * outputs[:, 0] + b * inputs[:, 1]


def test_output_only_narx_system():
    """A second-order system of which only the position is measured (NARX form).

    The layout's "states" are the measured outputs: a window of two past outputs
    and inputs carries the unmeasured velocity. Fitted on noisy one-step rows, the
    model recovers the coefficients, and with the true ones its simulation
    reproduces the noise-free output from two measured samples.
    """
    from skhybrid.domain import ParametricModel

    rng = np.random.default_rng(0)
    true = {"a1": 1.6, "a2": -0.8, "b": 0.5}
    U = rng.normal(size=(5, 150, 1))
    Y = np.zeros((5, 150, 1))
    for t in range(1, 149):
        Y[:, t + 1] = (
            true["a1"] * Y[:, t] + true["a2"] * Y[:, t - 1] + true["b"] * U[:, t]
        )
    layout = WindowLayout(
        n_states=1, n_inputs=1, n_steps=2, state_names=["y"], input_names=["u"]
    )
    assert layout.feature_names() == ["y[t-1]", "u[t-1]", "y[t]", "u[t]"]
    noisy = Y + 0.01 * rng.normal(size=Y.shape)
    X, y = layout.make_rows(list(noisy), list(U))
    model = ParametricModel(_arx, {"a1": 1.0, "a2": 0.0, "b": 0.0}, n_steps=2)
    model.fit(X, y)
    for name, value in true.items():
        assert abs(model.params_[name] - value) < 0.05, model.params_

    exact = ParametricModel(_arx, true, fixed=tuple(true), n_steps=2).fit(X, y)
    sim = exact.simulate(U, Y[:, :2])
    np.testing.assert_allclose(sim, Y, rtol=0, atol=1e-10)


def test_booster_with_residual_inputs_simulates_as_a_whole():
    """A booster whose later stage reads residuals on a 3-step window.

    Its simulation is the loop a user would write: predict on the window of the
    simulated history, shift the window, repeat; the residual inputs are built
    from the simulated states (see the booster's docstring).
    """
    X_seq, U_seq = _sequences(n_traj=3, n_times=80, seed=5)
    layout = WindowLayout(N_STATES, N_INPUTS, 3)
    X, y = layout.make_rows(list(X_seq), list(U_seq))
    from skhybrid.domain import LinearStateSpaceModel

    model = HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel(n_steps=3)),
            ("dense", DenseRegressor((8,), max_epochs=5, random_state=0)),
        ],
        stage_input="window+prediction+residuals",
        n_steps=3,
    ).fit(X, y)
    n_init = 4
    sim = model.simulate(U_seq, X_seq[:, :n_init])
    for i in range(3):
        states = list(X_seq[i, :n_init])
        for t in range(n_init, X_seq.shape[1]):
            window = layout.join(
                np.asarray(states[t - 3 : t])[None], U_seq[i, t - 3 : t][None]
            )
            states.append(model.predict(window)[0])
        np.testing.assert_allclose(sim[i], np.asarray(states), rtol=0, atol=1e-12)
    # The network's stage changes the simulation (its residual inputs are live).
    physics = model.stages_[0][1].simulate(U_seq, X_seq[:, :n_init])
    assert np.abs(sim[:, n_init:] - physics[:, n_init:]).max() > 1e-6
