"""Free-run models of records that add no feedback loop to a physics' free run.

- :class:`NARXSimulator`: a one-step regressor on windows of past outputs and
  inputs, rolled forward by :func:`skhybrid.simulation.simulate` (the measured
  candidate family's "linear ARX" and "dense NARX");
- :class:`PhysicsCorrection`: a fitted physics simulated in free run plus a
  static regressor of its own recent simulated output and inputs, which predicts
  the physics' output error (the correction reads no measured output, so it
  cannot destabilise the simulation; the family's "physics + linear / dense /
  dense ensemble");
- ``_TransformedInputs`` (private): a fitted model fed a transform of the
  record's inputs (the Silverbox's ``[u(t), u(t + 1)]``).

Both public estimators fit whole records, ``fit(X, y)`` with ``X`` a record's
inputs and ``y`` its measured outputs (or lists of records), as
:class:`~skhybrid.domain.WienerHammersteinModel` does, and follow the library's
``simulate(inputs, initial, *, init="measured", n_samples=None,
random_state=None, return_std=False)`` contract. None of these has a noise
model, so sample paths and bands raise a ``ValueError``.

``_NARXSimulator`` and ``_PhysicsCorrection`` are the names the classes had
while private: aliases, so that run folders pickled under them still load.
"""

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from skhybrid.hybrid._narx import NARXSimulator

# _windows was defined here before the split; it is re-exported where it was.
from skhybrid.hybrid._physics_correction import (  # noqa: F401 (re-exported)
    PhysicsCorrection,
    _windows,
)
from skhybrid.hybrid._record_checks import _check_simulate_options

__all__ = ["NARXSimulator", "PhysicsCorrection"]


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
        # PhysicsCorrection cloned) keeps the fitted model instead of
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


#: The names of the classes while they were private: run folders pickled under
#: them still load, and code that imports them keeps working.
_NARXSimulator = NARXSimulator
_PhysicsCorrection = PhysicsCorrection
