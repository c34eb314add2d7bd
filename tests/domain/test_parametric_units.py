"""ParametricModel fits the same whatever the units, and says when it cannot."""

import re
import warnings

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from skhybrid.domain import ParametricModel

SCALES = [1.0, 1e-3, 1e-4, 1e-8, 1e6]


def gain(X, *, k, xp=np):
    return k * X[:, 0]


def damped(X, *, omega, zeta, xp=np):
    """Second-order difference equation: linear in x, nonlinear in the parameters."""
    dt = 0.1
    a1 = 2 - 2 * zeta * omega * dt - (omega * dt) ** 2
    a2 = 2 * zeta * omega * dt - 1
    return a1 * X[:, 1] + a2 * X[:, 0]


def _fit_quietly(model, X, y):
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        return model.fit(X, y)


@pytest.mark.parametrize("jac", ["2-point", "autograd"])
@pytest.mark.parametrize("scale", SCALES)
def test_gain_is_found_at_any_scale_of_the_data(scale, jac):
    # The minimal case: at 1e-4 the fit returned k=1.0 after one
    # evaluation, with a plausible standard error and no warning.
    X = np.linspace(0, 1, 200)[:, None] * scale
    model = _fit_quietly(ParametricModel(gain, {"k": 1.0}, jac=jac), X, 2 * X[:, 0])
    assert model.params_["k"] == pytest.approx(2.0, rel=1e-6)
    assert model.result_.nfev > 1
    assert model.params_std_["k"] < 1e-6


@pytest.mark.parametrize("scale", SCALES)
def test_noisy_fit_and_standard_errors_do_not_depend_on_units(scale, rng):
    X = np.linspace(0, 1, 300)[:, None]
    y = 2 * X[:, 0] + 0.05 * rng.standard_normal(300)
    reference = _fit_quietly(ParametricModel(gain, {"k": 1.0}), X, y)
    model = _fit_quietly(ParametricModel(gain, {"k": 1.0}), X * scale, y * scale)
    assert model.params_["k"] == pytest.approx(reference.params_["k"], rel=1e-6)
    assert model.params_std_["k"] == pytest.approx(reference.params_std_["k"], rel=1e-4)
    # The result is reported in the data's units.
    assert model.result_.cost == pytest.approx(
        reference.result_.cost * scale**2, rel=1e-6
    )


@pytest.mark.parametrize("scale", SCALES)
def test_nonlinear_parameters_are_found_at_any_scale(scale, rng):
    x = np.zeros(402)
    x[0], x[1] = 1.0, 0.99
    for t in range(2, 402):
        x[t] = damped(x[None, t - 2 : t], omega=2.0, zeta=0.1)[0]
    X = np.column_stack([x[:-2], x[1:-1]]) * scale
    y = x[2:] * scale
    model = _fit_quietly(
        ParametricModel(damped, {"omega": 1.0, "zeta": 0.5}, n_steps=2), X, y
    )
    assert model.params_["omega"] == pytest.approx(2.0, rel=1e-4)
    assert model.params_["zeta"] == pytest.approx(0.1, rel=1e-3)


@pytest.mark.parametrize("k_true", [3e-7, 3e7])
def test_parameters_of_any_size_are_found(k_true):
    # An inertia in kg m^2 or a stiffness in N/m: the start has the right order.
    X = np.linspace(0, 1, 200)[:, None]
    model = _fit_quietly(ParametricModel(gain, {"k": k_true / 3}), X, k_true * X[:, 0])
    assert model.params_["k"] == pytest.approx(k_true, rel=1e-6)


def test_warns_when_the_optimiser_stops_without_moving():
    # A start at zero for a parameter of order 1e9: the gradient is below the
    # optimiser's tolerance, so it stops at once; that must not pass silently.
    X = np.linspace(0, 1, 200)[:, None]
    with pytest.warns(ConvergenceWarning, match="stopped at the starting values"):
        model = ParametricModel(gain, {"k": 0.0}).fit(X, 1e9 * X[:, 0])
    assert model.params_["k"] == 0.0


def ignores_k(X, *, k, xp=np):
    return X[:, 0] + 0 * k


def test_warns_when_the_parameter_does_not_change_the_predictions():
    X = np.linspace(0, 1, 200)[:, None]
    with pytest.warns(ConvergenceWarning, match="parameters change the predictions"):
        ParametricModel(ignores_k, {"k": 1.0}).fit(X, 2 * X[:, 0])


