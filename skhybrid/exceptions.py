"""Warnings and errors specific to skhybrid.

scikit-learn's :class:`~sklearn.exceptions.ConvergenceWarning` is used for optimisers
that stop before converging; the classes here cover what scikit-learn has no name for.
"""

__all__ = [
    "NonWhiteResidualWarning",
    "SimulationDivergedError",
    "TrainingDivergedError",
]


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


class SimulationDivergedError(FloatingPointError, ValueError):
    """A free-run simulation produced non-finite states.

    The message names the first time step at which a state became NaN or
    infinite. Subclasses :class:`ValueError` and :class:`FloatingPointError`, as
    :class:`TrainingDivergedError` does.
    """
