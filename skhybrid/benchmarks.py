"""Deprecated alias of :mod:`skhybrid.experiments`, kept for one release (0.2).

The paper's experiments moved to :mod:`skhybrid.experiments` so that the name
``benchmarks`` belongs to the speed scripts in the repository's ``benchmarks/``
folder only. ``import skhybrid.benchmarks`` still works and warns.
"""

import warnings

from skhybrid.experiments import *  # noqa: F403
from skhybrid.experiments import __all__  # noqa: F401

warnings.warn(
    "skhybrid.benchmarks was renamed skhybrid.experiments in skhybrid 0.2; the old "
    "name will be removed in 0.3. Import from skhybrid.experiments instead.",
    FutureWarning,
    stacklevel=2,
)
