"""Loss functions on residuals: the Ljung-Box statistic and the stage objectives.

Pure functions of residual arrays (NumPy or torch, one implementation each); no
estimators live here.
"""

from skhybrid.losses._ljung_box import (
    autocorrelation,
    autocovariance_norm,
    ljung_box,
    weighted_autocorrelations,
)
from skhybrid.losses.base import (
    OBJECTIVES,
    check_objective,
    mse,
    needs_time_order,
    objective_residuals,
    objective_value,
)

__all__ = [
    "OBJECTIVES",
    "autocorrelation",
    "autocovariance_norm",
    "check_objective",
    "ljung_box",
    "mse",
    "needs_time_order",
    "objective_residuals",
    "objective_value",
    "weighted_autocorrelations",
]
