"""Several starts: fit each briefly, go on from the best.

A simulation-error fit of a physics with a latent state can stop in a local
minimum from a start well within a factor of two or three of the truth (on the
cascaded tanks' own structure, simulated, some starts drawn within a factor
2.2 do: ``benchmarks/bench_rough_start.py``). A short fit from each of several
starts ranks the valleys roughly, and the final fit continues from the start
whose short fit is best (or, with ``starts_nfev=None``, whose fit to
convergence is). A lower cost on the fitting records is not always a better
simulation elsewhere, so the result is judged on validation data.
:class:`~skhybrid.domain.StateSpaceModel`'s ``starts`` runs this before its
fit; :func:`random_starts` draws starts around a model's parameters.
"""

import numbers
import warnings

import numpy as np
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state

from skhybrid.exceptions import IdentifiabilityWarning, SimulationDivergedError
from skhybrid.utils._lockstep import run_in_lockstep

#: Errors of a short fit that drop its start instead of stopping the fit.
START_ERRORS = (ValueError, ArithmeticError, SimulationDivergedError)

__all__ = ["best_short_fit", "check_starts", "random_starts"]


def check_starts(starts, params, fixed, bounds=None):
    """Validate ``starts`` against a model's parameters and their bounds.

    Parameters
    ----------
    starts : list or tuple of dict, or None
        Values of free parameters, each dict one start.
    params : dict
        The model's starting values.
    fixed : sequence of str
        The model's fixed parameters.
    bounds : dict of str to (float, float) or None, default=None
        The model's bounds: a start outside them is refused, as ``params``
        outside them are.

    Returns
    -------
    starts : list of dict
        Empty where ``starts`` is None.
    """
    if starts is None:
        return []
    if not isinstance(starts, (list, tuple)) or not starts:
        raise TypeError(
            "starts must be a non-empty list of dicts of free parameter values, "
            f"or None; got starts={starts!r}."
        )
    out = []
    for i, start in enumerate(starts):
        if not isinstance(start, dict):
            raise TypeError(
                "every entry of starts must be a dict of free parameter values; "
                f"got {start!r} in starts={starts!r}."
            )
        for name, value in start.items():
            if name not in params or name in fixed:
                raise ValueError(
                    f"starts names {name!r}, which is not a free parameter of the "
                    f"model (params: {sorted(params)}, fixed: {list(fixed)}); got "
                    f"starts={starts!r}."
                )
            if not _finite_number(value):
                raise ValueError(
                    f"starts[{i}][{name!r}] must be a finite number; got {value!r}."
                )
            lo, hi = _pair((bounds or {}).get(name))
            if not lo <= value <= hi:
                raise ValueError(
                    f"starts[{i}][{name!r}] is {value!r}, outside its bounds "
                    f"({lo}, {hi}); change the start or the bounds (a start outside "
                    "them is refused as an initial value in params is)."
                )
        out.append({name: float(value) for name, value in start.items()})
    return out


def _pair(pair):
    """``(lower, upper)`` of a bounds entry; unbounded where absent or malformed.

    A malformed entry is reported by the fit itself, naming the parameter.
    """
    try:
        lo, hi = (float(v) for v in pair)
    except (TypeError, ValueError):
        return -np.inf, np.inf
    return lo, hi


def _finite_number(value):
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, bool)
        and bool(np.isfinite(value))
    )


