"""Specs and settings as JSON that does not depend on the session.

What a run's identity and its seal hash: estimators by class and parameters,
functions by ``module.qualname``, never a ``repr`` holding a memory address, so
the same spec gives the same hash in every process.
"""

import functools
import json
import re

import numpy as np

__all__ = ["canonical", "describe", "qualified_name"]


def qualified_name(obj):
    """``module.qualname`` of a function or class: the same in every session."""
    module = getattr(obj, "__module__", None) or type(obj).__module__
    name = getattr(obj, "__qualname__", None) or getattr(obj, "__name__", None)
    return f"{module}.{name or type(obj).__qualname__}"


def describe(value):
    """``value`` as JSON-ready data that does not depend on the session.

    Estimators by class and parameters, callables by ``module.qualname``; never
    a ``repr`` holding a memory address, so the seal's hash repeats in a fresh
    process and after a resume.
    """
    if hasattr(value, "get_params") and not isinstance(value, type):
        params = value.get_params(deep=False)
        return {
            "class": qualified_name(type(value)),
            "params": {k: describe(v) for k, v in sorted(params.items())},
        }
    if isinstance(value, dict):
        return {str(k): describe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [describe(v) for v in value]
    if isinstance(value, np.ndarray):
        return describe(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, functools.partial):
        return {
            "partial": describe(value.func),
            "args": describe(list(value.args)),
            "keywords": describe(value.keywords),
        }
    if callable(value):
        return qualified_name(value)
    return re.sub(r" at 0x[0-9a-fA-F]+", "", repr(value))


def canonical(value):
    """``value`` as canonical JSON: sorted keys, no spaces."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)
