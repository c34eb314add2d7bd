"""Continuation: fits through a sequence of values of a fixed parameter.

A physics with a smoothing parameter (the width of a friction law's sign, the
sharpness of a saturation) has a rough simulation-error surface at the value it
is meant to be used at: least squares stops in whichever of many nearby local
minima its path meets first, and that path moves with the last bits of the
arithmetic (another BLAS kernel, another machine). Fitted first at a smoother
value, and from there at the next, each fit starts inside the basin the
smoother surface leads to. :class:`~skhybrid.domain.StateSpaceModel`'s
``continuation`` parameter runs these stages before its final fit.
"""

import numbers
import warnings

import numpy as np
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from skhybrid.exceptions import IdentifiabilityWarning


def continuation_stages(continuation, params, fixed):
    """The stages of ``continuation``: one dict of values per stage, in order.

    Parameters
    ----------
    continuation : dict of str to sequence of float, or None
        For each fixed parameter, its values at the stages before the final
        fit (which uses its value in ``params``). Every sequence has the same
        length.
    params : dict
        The model's starting values.
    fixed : sequence of str
        The model's fixed parameters.

    Returns
    -------
    stages : list of dict
        Empty where ``continuation`` is None or empty.
    """
    if continuation is None:
        return []
    if not isinstance(continuation, dict):
        raise TypeError(
            "continuation must be a dict of fixed parameter names to sequences of "
            f"values, or None; got continuation={continuation!r}."
        )
    if not continuation:
        return []
    lengths = set()
    for name, values in continuation.items():
        if name not in params or name not in fixed:
            raise ValueError(
                f"continuation names {name!r}, which is not a fixed parameter of "
                f"the model (params: {sorted(params)}, fixed: {list(fixed)}); a "
                "continuation steps a parameter held fixed in every fit. Got "
                f"continuation={continuation!r}."
            )
        if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
            raise TypeError(
                f"continuation[{name!r}] must be a sequence of numbers, one per "
                f"stage; got {values!r}."
            )
        if len(values) == 0 or not all(
            isinstance(v, numbers.Real) and not isinstance(v, bool) and np.isfinite(v)
            for v in values
        ):
            raise ValueError(
                f"continuation[{name!r}] must hold one or more finite numbers; got "
                f"{values!r}."
            )
        lengths.add(len(values))
    if len(lengths) > 1:
        raise ValueError(
            "every parameter of continuation needs the same number of stages; got "
            f"continuation={continuation!r}."
        )
    (n_stages,) = lengths
    return [
        {name: float(values[k]) for name, values in continuation.items()}
        for k in range(n_stages)
    ]


def continued_start(model, method, *args, base=None):
    """The start of ``model``'s final fit, after its ``continuation`` stages.

    Each stage fits a copy of ``model`` by its public ``method`` (``"fit"`` or
    ``"fit_simulation"``, on ``args``), the copy holding the stage's values of
    the continued parameters and no continuation of its own, and starting
    from the previous stage's fitted parameters; a stage that stops short of
    convergence still hands on its parameters, so its ``ConvergenceWarning``
    and ``IdentifiabilityWarning`` are not raised (the final fit's are).

    Parameters
    ----------
    model : StateSpaceModel
        The model about to be fitted.
    method : {"fit", "fit_simulation"}
        The fit the stages run, the one the final fit will run.
    *args
        Its data.
    base : dict or None, default=None
        The first stage's start (a start chosen among several), else
        ``model.params``.

    Returns
    -------
    start : dict or None
        The parameters the final fit starts from (the continued parameters at
        their values in ``model.params``); None where there are no stages.
    """
    stages = continuation_stages(model.continuation, model.params, model.fixed)
    if not stages:
        return None
    start = dict(base if base is not None else model.params)
    for values in stages:
        stage = clone(model).set_params(
            params={**start, **values},
            continuation=None,
            starts=None,
            noise_model=None,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            warnings.simplefilter("ignore", IdentifiabilityWarning)
            getattr(stage, method)(*args)
        start = dict(stage.params_)
    return {**start, **{name: model.params[name] for name in model.continuation}}
