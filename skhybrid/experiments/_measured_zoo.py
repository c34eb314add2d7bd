"""The model zoo of the measured benchmarks and its one choose-refit-score rule.

Every model is fitted on the estimation record only. Choices (window lengths,
segment lengths, the horizon ``T`` and the architecture of the state-space
hybrid, and the model to quote) are made on its validation tail, the last 25 %:
a candidate is fitted on the first 75 % and simulated in free run over the tail
from the tail's first ``n_init`` measured outputs, as the official protocol
simulates a test record. The chosen candidate is then refitted on the whole
record (except the state-space hybrid, quoted as fitted on the first 75 %) and
simulated on every test record. :func:`choose_and_refit` is that rule, written
once; each model of the zoo is a :class:`ZooModel`: its candidates, how one is
fitted, and what it needs from models fitted before it.
"""

import itertools
import logging
import time
import warnings
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
from sklearn.base import clone
from sklearn.linear_model import Ridge

from skhybrid.exceptions import SimulationDivergedError, TrainingDivergedError
from skhybrid.experiments._measured_physics import fit_segments
from skhybrid.experiments._progress import attach_epoch_logger
from skhybrid.experiments._runner import _interrupts_raise, _physical_params
from skhybrid.hybrid import _NARXSimulator, _PhysicsCorrection, _TransformedInputs

__all__ = ["MeasuredContext", "ZooModel", "choose_and_refit", "fit_model", "zoo"]

logger = logging.getLogger(__name__)

#: Share of the estimation record held out at its end for every choice.
VALIDATION_FRACTION = 0.25

#: What a failed free run raises (its score is then infinite, its test RMSE NaN).
SIMULATION_ERRORS = (SimulationDivergedError, FloatingPointError, ValueError)


def _rmse(y, pred, n_init):
    return float(
        np.sqrt(np.mean((np.ravel(y)[n_init:] - np.ravel(pred)[n_init:]) ** 2))
    )


def _tail_split(u, y, fraction=VALIDATION_FRACTION):
    cut = int(len(u) * (1 - fraction))
    return (u[:cut], y[:cut]), (u[cut:], y[cut:])


def _records(u, y, n):
    """``n`` consecutive records of equal length (the rest joins the last)."""
    size = len(u) // n
    edges = [i * size for i in range(n)] + [len(u)]
    U, Y = zip(*[(u[a:b], y[a:b]) for a, b in itertools.pairwise(edges)], strict=True)
    return list(U), list(Y)


def _score(model, u, y, n_init):
    """Free-run RMSE of a record from its first ``n_init`` outputs (inf: failed)."""
    try:
        pred = model.simulate(u, y[:n_init])
    except SIMULATION_ERRORS:
        return float("inf")
    value = _rmse(y, pred, n_init)
    return value if np.isfinite(value) else float("inf")


@dataclass(frozen=True)
class MeasuredContext:
    """What every fit of a measured run reads: the system, its record, settings.

    Parameters
    ----------
    system : MeasuredSystem
        The benchmark.
    u, y : ndarray of shape (n_times, 1)
        The estimation record.
    n_init : int
        Samples of the official initialisation window.
    dt : float
        Sample period.
    quick : bool
        Shorter fits and fewer candidates.
    seed : int
        Seed of the networks.
    sink : object or None, default=None
        Where networks report their epochs (progress), or None.
    label : str, default=""
        The model being fitted (names its epochs).
    """

    system: object
    u: np.ndarray
    y: np.ndarray
    n_init: int
    dt: float
    quick: bool
    seed: int
    sink: object = None
    label: str = ""


def _watch(estimator, ctx):
    """Report the networks' epochs inside ``estimator`` to the run's progress."""
    if ctx.sink is not None and hasattr(estimator, "get_params"):
        attach_epoch_logger(estimator, ctx.sink, ctx.label)
    return estimator


def _official_init(candidate, n_init):
    return n_init


