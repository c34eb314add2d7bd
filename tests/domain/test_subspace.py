"""subspace_state_space: a linear state-space start from N4SID."""

import pickle
import warnings

import numpy as np
import pytest
from sklearn.base import clone

from skhybrid.domain import StateSpaceModel, subspace_state_space
from skhybrid.domain._subspace import linear_output, linear_state_update

A_TRUE = np.array([[0.9, 0.2, 0.0], [-0.2, 0.9, 0.0], [0.0, 0.0, 0.7]])


def _system(seed=1):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((3, 2)), rng.standard_normal((2, 3))


def _simulate(u, B, C, x0=(0.0, 0.0, 0.0)):
    """Two inputs around 0.5, two outputs offset by (1, -2)."""
    x, ys = np.asarray(x0, dtype=float), []
    for step in u:
        ys.append(C @ x + np.array([1.0, -2.0]))
        x = A_TRUE @ x + B @ (step - 0.5)
    return np.array(ys)


def _poles(params, order):
    A = np.array([[params[f"a_{i}_{j}"] for j in range(order)] for i in range(order)])
    return np.sort_complex(np.linalg.eigvals(A))


@pytest.fixture(scope="module")
def mimo():
    B, C = _system()
    rng = np.random.default_rng(2)
    u = rng.standard_normal((2000, 2)) + 0.5
    y = _simulate(u, B, C) + 0.01 * rng.standard_normal((2000, 2))
    u_new = rng.standard_normal((400, 2)) + 0.5
    y_new = _simulate(u_new, B, C, x0=(1.0, 0.0, -1.0))
    return u, y, u_new, y_new


def test_subspace_finds_the_poles_and_the_means(mimo):
    u, y, _, _ = mimo
    model = subspace_state_space(u, y, 3)
    assert isinstance(model, StateSpaceModel)
    np.testing.assert_allclose(
        _poles(model.params, 3), np.sort_complex(np.linalg.eigvals(A_TRUE)), atol=5e-3
    )
    # The outputs' means are the output biases; the state bias is -B mean(u).
    np.testing.assert_allclose(
        [model.params["y_bias_0"], model.params["y_bias_1"]], y.mean(axis=0)
    )
    B = np.array([[model.params[f"b_{i}_{k}"] for k in range(2)] for i in range(3)])
    np.testing.assert_allclose(
        [model.params[f"x_bias_{i}"] for i in range(3)], -B @ u.mean(axis=0)
    )


def test_fit_simulation_refines_it_to_a_held_out_record(mimo):
    u, y, u_new, y_new = mimo
    start = subspace_state_space(u, y, 3, n_init=20, max_nfev=50)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no identifiability or overflow noise
        model = clone(start).fit_simulation(u, y)
    pred = model.simulate(u_new, y_new[:20])
    # Noise of 0.01 on the fitting record; the held-out one is noiseless and
    # starts from another state, estimated from its first 20 samples.
    rmse = np.sqrt(np.mean((pred[20:] - y_new[20:]) ** 2))
    assert rmse < 0.003
    np.testing.assert_allclose(
        _poles(model.params_, 3), np.sort_complex(np.linalg.eigvals(A_TRUE)), atol=2e-3
    )


def test_subspace_model_pickles_and_runs_in_torch(mimo):
    import torch

    u, y, _, _ = mimo
    model = subspace_state_space(u, y, 3)
    again = pickle.loads(pickle.dumps(model))
    assert again.params == model.params
    x = np.random.default_rng(0).standard_normal((5, 3))
    steps = np.random.default_rng(1).standard_normal((5, 2))
    xt, ut = torch.as_tensor(x), torch.as_tensor(steps)
    params = {k: torch.tensor(v, requires_grad=True) for k, v in model.params.items()}
    out = linear_state_update(xt, ut, xp=torch, **params)
    expected = linear_state_update(x, steps, xp=np, **model.params)
    np.testing.assert_allclose(out.detach().numpy(), expected)
    linear_output(xt, xp=torch, **params).sum().backward()
    assert params["c_0_0"].grad is not None


def test_state_update_takes_one_parameter_set_per_row():
    # vectorized=True gives every row its own value of a free parameter.
    params = {"a_0_0": np.array([0.5, 2.0]), "b_0_0": 1.0, "x_bias_0": 0.0}
    out = linear_state_update(np.ones((2, 1)), np.zeros((2, 1)), xp=np, **params)
    np.testing.assert_allclose(out, [[0.5], [2.0]])


def test_unstable_estimate_and_dropped_feedthrough_warn():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((600, 1))
    # y(t) = u(t): all feedthrough, no dynamics to speak of.
    with pytest.warns(UserWarning, match="direct feedthrough D"):
        subspace_state_space(u, u.copy(), 1)
    grow = np.zeros((600, 1))
    for t in range(1, 600):
        grow[t] = 1.01 * grow[t - 1] + u[t - 1, 0]
    with pytest.warns(UserWarning, match="unstable"):
        subspace_state_space(u, grow, 1)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"order": 0}, ValueError, "order must be a positive integer; got order=0"),
        ({"order": 2.5}, ValueError, "got order=2.5"),
        ({"order": True}, ValueError, "got order=True"),
        ({"order": 2, "block_rows": 2}, ValueError, "got block_rows=2"),
        ({"order": 2, "block_rows": 200}, ValueError, "too short for block_rows=200"),
        ({"order": 2, "time": "continuous"}, TypeError, "sets time itself"),
        ({"order": 2, "rhs": print}, TypeError, "sets rhs itself"),
    ],
)
def test_bad_arguments_are_named(kwargs, error, match):
    u = np.random.default_rng(0).standard_normal((300, 1))
    with pytest.raises(error, match=match):
        subspace_state_space(u, u, **kwargs)


def test_bad_records_are_named():
    u = np.random.default_rng(0).standard_normal((300, 1))
    with pytest.raises(ValueError, match="same number of samples; got 300 and 299"):
        subspace_state_space(u, u[:-1], 2)
    bad = u.copy()
    bad[5] = np.nan
    with pytest.raises(ValueError, match="outputs holds NaN"):
        subspace_state_space(u, bad, 2)
    with pytest.raises(TypeError, match="inputs must be one record"):
        subspace_state_space([u, u], u, 2)
    with pytest.raises(ValueError, match=r"got shape \(300, 1, 1\)"):
        subspace_state_space(u[:, :, None], u, 2)


def test_a_long_record_fits_in_little_memory():
    # A full SVD of the observability estimate would need a (n, n) factor:
    # 80 GB at 100,000 samples. The thin one needs a few megabytes.
    rng = np.random.default_rng(0)
    u = rng.standard_normal((100_000, 1))
    y = np.zeros((100_000, 1))
    for t in range(1, 100_000):
        y[t] = 0.95 * y[t - 1] + u[t - 1, 0]
    model = subspace_state_space(u, y, 1)
    assert model.params["a_0_0"] == pytest.approx(0.95, abs=1e-6)
