"""Checks shared by the free-run models of records (skhybrid.hybrid._correction).

The widths a fitted model's ``simulate`` reads, the records' lengths, and the
options of the ``simulate`` contract a model without a noise model lacks. The
records a ``fit(X, y)`` of whole records takes (one record, or lists of them)
are validated by :func:`skhybrid.utils._validation.validate_records`, shared
with the domain's whole-record models.
"""

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
