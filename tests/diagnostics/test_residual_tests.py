"""Tests of the residual tests: whiteness, autocorrelation, independence, dB."""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import stats
from scipy.signal import lfilter
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa.stattools import acf, ccf

from skhybrid.diagnostics import (
    ljung_box_test,
    residual_acf,
    residual_input_correlation,
    rmse_db,
)
from skhybrid.losses import autocorrelation, ljung_box


def _ar1(rng, phi, shape):
    """AR(1) series along axis 0, started from its stationary distribution."""
    noise = rng.standard_normal(shape)
    noise[0] /= np.sqrt(1.0 - phi**2)
    return lfilter([1.0], [1.0, -phi], noise, axis=0)


def _binomial_bounds(n, p, tail=1e-4):
    """Central interval holding Binomial(n, p) with probability 1 - 2 * tail.

    ``tail=1e-4`` (about 3.7 sigma) keeps a sweep over 100 seeds of the few
    level tests below from failing by chance, while a test whose true level is
    off by a few percent still fails.
    """
    dist = stats.binom(n, p)
    return dist.ppf(tail), dist.isf(tail)


# ----------------------------------------------------------------------------------
# ljung_box_test
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("lags", [1, 5, 20])
def test_ljung_box_test_matches_statsmodels_and_loss(rng, lags):
    x = rng.standard_normal((300, 3))
    x[:, 1] = _ar1(rng, 0.6, 300)
    res = ljung_box_test(x, lags=lags)
    for j in range(3):
        frame = acorr_ljungbox(x[:, j], lags=[lags])
        assert_allclose(res.statistic[j], frame["lb_stat"].iloc[0], rtol=1e-12)
        assert_allclose(res.pvalue[j], frame["lb_pvalue"].iloc[0], rtol=1e-12)
    # One idea, two implementations: the training loss and the diagnostic agree.
    assert_allclose(res.statistic, ljung_box(x, lags=lags, reduction="none"), rtol=1e-9)
    assert_allclose(res.pvalue, stats.chi2.sf(res.statistic, lags), rtol=1e-9)


def test_ljung_box_test_1d_and_model_df(rng):
    x = rng.standard_normal(200)
    res = ljung_box_test(x, lags=10, model_df=2)
    assert res.statistic.shape == (1,) and res.df == 8
    assert_allclose(res.statistic[0], ljung_box(x, lags=10), rtol=1e-9)
    assert_allclose(res.pvalue, stats.chi2.sf(res.statistic, 8), rtol=1e-9)


def test_whiteness_holds_its_level_on_white_noise(global_random_seed):
    """About 95 % of 400 white-noise draws pass at alpha = 0.05."""
    rng = np.random.default_rng(global_random_seed)
    draws = rng.standard_normal((500, 400))  # 400 series as 400 columns
    res = ljung_box_test(draws, lags=10, alpha=0.05)
    n_passed = int(res.passed.sum())
    low, high = _binomial_bounds(400, 0.95)
    assert low <= n_passed <= high, (n_passed, low, high)


def test_whiteness_rejects_every_ar1_draw(global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    draws = _ar1(rng, 0.5, (2000, 20))
    res = ljung_box_test(draws, lags=20, alpha=0.05)
    assert not res.passed.any()
    assert not res.is_white


def test_whitenessresult_is_frozen(rng):
    res = ljung_box_test(rng.standard_normal(100), lags=5)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.lags = 3


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"lags": 0}, "lags must be an integer >= 1"),
        ({"lags": 100}, "lags must be at most 99"),
        ({"lags": 2.0}, "got lags=2.0"),
        ({"lags": 5, "model_df": 5}, "model_df must be at most 4"),
        ({"lags": 5, "alpha": 1.5}, "got alpha=1.5"),
    ],
)
def test_ljung_box_test_rejects_bad_parameters(rng, kwargs, match):
    with pytest.raises(ValueError, match=match):
        ljung_box_test(rng.standard_normal(100), **kwargs)


def test_ljung_box_test_rejects_nan_and_3d():
    with pytest.raises(ValueError, match="residuals"):
        ljung_box_test(np.array([1.0, np.nan, 2.0, 3.0]), lags=1)
    with pytest.raises(ValueError):
        ljung_box_test(np.zeros((5, 2, 2)), lags=1)


