"""Fits that cannot succeed say why: a diverging simulation, too few samples."""

import warnings

import numpy as np
import pytest

from skhybrid.domain import StateSpaceModel
from skhybrid.exceptions import SimulationDivergedError


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
