"""Input checks, bookkeeping and docstring entries the diagnostics Displays share."""

from collections.abc import Mapping

import numpy as np

from skhybrid.diagnostics._tests import _as_2d

__all__ = []

#: The fitted attributes of a Display drawing one panel per output in a row.
_OUTPUT_PANELS_ATTRIBUTES = """\
axes_ : ndarray of matplotlib Axes of shape (n_outputs,)
    One panel per output.
ax_ : matplotlib Axes
    The first panel.
figure_ : matplotlib Figure
    Figure holding the panels."""

#: The ``ax`` of the constructors of a Display drawing one panel per output.
_OUTPUT_AXES = """\
ax : matplotlib Axes, array of Axes or None, default=None
    One Axes per output."""


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


def _checked_predictions(mapping, y_true, name):
    """``y_true`` checked, and each model's predictions in ``mapping`` checked lazily.

    ``mapping`` (called ``name`` in errors) must be a non-empty dict of arrays of
    the shape of ``y_true``. The second value returned is a generator of ``(key,
    predictions)`` that checks each model as it reaches it, so that errors come in
    the order of the models.
    """
    mapping = _check_models(mapping, name)
    yt = _as_2d(y_true, "y_true")
    return yt, (
        (key, _predictions_like(val, yt, f"{name}[{key!r}]"))
        for key, val in mapping.items()
    )


def _store_panels(display, fig, axes):
    """Set ``display.axes_``, ``ax_`` (the first panel) and ``figure_``; return it."""
    display.axes_ = axes
    display.ax_ = axes.flat[0]
    display.figure_ = fig
    return display
