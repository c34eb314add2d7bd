"""Fits that cannot succeed say why: a diverging simulation, too few samples."""

import warnings

import numpy as np
import pytest

from skhybrid.domain import ParametricModel, StateSpaceModel, WienerHammersteinModel
from skhybrid.exceptions import IdentifiabilityWarning, SimulationDivergedError


def cubic(x, u, *, xp, a, b):
    """Discrete x(t+1) = a x^3 + b u: blows up from any state much above 1."""
    return a * x**3 + b * u


def linear(x, u, *, xp, a, b):
    return a * x + b * u


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((400, 1))
    return u, 0.1 * np.cumsum(u, axis=0)


@pytest.mark.parametrize(
    "rhs, params", [(cubic, {"a": 2.0, "b": 1.0}), (linear, {"a": 1.2, "b": 1.0})]
)
def test_a_fit_whose_simulation_overflows_says_so(record, rhs, params):
    # The cubic ended inside scipy with "array must not contain infs or NaNs";
    # the linear one returned a model whose rmse_ was 2e18, without a word.
    u, y = record
    model = StateSpaceModel(
        rhs, params, state_names=["x"], observed=["x"], time="discrete", n_init=5
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(
            SimulationDivergedError,
            match=r"StateSpaceModel.fit_simulation: the free run at the fitted "
            r"parameters .* diverges .* on record 0 from time step \d+.*bounds",
        ):
            model.fit_simulation(u, y)
    assert not hasattr(model, "params_")


def test_the_penalty_for_a_diverged_run_leaves_a_stable_fit_alone(record):
    u, _ = record
    truth = StateSpaceModel(
        linear,
        {"a": 0.9, "b": 1.0},
        state_names=["x"],
        observed=["x"],
        time="discrete",
        fixed=("a", "b"),
    ).fit_simulation(u, np.zeros_like(u))
    y = truth.simulate_from_state(u, [0.0])
    model = StateSpaceModel(
        linear,
        {"a": 0.95, "b": 0.5},
        state_names=["x"],
        observed=["x"],
        time="discrete",
        n_init=5,
    ).fit_simulation(u, y)
    assert model.params_["a"] == pytest.approx(0.9, abs=1e-6)


def _wiener_hammerstein_record(n=200):
    rng = np.random.default_rng(0)
    u = rng.standard_normal((n, 1))
    x = np.convolve(u[:, 0], [1.0, 0.5, 0.2])[:n]
    return u, np.tanh(x) + 0.01 * rng.standard_normal(n)


def test_an_underdetermined_wiener_hammerstein_fit_warns():
    # On 10 samples it interpolated the data (RMSE 6e-16) without a word.
    u, y = _wiener_hammerstein_record()
    model = WienerHammersteinModel(order=3, n_knots=8)
    with pytest.warns(
        IdentifiabilityWarning,
        match=r"WienerHammersteinModel fits \d+ free parameters to only \d+ "
        r"residuals.*a lower order or fewer n_knots",
    ) as record:
        model.fit(u[:10], y[:10])
    assert record[0].filename == __file__  # points at the user's call
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        WienerHammersteinModel(order=2, n_knots=4, n_starts=1).fit(u, y)


def test_an_underdetermined_least_squares_fit_warns():
    def line(X, *, a, b, xp=np):
        return a * X[:, 0] + b

    X = np.array([[0.0], [1.0]])
    with pytest.warns(
        IdentifiabilityWarning, match="ParametricModel fits 2 free parameters to only 2"
    ):
        ParametricModel(line, {"a": 1.0, "b": 0.0}).fit(X, [1.0, 3.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        ParametricModel(line, {"a": 1.0, "b": 0.0}, fixed=("b",)).fit(X, [1.0, 3.0])
