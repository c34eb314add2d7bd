"""Simulated and measured data sets of dynamical systems.

Simulators return a :class:`~sklearn.utils.Bunch` whose ``X`` and ``y`` follow the
window convention of :mod:`skhybrid.preprocessing`, with the raw per-episode
``states`` and ``inputs``, the noise-free targets ``y_clean`` and the ``oracle``
(the true equations applied to the noisy windows: the best any model can do).
Each simulator comes with the physics a benchmark fits to it:
:class:`~skhybrid.domain.PendulumModel` for :func:`make_pendulum`,
:func:`~skhybrid.domain.single_pendulum_step` for :func:`make_double_pendulum` and
:func:`~skhybrid.domain.dc_motor_step` (or
:class:`~skhybrid.domain.LinearStateSpaceModel`) for :func:`make_dc_motor`.

Loaders (``load_*``) read the measured benchmark data from a folder the caller
names and download nothing; fetchers (``fetch_*``) download the official files
once into a data home (:func:`get_data_home`: a parameter, or the
``SKHYBRID_DATA`` environment variable), check their SHA256 and return what the
matching loader returns.
"""

from skhybrid.datasets import _fetch, _loaders
from skhybrid.datasets._dc_motor import make_dc_motor
from skhybrid.datasets._double_pendulum import make_double_pendulum
from skhybrid.datasets._fetch import (  # noqa: F401 (in __all__ through _fetch's)
    fetch_cascaded_tanks,
    fetch_coupled_electric_drives,
    fetch_emps,
    fetch_friction_damper,
    fetch_silverbox,
    fetch_wiener_hammerstein,
    get_data_home,
)
from skhybrid.datasets._loaders import (  # noqa: F401 (in __all__ through _loaders's)
    load_cascaded_tanks,
    load_coupled_electric_drives,
    load_emps,
    load_friction_damper,
    load_silverbox,
    load_wiener_hammerstein,
)
from skhybrid.datasets._missing_physics import (
    MISSING_PHYSICS_MACHINES,
    make_missing_physics,
)
from skhybrid.datasets._pendulum import make_pendulum

# The fetchers and loaders are listed once, in their modules' ``__all__`` (the
# whole stays sorted).
__all__ = ["MISSING_PHYSICS_MACHINES"]
__all__ += _fetch.__all__ + _loaders.__all__
__all__ += [
    "make_dc_motor",
    "make_double_pendulum",
    "make_missing_physics",
    "make_pendulum",
]
