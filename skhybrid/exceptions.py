"""Warnings and errors specific to skhybrid.

scikit-learn's :class:`~sklearn.exceptions.ConvergenceWarning` is used for optimisers
that stop before converging; the classes here cover what scikit-learn has no name for.
"""

from sklearn.exceptions import (
    InconsistentVersionWarning as _SklearnInconsistentVersionWarning,
)

__all__ = [
    "IdentifiabilityWarning",
    "InconsistentVersionWarning",
    "NonWhiteResidualWarning",
    "RefusedTestRecordsError",
    "SimulationDivergedError",
    "TrainingDivergedError",
    "UnhelpfulCorrectionWarning",
]


class InconsistentVersionWarning(_SklearnInconsistentVersionWarning):
    """An estimator is unpickled under other versions than it was pickled with.

    Every skhybrid estimator records the versions of skhybrid, scikit-learn, torch
    and skorch in its pickle; loading it where any of them differs warns with this
    class. It subclasses scikit-learn's
    :class:`~sklearn.exceptions.InconsistentVersionWarning`, so a filter on that
    one covers both.

    Parameters
    ----------
    estimator_name : str
        Class name of the unpickled estimator.
    original_versions : dict of str to str or None
        Package versions recorded in the pickle.
    current_versions : dict of str to str or None
        Package versions installed now.

    Attributes
    ----------
    differences : dict of str to (str, str)
        Each package whose versions differ: (pickled, installed).
    """

    def __init__(self, *, estimator_name, original_versions, current_versions):
        self.estimator_name = estimator_name
        self.original_versions = dict(original_versions)
        self.current_versions = dict(current_versions)
        self.differences = {
            name: (self.original_versions.get(name), now)
            for name, now in self.current_versions.items()
            if self.original_versions.get(name) != now
        }
        # scikit-learn's attributes, for code that reads them.
        self.original_sklearn_version = self.original_versions.get("scikit-learn")
        self.current_sklearn_version = self.current_versions.get("scikit-learn")

    def __str__(self):
        differ = ", ".join(
            f"{name} {old} (now {new})" for name, (old, new) in self.differences.items()
        )
        return (
            f"Trying to unpickle estimator {self.estimator_name} made with {differ}. "
            "This might lead to breaking code or invalid results: refit the model "
            "under the installed versions, or install the versions it was made with."
        )


class NonWhiteResidualWarning(UserWarning):
    """Residuals of a fitted model fail a whiteness test.

    Raised as a warning where a model's final residuals are used as if they were
    white noise (for example by a noise model that assumes independent samples).
    """


class TrainingDivergedError(FloatingPointError, ValueError):
    """A training loss became NaN or infinite.

    Subclasses :class:`ValueError` (bad settings, usually a learning rate that is too
    large) and :class:`FloatingPointError` (what happened numerically).
    """


class RefusedTestRecordsError(ValueError):
    """A run's test records, read once its selection was sealed, are refused.

    A spec whose ``tests`` is a function reads its test records only after
    ``selection.json`` is written; a record that holds NaN, has other columns
    than the estimation records or is too short is refused then, before any
    model is simulated on it. The message names the record and says how to
    score the sealed selection once the records are fixed (``--resume``).
    Subclasses :class:`ValueError`.
    """


class SimulationDivergedError(FloatingPointError, ValueError):
    """A free-run simulation produced non-finite states.

    The message names the first time step at which a state became NaN or
    infinite. Subclasses :class:`ValueError` and :class:`FloatingPointError`, as
    :class:`TrainingDivergedError` does.
    """


class IdentifiabilityWarning(UserWarning):
    """The data determine only a combination of some fitted parameters.

    Warned after a least-squares fit whose Jacobian (of the residuals with respect
    to the free parameters, in relative units) is nearly singular: some direction in
    parameter space leaves the fit unchanged. The message names the parameters that
    move together along that direction and the combination the data do determine,
    for example ``a*b`` when only the product of ``a`` and ``b`` enters the model.
    Fix one of them (``fixed=``), reparametrise, or collect data that separate them.
    """


class UnhelpfulCorrectionWarning(UserWarning):
    """A hybrid's learned correction did not improve on its physics.

    Warned by :class:`~skhybrid.hybrid.StateSpaceHybridRegressor` when no
    trained epoch simulates its validation pieces better than the physics it
    started from; the hybrid then keeps its start, or becomes its physics,
    rather than a worse model, and sets ``correction_helped_ = False``. Not a
    :class:`~sklearn.exceptions.ConvergenceWarning`: the training ended as
    designed (early stopping), and more epochs would not change the verdict.
    """
