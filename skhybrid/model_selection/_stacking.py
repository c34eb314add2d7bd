"""A convex combination of models' free runs, and its weights.

The weights of a stack are fitted on out-of-fold free runs: each candidate's
simulation of blocks it was not fitted on (:class:`RecordBlockSplit`), so a
candidate that only memorised its training records gets no weight for it.
"""

import numpy as np
from scipy.optimize import nnls
from sklearn.base import BaseEstimator, clone
from sklearn.utils.validation import check_is_fitted

from skhybrid.model_selection._records import _check_records
from skhybrid.utils._docstrings import RECORD_INPUTS_INITIAL, fill_doc
from skhybrid.utils._simulate_contract import SimulateContract

__all__ = ["StackedSimulation"]


def _simplex_weights(P, t):
    """Least-squares weights on the simplex: ``min |P w - t|``, ``w >= 0``, sum 1.

    Solved by :func:`scipy.optimize.nnls` with the constraint ``sum(w) = 1`` as
    one heavily weighted extra row (its weight is 1e4 times the data's norm, so
    the sum is off by far less than the solver's own precision), then divided by
    its sum, so the weights sum to one exactly.

    Parameters
    ----------
    P : ndarray of shape (n_samples, n_models)
        Each model's out-of-fold run, flattened, one column per model.
    t : ndarray of shape (n_samples,)
        The measured outputs at the same samples.

    Returns
    -------
    w : ndarray of shape (n_models,)
        Non-negative weights summing to one.
    """
    P = np.asarray(P, dtype=float)
    t = np.asarray(t, dtype=float)
    scale = max(float(np.linalg.norm(P)), float(np.linalg.norm(t)), 1e-12)
    lam = 1e4 * scale
    A = np.vstack([P, np.full((1, P.shape[1]), lam)])
    b = np.append(t, lam)
    w, _ = nnls(A, b, maxiter=50 * P.shape[1] + 100)
    total = w.sum()
    if not np.isfinite(total) or total <= 0:
        return np.full(P.shape[1], 1.0 / P.shape[1])
    return w / total


def _cross_fitted_weights(oof, targets):
    """The weights of each fold, fitted on the other folds, and on all folds.

    Parameters
    ----------
    oof : list (over models) of list (over folds) of ndarray
        ``oof[m][k]``: model ``m``'s scored free-run samples on fold ``k``'s
        held-out blocks, flattened.
    targets : list (over folds) of ndarray
        The measured outputs at the same samples.

    Returns
    -------
    fold_weights : ndarray of shape (n_folds, n_models)
        Row ``k`` is fitted on every fold but ``k``.
    weights : ndarray of shape (n_models,)
        Fitted on every fold.
    """
    n_folds = len(targets)

    def design(folds):
        P = np.column_stack([np.concatenate([runs[k] for k in folds]) for runs in oof])
        return P, np.concatenate([targets[k] for k in folds])

    fold_weights = np.vstack(
        [
            _simplex_weights(*design([j for j in range(n_folds) if j != k]))
            for k in range(n_folds)
        ]
    )
    return fold_weights, _simplex_weights(*design(range(n_folds)))


def _as_2d(pred, n_times):
    pred = np.asarray(pred, dtype=float)
    return pred.reshape(n_times, -1)