def _window_init(candidate, n_init):
    # A NARX needs its whole window measured before its free run starts.
    return max(n_init, candidate)


@dataclass(frozen=True)
class ZooModel:
    """One model of the measured zoo: its candidates and how one is fitted.

    Parameters
    ----------
    fit : callable
        ``fit(candidate, u, y, ctx, deps, start)`` returns a fitted model with
        ``simulate(inputs, initial)``; ``deps`` maps each required model's name
        to its fit on the same record part, ``start`` is the chosen candidate's
        fit on the first 75 % when refitting (else None).
    candidates : callable
        ``candidates(ctx, records)`` returns ``{key: candidate}``; ``records``
        maps each required model's name to its fit record.
    requires : tuple of str, default=()
        Models fitted before this one, whose fits it uses.
    refit : bool, default=True
        Refit the chosen candidate on the whole record; False quotes its fit on
        the first 75 %.
    keep_validation_fit : bool, default=False
        Keep the chosen candidate's fit on the first 75 % too (models that
        require this one are chosen with it).
    score_init : callable, default=the official n_init
        ``score_init(candidate, n_init)``: samples that start the free run on the
        validation tail.
    fit_errors : tuple of exception types, default=()
        Errors of a candidate's fit that score it as infinitely bad.
    choice : str, default="chosen"
        Name of the chosen candidate in the fit record's ``selection``.
    """

    fit: object
    candidates: object
    requires: tuple = ()
    refit: bool = True
    keep_validation_fit: bool = False
    score_init: object = _official_init
    fit_errors: tuple = ()
    choice: str = "chosen"
    notes: dict = field(default_factory=dict)


# -- the fits ------------------------------------------------------------------------
def _dense(quick, seed):
    from skhybrid.neural import DenseRegressor

    return DenseRegressor(
        hidden_layer_sizes=(64, 64),
        max_epochs=15 if quick else 60,
        patience=10,
        batch_size=256,
        lr=3e-3,
        random_state=seed,
    )


def _arx_ridge(ctx):
    return Ridge(alpha=1e-6)


def _correction_ridge(ctx):
    return Ridge(alpha=1e-3)


def _dense_regressor(ctx):
    # Looked up at call time, so a test can replace _dense.
    return _dense(ctx.quick, ctx.seed)


def _fit_physics(segment, u, y, ctx, deps, start):
    """The system's physics fitted on ``u``, ``y`` (from ``start``'s params)."""
    system = ctx.system
    model = system.physics(u, y, ctx.dt, quick=ctx.quick)
    if start is not None:
        model.set_params(params=dict(start.params_))
    transform = system.physics_inputs
    u_model = u if transform is None else transform(u)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit_segments(model, u_model, y, segment)
    return _TransformedInputs(model, transform)


def _fit_narx(make_regressor, n, u, y, ctx, deps, start):
    model = _watch(_NARXSimulator(make_regressor(ctx), n), ctx)
    return model.fit(u, y)


def _fit_correction(make_regressor, n, u, y, ctx, deps, start):
    model = _PhysicsCorrection(
        deps["physics"], make_regressor(ctx), n_steps=n, n_init=ctx.n_init
    )
    return _watch(model, ctx).fit(u, y)


def _fit_state_space_hybrid(settings, u, y, ctx, deps, start):
    """A :class:`StateSpaceHybridRegressor` on records cut from ``u``, ``y``."""
    from skhybrid.hybrid import StateSpaceHybridRegressor

    system, physics = ctx.system, deps["physics"]
    transform = system.physics_inputs
    u_model = u if transform is None else transform(u)
    U, Y = _records(u_model, y, system.hybrid_records)
    start_physics = clone(physics.estimator).set_params(
        params=dict(physics.estimator.params_)
    )
    model = StateSpaceHybridRegressor(
        start_physics,
        n_init=ctx.n_init,
        warm_start_physics=False,
        random_state=ctx.seed,
        **settings,
    )
    _watch(model, ctx)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit_simulation(U, Y)
    return _TransformedInputs(model, transform)


