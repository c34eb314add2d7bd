"""Input checks shared by the diagnostics Displays."""

from collections.abc import Mapping

import numpy as np

from skhybrid.diagnostics._tests import _as_2d

__all__ = []


def _predictions_like(y_pred, y_true, name):
    pred = _as_2d(y_pred, name)
    if pred.shape != y_true.shape:
        raise ValueError(
            f"{name} must have the shape of y_true {y_true.shape}; got "
            f"{np.shape(y_pred)}."
        )
    return pred


def _check_models(mapping, name):
    if not isinstance(mapping, Mapping) or len(mapping) == 0:
        raise TypeError(
            f"{name} must be a non-empty dict mapping model names to arrays; got "
            f"{type(mapping).__name__}."
        )
    return mapping
