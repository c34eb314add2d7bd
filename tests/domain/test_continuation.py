"""StateSpaceModel(continuation=...): fits through a smoothing parameter's values."""

import warnings

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from skhybrid.domain import StateSpaceModel


def axis(x, u, *, xp, m, fc, fv, eps, dt):
    """A mass with Coulomb and viscous friction, the sign smoothed over ``eps``."""
    q, v = x[:, 0], x[:, 1]
    acc = (u[:, 0] - fc * xp.tanh(v / eps) - fv * v) / m
    v_next = v + dt * acc
    return xp.stack([q + dt * v_next, v_next], axis=1)


TRUTH = {"m": 1.0, "fc": 1.0, "fv": 0.5, "eps": 1e-4, "dt": 0.01}
# Off by a factor 2-3 in every free parameter.
ROUGH = {"m": 2.2, "fc": 0.3, "fv": 1.5, "eps": 1e-4, "dt": 0.01}


def _model(params, **kwargs):
    kwargs.setdefault("fixed", ("eps", "dt"))
    return StateSpaceModel(
        axis,
        params,
        state_names=["position", "velocity"],
        observed=["position"],
        time="discrete",
        n_init=10,
        max_nfev=200,
        **kwargs,
    )


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(0)
    t = np.arange(1000) * 0.01
    u = (2.0 * np.sin(0.7 * t) + 1.5 * np.sin(2.3 * t + 1.0))[:, None]
    truth = _model(TRUTH, fixed=tuple(TRUTH)).fit_simulation(u, np.zeros((1000, 1)))
    y = truth.simulate_from_state(u, [0.0, 0.0])
    return u, y + 1e-4 * rng.standard_normal(y.shape)


def _fit(model, u, y):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.fit_simulation(u, y)


def test_from_a_rough_start_it_finds_what_a_direct_fit_misses(record):
    u, y = record
    direct = _fit(_model(ROUGH), u, y)
    continued = _fit(_model(ROUGH, continuation={"eps": [1e-2, 1e-3]}), u, y)
    for name in ("m", "fc", "fv"):
        assert continued.params_[name] == pytest.approx(TRUTH[name], rel=0.05)
    assert max(abs(direct.params_[k] / TRUTH[k] - 1) for k in ("m", "fc", "fv")) > 0.3
    assert continued.rmse_ < direct.rmse_ / 10


def test_it_is_the_stages_fitted_one_after_the_other(record):
    u, y = record
    continued = _fit(_model(ROUGH, continuation={"eps": [1e-2]}), u, y)
    stage = _fit(_model({**ROUGH, "eps": 1e-2}), u, y)
    by_hand = _fit(_model({**stage.params_, "eps": 1e-4}), u, y)
    assert continued.params_ == by_hand.params_
    # The final fit is at the model's own value, and params is left as given.
    assert continued.params_["eps"] == 1e-4
    assert continued.params == ROUGH
    assert not hasattr(continued, "_chosen_start")


def test_the_one_step_fit_runs_the_stages_too(record):
    from skhybrid.preprocessing import make_windows

    u, y = record
    X, target = make_windows(y[:300], u[:300], n_steps=3)
    continued = _model(ROUGH, n_steps=3, continuation={"eps": [1e-2]})
    stage = _model({**ROUGH, "eps": 1e-2}, n_steps=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        continued.fit(X, target)
        by_hand = _model({**stage.fit(X, target).params_, "eps": 1e-4}, n_steps=3)
        by_hand.fit(X, target)
    assert continued.params_ == by_hand.params_


def test_only_the_final_fit_warns_of_convergence(record):
    u, y = record
    model = _model(ROUGH, continuation={"eps": [1e-2]}).set_params(max_nfev=2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.fit_simulation(u, y)
    stops = [w for w in caught if issubclass(w.category, ConvergenceWarning)]
    assert len(stops) == 1


@pytest.mark.parametrize(
    ("continuation", "error", "match"),
    [
        ({"m": [2.0]}, ValueError, "continuation names 'm', which is not a fixed"),
        ({"stiffness": [2.0]}, ValueError, "continuation names 'stiffness'"),
        ({"eps": 1e-2}, TypeError, r"continuation\['eps'\] must be a sequence"),
        ({"eps": []}, ValueError, r"continuation\['eps'\] must hold one or more"),
        ({"eps": [np.nan]}, ValueError, r"must hold one or more finite numbers"),
        (
            {"eps": [1e-2, 1e-3], "dt": [0.02]},
            ValueError,
            "the same number of stages",
        ),
        ([("eps", [1e-2])], (TypeError, ValueError), "continuation"),
    ],
)
def test_a_bad_continuation_is_named(record, continuation, error, match):
    u, y = record
    with pytest.raises(error, match=match):
        _model(ROUGH, continuation=continuation).fit_simulation(u[:100], y[:100])
