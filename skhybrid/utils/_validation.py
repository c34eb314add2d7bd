"""Checks of arguments (arrays, names) shared across subpackages."""

import numpy as np

from skhybrid.utils._sklearn_compat import validate_data

__all__ = [
    "as_columns",
    "check_known_names",
    "check_record_lengths",
    "first_not_finite",
    "validate_records",
]


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


def first_not_finite(parts):
    """Where the first NaN or infinite sample of aligned 2-D arrays is, in words.

    Parameters
    ----------
    parts : dict of str to ndarray of shape (n_times, n_columns_i)
        Aligned arrays by what they are (``{"inputs": u, "outputs": y}``); each
        may instead be ``(array, column_names)``.

    Returns
    -------
    where : str or None
        ``"the first at row r, outputs column c ('name'): nan; k in all"``, the
        earliest row first (then the first part and column), or None where every
        value is finite.
    """
    first, n_bad = None, 0
    for part, array in parts.items():
        names = None
        if isinstance(array, tuple):
            array, names = array
        bad = np.argwhere(~np.isfinite(np.asarray(array, dtype=float)))
        n_bad += len(bad)
        if len(bad) and (first is None or bad[0][0] < first[0]):
            row, col = (int(i) for i in bad[0])
            name = f" ({names[col]!r})" if names is not None else ""
            first = (row, f"{part} column {col}{name}", array[row, col])
    if first is None:
        return None
    row, column, value = first
    return f"the first at row {row}, {column}: {value}; {n_bad} in all"


def validate_records(estimator, X, y):
    """One record ``(X, y)`` or lists of records, validated, as lists of 2-D arrays.

    ``X`` and ``y`` are several records where both are lists (or tuples) of as
    many arrays, each ``y[i]`` at least 1-D; otherwise one record. Each record
    goes through scikit-learn's ``validate_data`` (the first one resets
    ``n_features_in_``, the others must match it). The whole-record models
    (:class:`~skhybrid.hybrid.NARXSimulator`,
    :class:`~skhybrid.hybrid.PhysicsCorrection`,
    :class:`~skhybrid.domain.WienerHammersteinModel`...) validate their
    ``fit(X, y)`` with it.

    Parameters
    ----------
    estimator : estimator
        The estimator being fitted (``n_features_in_`` is set on it).
    X : array-like of shape (n_times, n_inputs), or list of them
        One record's inputs, or each record's.
    y : array-like of shape (n_times,) or (n_times, n_outputs), or list of them
        The outputs, aligned with ``X``.

    Returns
    -------
    U : list of ndarray of shape (n_times_i, n_inputs)
        The inputs of each record, as floats.
    Y : list of ndarray of shape (n_times_i, n_outputs)
        The outputs of each record, as float columns.
    """
    several = (
        isinstance(X, (list, tuple))
        and isinstance(y, (list, tuple))
        and len(X) == len(y) > 0
        and all(np.ndim(y_i) >= 1 for y_i in y)
    )
    records = list(zip(X, y, strict=True)) if several else [(X, y)]
    U, Y = [], []
    for i, (u, y_i) in enumerate(records):
        if getattr(u, "ndim", None) == 1:
            name = f"X[{i}]" if several else "X"
            raise ValueError(
                f"{name} must be 2-D (n_times, n_inputs), one column per input; "
                f"got a 1-D array of shape {u.shape}. Give one input as "
                f"{name}.reshape(-1, 1)."
            )
        u, y_i = validate_data(
            estimator,
            u,
            y_i,
            reset=i == 0,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
        )
        U.append(u)
        Y.append(np.asarray(y_i, dtype=np.float64).reshape(len(y_i), -1))
    widths = sorted({y_i.shape[1] for y_i in Y})
    if len(widths) > 1:
        raise ValueError(
            f"every record of y must hold the same number of outputs; got {widths}."
        )
    return U, Y


def check_known_names(given, known, message):
    """Raise a ValueError when ``given`` names something ``known`` lacks.

    Parameters
    ----------
    given : iterable of str
        The names received (the keys of a dict).
    known : list of str
        The names allowed, in the order the message shows them.
    message : str
        The error message, formatted with ``unknown`` (the sorted names not
        in ``known``) and ``known``.

    Raises
    ------
    ValueError
        If a name of ``given`` is not in ``known``.
    """
    unknown = sorted(set(given) - set(known))
    if unknown:
        raise ValueError(message.format(unknown=unknown, known=known))


def check_record_lengths(estimator, Y, shortest, why):
    """Raise a ValueError where a record has fewer than ``shortest`` samples.

    Parameters
    ----------
    estimator : estimator
        The model being fitted; its class name goes into the message.
    Y : list of ndarray
        The records' outputs, as :func:`validate_records` returns them.
    shortest : int
        The fewest samples a record may hold.
    why : str
        What the samples are needed for, for the message.

    Raises
    ------
    ValueError
        If a record holds fewer than ``shortest`` samples.
    """
    for i, y in enumerate(Y):
        if len(y) < shortest:
            raise ValueError(
                f"{type(estimator).__name__} needs records of at least {shortest} "
                f"samples ({why}); record {i} has {len(y)} sample(s)."
            )
