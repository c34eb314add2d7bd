"""The stochastic part of a chosen model: tests, noise model, band coverage."""

import numpy as np
import pytest
from statsmodels.tsa.arima_process import ArmaProcess

from skhybrid.experiments._stochastic import band_coverage, fit_noise, residual_tests


def _ar_noise(n, seed, phi=0.7, scale=0.1):
    rng = np.random.default_rng(seed)
    return ArmaProcess([1, -phi], [1]).generate_sample(
        n, scale=scale, distrvs=rng.standard_normal
    )


def test_a_correct_model_with_its_true_noise_covers_the_nominal_level():
    # A model whose free run is the noise-free output: what is left is the
    # true AR(1) noise. Fitted on four validation blocks, its band covers a
    # long test record close to 95 %.
    blocks = [_ar_noise(2000, seed) for seed in range(4)]
    noise, description = fit_noise(blocks)
    assert description["lags"] == [1]
    assert description["coef"][0] == pytest.approx(0.7, abs=0.05)
    true_std = 0.1 / np.sqrt(1 - 0.7**2)
    assert description["std"] == pytest.approx(true_std, rel=0.1)
    t = np.arange(20000)
    y_sim = np.sin(0.01 * t)
    y = y_sim + _ar_noise(20000, 99)
    lower, upper, coverage = band_coverage(y, y_sim, 10, noise)
    assert coverage == pytest.approx(0.95, abs=0.02)
    assert np.all(lower < y_sim) and np.all(upper > y_sim)


def test_a_band_too_narrow_is_reported_as_such():
    # Noise fitted on residuals ten times smaller than the test's: the coverage
    # says so, nothing widens the band.
    noise, _ = fit_noise([0.1 * _ar_noise(4000, 0)])
    y_sim = np.zeros(5000)
    _, _, coverage = band_coverage(_ar_noise(5000, 1), y_sim, 10, noise)
    assert coverage < 0.5


def test_a_failed_free_run_has_no_coverage():
    noise, _ = fit_noise([_ar_noise(500, 0)])
    y_sim = np.full(100, np.nan)
    assert band_coverage(np.zeros(100), y_sim, 10, noise)[2] is None


def test_residual_tests_tell_white_from_coloured_and_input_dynamics():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((3000, 1))
    white = residual_tests(rng.standard_normal(3000), u)
    assert white["ljung_box_pvalue"] > 0.01
    assert white["input_correlation_pvalue"] > 0.01
    coloured = residual_tests(_ar_noise(3000, 1), u)
    assert coloured["ljung_box_pvalue"] < 1e-6
    # Residuals that still carry the input (missing dynamics) fail independence.
    missed = residual_tests(
        0.5 * np.r_[0.0, u[:-1, 0]] + 0.1 * rng.standard_normal(3000), u
    )
    assert missed["input_correlation_pvalue"] < 1e-6
    assert missed["max_abs_input_correlation"] > missed["input_correlation_band"]


def test_too_few_residuals_are_said_not_hidden():
    noise, description = fit_noise([np.ones(5)])
    assert noise is None and description["fitted"] is False
    assert residual_tests(np.ones(10), np.ones((10, 1)))["ljung_box_pvalue"] is None
