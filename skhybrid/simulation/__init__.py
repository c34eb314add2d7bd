"""Free-run simulation: roll any fitted next-state predictor forward.

Given the inputs of one or many experiments and a measured initial window, a
model predicts the next state, feeds it back into its window, and so on over the
whole horizon. Every estimator that predicts the next state has a ``simulate``
method with the same signature (:meth:`SimulatorMixin.simulate`); most delegate
to :func:`simulate`. :func:`fit_initial_states` is the package's one solver of
least-squares initial states (``init="least_squares"``, the latent states of a
:class:`~skhybrid.domain.StateSpaceModel`), :func:`check_trajectories` the one
validation of what ``simulate`` receives.
"""

from skhybrid.simulation._initial import fit_initial_states
from skhybrid.simulation._plot import SimulationDisplay
from skhybrid.simulation._simulate import (
    SimulatorMixin,
    check_finite_runs,
    check_trajectories,
    pack_trajectories,
    simulate,
    stack_trajectories,
)

__all__ = [
    "SimulationDisplay",
    "SimulatorMixin",
    "check_finite_runs",
    "check_trajectories",
    "fit_initial_states",
    "pack_trajectories",
    "simulate",
    "stack_trajectories",
]
