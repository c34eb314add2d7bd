"""Free-run simulation: roll any fitted next-state predictor forward.

Given the inputs of one or many experiments and a measured initial window, a
model predicts the next state, feeds it back into its window, and so on over the
whole horizon. Every estimator that predicts the next state has a ``simulate``
method that delegates to :func:`simulate`.
"""

from skhybrid.simulation._plot import SimulationDisplay
from skhybrid.simulation._simulate import SimulatorMixin, simulate

__all__ = ["SimulationDisplay", "SimulatorMixin", "simulate"]