# ----------------------------------------------------------------------------------
# residual_acf
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("bartlett", [True, False])
def test_residual_acf_matches_statsmodels(rng, bartlett):
    x = np.column_stack([rng.standard_normal(400), _ar1(rng, 0.7, 400)])
    res = residual_acf(x, nlags=15, alpha=0.1, bartlett_confint=bartlett)
    assert res.acf.shape == (16, 2) and res.confint.shape == (16, 2, 2)
    for j in range(2):
        rho, ci = acf(
            x[:, j],
            nlags=15,
            alpha=0.1,
            bartlett_confint=bartlett,
            result_object=False,
        )
        assert_allclose(res.acf[:, j], rho, rtol=1e-12)
        assert_allclose(res.confint[:, j], ci, rtol=1e-12)
    assert_allclose(res.acf, autocorrelation(x, 15), rtol=1e-9, atol=1e-12)
    z = stats.norm.ppf(0.95)
    if bartlett:
        # Bartlett's band widens with the lag for a coloured series.
        assert np.all(np.diff(res.band[1:, 1]) >= 0)
        assert res.band[-1, 1] > 1.5 * z / np.sqrt(400)
    else:
        assert_allclose(res.band[1:], z / np.sqrt(400), rtol=1e-9)
    assert not res.exceeds[0].any()
    assert res.exceeds[1, 1]  # the AR(1) series' first lag is significant


