"""TransformedInputSimulator: a fitted model fed a transform of a record's inputs."""

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.utils.validation import check_is_fitted

from skhybrid.simulation import (
    check_trajectories,
    pack_trajectories,
    stack_trajectories,
)
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._simulate_checks import check_simulate_options
from skhybrid.utils._simulate_contract import SimulateContract
from skhybrid.utils._sklearn_compat import HasMethods, _fit_context
from skhybrid.utils._transaction import TransactionalFitMixin
from skhybrid.utils._validation import validate_records

__all__ = ["TransformedInputSimulator"]

#: Attributes this wrapper learns itself in ``fit``; they never read through to
#: the wrapped model (whose inputs are the transformed ones).
_OWN_FITTED = ("n_features_in_", "feature_names_in_")


class TransformedInputSimulator(
    SimulateContract, TransactionalFitMixin, VersionedPickleMixin, BaseEstimator
):
    """A fitted model simulated on a transform of each record's inputs.

    ``simulate(inputs, initial)`` runs the wrapped model's
    ``simulate(input_transform(inputs), initial)``: a model fitted on derived inputs
    (the Silverbox's ``[u(t), u(t+1)]``, a sum of several inputs) is used on a
    record's own inputs. This is the model
    :func:`skhybrid.experiments.load_fitted` returns for a system whose spec
    has ``physics_inputs``.

    The wrapped model is used as it is, already fitted, like a
    :class:`sklearn.frozen.FrozenEstimator`: ``fit`` never refits it (it only
    validates the record, as :class:`PhysicsCorrection`'s ``fit`` does, and
    records the number of inputs), and :func:`sklearn.base.clone` (a search's
    refit, a :class:`PhysicsCorrection` cloned) keeps the same fitted model
    object instead of resetting it. The wrapped model's fitted attributes
    (``params_``, ``rmse_``, ``n_epochs_``...) read through the wrapper.

    Parameters
    ----------
    estimator : fitted model
        Anything with ``simulate(inputs, initial)``, fitted on the transformed
        inputs, such as a fitted :class:`~skhybrid.domain.StateSpaceModel` or
        :class:`NARXSimulator`; never refitted.
    input_transform : callable or None, default=None
        Maps a record's inputs ``(n_times, n_inputs)`` to the model's inputs
        ``(n_times, n_model_inputs)``; ``None`` passes them through as floats.

    Attributes
    ----------
    n_features_in_ : int
        Number of inputs (columns of ``X``, before the transform); set by
        ``fit``, absent from a wrapper that was never fitted.
    feature_names_in_ : ndarray of shape (`n_features_in_`,)
        Names of the inputs, where ``X`` was a DataFrame with string column
        names.

    See Also
    --------
    PhysicsCorrection : A fitted physics' free run plus a static correction.
    NARXSimulator : A one-step regressor of past outputs and inputs in free run.
    sklearn.frozen.FrozenEstimator : How scikit-learn keeps a fitted estimator
        through ``clone``.

    Examples
    --------
    The system ``y[t+1] = 0.5 y[t] + 0.1 u[t] + 0.2 u[t+1]`` reads the next
    input too: a linear ARX fitted on ``[u(t), u(t+1)]`` is exact, and the
    wrapper simulates it from the record's own input.

    >>> import numpy as np
    >>> from sklearn.base import clone
    >>> from sklearn.linear_model import Ridge
    >>> from skhybrid.hybrid import NARXSimulator, TransformedInputSimulator
    >>> def lead(u):
    ...     u = np.asarray(u, dtype=float)
    ...     return np.hstack([u, np.vstack([u[1:], u[-1:]])])
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(500, 1))
    >>> y = np.zeros((500, 1))
    >>> for t in range(499):
    ...     y[t + 1] = 0.5 * y[t] + 0.1 * u[t] + 0.2 * u[t + 1]
    >>> narx = NARXSimulator(Ridge(alpha=1e-8)).fit(lead(u), y)
    >>> model = TransformedInputSimulator(narx, input_transform=lead)
    >>> y_sim = model.simulate(u, y[:1])
    >>> bool(np.sqrt(np.mean((y_sim - y) ** 2)) < 1e-4)
    True
    >>> model.n_outputs_  # the wrapped model's fitted attribute
    1
    >>> clone(model).estimator is narx  # clone keeps the fitted model
    True
    """

    _parameter_constraints = {
        "estimator": [HasMethods(["simulate"])],
        "input_transform": [callable, None],
    }

    def __init__(self, estimator, input_transform=None):
        self.estimator = estimator
        self.input_transform = input_transform

    def __setstate__(self, state):
        # Run folders pickled before the class was public hold the transform
        # under its old name, ``transform``.
        state = dict(state)
        if "transform" in state and "input_transform" not in state:
            state["input_transform"] = state.pop("transform")
        super().__setstate__(state)

    def __sklearn_clone__(self):
        # As scikit-learn's clone, except that the fitted model is kept (the
        # same object, as sklearn.frozen.FrozenEstimator clones to itself):
        # cloned, it would be reset to an unfitted model.
        return type(self)(
            estimator=self.estimator,
            input_transform=clone(self.input_transform, safe=False),
        )

    def __sklearn_is_fitted__(self):
        try:
            check_is_fitted(self.estimator)
        except (TypeError, ValueError, AttributeError):
            return False
        return True

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = False  # frozen: fitted once its model is
        tags.target_tags.required = True
        tags.target_tags.multi_output = True
        return tags

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y):
        """Validate the records; the wrapped model is not refitted.

        Parameters
        ----------
        X : array-like of shape (n_times, n_inputs), or list of them
            The inputs of one record, or of each of several records (before
            the transform).
        y : array-like of shape (n_times,) or (n_times, n_outputs), or list \
of them
            The measured outputs of each record, aligned with ``X``.

        Returns
        -------
        self : TransformedInputSimulator
            The wrapper, with ``n_features_in_`` set; the wrapped model is
            unchanged.
        """
        validate_records(self, X, y)
        return self

    def inputs(self, inputs):
        """The model's inputs for a record's inputs.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs)
            The record's inputs.

        Returns
        -------
        model_inputs : ndarray
            ``input_transform(inputs)``, or the inputs as floats without a transform.
        """
        if self.input_transform is None:
            return np.asarray(inputs, dtype=float)
        return self.input_transform(inputs)

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
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
            Must be False: the wrapper adds no noise model.

        Returns
        -------
        outputs : ndarray
            The wrapped model's simulated outputs,
            ``estimator.simulate(input_transform(inputs), initial)``.
        """
        self._validate_params()
        U_list, Y0_list, form = check_trajectories(inputs, initial)
        check_simulate_options(
            self, init, n_samples, return_std, supported=("measured",)
        )
        expected = self.__dict__.get("n_features_in_")  # set by fit only
        n_inputs = U_list[0].shape[1]
        if expected is not None and n_inputs != expected:
            raise ValueError(
                f"inputs has {n_inputs} column(s); this "
                f"{type(self).__name__} was fitted on {expected} input(s)."
            )
        runs = [
            np.asarray(self.estimator.simulate(self.inputs(u), y0), dtype=float)
            for u, y0 in zip(U_list, Y0_list, strict=True)
        ]
        runs = [run.reshape(len(run), -1) for run in runs]
        Y, lengths = stack_trajectories(runs)
        return pack_trajectories(Y, lengths, form)

    def __getattr__(self, name):
        # The wrapped model's fitted attributes (and its other data attributes,
        # such as a physics' ``fixed``) read through. Parameters, private names,
        # the wrapper's own fitted attributes and the wrapped model's methods do
        # not: pickling and get_params never recurse, an unfitted wrapper has no
        # n_features_in_, and the wrapped model's predict or fit_simulation,
        # which read untransformed inputs, are not the wrapper's.
        if (
            name.startswith("_")
            or name in _OWN_FITTED
            or name in ("estimator", "input_transform", "transform")
        ):
            raise AttributeError(
                f"{type(self).__name__!r} object has no attribute {name!r}"
            )
        value = getattr(self.estimator, name)
        if callable(value) and not name.endswith("_"):
            raise AttributeError(
                f"{type(self).__name__!r} object has no attribute {name!r} (the "
                f"wrapped {type(self.estimator).__name__}'s {name} reads "
                "untransformed inputs; call it on .estimator)"
            )
        return value