@fill_doc(record_inputs_initial=RECORD_INPUTS_INITIAL)
class StackedSimulation(SimulateContract, BaseEstimator):
    """A weighted average of models' free runs: weights non-negative, summing to one.

    ``simulate`` runs every model from the same measured window and returns
    ``sum_m w_m * simulate_m(inputs, initial)``. Being convex, the combination
    stays within the range of its models at every time step. The weights are
    usually fitted by :class:`SimulationSearchCV` with ``stack=True`` on the
    models' out-of-fold free runs; its ``best_estimator_`` is then a stack of
    the models it refitted on the whole records (fitted once, not by
    :meth:`fit`).

    Parameters
    ----------
    estimators : list of (str, estimator)
        The named models, each with ``fit(U, Y)`` (lists of records) and
        ``simulate(inputs, initial)``; cloned and fitted by :meth:`fit`.
    weights : array-like of shape (n_estimators,), default=None
        Non-negative weights summing to one (within 1e-9); ``None`` weighs the
        models equally.

    Attributes
    ----------
    estimators_ : list of estimator
        The fitted models, in the order of ``estimators``.
    named_estimators_ : dict of str to estimator
        The same, by name.
    weights_ : ndarray of shape (n_estimators,)
        The weights used.

    See Also
    --------
    SimulationSearchCV : Fits the weights on out-of-fold free runs
        (``stack=True``) and scores the stack by cross-validation.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.base import BaseEstimator
    >>> from skhybrid.model_selection import StackedSimulation
    >>> class Constant(BaseEstimator):
    ...     def __init__(self, value=0.0):
    ...         self.value = value
    ...     def fit(self, U, Y):
    ...         self.fitted_ = True
    ...         return self
    ...     def simulate(self, inputs, initial):
    ...         return np.full((len(inputs), 1), self.value)
    >>> stack = StackedSimulation(
    ...     [("low", Constant(0.0)), ("high", Constant(4.0))], weights=[0.75, 0.25]
    ... ).fit([np.zeros((3, 1))], [np.zeros((3, 1))])
    >>> stack.simulate(np.zeros((3, 1)), np.zeros((1, 1))).ravel()
    array([1., 1., 1.])
    """

    def __init__(self, estimators, *, weights=None):
        self.estimators = estimators
        self.weights = weights

    @classmethod
    def _from_fitted(cls, named_models, weights):
        """A fitted stack of already fitted models (the search's refit)."""
        stack = cls(list(named_models), weights=list(map(float, weights)))
        stack._check_estimators()
        stack.weights_ = stack._check_weights()
        stack.estimators_ = [est for _, est in named_models]
        stack.named_estimators_ = dict(named_models)
        return stack

    def _check_weights(self):
        n = len(self.estimators)
        if self.weights is None:
            return np.full(n, 1.0 / n)
        w = np.asarray(self.weights, dtype=float)
        if w.shape != (n,):
            raise ValueError(
                f"weights has shape {w.shape}; expected ({n},), one weight per "
                f"estimator. Got weights={self.weights!r}."
            )
        if not np.all(np.isfinite(w)) or np.any(w < 0) or abs(w.sum() - 1) > 1e-9:
            raise ValueError(
                "weights must be non-negative and sum to one; got "
                f"weights={self.weights!r} (sum {w.sum()!r})."
            )
        return w

    def _check_estimators(self):
        if not isinstance(self.estimators, (list, tuple)) or not self.estimators:
            raise ValueError(
                "estimators must be a non-empty list of (name, estimator) pairs; "
                f"got estimators={self.estimators!r}."
            )
        names = []
        for i, pair in enumerate(self.estimators):
            if not (
                isinstance(pair, tuple)
                and len(pair) == 2
                and isinstance(pair[0], str)
                and hasattr(pair[1], "simulate")
            ):
                raise ValueError(
                    f"estimators[{i}] must be a (name, estimator) pair whose "
                    f"estimator has simulate(inputs, initial); got {pair!r}."
                )
            names.append(pair[0])
        if len(set(names)) != len(names):
            raise ValueError(f"estimators' names must be unique; got {names}.")

    def fit(self, U, Y):
        """Fit a clone of every model on the records.

        Parameters
        ----------
        U : list of array-like of shape (n_times_i, n_inputs)
            Inputs of each record.
        Y : list of array-like of shape (n_times_i, n_outputs)
            Measured outputs of each record.

        Returns
        -------
        self : StackedSimulation
            The fitted stack.
        """
        self._check_estimators()
        weights = self._check_weights()
        U, Y = _check_records(U, Y)
        fitted = [clone(est).fit(U, Y) for _, est in self.estimators]
        self.estimators_ = fitted
        self.named_estimators_ = {
            name: est for (name, _), est in zip(self.estimators, fitted, strict=True)
        }
        self.weights_ = weights
        return self

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Simulate every model in free run and average with the weights.

        Parameters
        ----------
        %(record_inputs_initial)s
        init : {"measured", "least_squares"}, default="measured"
            How each model starts; passed on where it is not the default.
        n_samples : None
            Must be None: a stack of free runs has no noise model.
        random_state : None
            Unused (no noise model).
        return_std : bool, default=False
            Must be False: a stack of free runs has no noise model.

        Returns
        -------
        outputs : ndarray of shape (n_times, n_outputs)
            The weighted average of the models' free runs.
        """
        check_is_fitted(self)
        if n_samples is not None or return_std:
            raise ValueError(
                f"n_samples={n_samples!r} and return_std={return_std!r} need a "
                "noise model; StackedSimulation has none: call simulate without "
                "them."
            )
        kwargs = {} if init == "measured" else {"init": init}
        n_times = len(inputs)
        total = 0.0
        for w, est in zip(self.weights_, self.estimators_, strict=True):
            if w == 0:
                continue
            total = total + w * _as_2d(est.simulate(inputs, initial, **kwargs), n_times)
        return total