# ----------------------------------------------------------------------------------
# residual_input_correlation
# ----------------------------------------------------------------------------------
def test_cross_correlation_matches_statsmodels_without_prewhitening(rng):
    e = rng.standard_normal((300, 2))
    u = rng.standard_normal((300, 3))
    res = residual_input_correlation(e, u, lags=8, prewhiten=False)
    assert res.ccf.shape == (17, 2, 3)
    assert_array_equal(res.lags, np.arange(-8, 9))
    for o in range(2):
        for i in range(3):
            # statsmodels' ccf(x, y)[k] = corr(x(t + k), y(t)): our positive lags.
            pos = ccf(e[:, o], u[:, i], adjusted=False, nlags=9, result_object=False)
            assert_allclose(res.ccf[8:, o, i], pos, rtol=1e-9, atol=1e-12)
            neg = ccf(u[:, i], e[:, o], adjusted=False, nlags=9, result_object=False)
            assert_allclose(res.ccf[8::-1, o, i], neg, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("prewhiten", [True, False])
def test_independence_flags_a_lagged_input_copy(rng, prewhiten):
    n = 2000
    u = _ar1(rng, 0.5, (n, 2))
    e = 0.8 * _ar1(rng, 0.5, n)
    e[4:] += 0.3 * u[:-4, 1]  # the model missed u_1(t - 4)
    res = residual_input_correlation(e, u, lags=10, prewhiten=prewhiten)
    assert not res.is_independent
    assert not res.passed[0, 1]
    assert res.any_exceeds[0, 1]
    assert res.lags[np.argmax(np.abs(res.ccf[:, 0, 1]))] == 4
    assert res.pvalue[0, 1] < 1e-6


@pytest.mark.parametrize("phi_e, phi_u", [(0.0, 0.0), (0.7, 0.0), (0.8, 0.9)])
def test_independence_holds_its_level(global_random_seed, phi_e, phi_u):
    """Independent residuals pass in about 95 % of draws, coloured or not."""
    rng = np.random.default_rng(global_random_seed)
    n_draws = 150
    e = _ar1(rng, phi_e, (600, n_draws))
    u = _ar1(rng, phi_u, (600, n_draws))
    n_passed = sum(
        residual_input_correlation(e[:, d], u[:, d], lags=10).is_independent
        for d in range(n_draws)
    )
    low, high = _binomial_bounds(n_draws, 0.95)
    assert low <= n_passed <= high, n_passed


def test_independence_prewhitening_orders(rng):
    e = _ar1(rng, 0.8, (1500, 1))
    u = rng.standard_normal((1500, 1))
    res = residual_input_correlation(e, u, lags=5)
    assert res.residual_ar_order[0] >= 1
    assert res.n_samples == 1500 - max(res.residual_ar_order[0], res.input_ar_order[0])
    raw = residual_input_correlation(e, u, lags=5, prewhiten=False)
    assert raw.n_samples == 1500 and raw.residual_ar_order[0] == 0


def test_independence_constant_series_and_errors(rng):
    res = residual_input_correlation(rng.standard_normal(50), np.ones(50), lags=3)
    assert_allclose(res.ccf, 0.0)
    with pytest.raises(ValueError, match="inputs must have one row per residual"):
        residual_input_correlation(np.zeros(10), np.zeros(11), lags=2)
    with pytest.raises(TypeError, match="prewhiten"):
        residual_input_correlation(np.zeros(10), np.zeros(10), lags=2, prewhiten=1)
    with pytest.raises(ValueError, match="max_ar_order"):
        residual_input_correlation(
            rng.standard_normal(20), rng.standard_normal(20), lags=10
        )


# ----------------------------------------------------------------------------------
# rmse_db
# ----------------------------------------------------------------------------------
def test_rmse_db_values(rng):
    y = rng.standard_normal((100, 2))
    err = rng.standard_normal((100, 2))
    expected = 20 * np.log10(np.sqrt(np.mean(err**2, axis=0)))
    assert_allclose(rmse_db(y, y + err), expected, rtol=1e-12)
    windows = rmse_db(y, y + err, window=30)
    assert windows.shape == (3, 2)  # the last 10 samples are dropped
    assert_allclose(
        windows[1], 20 * np.log10(np.sqrt(np.mean(err[30:60] ** 2, axis=0)))
    )
    assert_array_equal(rmse_db(y[:, 0], y[:, 0]), [-np.inf])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"window": 0}, "window must be an integer >= 1"),
        ({"window": 11}, "window must be at most 10"),
    ],
)
def test_rmse_db_rejects_bad_window(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rmse_db(np.zeros(10), np.ones(10), **kwargs)


def test_rmse_db_rejects_shape_mismatch():
    with pytest.raises(ValueError, match="same shape"):
        rmse_db(np.zeros((10, 2)), np.zeros((10, 1)))


def test_degenerate_residuals_give_documented_answers():
    import warnings

    from skhybrid.diagnostics import diagnose, ljung_box_test
    from skhybrid.domain import ParametricModel

    rng = np.random.default_rng(0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning either
        zero = ljung_box_test(np.zeros((100, 2)), lags=20)
        np.testing.assert_array_equal(zero.statistic, [0.0, 0.0])
        np.testing.assert_array_equal(zero.pvalue, [1.0, 1.0])
        assert zero.passed.all()
        mixed = np.column_stack([rng.standard_normal(300), np.full(300, 3.0)])
        res = ljung_box_test(mixed, lags=20)
        assert res.statistic[1] == 0.0 and res.pvalue[1] == 1.0
        assert 0 < res.pvalue[0] < 1
        # Any scale gives the same statistic, without overflow.
        for scale in (1e-200, 1e200, 1e300):
            np.testing.assert_allclose(
                ljung_box_test(mixed * scale, lags=20).statistic,
                res.statistic,
                rtol=1e-9,
            )

        def gain(X, *, k, xp=np):
            return k * X[:, :1]

        X = rng.normal(size=(200, 2))
        perfect = ParametricModel(gain, {"k": 2.0}, fixed=("k",)).fit(X, 2 * X[:, :1])
        report = diagnose(perfect, X, 2 * X[:, :1], lags=20)
        assert report.passed
    with pytest.raises(ValueError, match=r"NaN|infinity"):
        ljung_box_test(np.array([1.0, np.nan, 2.0, 3.0, 1.0]), lags=2)


@pytest.mark.parametrize("level", [0.0, 3.0, -1e-300, 1e300])
@pytest.mark.parametrize("bartlett", [True, False])
def test_residual_acf_of_constant_residuals_agrees_with_ljung_box(level, bartlett):
    """Zero or constant residuals: no NaN, no warning, white as Ljung-Box says."""
    import warnings

    n, nlags = 150, 12
    rng = np.random.default_rng(0)
    residuals = np.column_stack([np.full(n, level), rng.standard_normal(n)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # NumPy's "invalid value" included
        res = residual_acf(residuals, nlags=nlags, bartlett_confint=bartlett)
        whiteness = ljung_box_test(residuals, lags=nlags)
    assert np.all(np.isfinite(res.acf)) and np.all(np.isfinite(res.confint))
    assert_array_equal(res.acf[:, 0], np.r_[1.0, np.zeros(nlags)])
    z = stats.norm.ppf(0.975)
    assert_allclose(res.band[1:, 0], z / np.sqrt(n), rtol=1e-12)
    assert res.band[0, 0] == 0.0
    # Both tests call the constant column white.
    assert not res.exceeds[:, 0].any()
    assert whiteness.passed[0] and whiteness.statistic[0] == 0.0
    # The other column is untouched: statsmodels' answer.
    expected = acf(residuals[:, 1], nlags=nlags, fft=True)
    assert_allclose(res.acf[:, 1], expected, rtol=1e-10, atol=1e-12)


def test_residual_acf_does_not_depend_on_scale():
    x = np.random.default_rng(1).standard_normal((300, 1))
    base = residual_acf(x, nlags=10)
    for scale in (1e-200, 1e200, 1e300):
        scaled = residual_acf(x * scale, nlags=10)
        assert_allclose(scaled.acf, base.acf, rtol=1e-9, atol=1e-15)
        assert_allclose(scaled.band, base.band, rtol=1e-9, atol=1e-15)
