"""The only module of skhybrid that imports private scikit-learn names.

When scikit-learn moves its internals, only this file changes.
"""

from sklearn.base import _fit_context
from sklearn.externals import array_api_compat
from sklearn.utils import _safe_indexing
from sklearn.utils._param_validation import (
    HasMethods,
    Interval,
    Options,
    StrOptions,
    validate_params,
)
from sklearn.utils.metaestimators import _BaseComposition
from sklearn.utils.validation import validate_data

__all__ = [
    "HasMethods",
    "Interval",
    "Options",
    "StrOptions",
    "_BaseComposition",
    "_fit_context",
    "_safe_indexing",
    "array_api_compat",
    "validate_data",
    "validate_params",
]
