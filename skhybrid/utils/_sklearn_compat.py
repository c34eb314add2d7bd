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
    validate_parameter_constraints,
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
    "validate_parameter_constraints",
    "validate_params",
    "visual_block",
]


def visual_block(kind, estimators, **kwargs):
    """scikit-learn's HTML-representation block (a private class that moved in 1.7).

    Imported lazily: only an estimator's HTML representation needs it.

    Parameters
    ----------
    kind : {"serial", "parallel", "single"}
        How the estimators are laid out.
    estimators : list
        The estimators (or blocks) shown.
    **kwargs : dict
        ``names``, ``name_details`` and the other arguments of ``_VisualBlock``.

    Returns
    -------
    block : sklearn's _VisualBlock
    """
    try:
        from sklearn.utils._repr_html.estimator import _VisualBlock
    except ImportError:  # scikit-learn < 1.7
        from sklearn.utils._estimator_html_repr import _VisualBlock
    return _VisualBlock(kind, estimators, **kwargs)
