"""Tests of diagnose / diagnose_predictions and the DiagnosticReport."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import lfilter

from skhybrid.diagnostics import (
    diagnose,
    diagnose_predictions,
    ljung_box_test,
    residual_input_correlation,
)
from skhybrid.domain import LinearStateSpaceModel
from skhybrid.preprocessing import make_windows


def _simulate(seed, *, n=800, hidden_input_lag=0.0, noise_phi=0.0):
    """x(t+1) = 0.9 x(t) + 0.5 u(t) [+ c u(t-3)] + noise (AR(1) if noise_phi)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n + 1, 2))
    noise = lfilter([1.0], [1.0, -noise_phi], 0.05 * rng.standard_normal(n + 1))
    x = np.zeros((n + 1, 1))
    for t in range(n):
        delayed = u[t - 3, 0] if t >= 3 else 0.0
        x[t + 1] = 0.9 * x[t] + 0.5 * u[t, 0] - 0.2 * u[t, 1]
        x[t + 1] += hidden_input_lag * delayed + noise[t + 1]
    return x, u


def test_diagnose_passes_a_well_specified_model():
    states, inputs = _simulate(0)
    X, y = make_windows(states, inputs, n_steps=1)
    model = LinearStateSpaceModel().fit(X, y)
    report = diagnose(model, X, y, lags=15, alpha=0.05)
    assert report.passed
    assert report.n_tests == 3  # 1 whiteness + 1 output x 2 inputs
    assert_allclose(report.level, 0.05 / 3)
    residuals = y - model.predict(X).reshape(y.shape)
    assert_allclose(report.rmse, np.sqrt(np.mean(residuals**2, axis=0)))
    assert_allclose(report.rmse_db, 20 * np.log10(report.rmse))
    assert_allclose(report.whiteness.pvalue, ljung_box_test(residuals, 15).pvalue)
    expected = residual_input_correlation(residuals, inputs[:-1], lags=15)
    assert_allclose(report.independence.pvalue, expected.pvalue)


def test_diagnose_tells_missing_input_dynamics_from_coloured_noise():
    # Missing dynamics: the residual holds u(t - 3), which the model cannot see.
    states, inputs = _simulate(1, hidden_input_lag=0.3)
    X, y = make_windows(states, inputs)
    report = diagnose(LinearStateSpaceModel().fit(X, y), X, y, lags=15)
    assert not report.passed
    assert not report.independent[0]
    # Coloured noise only: the input dynamics are right, the residual is AR(1).
    # (The true model: a least-squares fit to AR noise would be biased and would
    # itself leave input-correlated residuals.)
    states, inputs = _simulate(2, noise_phi=0.8)
    X, y = make_windows(states, inputs)
    y_true_model = X @ np.array([[0.9], [0.5], [-0.2]])
    report = diagnose_predictions(y, y_true_model, inputs=X[:, 1:], lags=15)
    assert not report.passed
    assert not report.white[0]
    assert report.independent[0]


def test_diagnose_default_inputs_read_the_newest_step():
    states, inputs = _simulate(3)
    X, y = make_windows(states, inputs, n_steps=3)  # 3 steps of [x, u0, u1]
    model = LinearStateSpaceModel(n_steps=3).fit(X, y)
    report = diagnose(model, X, y, lags=10)
    assert report.independence.ccf.shape[1:] == (1, 2)
    assert report.input_names == ("u0", "u1")
    explicit = diagnose(model, X, y, lags=10, inputs=X[:, -2:])
    assert_allclose(report.independence.pvalue, explicit.independence.pvalue)
    every = diagnose(model, X, y, lags=10, inputs="X")
    assert every.independence.ccf.shape[2] == 9
    assert every.n_tests == 10


def test_diagnose_without_inputs_skips_independence():
    rng = np.random.default_rng(0)
    X, y = make_windows(np.cumsum(rng.standard_normal((300, 2)), axis=0))
    model = LinearStateSpaceModel().fit(X, y)
    report = diagnose(model, X, y, lags=10)
    assert report.independence is None and report.input_names == ()
    assert report.n_tests == 2
    frame = report.to_frame()
    assert frame["independence_pvalue"].isna().all()
    assert frame["independent"].all()


def test_report_frame_and_repr():
    rng = np.random.default_rng(0)
    u = rng.standard_normal(600)
    y = np.column_stack([rng.standard_normal(600), _ar(rng, 0.6, 600)])
    y_pred = np.zeros_like(y)
    report = diagnose_predictions(
        y,
        y_pred,
        inputs=u,
        lags=10,
        output_names=["theta", "omega"],
        input_names=["voltage"],
        estimator_name="MyModel",
    )
    frame = report.to_frame()
    assert list(frame.index) == ["theta", "omega"]
    assert list(frame.columns) == [
        "rmse",
        "rmse_db",
        "ljung_box_stat",
        "ljung_box_pvalue",
        "white",
        "independence_pvalue",
        "worst_input",
        "independent",
        "passed",
    ]
    assert frame.loc["theta", "white"] and not frame.loc["omega", "white"]
    assert frame["worst_input"].tolist() == ["voltage", "voltage"]
    assert frame["passed"].tolist() == [True, False]
    text = repr(report)
    assert text.startswith("DiagnosticReport(MyModel: n_samples=600, lags=10")
    assert "omega" in text and "not white" in text
    assert "FAILED at alpha=0.05" in text and "4 tests" in text


def _ar(rng, phi, n):
    return lfilter([1.0], [1.0, -phi], rng.standard_normal(n))


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"inputs": "states"}, ValueError, "inputs must be None, 'X' or an array"),
        ({"output_names": ["a", "b"]}, ValueError, "output_names must name each"),
        ({"alpha": 0.0}, ValueError, "alpha"),
    ],
)
def test_diagnose_rejects_bad_arguments(kwargs, error, match):
    states, inputs = _simulate(4, n=200)
    X, y = make_windows(states, inputs)
    model = LinearStateSpaceModel().fit(X, y)
    with pytest.raises(error, match=match):
        diagnose(model, X, y, lags=5, **kwargs)


def test_diagnose_predictions_rejects_mismatched_shapes():
    with pytest.raises(ValueError, match="same shape"):
        diagnose_predictions(np.zeros((20, 2)), np.zeros((20, 1)), lags=3)