def test_no_warning_when_the_start_is_already_optimal(rng):
    X = np.linspace(0, 1, 200)[:, None]
    y = 2 * X[:, 0] + 0.1 * rng.standard_normal(200)
    k_hat = float(np.linalg.lstsq(X, y, rcond=None)[0][0])
    model = _fit_quietly(ParametricModel(gain, {"k": k_hat}), X, y)
    assert model.params_["k"] == pytest.approx(k_hat, rel=1e-9)


def returns_scalar(X, *, k):
    return float(k)


def returns_list(X, *, k):
    return [k] * len(X)


def returns_three_columns(X, *, k):
    return k * np.column_stack([X[:, 0]] * 3)


def returns_too_few_rows(X, *, k):
    return k * X[:10, 0]


def returns_3d(X, *, k):
    return k * X[:, :, None]


@pytest.mark.parametrize(
    "func, got",
    [
        (returns_scalar, "a float without a shape"),
        (returns_list, "a list without a shape"),
        (returns_three_columns, "shape (50, 3)"),
        (returns_too_few_rows, "shape (10,)"),
        (returns_3d, "shape (50, 1, 1)"),
    ],
)
@pytest.mark.parametrize("n_outputs", [1, 2])
def test_wrong_shape_names_function_shape_and_expected_shape(func, got, n_outputs):
    X = np.linspace(0, 1, 50)[:, None]
    y = np.column_stack([X[:, 0]] * n_outputs) if n_outputs > 1 else X[:, 0]
    expected = "(50,) or (50, 1)" if n_outputs == 1 else "(50, 2), or (50, 1)"
    with pytest.raises(ValueError) as exc:
        ParametricModel(func, {"k": 1.0}).fit(X, y)
    message = str(exc.value)
    assert func.__name__ in message
    assert got in message
    assert re.search(rf"expected shape {re.escape(expected)}", message), message


def decay(X, *, k, xp=np):
    return xp.exp(-k * X[:, 0])


@pytest.mark.parametrize("scale", SCALES)
def test_standard_errors_of_a_nonlinear_parameter_do_not_depend_on_units(scale, rng):
    # X in seconds or in microseconds: k in 1/s or 1/us; k * X is the same. The
    # finite differences of the standard errors step on k's own scale (once they
    # stepped by 6e-6 on a k of 3e-7 and gave a standard error of 1e-14).
    x = np.linspace(0, 5, 300)[:, None]
    y = np.exp(-0.3 * x[:, 0]) + 0.01 * rng.standard_normal(300)
    reference = _fit_quietly(ParametricModel(decay, {"k": 0.1}), x, y)
    model = _fit_quietly(ParametricModel(decay, {"k": 0.1 / scale}), x * scale, y)
    assert model.params_["k"] * scale == pytest.approx(reference.params_["k"], rel=1e-6)
    assert model.params_std_["k"] * scale == pytest.approx(
        reference.params_std_["k"], rel=1e-4
    )


def emps_axis(X, *, M, Fv, Fc, offset, xp=np):
    """EMPS one step ahead: M a = tau - Fv v - Fc sign(v) - offset, at dt = 1 ms."""
    dt = 1e-3
    q_old, q_new, tau = X[:, 0], X[:, 2], X[:, 3]
    v = (q_new - q_old) / dt
    force = tau - Fv * v - Fc * xp.tanh(v / 1e-3) - offset
    return 2 * q_new - q_old + dt**2 / M * force


def test_measured_emps_in_si_units_is_fitted(shared_data_dir):
    # Positions in metres move by micrometres per step: the fit once stopped at its
    # starting values after one evaluation, silently.
    from skhybrid.datasets import load_emps

    data = load_emps(shared_data_dir / "emps")
    train = data.splits["train"]  # the estimation record only
    q = np.ravel(train.y)
    tau = np.ravel(train.u) * data.controller["gtau"]  # motor force in N
    X = np.column_stack([q[:-2], tau[:-2], q[1:-1], tau[1:-1]])
    start = {"M": 50.0, "Fv": 100.0, "Fc": 10.0, "offset": 0.0}
    model = _fit_quietly(ParametricModel(emps_axis, start, n_steps=2), X, q[2:])
    # The benchmark's IDIM-LS reference estimates (data/README.md): within 3 %.
    assert model.params_["M"] == pytest.approx(95.1089, rel=0.03)
    assert model.params_["Fv"] == pytest.approx(203.5034, rel=0.03)
    assert model.params_["Fc"] == pytest.approx(20.3935, rel=0.03)
