"""Simulated and measured data sets of dynamical systems.

Simulators return a :class:`~sklearn.utils.Bunch` whose ``X`` and ``y`` follow the
window convention of :mod:`skhybrid.preprocessing`, with the raw per-episode
``states`` and ``inputs``, the noise-free targets ``y_clean`` and the ``oracle``
(the true equations applied to the noisy windows: the best any model can do).
Each simulator comes with the physics a benchmark fits to it:
:class:`~skhybrid.domain.PendulumModel` for :func:`make_pendulum`,
:func:`single_pendulum_step` for :func:`make_double_pendulum` and
:func:`dc_motor_step` (or :class:`~skhybrid.domain.LinearStateSpaceModel`) for
:func:`make_dc_motor`.

Loaders read the measured benchmark data from a folder the caller names; nothing
is downloaded.
"""

from skhybrid.datasets._dc_motor import dc_motor_step, make_dc_motor
from skhybrid.datasets._double_pendulum import (
    make_double_pendulum,
    single_pendulum_step,
)
from skhybrid.datasets._loaders import load_cascaded_tanks, load_emps, load_silverbox
from skhybrid.datasets._pendulum import make_pendulum

__all__ = [
    "dc_motor_step",
    "load_cascaded_tanks",
    "load_emps",
    "load_silverbox",
    "make_dc_motor",
    "make_double_pendulum",
    "make_pendulum",
    "single_pendulum_step",
]