# -- the candidates ------------------------------------------------------------------
def _segments(ctx, records):
    return {segment: segment for segment in ctx.system.segments}


def _arx_windows(ctx, records):
    return {n: n for n in ((2, 4) if ctx.quick else (2, 4, 8))}


def _linear_arx_window(ctx, records):
    # The dense NARX reads the window the linear ARX chose.
    n = records["linear ARX"]["selection"]["n"]
    return {n: n}


def _correction_windows(ctx, records):
    return {n: n for n in ((1, 10) if ctx.quick else (1, 10, 50))}


def _hybrids(ctx, records):
    return ctx.system.hybrid_candidates(ctx.quick)


def zoo(system, quick=False):
    """The measured zoo of ``system``, in the order the report lists it.

    Parameters
    ----------
    system : MeasuredSystem
        The benchmark (its physics, segment lengths and hybrid candidates).
    quick : bool, default=False
        Fewer candidates (the hybrid's are the system's quick ones).

    Returns
    -------
    zoo : dict of str to ZooModel
        The physics, a linear ARX, a dense NARX, the physics with a linear and a
        dense static correction, and, where the system has candidates, the
        state-space hybrid.
    """
    models = {
        "physics": ZooModel(
            _fit_physics, _segments, keep_validation_fit=True, choice="segment"
        ),
        "linear ARX": ZooModel(
            partial(_fit_narx, _arx_ridge),
            _arx_windows,
            score_init=_window_init,
            fit_errors=(ValueError, FloatingPointError),
            choice="n",
        ),
        "dense NARX": ZooModel(
            partial(_fit_narx, _dense_regressor),
            _linear_arx_window,
            requires=("linear ARX",),
            score_init=_window_init,
            choice="n",
            notes={"window": "the linear ARX's"},
        ),
        "physics + linear": ZooModel(
            partial(_fit_correction, _correction_ridge),
            _correction_windows,
            requires=("physics",),
            choice="n",
        ),
        "physics + dense": ZooModel(
            partial(_fit_correction, _dense_regressor),
            _correction_windows,
            requires=("physics",),
            choice="n",
        ),
    }
    if system.hybrid_candidates(quick):
        # T and the architecture chosen on the tail; the chosen one is quoted as
        # fitted on the first 75 % (a refit on the whole record would double the
        # time).
        models["state-space hybrid"] = ZooModel(
            _fit_state_space_hybrid,
            _hybrids,
            requires=("physics",),
            refit=False,
            fit_errors=(TrainingDivergedError, SimulationDivergedError),
        )
    return models


# -- choose, refit, score --------------------------------------------------------------
def choose_and_refit(model, ctx, deps):
    """Fit each candidate on the first 75 %, choose on the tail, refit the choice.

    Parameters
    ----------
    model : ZooModel
        The model's candidates and fit.
    ctx : MeasuredContext
        The system, the estimation record and the settings.
    deps : dict of str to dict
        For each required model: ``model`` (its fit on the whole record),
        ``validation_fit`` (on the first 75 %) and ``fit`` (its fit record).

    Returns
    -------
    fitted : object or None
        The chosen model as quoted (None when every candidate failed).
    validation_fit : object or None
        The chosen candidate's fit on the first 75 %.
    selection : dict
        Validation RMSE of every candidate (official units), the choice and on
        what the quoted model was fitted.
    """
    u, y, n_init = ctx.u, ctx.y, ctx.n_init
    (u_a, y_a), (u_b, y_b) = _tail_split(u, y)
    scale = ctx.system.scale
    candidates = model.candidates(ctx, {k: d["fit"] for k, d in deps.items()})
    on_part = {k: d["validation_fit"] for k, d in deps.items()}
    scores, fitted = {}, {}
    for key, candidate in candidates.items():
        t0 = time.perf_counter()
        try:
            fit = model.fit(candidate, u_a, y_a, ctx, on_part, None)
        except model.fit_errors as exc:
            scores[key] = float("inf")
            logger.info("%s %s: %s", ctx.label, key, exc)
            continue
        scores[key] = _score(fit, u_b, y_b, model.score_init(candidate, n_init))
        fitted[key] = fit
        logger.info(
            "%s %s: validation %.4g (%.0f s)",
            ctx.label,
            key,
            scale * scores[key],
            time.perf_counter() - t0,
        )
    best = min(scores, key=scores.get)
    validation_fit = fitted.get(best)
    if validation_fit is not None and model.refit:
        whole = {k: d["model"] for k, d in deps.items()}
        chosen = model.fit(candidates[best], u, y, ctx, whole, validation_fit)
    else:
        chosen = validation_fit
    selection = {
        "validation_rmse_by_candidate": {str(k): scale * v for k, v in scores.items()},
        model.choice: best,
        "validation_rmse": scale * scores[best],
        "fitted_on": (
            "the whole estimation record"
            if model.refit
            else "the first 75 % of the estimation record"
        ),
        **model.notes,
    }
    if isinstance(candidates[best], dict):
        selection["settings"] = {k: repr(v) for k, v in candidates[best].items()}
    return chosen, validation_fit, selection


