"""NARXSimulator: a one-step regressor of past outputs and inputs, in free run."""

from numbers import Integral

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import check_trajectories, simulate
from skhybrid.utils._docstrings import (
    RECORD_MODEL_DOCS,
    RECORDS_FEATURES_IN,
    fill_doc,
)
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._simulate_checks import check_fitted_widths, check_simulate_options
from skhybrid.utils._simulate_contract import SimulateContract
from skhybrid.utils._sklearn_compat import HasMethods, Interval, _fit_context
from skhybrid.utils._transaction import TransactionalFitMixin
from skhybrid.utils._validation import check_record_lengths, validate_records

__all__ = ["NARXSimulator"]


@fill_doc(**RECORD_MODEL_DOCS, records_features_in=RECORDS_FEATURES_IN)
class NARXSimulator(
    SimulateContract, TransactionalFitMixin, VersionedPickleMixin, BaseEstimator
):
    """A one-step NARX regressor on windows of past outputs and inputs, in free run.

    ``fit`` cuts each record into rows of the ``n_steps`` latest outputs and
    inputs, oldest first (the layout of
    :class:`~skhybrid.preprocessing.WindowLayout`), standardises them and fits
    a clone of ``regressor`` to the output at the next time step; ``simulate``
    rolls the fitted pipeline forward from a measured initial window with
    :func:`skhybrid.simulation.simulate`, feeding its own predictions back.
    With a linear regressor this is an ARX model, with a network a NARX model.

    Like :class:`~skhybrid.domain.WienerHammersteinModel`, it fits whole
    records: ``X`` holds a record's inputs and ``y`` its measured outputs, and
    the model has no ``predict`` (a one-step prediction needs past outputs as
    well as inputs): the fitted one-step pipeline is ``model_``, whose
    ``predict`` reads rows laid out by
    ``WindowLayout(n_outputs, n_inputs, n_steps)``.

    Parameters
    ----------
    regressor : estimator
        A scikit-learn regressor of the next output (``Ridge()`` for a linear
        ARX, a network for a NARX); cloned in ``fit``.
    n_steps : int, default=1
        Time steps per window: the model's order.

    Attributes
    ----------
    model_ : Pipeline
        The fitted ``StandardScaler`` and regressor: the one-step predictor.
    %(records_features_in)s
    n_outputs_ : int
        Number of outputs (columns of ``y``).

    See Also
    --------
    PhysicsCorrection : A fitted physics' free run plus a static correction.
    skhybrid.simulation.simulate : The free run of any one-step predictor.
    skhybrid.preprocessing.WindowLayout : The layout of the windows.

    Examples
    --------
    A first-order system ``y[t+1] = 0.9 y[t] + 0.1 u[t]``: the linear ARX of one
    step recovers it, and its free run follows the measured output.

    >>> import numpy as np
    >>> from sklearn.linear_model import Ridge
    >>> from skhybrid.hybrid import NARXSimulator
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(500, 1))
    >>> y = np.zeros((500, 1))
    >>> for t in range(499):
    ...     y[t + 1] = 0.9 * y[t] + 0.1 * u[t]
    >>> model = NARXSimulator(Ridge(alpha=1e-6), n_steps=1).fit(u, y)
    >>> y_sim = model.simulate(u, y[:1])
    >>> bool(np.sqrt(np.mean((y_sim - y) ** 2)) < 1e-4)
    True
    """

    _parameter_constraints = {
        "regressor": [HasMethods(["fit", "predict"])],
        "n_steps": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(self, regressor, n_steps=1):
        self.regressor = regressor
        self.n_steps = n_steps

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        tags.target_tags.multi_output = True
        return tags

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y):
        """Fit the one-step regressor on one record or several.

        Parameters
        ----------
        %(records_x)s
        y : array-like of shape (n_times,) or (n_times, n_outputs), or list \
of them
            The measured outputs of each record, aligned with ``X``; windows
            never span two records, and each record needs at least
            ``n_steps + 1`` samples.

        Returns
        -------
        self : NARXSimulator
            The fitted model.
        """
        U, Y = validate_records(self, X, y)
        check_record_lengths(
            self,
            Y,
            self.n_steps + 1,
            f"a window of n_steps={self.n_steps} and the output after it",
        )
        layout = WindowLayout(
            n_states=Y[0].shape[1], n_inputs=U[0].shape[1], n_steps=self.n_steps
        )
        rows = [layout.make_rows(y_i, u) for u, y_i in zip(U, Y, strict=True)]
        X_rows = np.vstack([r[0] for r in rows])
        target = np.concatenate([r[1] for r in rows])
        self.n_outputs_ = Y[0].shape[1]
        self.model_ = make_pipeline(StandardScaler(), clone(self.regressor)).fit(
            X_rows, target
        )
        return self

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Simulate in free run from measured initial windows.

        Follows :func:`skhybrid.simulation.simulate`: the model predicts the
        next output from its window, the window shifts one step, and so on to
        the end of the inputs; the first ``n_init`` samples returned are the
        measured ones.

        Parameters
        ----------
        %(record_inputs)s
        initial : array-like of shape (n_init, n_outputs), (n_trajectories, \
n_init, n_outputs) or list of 2-D arrays
            Measured outputs of the first ``n_init >= n_steps`` samples.
        init : {"measured", "least_squares"}, default="measured"
            Start from the newest ``n_steps`` measured samples as they are, or
            from the first window fitted so that the free run matches the whole
            measured initial window (see :func:`skhybrid.simulation.simulate`).
        %(no_noise_simulate_options)s

        Returns
        -------
        outputs : ndarray or list of ndarray
            Simulated outputs ``(n_times, n_outputs)`` in the container form
            of ``inputs``.
        """
        check_is_fitted(self)
        check_simulate_options(self, init, n_samples, return_std)
        U_list, Y0_list, _ = check_trajectories(inputs, initial)
        check_fitted_widths(self, U_list[0].shape[1], Y0_list[0].shape[1])
        return simulate(self.model_, inputs, initial, init=init)
