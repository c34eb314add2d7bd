"""Interpolative and extrapolative test sets (section 5 and Fig. 2 of the paper).

- :func:`in_convex_hull`: exact hull membership that scales with dimension;
- :func:`interpolation_extrapolation_split`: training, interpolative and
  extrapolative sets, like ``train_test_split``;
- :class:`ConvexHullSplit`: cross-validation with test folds outside (or inside)
  the convex hull of the training fold, cut from different directions;
- :class:`ExtrapolationSplit`: train inside a range of chosen features, test
  outside it (amplitude extrapolation);
- :class:`ConvexHullSplitDisplay`: draws a split over two features;
- :class:`RecordBlockSplit`: blocked cross-validation of records simulated in
  free run, and :func:`take_pieces`, the arrays of its folds;
- :class:`SimulationSearchCV`: chooses among candidate models by their
  cross-validated free-run RMSE and refits the winner;
- :class:`StackedSimulation`: a convex combination of models' free runs;
- :class:`SimulationFit`: a model of records fitted by its free-run error, over
  segments (how the search fits a model with ``fit_simulation``).
"""

from skhybrid.model_selection._hull import in_convex_hull
from skhybrid.model_selection._plot import ConvexHullSplitDisplay
from skhybrid.model_selection._records import RecordBlockSplit, take_pieces
from skhybrid.model_selection._search import SimulationSearchCV
from skhybrid.model_selection._simulation_fit import SimulationFit
from skhybrid.model_selection._split import (
    ConvexHullSplit,
    ExtrapolationSplit,
    interpolation_extrapolation_split,
)
from skhybrid.model_selection._stacking import StackedSimulation

# For the measured family's stack (skhybrid.experiments), kept out of __all__:
# the weights of each fold fitted on the other folds' out-of-fold runs.
from skhybrid.model_selection._stacking import (
    _cross_fitted_weights as _cross_fitted_weights,
)

__all__ = [
    "ConvexHullSplit",
    "ConvexHullSplitDisplay",
    "ExtrapolationSplit",
    "RecordBlockSplit",
    "SimulationFit",
    "SimulationSearchCV",
    "StackedSimulation",
    "in_convex_hull",
    "interpolation_extrapolation_split",
    "take_pieces",
]