def best_short_fit(models, method, *args):
    """Fit each model briefly; the fitted one with the lowest cost.

    Parameters
    ----------
    models : sequence of DomainModel
        Unfitted, each with its start and the short fit's ``max_nfev``.
    method : {"fit", "fit_simulation"}
        The fit each runs.
    *args
        Its data.

    Returns
    -------
    best : DomainModel or None
        None where every short fit failed (an error in ``START_ERRORS``) or
        ended with a cost that is not finite.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        if method == "fit_simulation" and len(models) > 1:
            # The short fits run side by side, their free runs in one batch.
            outcomes = run_in_lockstep(
                models, lambda model: getattr(model, method)(*args)
            )
        else:
            outcomes = []
            for model in models:
                try:
                    outcomes.append(getattr(model, method)(*args))
                except START_ERRORS as exc:
                    outcomes.append(exc)
    best, best_cost = None, np.inf
    for model, outcome in zip(models, outcomes, strict=True):
        if isinstance(outcome, BaseException):
            if isinstance(outcome, START_ERRORS):
                continue
            raise outcome
        result = getattr(model, "result_", None)
        cost = 0.0 if result is None else float(result.cost)
        if np.isfinite(cost) and cost < best_cost:
            best, best_cost = model, cost
    return best


def short_fit_start(model, method, *args):
    """The parameters ``model``'s fit starts from, after its ``starts``.

    The model's own ``params`` and each of its ``starts`` (values that override
    them) are fitted by ``method`` with ``starts_nfev`` evaluations (None: the
    model's own ``max_nfev``, each to convergence), without continuation or
    noise model; their warnings are not raised.

    Parameters
    ----------
    model : StateSpaceModel
        The model about to be fitted.
    method : {"fit", "fit_simulation"}
        Its fit.
    *args
        Its data.

    Returns
    -------
    start : dict or None
        The best short fit's parameters (the fixed ones at their values in
        ``model.params``); None where the model has no ``starts`` or every
        short fit failed.
    """
    bounds = model.resolved_bounds()
    starts = check_starts(model.starts, model.params, model.fixed, bounds)
    if not starts:
        return None
    candidates = [dict(model.params)] + [{**model.params, **s} for s in starts]
    models = [
        clone(model).set_params(
            params=params,
            starts=None,
            continuation=None,
            noise_model=None,
            max_nfev=(
                model.max_nfev if model.starts_nfev is None else model.starts_nfev
            ),
        )
        for params in candidates
    ]
    best = best_short_fit(models, method, *args)
    if best is None:
        return None
    fitted = best.params_
    return {**model.params, **{k: fitted[k] for k in model.params if k in fitted}}


def random_starts(model, n_starts, *, factor=5.0, random_state=None):
    """Starts drawn around a model's free parameters, for its ``starts``.

    Each free parameter's value is multiplied by a factor drawn log-uniformly
    from ``[1 / factor, factor]`` (a parameter at zero stays there) and put back
    inside its bounds.

    Parameters
    ----------
    model : StateSpaceModel
        The model; its ``params``, ``fixed`` and ``bounds`` are read.
    n_starts : int
        Number of starts.
    factor : float, default=5.0
        How far a start may lie from ``params``, as a ratio (> 1). Wide on
        purpose: from a start in a wrong valley, starts drawn close to it fall
        back into the same valley.
    random_state : int, RandomState instance or None, default=None
        Seed of the draws.

    Returns
    -------
    starts : list of dict
        ``n_starts`` dicts of the free parameters' values.

    Examples
    --------
    >>> from skhybrid.domain import StateSpaceModel, random_starts
    >>> def decay(x, u, *, xp, a, b):
    ...     return -a * x + b * u
    >>> model = StateSpaceModel(decay, {"a": 1.0, "b": 2.0}, state_names=["x"], dt=0.1)
    >>> starts = random_starts(model, 4, factor=2.0, random_state=0)
    >>> len(starts), sorted(starts[0])
    (4, ['a', 'b'])
    >>> model.set_params(starts=starts)  # doctest: +ELLIPSIS
    StateSpaceModel(...)
    """
    if (
        isinstance(n_starts, bool)
        or not isinstance(n_starts, numbers.Integral)
        or n_starts < 1
    ):
        raise ValueError(f"n_starts must be an int >= 1; got n_starts={n_starts!r}.")
    if not _finite_number(factor) or factor <= 1:
        raise ValueError(f"factor must be a finite number > 1; got factor={factor!r}.")
    params = getattr(model, "params", None)
    if not isinstance(params, dict) or not hasattr(model, "fixed"):
        raise TypeError(
            "model must be a model with params, fixed and bounds (a "
            "StateSpaceModel); got "
            f"model={model!r} of type {type(model).__name__}."
        )
    rng = check_random_state(random_state)
    # The bounds the fit checks the starts against (a model's defaults too).
    resolve = getattr(model, "resolved_bounds", None)
    bounds = resolve(params) if resolve is not None else (model.bounds or {})
    free = [k for k in params if k not in model.fixed]
    for name in free:
        try:
            value = float(params[name])
        except (TypeError, ValueError):
            value = np.nan
        if isinstance(params[name], bool) or not np.isfinite(value):
            raise ValueError(
                f"random_starts draws around the model's free parameters, which "
                f"must be finite scalars; got params[{name!r}]={params[name]!r}."
            )
    starts = []
    for _ in range(n_starts):
        start = {}
        for name in free:
            value = float(params[name])
            draw = value * float(np.exp(rng.uniform(-np.log(factor), np.log(factor))))
            low, high = _pair(bounds.get(name))
            start[name] = float(np.clip(draw, low, high))
        starts.append(start)
    return starts
