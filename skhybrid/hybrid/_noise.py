"""Stochastic models of the final residuals: the ``N(phi)`` term of Eq. 1.

Two models, fitted on the residual a deterministic model leaves, in time order:

- :class:`GaussianNoise`: independent draws with a mean and a covariance across
  outputs;
- :class:`AutoRegressiveNoise`: one autoregressive process per output, fitted with
  statsmodels (:func:`~statsmodels.tsa.ar_model.ar_select_order` chooses the order
  by an information criterion, :class:`~statsmodels.tsa.ar_model.AutoReg` fits it).

They are small objects with ``fit(residuals)``, ``std()`` and
``sample(n_samples, random_state)``, used by
:class:`~skhybrid.hybrid.HybridBoostingRegressor` through its ``noise_model``
parameter and readable there as ``noise_model_``.
"""

import warnings
from numbers import Integral

import numpy as np
from sklearn.utils import check_random_state

from skhybrid.utils._docstrings import fill_doc
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    Interval,
    StrOptions,
    validate_parameter_constraints,
)
from skhybrid.utils._transaction import TransactionalFitMixin

__all__ = ["AutoRegressiveNoise", "GaussianNoise", "make_noise_model"]

NOISE_MODELS = ("gaussian", "ar")

#: The sections of the noise models' ``fit`` and ``sample``, one contract.
_NOISE_DOCS = {
    "fit_sections": """\
Parameters
----------
residuals : array-like of shape (n_samples,) or (n_samples, n_outputs)
    Final residuals of a model, in time order.

Returns
-------
self : object
    The fitted noise model.""",
    "sample_sections": """\
Parameters
----------
n_samples : int
    Number of rows to draw.
random_state : int, RandomState instance or None, default=None
    Seed of the draw.

Returns
-------
noise : ndarray of shape (n_samples, n_outputs)
    The draws.""",
}


@fill_doc(**_NOISE_DOCS)
class GaussianNoise(TransactionalFitMixin, VersionedPickleMixin):
    """Independent Gaussian noise with a mean and a covariance across outputs.

    Attributes
    ----------
    mean_ : ndarray of shape (n_outputs,)
        Mean of the residuals.
    cov_ : ndarray of shape (n_outputs, n_outputs)
        Covariance of the residuals across outputs (``ddof=1``).
    n_outputs_ : int
        Number of outputs.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.hybrid import GaussianNoise
    >>> r = np.random.default_rng(0).normal(0.0, 2.0, size=(5000, 1))
    >>> noise = GaussianNoise().fit(r)
    >>> round(float(noise.std()[0]), 1)
    2.0
    """

    def fit(self, residuals):
        """Estimate the mean and the covariance across outputs of ``residuals``.

        %(fit_sections)s
        """
        r = _as_2d(residuals)
        if r.shape[0] < 2:
            raise ValueError(
                "noise_model='gaussian' needs at least 2 residual rows to estimate a "
                f"covariance; got n_samples={r.shape[0]}."
            )
        self.n_outputs_ = r.shape[1]
        self.mean_ = r.mean(axis=0)
        self.cov_ = np.atleast_2d(np.cov(r, rowvar=False, ddof=1))
        return self

    def std(self):
        """Return the standard deviation of each output.

        Returns
        -------
        std : ndarray of shape (n_outputs,)
            Standard deviation of each output.
        """
        return np.sqrt(np.clip(np.diag(self.cov_), 0, None))

    def sample(self, n_samples, random_state=None):
        """Draw ``n_samples`` independent rows.

        %(sample_sections)s
        """
        rng = check_random_state(random_state)
        # A symmetric square root (eigh) also handles a singular covariance.
        w, V = np.linalg.eigh(self.cov_)
        root = V * np.sqrt(np.clip(w, 0, None))
        z = rng.standard_normal((n_samples, self.n_outputs_))
        return self.mean_ + z @ root.T


