"""Static corrections of a simulated model, and models fed transformed inputs.

The measured benchmarks' zoo compares the physics with compositions that add no
feedback loop to its free run:

- :class:`_NARXSimulator`: a one-step regressor on windows of past outputs and
  inputs, rolled forward by :func:`skhybrid.simulation.simulate`;
- :class:`_PhysicsCorrection`: a fitted physics simulated in free run plus a static
  regressor of its own recent simulated output and inputs, which predicts the
  physics' output error (the correction reads no measured output, so it cannot
  destabilise the simulation);
- :class:`_TransformedInputs`: a fitted model fed a transform of the record's
  inputs (the Silverbox's ``[u(t), u(t + 1)]``).

Each ``simulate`` follows the library's contract
``simulate(inputs, initial, *, init="measured", n_samples=None,
random_state=None, return_std=False)``; none of these has a noise model, so
sample paths and bands raise a ``ValueError``.
"""

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import simulate
from skhybrid.utils._validation import as_columns

__all__ = []  # private: used by skhybrid.experiments' measured zoo

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


def _as_records(inputs, outputs):
    """One record ``(u, y)``, or lists of records, as two lists of 2-D arrays."""
    if isinstance(inputs, (list, tuple)):
        if not isinstance(outputs, (list, tuple)) or len(outputs) != len(inputs):
            raise ValueError(
                "inputs and outputs must both be one record or lists of as many "
                f"records; got {type(inputs).__name__} and {type(outputs).__name__}."
            )
        U = [as_columns(u, f"inputs[{i}]") for i, u in enumerate(inputs)]
        Y = [as_columns(y, f"outputs[{i}]") for i, y in enumerate(outputs)]
    else:
        U, Y = [as_columns(inputs, "inputs")], [as_columns(outputs, "outputs")]
    for i, (u, y) in enumerate(zip(U, Y, strict=True)):
        if len(u) != len(y):
            raise ValueError(
                f"record {i} holds {len(u)} input and {len(y)} output time steps; "
                "each record's inputs and outputs must be aligned."
            )
    return U, Y


def _windows(columns, n):
    """Rows ``[c(t-n+1..t) for each column]`` for every t, edge-padded at the start.

    Parameters
    ----------
    columns : list of array-like of shape (n_times,)
        The series, each flattened.
    n : int
        Samples per window.

    Returns
    -------
    X : ndarray of shape (n_times, n * len(columns))
        Row ``t`` holds each column's window, oldest first.
    """
    X = np.column_stack([np.ravel(c) for c in columns])
    padded = np.vstack([np.repeat(X[:1], n - 1, axis=0), X])
    view = np.lib.stride_tricks.sliding_window_view(padded, n, axis=0)
    return view.reshape(len(X), -1)


def _check_n_steps(n_steps):
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)):
        raise TypeError(f"n_steps must be an int >= 1; got n_steps={n_steps!r}.")
    if n_steps < 1:
        raise ValueError(f"n_steps must be an int >= 1; got n_steps={n_steps!r}.")


class _NARXSimulator(BaseEstimator):
    """A one-step NARX regressor (window of past outputs and inputs) in free run.

    ``fit`` builds rows of ``n_steps`` past outputs and inputs
    (:class:`~skhybrid.preprocessing.WindowLayout`), standardises them and fits a
    clone of ``regressor`` to the next output; ``simulate`` rolls the fitted
    pipeline forward with :func:`skhybrid.simulation.simulate`.

    Parameters
    ----------
    regressor : estimator
        A scikit-learn regressor (cloned in ``fit``).
    n_steps : int, default=1
        Time steps per window.

    Attributes
    ----------
    model_ : Pipeline
        The fitted ``StandardScaler`` and regressor.
    """

    def __init__(self, regressor, n_steps=1):
        self.regressor = regressor
        self.n_steps = n_steps

    def fit(self, inputs, outputs):
        """Fit the one-step regressor on one record or several.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), or list of them
            The inputs of each record.
        outputs : array-like of shape (n_times, n_outputs), or list of them
            The measured outputs of each record; windows never span two records.

        Returns
        -------
        self : _NARXSimulator
            The fitted model.
        """
        _check_n_steps(self.n_steps)
        U, Y = _as_records(inputs, outputs)
        layout = WindowLayout(
            n_states=Y[0].shape[1], n_inputs=U[0].shape[1], n_steps=self.n_steps
        )
        rows = [layout.make_rows(y, u) for u, y in zip(U, Y, strict=True)]
        X = np.vstack([r[0] for r in rows])
        target = np.concatenate([r[1] for r in rows])
        self.model_ = make_pipeline(StandardScaler(), clone(self.regressor)).fit(
            X, target
        )
        return self

    def simulate(
        self,
        inputs,
        initial,
        *,
        init="measured",
        n_samples=None,
        random_state=None,
        return_std=False,
    ):
        """Simulate in free run from a measured initial window.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            Inputs over the whole record, initial window included.
        initial : array-like of shape (n_init, n_outputs)
            Measured outputs of the first ``n_init >= n_steps`` samples.
        init : {"measured", "least_squares"}, default="measured"
            How the simulation starts (see :func:`skhybrid.simulation.simulate`).
        n_samples : None
            Must be None: the model has no noise model.
        random_state : None
            Unused (no noise model).
        return_std : bool, default=False
            Must be False: the model has no noise model.

        Returns
        -------
        outputs : ndarray of shape (n_times, n_outputs)
            The first ``n_init`` samples are the measured ones.
        """
        check_is_fitted(self)
        _check_simulate_options(self, init, n_samples, return_std, _INITS)
        return simulate(self.model_, inputs, initial, init=init)


