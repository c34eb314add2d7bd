"""Neural stages: skorch-backed dense, recurrent and cyclic regressors.

Each estimator is a plain scikit-learn estimator that builds a
:class:`skorch.NeuralNetRegressor` in ``fit`` and trains it with the paper's
protocol: Adam (``lr=0.01``), the learning rate halved on a 10-epoch plateau of the
validation loss, early stopping after 30 epochs with the best weights restored,
mini-batches of 512 rows, batch normalisation at the input, and a validation set
taken from the end of the time-ordered rows. Objectives with a Ljung-Box term
(:mod:`skhybrid.losses`) train on contiguous blocks of rows.
"""

from skhybrid.neural._base import BaseNeuralRegressor
from skhybrid.neural._callbacks import EpochProgress
from skhybrid.neural._cyclic import CyclicRegressor
from skhybrid.neural._dense import DenseRegressor
from skhybrid.neural._rnn import RNNRegressor

__all__ = [
    "BaseNeuralRegressor",
    "CyclicRegressor",
    "DenseRegressor",
    "EpochProgress",
    "RNNRegressor",
]
