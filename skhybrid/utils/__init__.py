"""Utilities: estimator discovery and the array namespace shared by NumPy and torch."""

from skhybrid.utils._array_api import get_namespace, to_numpy
from skhybrid.utils._show_versions import show_versions
from skhybrid.utils.discovery import all_displays, all_estimators, all_functions

__all__ = [
    "all_displays",
    "all_estimators",
    "all_functions",
    "get_namespace",
    "show_versions",
    "to_numpy",
]
