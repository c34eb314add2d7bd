"""Hybrid physics / neural / stochastic models of dynamical systems.

``skhybrid`` models a measured output as the sum of a domain (physics) model fitted
with :func:`scipy.optimize.least_squares`, neural stages fitted to what the physics
leaves, and a stochastic noise model for the remainder (Eq. 1 of the method paper)::

    Y = f(X; theta) + NN(X; W) + N(phi)

Every model is a scikit-learn estimator. The subpackages hold:

- :mod:`skhybrid.losses`: the Ljung-Box statistic and the training objectives;
- :mod:`skhybrid.domain`: physics models fitted with least squares;
- :mod:`skhybrid.neural`: skorch-backed dense, recurrent and cyclic networks;
- :mod:`skhybrid.hybrid`: boosting and joint ensembles of the two, and noise models;
- :mod:`skhybrid.model_selection`: interpolative and extrapolative test sets;
- :mod:`skhybrid.diagnostics`: residual whiteness and independence tests, figures;
- :mod:`skhybrid.datasets`: simulators and loaders of measured data;
- :mod:`skhybrid.preprocessing`: windows of history from raw sequences;
- :mod:`skhybrid.simulation`: free-run simulation from measured initial windows;
- :mod:`skhybrid.experiments`: the paper's experiments and their report;
- :mod:`skhybrid.utils`: estimator discovery and shared array helpers.

Every subpackage is an attribute of ``skhybrid`` and is imported on first use, so
``import skhybrid`` does not import torch. :func:`show_versions` prints the
versions of Python, skhybrid and its dependencies for a bug report.
"""

import importlib

__version__ = "0.2.0.dev0"

__all__ = [
    "__version__",
    "benchmarks",
    "datasets",
    "diagnostics",
    "domain",
    "exceptions",
    "experiments",
    "hybrid",
    "losses",
    "model_selection",
    "neural",
    "preprocessing",
    "show_versions",
    "simulation",
    "utils",
]

#: Where each lazily resolved attribute lives (the subpackages resolve to
#: themselves).
_LAZY_FUNCTIONS = {"show_versions": "skhybrid.utils._show_versions"}


def __getattr__(name):
    # Subpackages load on first use, as scikit-learn's do, so that
    # `import skhybrid` stays light: no torch, skorch or scikit-learn, which
    # lets `skhybrid --help` answer in well under a second.
    if name in _LAZY_FUNCTIONS:
        return getattr(importlib.import_module(_LAZY_FUNCTIONS[name]), name)
    if name in __all__ and name != "__version__":
        return importlib.import_module(f"skhybrid.{name}")
    raise AttributeError(f"module 'skhybrid' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
