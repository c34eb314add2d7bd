"""Fit a model of records by its free-run (simulation) error, on segments.

A model of a dynamical system with latent states, such as
:class:`~skhybrid.domain.StateSpaceModel`, has two fits: ``fit(X, y)`` on
windows of history, one step ahead (scikit-learn's ``(X, y)`` contract, which
its common checks test), and ``fit_simulation(inputs, outputs)`` on whole
records, by the error of its free run. A search over records
(:class:`SimulationSearchCV`) judges models in free run, so it fits such a model
by ``fit_simulation``; :class:`SimulationFit` is that fit as an estimator of
records, with the segment length of multiple shooting as a parameter a grid can
search.
"""

import itertools
from numbers import Integral

from sklearn.base import BaseEstimator, clone
from sklearn.utils.metaestimators import available_if
from sklearn.utils.validation import check_is_fitted

from skhybrid.model_selection._records import _check_records
from skhybrid.utils._docstrings import RECORD_INPUTS_INITIAL, fill_doc
from skhybrid.utils._sklearn_compat import HasMethods, Interval, _fit_context

__all__ = ["SimulationFit"]


def fits_by_simulation(model):
    """Whether a model of records is fitted by ``fit_simulation``."""
    return callable(getattr(model, "fit_simulation", None))


def _segments(U, Y, segment):
    """Consecutive segments of ``segment`` samples of each record.

    The remainder of a record (fewer than ``segment`` samples) joins its last
    segment; ``segment=None`` keeps whole records.
    """
    pieces_U, pieces_Y = [], []
    for u, y in zip(U, Y, strict=True):
        n = len(y)
        if segment is None or segment >= n:
            bounds = [0, n]
        else:
            bounds = [i * segment for i in range(n // segment)] + [n]
        for a, b in itertools.pairwise(bounds):
            pieces_U.append(u[a:b])
            pieces_Y.append(y[a:b])
    return pieces_U, pieces_Y


def fit_records(model, U, Y, segment=None):
    """Fit ``model`` itself (not a clone) on lists of records.

    By ``fit_simulation`` over segments of the records where the model has one,
    else by ``fit(U, Y)``. This is the fit of :class:`SimulationFit` and of every
    candidate of :class:`SimulationSearchCV`.
    """
    if not fits_by_simulation(model):
        return model.fit(U, Y)
    n_init = getattr(model, "n_init", None)
    if segment is not None and isinstance(n_init, Integral) and segment <= n_init:
        raise ValueError(
            f"segment={segment} must exceed the model's n_init={n_init}: a "
            "segment's first n_init samples only estimate its initial state."
        )
    pieces_U, pieces_Y = _segments(U, Y, segment)
    if len(pieces_U) == 1:
        return model.fit_simulation(pieces_U[0], pieces_Y[0])
    return model.fit_simulation(pieces_U, pieces_Y)


def _estimator_has(attr):
    def check(self):
        if hasattr(self, "estimator_"):
            return hasattr(self.estimator_, attr)
        return hasattr(self.estimator, attr)

    return check


@fill_doc(record_inputs_initial=RECORD_INPUTS_INITIAL)
class SimulationFit(BaseEstimator):
    """A model fitted on records by its free-run error, over segments.

    ``fit(U, Y)`` fits a clone of ``estimator`` by its ``fit_simulation`` on
    the records, cut into consecutive segments of ``segment`` samples (multiple
    shooting: each segment's initial state is estimated from its own first
    ``n_init`` samples). ``simulate`` runs the fitted clone. This is the fit that
    :class:`SimulationSearchCV` gives every candidate with a ``fit_simulation``
    (on whole records), and the fit of the physics in
    :func:`~skhybrid.experiments.run_system` (at the segment length chosen by
    cross-validation): give ``SimulationFit(model)`` as a candidate to search
    the segment length as the run does, ``{"segment": [None, 500]}``.

    Parameters
    ----------
    estimator : estimator
        A model with ``fit_simulation(inputs, outputs)`` on lists of records
        and ``simulate(inputs, initial)``, such as
        :class:`~skhybrid.domain.StateSpaceModel` or
        :class:`~skhybrid.hybrid.StateSpaceHybridRegressor`. A model without
        ``fit_simulation`` is fitted with ``fit(U, Y)`` on the whole records.
    segment : int or None, default=None
        Samples per segment; ``None`` fits whole records. It must exceed the
        estimator's ``n_init``; a record's remainder joins its last segment.

    Attributes
    ----------
    estimator_ : estimator
        The fitted clone of ``estimator``.
    n_segments_ : int
        Segments it was fitted on.

    See Also
    --------
    SimulationSearchCV : Chooses among such models by cross-validated free-run
        RMSE.
    skhybrid.domain.StateSpaceModel.fit_simulation : The fit it calls.

    Notes
    -----
    Why an adapter rather than a ``fit(U, Y)`` that takes lists of records:
    ``fit(X, y)`` of a domain model is scikit-learn's contract, one step ahead
    on 2-D windows, which its common checks (``check_estimator``) test and
    which ``Pipeline``, ``GridSearchCV`` and ``cross_val_score`` call. A list of
    equally long records is also a 3-D array, and a list of 2-D arrays is
    array-like: one method taking both would guess from the input's shape
    which of two objectives to minimise. The adapter says which, once, and its
    ``segment`` is a parameter like any other.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import StateSpaceModel
    >>> from skhybrid.model_selection import SimulationFit
    >>> def decay(x, u, *, xp, a, b):
    ...     return a * x + b * u
    >>> def model(params, **kwargs):
    ...     return StateSpaceModel(
    ...         decay, params, state_names=["x"], observed=["x"], time="discrete",
    ...         n_init=1, **kwargs,
    ...     )
    >>> u = np.random.default_rng(0).normal(size=(200, 1))
    >>> truth = model({"a": 0.9, "b": 0.5}, fixed=("a", "b"))
    >>> y = truth.fit_simulation(u, np.zeros((200, 1))).simulate_from_state(u, [0.0])
    >>> fit = SimulationFit(model({"a": 0.5, "b": 1.0}), segment=100).fit([u], [y])
    >>> fit.n_segments_, round(float(fit.estimator_.params_["a"]), 3)
    (2, 0.9)
    """

    _parameter_constraints = {
        "estimator": [HasMethods(["simulate"])],
        "segment": [Interval(Integral, 1, None, closed="left"), None],
    }

    def __init__(self, estimator, *, segment=None):
        self.estimator = estimator
        self.segment = segment

    @property
    def fits_in_lockstep(self):
        """Whether the estimator's fits gain from running side by side.

        :class:`SimulationSearchCV` then fits a candidate's folds in lockstep,
        their free runs simulated as one batch.
        """
        return bool(getattr(self.estimator, "fits_in_lockstep", False))

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, U, Y):
        """Fit a clone of the estimator by its free-run error on the records.

        Parameters
        ----------
        U : list of array-like of shape (n_times_i, n_inputs)
            Inputs of each record (or one record, or a 3-D array of records).
        Y : list of array-like of shape (n_times_i, n_outputs)
            Measured outputs of each record, aligned with ``U``.

        Returns
        -------
        self : SimulationFit
            The fitted adapter.
        """
        U, Y = _check_records(U, Y)
        estimator = clone(self.estimator)
        self.n_segments_ = (
            len(_segments(U, Y, self.segment)[0])
            if fits_by_simulation(estimator)
            else len(U)
        )
        self.estimator_ = fit_records(estimator, U, Y, self.segment)
        return self

    def simulate(self, inputs, initial, **kwargs):
        """The fitted estimator's free run.

        Parameters
        ----------
        %(record_inputs_initial)s
        **kwargs : dict
            Passed on to ``estimator_.simulate``.

        Returns
        -------
        outputs : ndarray
            What ``estimator_.simulate`` returns.
        """
        check_is_fitted(self, "estimator_")
        return self.estimator_.simulate(inputs, initial, **kwargs)

    @available_if(_estimator_has("predict"))
    def predict(self, X):
        """Predict with the fitted estimator.

        Parameters
        ----------
        X : array-like
            What ``estimator_.predict`` takes.

        Returns
        -------
        y_pred : ndarray
            What ``estimator_.predict`` returns.
        """
        check_is_fitted(self, "estimator_")
        return self.estimator_.predict(X)
