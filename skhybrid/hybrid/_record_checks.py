"""Checks shared by the free-run models of records (skhybrid.hybrid._correction).

The records a ``fit(X, y)`` of whole records takes (one record, or lists of
them), the widths a fitted model's ``simulate`` reads, and the options of the
``simulate`` contract a model without a noise model lacks.
"""

import numpy as np

from skhybrid.utils._sklearn_compat import validate_data

__all__ = []

#: The initial-state options of the ``simulate`` contract.
_INITS = ("measured", "least_squares")


def _check_simulate_options(estimator, init, n_samples, return_std, supported):
    """Raise a ValueError for options of the contract ``estimator`` lacks."""
    name = type(estimator).__name__
    if not isinstance(init, str) or init not in _INITS:
        raise ValueError(f"init must be one of {_INITS}; got init={init!r}.")
    if init not in supported:
        raise ValueError(
            f"{name} supports init in {supported}; got init={init!r}. Its free "
            "run starts from the measured window as it is."
        )
    if n_samples is not None or return_std:
        raise ValueError(
            f"n_samples={n_samples!r} and return_std={return_std!r} need a noise "
            f"model; {name} has none: call simulate without them."
        )


def _validate_records(estimator, X, y):
    """One record ``(X, y)`` or lists of records, validated, as lists of 2-D arrays.

    ``X`` and ``y`` are several records where both are lists (or tuples) of as
    many arrays, each ``y[i]`` at least 1-D; otherwise one record. Each record
    goes through scikit-learn's ``validate_data`` (the first one resets
    ``n_features_in_``, the others must match it).

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


def _check_lengths(estimator, Y, shortest, why):
    """Raise a ValueError where a record has fewer than ``shortest`` samples."""
    for i, y in enumerate(Y):
        if len(y) < shortest:
            raise ValueError(
                f"{type(estimator).__name__} needs records of at least {shortest} "
                f"samples ({why}); record {i} has {len(y)} sample(s)."
            )


def _check_columns(estimator, n_inputs, n_outputs):
    """Raise a ValueError where a record's widths differ from the fitted ones.

    Models pickled while the classes were private lack ``n_features_in_`` and
    ``n_outputs_``: nothing is checked against what they lack.
    """
    name = type(estimator).__name__
    expected = getattr(estimator, "n_features_in_", None)
    if expected is not None and n_inputs != expected:
        raise ValueError(
            f"inputs has {n_inputs} column(s); this {name} was fitted on "
            f"{expected} input(s)."
        )
    expected = getattr(estimator, "n_outputs_", None)
    if expected is not None and n_outputs != expected:
        raise ValueError(
            f"initial has {n_outputs} column(s); this {name} was fitted on "
            f"{expected} output(s)."
        )
