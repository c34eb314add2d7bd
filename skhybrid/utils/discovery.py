"""Find the public estimators, displays and functions of skhybrid.

Used by ``tests/test_common.py`` so that every estimator, including those added
later, runs scikit-learn's ``check_estimator`` suite without being listed by hand.
"""

import inspect
import pkgutil
from importlib import import_module
from operator import itemgetter

from sklearn.base import (
    BaseEstimator,
    ClassifierMixin,
    RegressorMixin,
    TransformerMixin,
)

__all__ = ["all_displays", "all_estimators", "all_functions"]

#: The subpackages and modules whose ``__all__`` make skhybrid's public API, in
#: the order the API reference lists them (docs/conf.py, tests/test_docstrings.py).
PUBLIC_MODULES = (
    "domain",
    "neural",
    "neural.engine",
    "hybrid",
    "simulation",
    "losses",
    "model_selection",
    "diagnostics",
    "datasets",
    "preprocessing",
    "experiments",
    "benchmarks",
    "exceptions",
    "utils",
)

_SKIP_MODULE_PARTS = {"tests", "cli", "__main__"}

#: Model-selection meta-estimators left out of :func:`all_estimators`, with why.
#: scikit-learn runs its common checks on GridSearchCV wrapped around a Ridge;
#: these wrap models of records instead: their ``fit(U, Y)`` takes lists of
#: records, not the ``(X, y)`` windows that the common checks and the simulation,
#: fit-safety and pickle tests feed every estimator. tests/model_selection runs
#: scikit-learn's API checks that need no data on them (get_params, set_params,
#: clone, nothing set in __init__, parameter validation).
RECORD_META_ESTIMATORS = {
    "SimulationFit": "fits lists of records, not (X, y) windows",
    "SimulationSearchCV": "fits lists of records, not (X, y) windows",
    "StackedSimulation": "fits lists of records, not (X, y) windows",
}


def _public_modules():
    import skhybrid

    names = []
    for info in pkgutil.walk_packages(skhybrid.__path__, prefix="skhybrid."):
        parts = info.name.split(".")
        if _SKIP_MODULE_PARTS.intersection(parts):
            continue
        names.append(info.name)
    return [import_module(name) for name in sorted(names)]


def _public_classes():
    seen = {}
    for module in _public_modules():
        for name, cls in inspect.getmembers(module, inspect.isclass):
            if name.startswith("_") or not cls.__module__.startswith("skhybrid"):
                continue
            seen[name] = cls
    return seen


def all_estimators(type_filter=None):
    """Return the public estimators of skhybrid.

    Parameters
    ----------
    type_filter : {"regressor", "classifier", "transformer"}, list of those or None, \
            default=None
        Keep only estimators of these kinds; ``None`` keeps all.

    Returns
    -------
    estimators : list of (name, class) tuples
        Sorted by name. Abstract base classes are left out, and so are the
        model-selection meta-estimators over lists of records
        (``RECORD_META_ESTIMATORS``: ``SimulationFit``, ``SimulationSearchCV``,
        ``StackedSimulation``), which do not take ``(X, y)``.

    Examples
    --------
    >>> from skhybrid.utils import all_estimators
    >>> names = [name for name, _ in all_estimators()]
    >>> "PendulumModel" in names
    True
    """
    mixins = {
        "regressor": RegressorMixin,
        "classifier": ClassifierMixin,
        "transformer": TransformerMixin,
    }
    if type_filter is not None:
        kinds = [type_filter] if isinstance(type_filter, str) else list(type_filter)
        unknown = set(kinds) - set(mixins)
        if unknown:
            raise ValueError(
                f"type_filter got {sorted(unknown)}; expected a subset of "
                f"{sorted(mixins)} or None."
            )
    estimators = []
    for name, cls in _public_classes().items():
        if not issubclass(cls, BaseEstimator) or inspect.isabstract(cls):
            continue
        if name in RECORD_META_ESTIMATORS:
            continue
        if getattr(cls, "_is_abstract_base", False) and "_is_abstract_base" in vars(
            cls
        ):
            continue
        if type_filter is not None and not any(
            issubclass(cls, mixins[kind]) for kind in kinds
        ):
            continue
        estimators.append((name, cls))
    return sorted(estimators, key=itemgetter(0))


def all_displays():
    """Return the public Display classes of skhybrid, as sorted (name, class) pairs.

    Returns
    -------
    displays : list of tuple of (str, type)
        Name and class of every Display.

    Examples
    --------
    >>> from skhybrid.utils import all_displays
    >>> all(name.endswith("Display") for name, _ in all_displays())
    True
    """
    return sorted(
        (name, cls)
        for name, cls in _public_classes().items()
        if name.endswith("Display")
    )


def all_functions():
    """Return the public functions of skhybrid, as sorted (name, function) pairs.

    Returns
    -------
    functions : list of tuple of (str, callable)
        Name and function of every public function.

    Examples
    --------
    >>> from skhybrid.utils import all_functions
    >>> "ljung_box" in [name for name, _ in all_functions()]
    True
    """
    functions = {}
    for module in _public_modules():
        public = getattr(module, "__all__", None)
        if public is None:
            continue
        for name in public:
            obj = getattr(module, name, None)
            if inspect.isfunction(obj) and obj.__module__.startswith("skhybrid"):
                functions[name] = obj
    return sorted(functions.items(), key=itemgetter(0))
