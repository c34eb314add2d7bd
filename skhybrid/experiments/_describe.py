"""Specs and settings as JSON that does not depend on the session.

What a run's identity and its seal hash: estimators by class and parameters,
functions by ``module.qualname``, never a ``repr`` holding a memory address, so
the same spec gives the same hash in every process.
"""

import functools
import hashlib
import json
import re

import numpy as np

__all__ = ["canonical", "describe", "qualified_name", "spec_digest", "spec_fields"]


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


def spec_fields(spec):
    """What a spec says of its system and candidates, without its records.

    Parameters
    ----------
    spec : SystemSpec
        The system.

    Returns
    -------
    fields : dict
        Name, ``n_init``, the physics and its inputs, the candidates and the
        notes, described without memory addresses.
    """
    return {
        "name": spec.name,
        "n_init": spec.n_init,
        "physics": describe(spec.physics),
        "physics_inputs": describe(spec.physics_inputs),
        "segments": describe(spec.segments),
        "hybrids": describe(spec.hybrids),
        "hybrid_records": spec.hybrid_records,
        "notes": spec.notes,
    }


def spec_digest(spec):
    """SHA-256 of what a spec says before its records are read.

    The physics, its inputs, the candidates, ``n_init``, ``dt`` and the notes,
    described without memory addresses (:func:`spec_fields` with the sample
    period and the physics' starts): the same spec gives the same digest in
    every session.

    Parameters
    ----------
    spec : SystemSpec
        The system.

    Returns
    -------
    digest : str
        Hex digest.
    """
    fields = {
        **spec_fields(spec),
        "dt": spec.dt,
        "physics_starts": describe(spec.physics_starts),
    }
    return hashlib.sha256(canonical(fields).encode()).hexdigest()
