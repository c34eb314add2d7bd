"""Hybrid compositions of domain and neural models, and noise models.

The decomposition ``Y = f(X; theta) + NN(X; W) + N(phi)`` of the method paper:

- :class:`HybridBoostingRegressor`: the sequential (boosting) composition, each
  stage fitted to what the earlier stages left, with per-stage validation scores,
  ``decompose``, residual whiteness after each stage, a noise model, and the cyclic
  composition through a :class:`~skhybrid.neural.CyclicRegressor` stage;
- :class:`HybridEnsembleRegressor`: the parallel composition, physics parameters and
  network weights trained jointly in torch;
- :class:`StateSpaceHybridRegressor`: physics state equations plus a network
  correction and an initial-state encoder, trained by the simulation error;
- :class:`NARXSimulator`: a one-step regressor of past outputs and inputs,
  simulated in free run (a linear ARX or a dense NARX);
- :class:`PhysicsCorrection`: a fitted physics' free run plus a static
  regressor of its own recent simulated output and the inputs;
- :class:`TransformedInputSimulator`: a fitted model simulated on a transform
  of each record's inputs (the Silverbox's ``[u(t), u(t+1)]``);
- :class:`GaussianNoise` and :class:`AutoRegressiveNoise`: the stochastic term.
"""

from skhybrid.hybrid._boosting import HybridBoostingRegressor, StageWhiteness

# The private names of NARXSimulator, PhysicsCorrection and
# TransformedInputSimulator (aliases, for run folders pickled under them and code
# that imports them, such as the measured zoo's _TransformedInputs) and the
# state-space hybrid's sub-sequence count, re-exported (not in __all__) for
# skhybrid.experiments, which may not import a private module.
from skhybrid.hybrid._correction import _NARXSimulator as _NARXSimulator
from skhybrid.hybrid._correction import _PhysicsCorrection as _PhysicsCorrection
from skhybrid.hybrid._correction import _TransformedInputs as _TransformedInputs
from skhybrid.hybrid._ensemble import HybridEnsembleRegressor
from skhybrid.hybrid._narx import NARXSimulator
from skhybrid.hybrid._noise import AutoRegressiveNoise, GaussianNoise
from skhybrid.hybrid._physics_correction import PhysicsCorrection
from skhybrid.hybrid._state_space import MIN_SUBSEQUENCES as MIN_SUBSEQUENCES
from skhybrid.hybrid._state_space import StateSpaceHybridRegressor
from skhybrid.hybrid._transformed_inputs import TransformedInputSimulator

__all__ = [
    "AutoRegressiveNoise",
    "GaussianNoise",
    "HybridBoostingRegressor",
    "HybridEnsembleRegressor",
    "NARXSimulator",
    "PhysicsCorrection",
    "StageWhiteness",
    "StateSpaceHybridRegressor",
    "TransformedInputSimulator",
]
