"""The model zoo of measured systems and its one choose-refit rule.

Every model is fitted on the estimation records only. Choices (window lengths,
segment lengths, the horizon ``T`` and the architecture of the state-space
hybrid, and the model to quote) are made on their validation tails, the last
25 % of each record: a candidate is fitted on the first 75 % of every record and
simulated in free run over each tail from the tail's first ``n_init`` measured
outputs, as the official protocol simulates a test record; its score is the RMSE
over every tail's simulated samples. The chosen candidate is then refitted on the
whole records (except the state-space hybrid, quoted as fitted on the first
75 %). Test records are simulated later, once the selection is sealed
(:mod:`skhybrid.experiments._sealed`). :func:`choose_and_refit` is that rule, written
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
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import Ridge

from skhybrid.domain import StateSpaceModel
from skhybrid.exceptions import SimulationDivergedError, TrainingDivergedError
from skhybrid.experiments._fitting import (
    fit_segments,
    interrupts_raise,
    physical_params,
)
from skhybrid.experiments._progress import attach_epoch_logger
from skhybrid.experiments._spec import pieces_per_record
from skhybrid.hybrid import _NARXSimulator, _PhysicsCorrection, _TransformedInputs

__all__ = [
    "MeasuredContext",
    "ZooModel",
    "choose_and_refit",
    "fit_model",
    "pooled_rmse",
    "simulate_records",
    "zoo",
]

logger = logging.getLogger(__name__)

#: Share of the estimation record held out at its end for every choice.
VALIDATION_FRACTION = 0.25

#: What a failed free run raises (its score is then infinite, its test RMSE NaN).
SIMULATION_ERRORS = (SimulationDivergedError, FloatingPointError, ValueError)


def _rmse(y, pred, n_init):
    return float(
        np.sqrt(np.mean((np.ravel(y)[n_init:] - np.ravel(pred)[n_init:]) ** 2))
    )


def pooled_rmse(Y, preds, n_init):
    """RMSE over every record's samples after its first ``n_init``.

    Parameters
    ----------
    Y, preds : list of array-like of shape (n_times_i,) or (n_times_i, 1)
        Measured and simulated outputs of each record.
    n_init : int
        Samples of each record's initialisation window (not scored).

    Returns
    -------
    rmse : float
        ``sqrt(sum of squared errors / number of scored samples)``.
    """
    errors = np.concatenate(
        [
            np.ravel(y)[n_init:] - np.ravel(p)[n_init:]
            for y, p in zip(Y, preds, strict=True)
        ]
    )
    return float(np.sqrt(np.mean(errors**2)))


def _tail_split(U, Y, fraction=VALIDATION_FRACTION):
    """The first ``1 - fraction`` of every record, and the tails."""
    cuts = [int(len(u) * (1 - fraction)) for u in U]
    head = (
        [u[:c] for u, c in zip(U, cuts, strict=True)],
        [y[:c] for y, c in zip(Y, cuts, strict=True)],
    )
    tail = (
        [u[c:] for u, c in zip(U, cuts, strict=True)],
        [y[c:] for y, c in zip(Y, cuts, strict=True)],
    )
    return head, tail


def _records(U, Y, n):
    """About ``n`` consecutive pieces cut from the records, in proportion to length.

    Each record gives at least one piece; within a record the pieces have equal
    length (the rest joins its last).
    """
    pieces_U, pieces_Y = [], []
    for u, y, k in zip(U, Y, pieces_per_record([len(u) for u in U], n), strict=True):
        size = len(u) // k
        edges = [i * size for i in range(k)] + [len(u)]
        for a, b in itertools.pairwise(edges):
            pieces_U.append(u[a:b])
            pieces_Y.append(y[a:b])
    return pieces_U, pieces_Y


def simulate_records(model, U, Y, n_init):
    """Free runs of ``model`` over records from their first ``n_init`` outputs.

    Parameters
    ----------
    model : object
        Anything with ``simulate(inputs, initial)``.
    U, Y : list of ndarray
        Inputs and measured outputs of each record.
    n_init : int
        Measured samples that start each free run.

    Returns
    -------
    preds : list of ndarray of shape (n_times_i,)
        The simulated outputs; NaN throughout where a free run failed.
    errors : list of str or None
        Why each failed (None where it did not).
    """
    preds, errors = [], []
    for u, y in zip(U, Y, strict=True):
        try:
            pred = np.ravel(model.simulate(u, y[:n_init])).astype(float)
            errors.append(None)
        except SIMULATION_ERRORS as exc:
            pred = np.full(len(y), np.nan)
            errors.append(str(exc))
        preds.append(pred)
    return preds, errors


def _score(model, U, Y, n_init):
    """Pooled free-run RMSE of records from their first ``n_init`` outputs.

    Infinite where a free run failed or is not finite.

    Returns
    -------
    score : float
        The RMSE.
    preds : list of ndarray
        The free runs (NaN where one failed).
    """
    preds, errors = simulate_records(model, U, Y, n_init)
    if any(errors):
        return float("inf"), preds
    value = pooled_rmse(Y, preds, n_init)
    return (value if np.isfinite(value) else float("inf")), preds


@dataclass(frozen=True)
class MeasuredContext:
    """What every fit of a measured run reads: the system, its records, settings.

    Parameters
    ----------
    system : MeasuredSystem
        The system (its spec's physics, candidates and units).
    U, Y : list of ndarray of shape (n_times_i, n_inputs) and (n_times_i, 1)
        The estimation records.
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
    U: list
    Y: list
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
        ``fit(candidate, U, Y, ctx, deps, start)`` returns a fitted model with
        ``simulate(inputs, initial)``; ``U`` and ``Y`` are lists of records,
        ``deps`` maps each required model's name to its fit on the same record
        parts, ``start`` is the chosen candidate's fit on the first 75 % when
        refitting (else None).
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


#: Networks the dense ensemble correction averages.
ENSEMBLE_SIZE = 3


def _dense_ensemble(ctx):
    """The mean of ``ENSEMBLE_SIZE`` dense networks of other seeds than the run's."""
    from sklearn.ensemble import VotingRegressor

    return VotingRegressor(
        [
            (f"seed-{k}", _dense(ctx.quick, 1000 * k + ctx.seed))
            for k in range(1, ENSEMBLE_SIZE + 1)
        ]
    )


def _arx_ridge(ctx):
    return Ridge(alpha=1e-6)


def _correction_ridge(ctx):
    return Ridge(alpha=1e-3)


def _dense_regressor(ctx):
    # Looked up at call time, so a test can replace _dense.
    return _dense(ctx.quick, ctx.seed)


def _model_inputs(system, U):
    transform = system.physics_inputs
    return list(U) if transform is None else [transform(u) for u in U]


def _fit_physics(segment, U, Y, ctx, deps, start):
    """The system's physics fitted on the records (from ``start``'s params)."""
    system = ctx.system
    U_model = _model_inputs(system, U)
    model = system.physics(U_model, Y, ctx.dt, quick=ctx.quick)
    if start is not None and isinstance(getattr(start, "params_", None), dict):
        # The refit continues from the chosen candidate's fit, in the valley
        # the validation tail judged: its starts are not fitted again.
        model.set_params(params=dict(start.params_))
        if "starts" in model.get_params(deep=False):
            model.set_params(starts=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit_segments(model, U_model, Y, segment)
    # A fit that stopped short of convergence is kept, and said so in the run's
    # record (fits.<model>.warnings, the report); other warnings stay quiet.
    pieces = "whole records" if segment is None else f"segments of {segment} samples"
    for w in caught:
        if issubclass(w.category, ConvergenceWarning):
            warnings.warn(
                f"physics fit on {pieces}: {w.message}",
                ConvergenceWarning,
                stacklevel=2,
            )
    return _TransformedInputs(model, system.physics_inputs)


def _fit_narx(make_regressor, n, U, Y, ctx, deps, start):
    model = _watch(_NARXSimulator(make_regressor(ctx), n), ctx)
    return model.fit(list(U), list(Y))


def _fit_correction(make_regressor, n, U, Y, ctx, deps, start):
    model = _PhysicsCorrection(
        deps["physics"], make_regressor(ctx), n_steps=n, n_init=ctx.n_init
    )
    return _watch(model, ctx).fit(list(U), list(Y))


def _fit_state_space_hybrid(settings, U, Y, ctx, deps, start):
    """A :class:`StateSpaceHybridRegressor` on pieces cut from the records."""
    from skhybrid.hybrid import StateSpaceHybridRegressor

    system, physics = ctx.system, deps["physics"]
    if not isinstance(physics.estimator, StateSpaceModel):
        raise TypeError(
            "The state-space hybrid needs a StateSpaceModel physics (it trains "
            "through its equations); the spec's physics(U, Y, dt) returned a "
            f"{type(physics.estimator).__name__}. Set the spec's hybrids=None."
        )
    U, Y = _records(_model_inputs(system, U), Y, system.hybrid_records)
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
    return _TransformedInputs(model, system.physics_inputs)


# -- the candidates ------------------------------------------------------------------
def _segments(ctx, records):
    return {segment: segment for segment in ctx.system.segment_candidates(ctx)}


def _arx_windows(ctx, records):
    # A test record's free run starts from n_init measured samples: no window
    # may need more.
    windows = [n for n in ((2, 4) if ctx.quick else (2, 4, 8)) if n <= ctx.n_init]
    return {n: n for n in windows or [ctx.n_init]}


def _linear_arx_window(ctx, records):
    # The dense NARX reads the window the linear ARX chose.
    n = records["linear ARX"]["selection"]["n"]
    return {n: n}


def _dense_correction_window(ctx, records):
    # The ensemble reads the window the single dense correction chose.
    n = records["physics + dense"]["selection"]["n"]
    return {n: n}


def _correction_windows(ctx, records):
    return {n: n for n in ((1, 10) if ctx.quick else (1, 10, 50))}


def _hybrids(ctx, records):
    return ctx.system.hybrid_candidates(ctx)


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
        dense static correction and with the mean of three dense corrections
        (the dense one's window), and, where the system has candidates, the
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
        "physics + dense ensemble": ZooModel(
            partial(_fit_correction, _dense_ensemble),
            _dense_correction_window,
            requires=("physics", "physics + dense"),
            choice="n",
            notes={
                "window": "the physics + dense's",
                "networks": f"{ENSEMBLE_SIZE} dense networks averaged",
            },
        ),
    }
    if system.has_hybrids(quick):
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
    """Fit each candidate on the first 75 %, choose on the tails, refit the choice.

    Parameters
    ----------
    model : ZooModel
        The model's candidates and fit.
    ctx : MeasuredContext
        The system, the estimation records and the settings.
    deps : dict of str to dict
        For each required model: ``model`` (its fit on the whole records),
        ``validation_fit`` (on the first 75 %) and ``fit`` (its fit record).

    Returns
    -------
    fitted : object or None
        The chosen model as quoted (None when every candidate failed).
    validation_fit : object or None
        The chosen candidate's fit on the first 75 %.
    selection : dict
        Validation RMSE of every candidate (official units), the choice, on
        what the quoted model was fitted and, under ``errors``, why each
        candidate whose fit failed did (its exception's type and message).
    runs : list of ndarray or None
        The chosen candidate's free runs over the validation tails (None when
        every candidate failed).
    """
    U, Y, n_init = ctx.U, ctx.Y, ctx.n_init
    (u_a, y_a), (u_b, y_b) = _tail_split(U, Y)
    scale = ctx.system.scale
    candidates = model.candidates(ctx, {k: d["fit"] for k, d in deps.items()})
    on_part = {k: d["validation_fit"] for k, d in deps.items()}
    scores, fitted, errors, runs = {}, {}, {}, {}
    for key, candidate in candidates.items():
        t0 = time.perf_counter()
        try:
            fit = model.fit(candidate, u_a, y_a, ctx, on_part, None)
        except model.fit_errors as exc:
            scores[key] = float("inf")
            errors[str(key)] = f"{type(exc).__name__}: {exc}"
            logger.info("%s %s: %s", ctx.label, key, exc)
            continue
        scores[key], runs[key] = _score(
            fit, u_b, y_b, model.score_init(candidate, n_init)
        )
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
        chosen = model.fit(candidates[best], U, Y, ctx, whole, validation_fit)
    else:
        chosen = validation_fit
    selection = {
        "validation_rmse_by_candidate": {str(k): scale * v for k, v in scores.items()},
        model.choice: best,
        "validation_rmse": scale * scores[best],
        "fitted_on": (
            "the whole estimation records"
            if model.refit
            else "the first 75 % of each estimation record"
        ),
        **model.notes,
    }
    if errors:
        selection["errors"] = errors
    if isinstance(candidates[best], dict):
        selection["settings"] = {k: repr(v) for k, v in candidates[best].items()}
    if best in runs:
        # The chosen candidate's free runs over the validation tails, and the
        # sample each is scored from: its residuals are the stochastic part.
        selection["validation_start"] = int(model.score_init(candidates[best], n_init))
    return chosen, validation_fit, selection, runs.get(best)


def _n_epochs(model):
    """Epochs of the network inside ``model``, if any."""
    inner = getattr(model, "model_", None)
    for est in (model, getattr(inner, "steps", [[None, None]])[-1][1]):
        value = getattr(est, "n_epochs_", None)
        if value is not None:
            return int(value)
    return None


def fit_model(name, model, ctx, deps, sink=None):
    """Choose and refit one model of the zoo (runs in a joblib worker).

    No test record is read here: the test records are simulated once every
    choice is sealed (:func:`skhybrid.experiments._sealed.score_tests`).

    Parameters
    ----------
    name : str
        The model's name in the zoo.
    model : ZooModel
        Its candidates and fit.
    ctx : MeasuredContext
        The system, the estimation records and the settings.
    deps : dict of str to dict
        The required models' fits (see :func:`choose_and_refit`).
    sink : object or None, default=None
        Where networks report their epochs.

    Returns
    -------
    name : str
        ``name``.
    out : dict
        ``estimator``, ``extras`` (``validation_fit`` where kept),
        ``predictions`` (empty: no test record is simulated yet), ``fit_time``,
        ``n_epochs``, ``params``, ``warnings``, ``validation_rmse``,
        ``selection`` and ``validation_runs`` (the chosen candidate's free runs
        over the validation tails).
    """
    ctx = replace(ctx, sink=sink, label=name)
    with warnings.catch_warnings(record=True) as caught, interrupts_raise():
        warnings.simplefilter("always")
        start = time.perf_counter()
        chosen, validation_fit, selection, runs = choose_and_refit(model, ctx, deps)
        fit_time = time.perf_counter() - start
    if chosen is None:
        selection["failed"] = "every candidate's fit failed"
    messages = sorted(
        {
            f"{w.category.__name__}: {w.message}"
            for w in caught
            if not issubclass(w.category, DeprecationWarning)
        }
    )
    # A candidate that failed is named where the report lists what went wrong.
    messages += [
        f"candidate {key} failed: {reason}"
        for key, reason in selection.get("errors", {}).items()
    ]
    extras = {}
    if model.keep_validation_fit and validation_fit is not None:
        extras["validation_fit"] = validation_fit
    params = {} if chosen is None else physical_params(chosen)
    rmse = getattr(chosen, "rmse_", None) if name == "physics" else None
    if rmse is not None:
        selection["estimation_rmse"] = ctx.system.scale * float(rmse)
    return name, {
        "estimator": chosen,
        "extras": extras,
        "predictions": {},
        "fit_time": fit_time,
        "n_epochs": None if chosen is None else _n_epochs(chosen),
        "params": params,
        "warnings": messages,
        "validation_rmse": selection["validation_rmse"],
        "selection": selection,
        "validation_runs": runs,
    }
