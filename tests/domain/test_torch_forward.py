"""The public torch contract of DomainModel: free-parameter vector, torch forward."""

import numpy as np
import pytest
import torch
from numpy.testing import assert_allclose, assert_array_equal

from skhybrid.domain import LinearStateSpaceModel, ParametricModel


def line(X, *, a, b, xp=np):
    return a * X[:, :1] + b


def line_numpy_only(X, *, a, b):
    return a * X[:, :1] + b


def _data(n=50):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(n, 2))
    return X, 2.0 * X[:, 0] + 0.5 + 0.01 * rng.normal(size=n)


def test_torch_forward_matches_predict_and_is_differentiable():
    X, y = _data()
    model = ParametricModel(line, {"a": 1.0, "b": 0.0}, bounds={"a": (0, 5)}).fit(X, y)
    theta = torch.tensor(model.pack_params(model.params_), requires_grad=True)
    out = model.torch_forward(torch.tensor(X), theta)
    assert out.shape == (50, 1)
    assert_allclose(out.detach().numpy()[:, 0], model.predict(X), rtol=1e-12)
    out.sum().backward()
    assert_allclose(theta.grad.numpy(), [X[:, 0].sum(), 50.0])
    lower, upper = model.free_bounds_
    assert_array_equal(lower, [0.0, -np.inf])
    assert_array_equal(upper, [5.0, np.inf])


def test_pack_unpack_round_trip_with_fixed_and_array_parameters():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 3))
    # Every coefficient and offset non-zero: on exact data a zero one is fitted
    # at rounding level, and the identifiability check cannot tell its scale.
    A = np.array([[0.9, 0.1], [-0.2, 0.8]])
    Y = X[:, :2] @ A.T + 0.5 * X[:, 2:] + [0.3, -0.1]
    model = LinearStateSpaceModel().fit(X, Y)
    theta = model.pack_params(model.params_)
    assert theta.shape == (sum(np.size(v) for v in model.params_.values()),)
    back = model.unpack_params(theta)
    for name, value in model.params_.items():
        assert_allclose(back[name], value)
    tensors = model.unpack_params(torch.as_tensor(theta))
    assert all(isinstance(v, torch.Tensor) for v in tensors.values())
    with pytest.raises(ValueError, match=r"theta has shape \(3,\)"):
        model.unpack_params(np.zeros(3))
    with pytest.raises(ValueError, match="missing the free parameters"):
        model.pack_params({})

    fixed = ParametricModel(line, {"a": 1.0, "b": 0.25}, fixed=("b",))
    fixed.fit(*_data())
    assert_array_equal(fixed.pack_params(fixed.params_), [fixed.params_["a"]])
    assert fixed.unpack_params(np.array([3.0])) == {"a": 3.0, "b": 0.25}


def test_initialize_is_a_fit_without_iterations():
    X, y = _data()
    model = ParametricModel(line, {"a": 1.0, "b": 0.0}).initialize(X, y)
    assert model.params_ == {"a": 1.0, "b": 0.0}
    assert model.result_ is None and np.isnan(model.params_std_["a"])
    assert_allclose(model.predict(X), X[:, 0])
    assert model.free_params_ == ["a", "b"]


def test_torch_forward_needs_xp():
    X, y = _data()
    model = ParametricModel(line_numpy_only, {"a": 1.0, "b": 0.0}).fit(X, y)
    with pytest.raises(ValueError, match="needs func to take an 'xp'"):
        model.torch_forward(torch.tensor(X), torch.zeros(2, dtype=torch.float64))
