"""Residual diagnostics: whiteness, independence, error in dB, and the paper's figures.

A model is only as trustworthy as its residuals. The tests here are the ones a
system-identification engineer runs (MATLAB's ``resid``, statsmodels' residual
tests), each returning a frozen dataclass:

- :func:`ljung_box_test`: whiteness per output (statsmodels ``acorr_ljungbox``);
- :func:`residual_acf`: autocorrelation with confidence bands;
- :func:`residual_input_correlation`: cross-correlation with the inputs, the
  independence test that tells missing input dynamics from coloured noise;
- :func:`rmse_db`: ``20 log10(RMSE)`` per output, whole series or windows;
- :func:`diagnose` / :func:`diagnose_predictions`: all of it in one
  :class:`DiagnosticReport` with a pass or fail verdict.

The figures are scikit-learn style Displays (``from_estimator``,
``from_predictions``, ``plot(ax=...)``): :class:`ResidualACFDisplay`,
:class:`RMSEBoxDisplay` and :class:`DecompositionDisplay`.
"""

from skhybrid.diagnostics._plot.decomposition import DecompositionDisplay
from skhybrid.diagnostics._plot.residual_acf import ResidualACFDisplay
from skhybrid.diagnostics._plot.rmse_box import RMSEBoxDisplay
from skhybrid.diagnostics._report import (
    DiagnosticReport,
    diagnose,
    diagnose_predictions,
)
from skhybrid.diagnostics._tests import (
    ACFResult,
    CrossCorrelationResult,
    WhitenessResult,
    ljung_box_test,
    residual_acf,
    residual_input_correlation,
    rmse_db,
)

__all__ = [
    "ACFResult",
    "CrossCorrelationResult",
    "DecompositionDisplay",
    "DiagnosticReport",
    "RMSEBoxDisplay",
    "ResidualACFDisplay",
    "WhitenessResult",
    "diagnose",
    "diagnose_predictions",
    "ljung_box_test",
    "residual_acf",
    "residual_input_correlation",
    "rmse_db",
]