class _PhysicsCorrection(BaseEstimator):
    """A fitted physics in free run plus a static map of its recent window.

    The correction reads ``[y_phys(t-n+1..t), u(t-n+1..t)]`` (the physics' own
    simulated output, never a measured one) and predicts ``y(t) - y_phys(t)``,
    so it adds no feedback loop and cannot destabilise the simulation. The
    physics is used as it is, already fitted (like
    :class:`sklearn.frozen.FrozenEstimator`): ``fit`` fits the correction only.

    Parameters
    ----------
    physics : fitted model
        Anything with ``simulate(inputs, initial)`` of one output (a fitted
        :class:`~skhybrid.domain.StateSpaceModel`, say); not refitted.
    regressor : estimator
        A scikit-learn regressor for the correction (cloned in ``fit``).
    n_steps : int, default=1
        Samples per window the correction reads.
    n_init : int, default=1
        Measured samples from which ``fit`` simulates the physics over the
        training record.

    Attributes
    ----------
    model_ : Pipeline
        The fitted ``StandardScaler`` and correction regressor.
    """

    def __init__(self, physics, regressor, n_steps=1, n_init=1):
        self.physics = physics
        self.regressor = regressor
        self.n_steps = n_steps
        self.n_init = n_init

    def _physics_run(self, inputs, initial):
        return np.ravel(self.physics.simulate(inputs, initial))

    def fit(self, inputs, outputs):
        """Simulate the physics over each record and fit the correction.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), or list of them
            The inputs of each record.
        outputs : array-like of shape (n_times,) or (n_times, 1), or list of them
            The measured output of each record; the physics starts from its
            first ``n_init`` samples.

        Returns
        -------
        self : _PhysicsCorrection
            The fitted model.
        """
        _check_n_steps(self.n_steps)
        U, Y = _as_records(inputs, outputs)
        for y in Y:
            if y.shape[1] != 1:
                raise ValueError(
                    f"outputs must hold one output; got {y.shape[1]} columns."
                )
        Y_phys = [
            self._physics_run(u, y[: self.n_init]) for u, y in zip(U, Y, strict=True)
        ]
        return self.fit_on_physics(U, Y, Y_phys)

    def fit_on_physics(self, inputs, outputs, physics_outputs):
        """Fit the correction given the physics' simulated output on each record.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), or list of them
            The inputs of each record.
        outputs : array-like of shape (n_times,) or (n_times, 1), or list of them
            The measured output of each record.
        physics_outputs : array-like of shape (n_times,) or (n_times, 1), or \
list of them
            The physics' free run over each record.

        Returns
        -------
        self : _PhysicsCorrection
            The fitted model.
        """
        _check_n_steps(self.n_steps)
        U, Y = _as_records(inputs, outputs)
        if not isinstance(physics_outputs, (list, tuple)):
            physics_outputs = [physics_outputs]
        X = np.vstack(
            [
                _windows([p, *u.T], self.n_steps)
                for u, p in zip(U, physics_outputs, strict=True)
            ]
        )
        target = np.concatenate(
            [np.ravel(y) - np.ravel(p) for y, p in zip(Y, physics_outputs, strict=True)]
        )
        self.model_ = make_pipeline(StandardScaler(), clone(self.regressor)).fit(
            X, target
        )
        return self

    def correct(self, inputs, physics_outputs):
        """The corrected output for the physics' simulated output.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            The record's inputs.
        physics_outputs : array-like of shape (n_times,) or (n_times, 1)
            The physics' free run over the record.

        Returns
        -------
        outputs : ndarray of shape (n_times,)
            ``physics_outputs`` plus the correction.
        """
        check_is_fitted(self)
        u = as_columns(inputs, "inputs")
        X = _windows([physics_outputs, *u.T], self.n_steps)
        return np.ravel(physics_outputs) + np.ravel(self.model_.predict(X))

    def simulate(
        self,
        inputs,
        initial,
        *,
        init="measured",
        n_samples=None,
        random_state=None,
        return_std=False,
    ):
        """The physics' free run from the measured window, corrected.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            Inputs over the whole record, initial window included.
        initial : array-like of shape (n_init, 1)
            Measured outputs of the first samples; the physics estimates its
            initial state from them.
        init : {"measured"}, default="measured"
            Only ``"measured"``: the physics starts from the measured window.
        n_samples : None
            Must be None: the model has no noise model.
        random_state : None
            Unused (no noise model).
        return_std : bool, default=False
            Must be False: the model has no noise model.

        Returns
        -------
        outputs : ndarray of shape (n_times, 1)
            The corrected free run.
        """
        check_is_fitted(self)
        _check_simulate_options(self, init, n_samples, return_std, ("measured",))
        y_phys = self._physics_run(inputs, initial)
        return self.correct(inputs, y_phys)[:, None]


