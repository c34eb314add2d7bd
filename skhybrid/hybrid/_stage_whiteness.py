"""Whiteness of a boosted hybrid's residual after each stage (Ljung-Box)."""

import warnings
from dataclasses import dataclass

import numpy as np

from skhybrid.exceptions import NonWhiteResidualWarning

__all__ = ["StageWhiteness"]


@dataclass(frozen=True, eq=False)
class StageWhiteness:
    """Ljung-Box test of the training residual after each stage, per output.

    Computed with :func:`statsmodels.stats.diagnostic.acorr_ljungbox` at the single
    lag ``lags``, on the residual of every training row (validation slice included)
    in the order given to ``fit``.

    Parameters
    ----------
    stage_names : tuple of str
        Names of the kept stages, in order; row ``i`` of ``statistic`` and
        ``pvalue`` is the residual after stages ``0..i``.
    lags : int
        Lag of the test (``ljung_box_lags``, at most ``n_samples - 1``).
    statistic : ndarray of shape (n_stages, n_outputs)
        Ljung-Box ``Q`` statistic.
    pvalue : ndarray of shape (n_stages, n_outputs)
        The p-value of ``Q`` under the null hypothesis of white residuals; a small
        value means the stage left predictable structure.
    """

    stage_names: tuple
    lags: int
    statistic: np.ndarray
    pvalue: np.ndarray


def _whiteness(names, residuals, lags):
    from statsmodels.stats.diagnostic import acorr_ljungbox

    n_outputs = residuals[0].shape[1] if residuals else 0
    n = residuals[0].shape[0] if residuals else 0
    lags = int(min(lags, n - 1))
    stat = np.full((len(residuals), n_outputs), np.nan)
    pval = np.full((len(residuals), n_outputs), np.nan)
    if lags >= 1:
        for i, r in enumerate(residuals):
            for k in range(n_outputs):
                if np.ptp(r[:, k]) == 0:
                    continue  # a constant residual has no autocorrelation to test
                with np.errstate(all="ignore"):
                    table = acorr_ljungbox(r[:, k], lags=[lags])
                stat[i, k] = float(table["lb_stat"].iloc[0])
                pval[i, k] = float(table["lb_pvalue"].iloc[0])
    return StageWhiteness(tuple(names), max(lags, 0), stat, pval)


def _warn_if_not_white(whiteness, alpha=0.01):
    pvalue = whiteness.pvalue[-1]
    bad = np.flatnonzero(pvalue < alpha)
    if bad.size:
        warnings.warn(
            f"the final residual of outputs {bad.tolist()} is not white (Ljung-Box "
            f"p-value {np.round(pvalue[bad], 4).tolist()} < {alpha} at lag "
            f"{whiteness.lags}), but noise_model='gaussian' assumes independent "
            "rows; use noise_model='ar', or a stage with objective='ljung_box'.",
            NonWhiteResidualWarning,
            stacklevel=3,
        )