@fill_doc(**_NOISE_DOCS)
class AutoRegressiveNoise(TransactionalFitMixin, VersionedPickleMixin):
    """One autoregressive process per output, order chosen by an information criterion.

    For each output, :func:`statsmodels.tsa.ar_model.ar_select_order` picks the lags
    (up to ``max_lag``) that minimise ``ic``, and
    :class:`statsmodels.tsa.ar_model.AutoReg` fits them with a constant::

        r(t) = intercept + sum_k coef_k r(t - k) + e(t),   e(t) ~ N(0, sigma^2)

    The residuals must be in time order. The outputs are modelled independently
    (no cross-correlation between outputs).

    Parameters
    ----------
    max_lag : int, default=10
        Largest lag considered; lowered to ``n_samples // 4`` for short series.
    ic : {"bic", "aic", "hqic"}, default="bic"
        Information criterion of the order selection.

    Attributes
    ----------
    lags_ : list of ndarray
        Selected lags of each output (empty for white noise).
    coef_ : list of ndarray
        AR coefficient of each selected lag, per output.
    intercept_ : ndarray of shape (n_outputs,)
        Constant term of each output's recursion.
    sigma_ : ndarray of shape (n_outputs,)
        Standard deviation of the innovations ``e(t)``.
    mean_ : ndarray of shape (n_outputs,)
        Stationary mean ``intercept / (1 - sum(coef))``.
    n_outputs_ : int
        Number of outputs.

    Examples
    --------
    >>> import numpy as np
    >>> from statsmodels.tsa.arima_process import ArmaProcess
    >>> from skhybrid.hybrid import AutoRegressiveNoise
    >>> e = ArmaProcess([1, -0.6], [1]).generate_sample(
    ...     3000, distrvs=np.random.default_rng(0).standard_normal)
    >>> noise = AutoRegressiveNoise().fit(e[:, None])
    >>> noise.lags_[0].tolist(), round(float(noise.coef_[0][0]), 1)
    ([1], 0.6)
    """

    _parameter_constraints = {
        "max_lag": [Interval(Integral, 1, None, closed="left")],
        "ic": [StrOptions({"aic", "bic", "hqic"})],
    }

    def __init__(self, max_lag=10, ic="bic"):
        self.max_lag = max_lag
        self.ic = ic

    def fit(self, residuals):
        """Select the order and fit one AR model per output of ``residuals``.

        %(fit_sections)s
        """
        from statsmodels.tsa.ar_model import AutoReg, ar_select_order

        # Not a BaseEstimator (no get_params): validate the constraints directly.
        validate_parameter_constraints(
            self._parameter_constraints,
            {"max_lag": self.max_lag, "ic": self.ic},
            caller_name=type(self).__name__,
        )
        r = _as_2d(residuals)
        n = r.shape[0]
        if n < 12:
            raise ValueError(
                "noise_model='ar' needs at least 12 residual rows in time order to "
                f"select an autoregressive order; got n_samples={n}."
            )
        max_lag = max(1, min(self.max_lag, n // 4))
        self.n_outputs_ = r.shape[1]
        self.lags_, self.coef_ = [], []
        intercept, sigma = [], []
        for k in range(r.shape[1]):
            series = r[:, k]
            with warnings.catch_warnings():
                # statsmodels warns about frequency-less data; rows have no dates.
                warnings.simplefilter("ignore", category=UserWarning)
                selected = ar_select_order(
                    series, maxlag=max_lag, ic=self.ic, trend="c"
                )
                lags = list(selected.ar_lags or [])
                result = AutoReg(series, lags=lags or 0, trend="c").fit()
            params = np.asarray(result.params, dtype=float)
            intercept.append(float(params[0]))
            self.lags_.append(np.asarray(lags, dtype=int))
            self.coef_.append(params[1:])
            sigma.append(float(np.sqrt(result.sigma2)))
        self.intercept_ = np.asarray(intercept)
        self.sigma_ = np.asarray(sigma)
        self.mean_ = np.asarray(
            [
                c / (1.0 - a.sum())
                for c, a in zip(self.intercept_, self.coef_, strict=True)
            ]
        )
        return self

    def _ar_polynomial(self, k):
        lags, coef = self.lags_[k], self.coef_[k]
        order = int(lags.max()) if lags.size else 0
        poly = np.zeros(order + 1)
        poly[0] = 1.0
        poly[lags] = -coef
        return poly

    def std(self):
        """Return the stationary (marginal) standard deviation of each output.

        The standard deviation of the process itself, not of its innovations: the
        uncertainty of one row when the residuals of neighbouring rows are unknown.
        Infinite for a non-stationary fit.

        Returns
        -------
        std : ndarray of shape (n_outputs,)
            Standard deviation of each output.
        """
        from statsmodels.tsa.arima_process import arma_acovf

        out = np.empty(self.n_outputs_)
        for k in range(self.n_outputs_):
            poly = self._ar_polynomial(k)
            if np.any(np.abs(np.roots(poly[::-1])) <= 1.0) and poly.size > 1:
                out[k] = np.inf
                continue
            var = arma_acovf(poly, [1.0], nobs=1, sigma2=self.sigma_[k] ** 2)[0]
            out[k] = np.sqrt(var)
        return out

    def sample(self, n_samples, random_state=None):
        """Simulate each output's AR process along ``n_samples`` consecutive rows.

        The simulation starts after a burn-in of 200 steps plus the largest lag,
        so it starts from (close to) the stationary distribution.

        %(sample_sections)s
        """
        from statsmodels.tsa.arima_process import ArmaProcess

        rng = check_random_state(random_state)
        out = np.empty((n_samples, self.n_outputs_))
        for k in range(self.n_outputs_):
            poly = self._ar_polynomial(k)
            draws = ArmaProcess(poly, [1.0]).generate_sample(
                n_samples,
                scale=self.sigma_[k],
                distrvs=rng.standard_normal,
                burnin=200 + poly.size,
            )
            out[:, k] = draws + self.mean_[k]
        return out


def make_noise_model(noise_model, *, max_lag=10):
    """Return an unfitted noise model for a ``noise_model`` name, or ``None``."""
    if noise_model is None:
        return None
    if noise_model == "gaussian":
        return GaussianNoise()
    if noise_model == "ar":
        return AutoRegressiveNoise(max_lag=max_lag)
    raise ValueError(
        f"noise_model must be one of {NOISE_MODELS} or None; got "
        f"noise_model={noise_model!r}."
    )


def _as_2d(residuals):
    r = np.asarray(residuals, dtype=float)
    return r[:, None] if r.ndim == 1 else r