def _n_epochs(model):
    """Epochs of the network inside ``model``, if any."""
    inner = getattr(model, "model_", None)
    for est in (model, getattr(inner, "steps", [[None, None]])[-1][1]):
        value = getattr(est, "n_epochs_", None)
        if value is not None:
            return int(value)
    return None


def fit_model(name, model, ctx, deps, tests, sink=None):
    """Choose, refit and simulate one model of the zoo (runs in a joblib worker).

    Parameters
    ----------
    name : str
        The model's name in the zoo.
    model : ZooModel
        Its candidates and fit.
    ctx : MeasuredContext
        The system, the estimation record and the settings.
    deps : dict of str to dict
        The required models' fits (see :func:`choose_and_refit`).
    tests : dict of str to tuple of ndarray
        ``{split: (u, y)}``: the test records.
    sink : object or None, default=None
        Where networks report their epochs.

    Returns
    -------
    name : str
        ``name``.
    out : dict
        ``estimator``, ``extras`` (``validation_fit`` where kept), ``predictions``
        (the free run of each test record; NaN where it failed), ``fit_time``,
        ``n_epochs``, ``params``, ``warnings``, ``validation_rmse`` and
        ``selection``.
    """
    ctx = replace(ctx, sink=sink, label=name)
    with warnings.catch_warnings(record=True) as caught, _interrupts_raise():
        warnings.simplefilter("always")
        start = time.perf_counter()
        chosen, validation_fit, selection = choose_and_refit(model, ctx, deps)
        fit_time = time.perf_counter() - start
        predictions = {}
        for split, (u, y) in tests.items():
            pred = np.full(len(y), np.nan)
            if chosen is None:
                selection["failed"] = "every candidate's fit failed"
            else:
                try:
                    pred = np.ravel(chosen.simulate(u, y[: ctx.n_init])).astype(float)
                except SIMULATION_ERRORS as exc:
                    selection["diverged_on_" + split] = str(exc)
            predictions[split] = pred
    messages = sorted(
        {
            f"{w.category.__name__}: {w.message}"
            for w in caught
            if not issubclass(w.category, DeprecationWarning)
        }
    )
    extras = {}
    if model.keep_validation_fit and validation_fit is not None:
        extras["validation_fit"] = validation_fit
    params = {} if chosen is None else _physical_params(chosen)
    if name == "physics" and chosen is not None:
        selection["estimation_rmse"] = ctx.system.scale * float(chosen.rmse_)
    return name, {
        "estimator": chosen,
        "extras": extras,
        "predictions": predictions,
        "fit_time": fit_time,
        "n_epochs": None if chosen is None else _n_epochs(chosen),
        "params": params,
        "warnings": messages,
        "validation_rmse": selection["validation_rmse"],
        "selection": selection,
    }
