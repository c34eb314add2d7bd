"""PhysicsCorrection: a fitted physics' free run plus a static correction."""

from numbers import Integral

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import NotFittedError
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from skhybrid.simulation import (
    check_trajectories,
    pack_trajectories,
    stack_trajectories,
)
from skhybrid.utils._docstrings import (
    RECORD_MODEL_DOCS,
    RECORDS_FEATURES_IN,
    fill_doc,
)
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._simulate_checks import check_fitted_widths, check_simulate_options
from skhybrid.utils._simulate_contract import SimulateContract
from skhybrid.utils._sklearn_compat import HasMethods, Interval, _fit_context
from skhybrid.utils._transaction import TransactionalFitMixin, transactional
from skhybrid.utils._validation import (
    as_columns,
    check_record_lengths,
    validate_records,
)

__all__ = ["PhysicsCorrection"]


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


@fill_doc(**RECORD_MODEL_DOCS, records_features_in=RECORDS_FEATURES_IN)
class PhysicsCorrection(
    SimulateContract, TransactionalFitMixin, VersionedPickleMixin, BaseEstimator
):
    """A fitted physics in free run plus a static map of its own recent window.

    The correction reads ``[y_phys(t-n+1..t), u(t-n+1..t)]`` (the physics' own
    simulated output, never a measured one, and the inputs; the windows are
    edge-padded at a record's start) and predicts ``y(t) - y_phys(t)``, so it
    adds no feedback loop and cannot destabilise the simulation: the
    corrected model is stable wherever the physics is.

    The physics is used as it is, already fitted, like a
    :class:`sklearn.frozen.FrozenEstimator`: ``fit`` fits the correction only,
    and :func:`sklearn.base.clone` (a search's refit, a cross-validation)
    keeps the same fitted physics object instead of resetting it. Do not
    change the physics through ``set_params(physics__...)``: give a new one.

    Like :class:`~skhybrid.domain.WienerHammersteinModel`, it fits whole
    records (``X`` a record's inputs, ``y`` its measured output) and has no
    ``predict``; :meth:`correct` corrects a given free run of the physics.

    Parameters
    ----------
    physics : fitted model
        Anything with ``simulate(inputs, initial)`` returning one output, such
        as a fitted :class:`~skhybrid.domain.StateSpaceModel`; never refitted.
    regressor : estimator
        A scikit-learn regressor of the physics' output error (``Ridge()`` for
        a linear correction, a network); cloned in ``fit``.
    n_steps : int, default=1
        Samples per window the correction reads.
    n_init : int, default=1
        Measured samples of each record from which ``fit`` simulates the
        physics (its initial window).

    Attributes
    ----------
    model_ : Pipeline
        The fitted ``StandardScaler`` and correction regressor.
    %(records_features_in)s
    n_outputs_ : int
        Number of outputs: 1.

    See Also
    --------
    NARXSimulator : A one-step regressor of past outputs and inputs in free run.
    skhybrid.hybrid.StateSpaceHybridRegressor : A network inside the state
        equations, trained by the simulation error.
    sklearn.frozen.FrozenEstimator : How scikit-learn keeps a fitted estimator
        through ``clone``.

    Examples
    --------
    The system ``y[t+1] = 0.9 y[t] + 0.1 u[t]`` and a physics whose pole is
    wrong (0.8): the correction of a 20-sample window lowers the free-run
    RMSE.

    >>> import numpy as np
    >>> from sklearn.linear_model import Ridge
    >>> from skhybrid.domain import StateSpaceModel
    >>> from skhybrid.hybrid import PhysicsCorrection
    >>> def first_order(x, u, *, xp, a, b):
    ...     return a * x + b * u
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(1000, 1))
    >>> y = np.zeros((1000, 1))
    >>> for t in range(999):
    ...     y[t + 1] = 0.9 * y[t] + 0.1 * u[t]
    >>> physics = StateSpaceModel(
    ...     first_order, {"a": 0.8, "b": 0.1}, state_names=["y"], observed=["y"],
    ...     time="discrete", fixed=("a", "b"),
    ... ).fit_simulation(u, y)
    >>> model = PhysicsCorrection(physics, Ridge(alpha=1e-6), n_steps=20).fit(u, y)
    >>> def rmse(y_sim):
    ...     return float(np.sqrt(np.mean((y_sim - y) ** 2)))
    >>> bool(rmse(model.simulate(u, y[:1])) < 0.2 * rmse(physics.simulate(u, y[:1])))
    True
    """

    _parameter_constraints = {
        "physics": [HasMethods(["simulate"])],
        "regressor": [HasMethods(["fit", "predict"])],
        "n_steps": [Interval(Integral, 1, None, closed="left")],
        "n_init": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(self, physics, regressor, n_steps=1, n_init=1):
        self.physics = physics
        self.regressor = regressor
        self.n_steps = n_steps
        self.n_init = n_init

    def __sklearn_clone__(self):
        # As scikit-learn's clone, except that the fitted physics is kept (the
        # same object, as sklearn.frozen.FrozenEstimator clones to itself):
        # cloned, it would be reset to an unfitted model.
        params = self.get_params(deep=False)
        physics = params.pop("physics")
        params = {k: clone(v, safe=False) for k, v in params.items()}
        return type(self)(physics=physics, **params)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        return tags

    def _check_physics(self):
        """Raise NotFittedError where the physics is an unfitted estimator."""
        if not hasattr(self.physics, "fit"):
            return  # not an estimator: used as it is
        try:
            check_is_fitted(self.physics)
        except NotFittedError:
            raise NotFittedError(
                f"physics must be a fitted model (it is used as it is, never "
                f"refitted); got an unfitted {type(self.physics).__name__}. Fit it "
                "first (a StateSpaceModel by fit_simulation)."
            ) from None

    def _physics_run(self, inputs, initial):
        return np.ravel(self.physics.simulate(inputs, initial))

    def _validate(self, X, y):
        U, Y = validate_records(self, X, y)
        if Y[0].shape[1] != 1:
            raise ValueError(
                "y: the measured outputs must hold one output (the physics' "
                f"output); got {Y[0].shape[1]} columns."
            )
        self.n_outputs_ = 1
        return U, Y

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y):
        """Simulate the physics over each record and fit the correction.

        Parameters
        ----------
        %(records_x)s
        y : array-like of shape (n_times,) or (n_times, 1), or list of them
            The measured output of each record, aligned with ``X``; the physics
            starts from its first ``n_init`` samples, and each record needs at
            least ``n_init + 1``.

        Returns
        -------
        self : PhysicsCorrection
            The fitted model.
        """
        self._check_physics()
        U, Y = self._validate(X, y)
        check_record_lengths(
            self,
            Y,
            self.n_init + 1,
            f"n_init={self.n_init} to start the physics, and one more",
        )
        Y_phys = [
            self._physics_run(u, y_i[: self.n_init])
            for u, y_i in zip(U, Y, strict=True)
        ]
        return self._fit_correction(U, Y, Y_phys)

    @transactional
    @_fit_context(prefer_skip_nested_validation=False)
    def fit_on_physics(self, X, y, physics_outputs):
        """Fit the correction given the physics' free run over each record.

        For a physics run that is at hand already; :meth:`fit` simulates it.

        Parameters
        ----------
        %(records_x)s
        y : array-like of shape (n_times,) or (n_times, 1), or list of them
            The measured output of each record.
        physics_outputs : array-like of shape (n_times,) or (n_times, 1), or \
list of them
            The physics' free run over each record.

        Returns
        -------
        self : PhysicsCorrection
            The fitted model.
        """
        U, Y = self._validate(X, y)
        if not isinstance(physics_outputs, (list, tuple)):
            physics_outputs = [physics_outputs]
        if len(physics_outputs) != len(U):
            raise ValueError(
                f"physics_outputs must hold one run per record: {len(U)} "
                f"record(s); got {len(physics_outputs)}."
            )
        Y_phys = []
        for i, (p, y_i) in enumerate(zip(physics_outputs, Y, strict=True)):
            p = np.ravel(as_columns(p, f"physics_outputs[{i}]"))
            if len(p) != len(y_i):
                raise ValueError(
                    f"physics_outputs[{i}] holds {len(p)} samples; record {i} "
                    f"holds {len(y_i)}."
                )
            Y_phys.append(p)
        return self._fit_correction(U, Y, Y_phys)

    def _fit_correction(self, U, Y, Y_phys):
        X_rows = np.vstack(
            [_windows([p, *u.T], self.n_steps) for u, p in zip(U, Y_phys, strict=True)]
        )
        target = np.concatenate(
            [np.ravel(y) - np.ravel(p) for y, p in zip(Y, Y_phys, strict=True)]
        )
        self.model_ = make_pipeline(StandardScaler(), clone(self.regressor)).fit(
            X_rows, target
        )
        return self

    def correct(self, inputs, physics_outputs):
        """The corrected output for a free run of the physics.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            The record's inputs.
        physics_outputs : array-like of shape (n_times,) or (n_times, 1)
            The physics' free run over the record (from any initial state).

        Returns
        -------
        outputs : ndarray of shape (n_times,)
            ``physics_outputs`` plus the correction.
        """
        check_is_fitted(self)
        u = as_columns(inputs, "inputs")
        p = np.ravel(as_columns(physics_outputs, "physics_outputs"))
        check_fitted_widths(self, u.shape[1], 1)
        if len(p) != len(u):
            raise ValueError(
                f"physics_outputs holds {len(p)} samples; inputs holds {len(u)}."
            )
        X_rows = _windows([p, *u.T], self.n_steps)
        return p + np.ravel(self.model_.predict(X_rows))

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """The physics' free run from each measured window, corrected.

        Follows the contract of :func:`skhybrid.simulation.simulate`: the first
        ``n_init`` samples returned are the measured ones.

        Parameters
        ----------
        %(record_inputs)s
        initial : array-like of shape (n_init, 1), (n_trajectories, n_init, 1) \
or list of 2-D arrays
            Measured outputs of the first samples; the physics estimates its
            initial state from them.
        init : {"measured"}, default="measured"
            Only ``"measured"``: the physics starts from the measured window.
        %(no_noise_simulate_options)s

        Returns
        -------
        outputs : ndarray or list of ndarray
            The corrected free runs ``(n_times, 1)`` in the container form of
            ``inputs``.
        """
        check_is_fitted(self)
        U_list, Y0_list, form = check_trajectories(inputs, initial)
        check_simulate_options(
            self, init, n_samples, return_std, supported=("measured",)
        )
        check_fitted_widths(self, U_list[0].shape[1], Y0_list[0].shape[1])
        runs = []
        for u, y0 in zip(U_list, Y0_list, strict=True):
            y = self.correct(u, self._physics_run(u, y0))
            y[: len(y0)] = y0[:, 0]  # the measured window, as returned by simulate
            runs.append(y[:, None])
        Y, lengths = stack_trajectories(runs)
        return pack_trajectories(Y, lengths, form)
