"""ParametricModel (user functions) and LinearStateSpaceModel."""

import pickle

import numpy as np
import pytest

from skhybrid.domain import LinearStateSpaceModel, ParametricModel


def damped(X, *, omega, zeta, xp=np):
    """Second-order difference equation using the two steps of a window."""
    dt = 0.1
    x_old, x_new = X[:, 0], X[:, 1]
    a1 = 2 - 2 * zeta * omega * dt - (omega * dt) ** 2
    a2 = 2 * zeta * omega * dt - 1
    return a1 * x_new + a2 * x_old


def numpy_only(X, *, k):
    return np.tanh(k * X[:, 0])


def _oscillator(rng, n=400, omega=2.0, zeta=0.1, noise=0.0):
    x = np.zeros(n + 2)
    x[0], x[1] = 1.0, 0.99
    for t in range(2, n + 2):
        x[t] = damped(x[None, t - 2 : t], omega=omega, zeta=zeta)[0]
    X = np.column_stack([x[:-2], x[1:-1]])
    return X, x[2:] + noise * rng.standard_normal(n)


@pytest.mark.parametrize("jac", ["2-point", "3-point", "autograd"])
def test_parametric_model_uses_whole_window(rng, jac):
    X, y = _oscillator(rng)
    model = ParametricModel(
        damped, {"omega": 1.0, "zeta": 0.5}, n_steps=2, jac=jac
    ).fit(X, y)
    # least_squares stops at its default ftol/xtol/gtol of 1e-8 on the cost.
    np.testing.assert_allclose(model.params_["omega"], 2.0, rtol=1e-4)
    np.testing.assert_allclose(model.params_["zeta"], 0.1, rtol=1e-3)
    assert set(model.params_std_) == {"omega", "zeta"}
    assert model.free_params_ == ["omega", "zeta"]


def test_parametric_model_bounds_and_fixed(rng):
    X, y = _oscillator(rng, noise=1e-3)
    model = ParametricModel(
        damped,
        {"omega": 1.0, "zeta": 0.05},
        bounds={"omega": (0.5, 1.5)},
        n_steps=2,
    ).fit(X, y)
    assert 0.5 <= model.params_["omega"] <= 1.5
    held = ParametricModel(
        damped, {"omega": 1.0, "zeta": 0.1}, fixed=("zeta",), n_steps=2
    ).fit(X, y)
    assert held.params_["zeta"] == 0.1
    np.testing.assert_allclose(held.params_["omega"], 2.0, rtol=1e-2)


def test_parametric_model_pickles_with_module_level_function(rng):
    X, y = _oscillator(rng)
    model = ParametricModel(damped, {"omega": 1.5, "zeta": 0.2}, n_steps=2).fit(X, y)
    np.testing.assert_array_equal(
        pickle.loads(pickle.dumps(model)).predict(X), model.predict(X)
    )


def test_parametric_model_errors(rng):
    X = rng.standard_normal((30, 1))
    y = X[:, 0]
    with pytest.raises(ValueError, match=r"params has keys \['c'\] that numpy_only"):
        ParametricModel(numpy_only, {"c": 1.0}).fit(X, y)
    with pytest.raises(ValueError, match="needs func to take an 'xp'"):
        ParametricModel(numpy_only, {"k": 1.0}, jac="autograd").fit(X, y)
    with pytest.raises(ValueError, match="parameter 'k' must be finite; got nan"):
        ParametricModel(numpy_only, {"k": np.nan}).fit(X, y)
    with pytest.raises(ValueError, match="at least one parameter"):
        ParametricModel(numpy_only, {}).fit(X, y)
    with pytest.raises(ValueError, match="y has 2 outputs"):
        ParametricModel(numpy_only, {"k": 1.0}).fit(X, np.column_stack([y, y]))
    with pytest.raises(ValueError, match=r"objective.*must be a str among"):
        ParametricModel(numpy_only, {"k": 1.0}, objective="l2").fit(X, y)


def test_linear_state_space_closed_form_and_stability(rng):
    A = np.array([[0.95, 0.05], [-0.1, 0.9]])
    B = np.array([[0.0], [0.1]])
    c = np.array([0.01, -0.02])
    X = rng.standard_normal((500, 3))
    y = X[:, :2] @ A.T + X[:, 2:] @ B.T + c + 1e-3 * rng.standard_normal((500, 2))
    model = LinearStateSpaceModel(n_inputs=1).fit(X, y)
    np.testing.assert_allclose(model.A_, A, atol=1e-3)
    np.testing.assert_allclose(model.B_, B, atol=1e-3)
    np.testing.assert_allclose(model.c_, c, atol=1e-3)
    assert model.result_ is None  # closed form
    np.testing.assert_allclose(
        np.sort(np.abs(model.eigenvalues_)),
        np.sort(np.abs(np.linalg.eigvals(A))),
        atol=1e-3,
    )
    assert model.is_stable_
    assert model.params_std_["A"].shape == (2, 2)
    assert np.all(model.params_std_["A"] > 0) and np.all(model.params_std_["A"] < 1e-3)
    # The iterative path reaches the same optimum.
    iterative = LinearStateSpaceModel(objective="mse+ljung_box", jac="autograd")
    iterative.fit(X, y)
    np.testing.assert_allclose(iterative.A_, A, atol=5e-3)


def test_linear_state_space_rejects_wrong_input_count(rng):
    X, y = rng.standard_normal((50, 4)), rng.standard_normal((50, 2))
    with pytest.raises(ValueError, match="n_inputs=1 but X has 4 columns per step"):
        LinearStateSpaceModel(n_inputs=1).fit(X, y)
    with pytest.raises(ValueError, match="a step has only 4 columns"):
        LinearStateSpaceModel().fit(X, rng.standard_normal((50, 5)))
