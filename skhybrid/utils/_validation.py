"""Checks of array arguments shared across subpackages."""

import numpy as np

__all__ = ["as_columns"]


def as_columns(values, name, *, columns="n_columns"):
    """``values`` as a 2-D float array ``(n_times, columns)``.

    Parameters
    ----------
    values : array-like of shape (n_times,) or (n_times, n_columns)
        The samples; a 1-D array becomes one column.
    name : str
        The argument's name, for the error message.
    columns : str, default="n_columns"
        What the columns are called in the error message (``"n_inputs"``).

    Returns
    -------
    array : ndarray of shape (n_times, n_columns)
        The samples as floats.

    Raises
    ------
    ValueError
        If ``values`` has another number of dimensions.
    """
    array = np.asarray(values, dtype=float)
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2:
        raise ValueError(
            f"{name} must have shape (n_times,) or (n_times, {columns}); got shape "
            f"{array.shape}."
        )
    return array