class _TransformedInputs(BaseEstimator):
    """A fitted model fed transformed inputs (the Silverbox's ``[u(t), u(t+1)]``).

    The model is used as it is, already fitted (like
    :class:`sklearn.frozen.FrozenEstimator`): ``fit`` does nothing, ``clone``
    returns the wrapper itself, and the fitted model's attributes
    (``params_``, ``rmse_``, ``n_epochs_``...) read through.

    Parameters
    ----------
    estimator : fitted model
        Anything with ``simulate(inputs, initial)``, fitted on transformed inputs.
    transform : callable or None, default=None
        Maps a record's inputs to the model's; ``None`` passes them through.
    """

    def __init__(self, estimator, transform=None):
        self.estimator = estimator
        self.transform = transform

    def __sklearn_clone__(self):
        # Frozen, as sklearn.frozen.FrozenEstimator: a clone (GridSearchCV, or a
        # _PhysicsCorrection cloned) keeps the fitted model instead of
        # resetting it.
        return self

    def __sklearn_is_fitted__(self):
        try:
            check_is_fitted(self.estimator)
        except (TypeError, ValueError, AttributeError):
            return False
        return True

    def fit(self, inputs=None, outputs=None):
        """Do nothing: the wrapped model is already fitted.

        Parameters
        ----------
        inputs, outputs : ignored
            Accepted for the estimator interface.

        Returns
        -------
        self : _TransformedInputs
            Unchanged.
        """
        return self

    def inputs(self, inputs):
        """The model's inputs for the record's inputs.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            The record's inputs.

        Returns
        -------
        model_inputs : ndarray
            ``transform(inputs)``, or the inputs as floats without a transform.
        """
        if self.transform is None:
            return np.asarray(inputs, dtype=float)
        return self.transform(inputs)

    def simulate(
        self,
        inputs,
        initial,
        *,
        init="measured",
        n_samples=None,
        random_state=None,
        return_std=False,
    ):
        """The wrapped model's free run on the transformed inputs.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            The record's inputs, initial window included.
        initial : array-like of shape (n_init, n_outputs)
            Measured outputs of the first samples.
        init : {"measured"}, default="measured"
            Only ``"measured"``.
        n_samples : None
            Must be None: the wrapper adds no noise model.
        random_state : None
            Unused.
        return_std : bool, default=False
            Must be False.

        Returns
        -------
        outputs : ndarray
            The wrapped model's simulated outputs.
        """
        _check_simulate_options(self, init, n_samples, return_std, ("measured",))
        return self.estimator.simulate(self.inputs(inputs), initial)

    def __getattr__(self, name):
        # Fitted attributes of the wrapped model read through; parameters and
        # private names do not (so that pickling and get_params never recurse).
        if name.startswith("_") or name in ("estimator", "transform"):
            raise AttributeError(name)
        return getattr(self.estimator, name)
