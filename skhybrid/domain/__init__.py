"""Domain (physics) models fitted with :func:`scipy.optimize.least_squares`.

Every model declares named parameters with initial values, optional bounds and a
``fixed`` set, writes its equations once for NumPy and torch, and reports
``params_`` with standard errors ``params_std_`` after ``fit``.
"""

from skhybrid.domain._base import DomainModel
from skhybrid.domain._block import WienerHammersteinModel
from skhybrid.domain._friction import (
    asymmetric_friction,
    coulomb_viscous_friction,
    stribeck_friction,
)
from skhybrid.domain._identifiability import check_identifiability
from skhybrid.domain._inputs import band_limited_inputs
from skhybrid.domain._linear import LinearStateSpaceModel
from skhybrid.domain._motor import dc_motor_step

# Internal, handed to skhybrid.experiments (the Wiener-Hammerstein physics of
# old run folders); not in __all__.
from skhybrid.domain._output_error import _LinearOutputError as _LinearOutputError
from skhybrid.domain._parametric import ParametricModel
from skhybrid.domain._pendulum import PendulumModel, pendulum_step, single_pendulum_step
from skhybrid.domain._progress import fit_progress
from skhybrid.domain._starts import random_starts
from skhybrid.domain._state_space import StateSpaceModel
from skhybrid.domain._subspace import subspace_state_space

__all__ = [
    "DomainModel",
    "LinearStateSpaceModel",
    "ParametricModel",
    "PendulumModel",
    "StateSpaceModel",
    "WienerHammersteinModel",
    "asymmetric_friction",
    "band_limited_inputs",
    "check_identifiability",
    "coulomb_viscous_friction",
    "dc_motor_step",
    "fit_progress",
    "pendulum_step",
    "random_starts",
    "single_pendulum_step",
    "stribeck_friction",
    "subspace_state_space",
]
