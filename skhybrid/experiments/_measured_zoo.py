"""The model zoo of measured systems and its one choose-refit rule.

Every model is fitted on the estimation records only. Every choice (window
lengths, segment lengths, the horizon ``T`` and the architecture of the
state-space hybrid, and the model to quote) is made by blocked cross-validation
of the records (:class:`~skhybrid.model_selection.SimulationSearchCV` over
:class:`~skhybrid.model_selection.RecordBlockSplit`): each record is cut into
four blocks; a candidate is fitted on the other blocks of every record (as
separate pieces) and simulated in free run over each held-out block from its
first ``n_init`` measured outputs, as the official protocol simulates a test
record; its score is the mean over the folds of the RMSE over every held-out
sample. The chosen candidate is refitted on the whole records. Test records are
simulated later, once the selection is sealed
(:mod:`skhybrid.experiments._sealed`). :func:`choose_and_refit` is that rule,
written once; each model of the zoo is a :class:`ZooModel`: its candidates, how
one is fitted, and what it needs from models fitted before it.
"""

import contextlib
import functools
import hashlib
import itertools
import logging
import pickle
import sys
import time
import warnings
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import joblib
import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import ConvergenceWarning, FitFailedWarning
from sklearn.linear_model import Ridge

from skhybrid.domain import StateSpaceModel, fit_progress
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.experiments._fitting import (
    fit_segments,
    interrupts_raise,
    physical_params,
)
from skhybrid.experiments._progress import (
    attach_epoch_logger,
    epoch_budget,
    physics_hook,
)
from skhybrid.experiments._spec import pieces_per_record, records_digest
from skhybrid.experiments._store import _write_atomic
from skhybrid.hybrid import (
    NARXSimulator,
    PhysicsCorrection,
    TransformedInputSimulator,
)
from skhybrid.model_selection import RecordBlockSplit, SimulationSearchCV

__all__ = [
    "MeasuredContext",
    "ZooModel",
    "choose_and_refit",
    "epochs_at_most",
    "fit_model",
    "pooled_rmse",
    "simulate_records",
    "zoo",
]

logger = logging.getLogger(__name__)

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
    cache : str or Path or None, default=None
        Where deterministic fits are kept (the run folder's cache), or None.
    searched : dict or None, default=None
        The model's search made at the run's first seed (``selection``, its
        chosen candidate's out-of-fold ``runs`` and the ``seed``): the chosen
        candidate is refitted at this seed, not searched again. None searches.
    n_jobs : int or None, default=None
        Workers of the search over candidates and folds (joblib's).
    n_threads : int or None, default=None
        Threads of torch and the BLAS while the model is chosen and refitted
        in this process, the same as in each worker (so a refit computes what
        it would in a worker); None leaves them.
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
    cache: object = None
    searched: object = None
    n_jobs: object = None
    n_threads: object = None


def _watch(estimator, ctx):
    """Report the networks' epochs inside ``estimator`` to the run's progress."""
    if ctx.sink is not None and hasattr(estimator, "get_params"):
        attach_epoch_logger(estimator, ctx.sink, ctx.label)
    return estimator


@dataclass(frozen=True)
class ZooModel:
    """One model of the measured zoo: its candidates and how one is fitted.

    Parameters
    ----------
    fit : callable
        ``fit(candidate, U, Y, ctx, deps, start)`` returns a fitted model with
        ``simulate(inputs, initial)``; ``U`` and ``Y`` are lists of records,
        ``deps`` maps ``"physics"`` to the physics fitted on the same records
        where the model requires it, ``start`` is None.
    candidates : callable
        ``candidates(ctx, records)`` returns ``{key: candidate}``; ``records``
        maps each required model's name to its fit record.
    requires : tuple of str, default=()
        Models chosen before this one, whose choices (or physics) it uses.
    deterministic : bool, default=False
        No fit depends on the seed: a fit is computed once per records and kept
        in the run's cache (shared by every seed and by the models built on it).
    choice : str, default="chosen"
        Name of the chosen candidate in the fit record's ``selection``.
    notes : dict, default={}
        What the report says of the model's candidates.
    epochs : callable or None, default=None
        ``epochs(ctx)`` returns the most epochs one fit of each candidate can
        train (:func:`~skhybrid.experiments._progress.epoch_budget` of its
        networks), in the order of its candidates; None for a model without
        networks. The progress bar's total (:func:`epochs_at_most`).
    """

    fit: object
    candidates: object
    requires: tuple = ()
    deterministic: bool = False
    choice: str = "chosen"
    notes: dict = field(default_factory=dict)
    epochs: object = None


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
    """The system's physics fitted on the records, over segments of them."""
    system = ctx.system
    U_model = _model_inputs(system, U)
    model = system.physics(U_model, Y, ctx.dt, quick=ctx.quick)
    pieces = "whole records" if segment is None else f"segments of {segment} samples"
    hook = None
    if ctx.sink is not None:  # the run's progress shows its evaluations
        hook = physics_hook(ctx.sink, f"{ctx.label or 'physics'} on {pieces}")
    with warnings.catch_warnings(record=True) as caught, fit_progress(hook):
        warnings.simplefilter("always")
        fit_segments(model, U_model, Y, segment)
    # A fit that stopped short of convergence is kept, and said so in the run's
    # record (fits.<model>.warnings, the report); other warnings stay quiet.
    for w in caught:
        if issubclass(w.category, ConvergenceWarning):
            warnings.warn(
                f"physics fit on {pieces}: {w.message}",
                ConvergenceWarning,
                stacklevel=2,
            )
    return TransformedInputSimulator(model, system.physics_inputs)


def _fit_narx(make_regressor, n, U, Y, ctx, deps, start):
    model = _watch(NARXSimulator(make_regressor(ctx), n), ctx)
    return model.fit(list(U), list(Y))


def _fit_correction(make_regressor, n, U, Y, ctx, deps, start):
    model = PhysicsCorrection(
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
    return TransformedInputSimulator(model, system.physics_inputs)


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


# -- the most epochs of each model's candidates (the progress bar's total) ------------
def _one_dense_epochs(ctx):
    return [epoch_budget(_dense_regressor(ctx))]


def _correction_dense_epochs(ctx):
    return _one_dense_epochs(ctx) * len(_correction_windows(ctx, {}))


def _ensemble_epochs(ctx):
    return [epoch_budget(_dense_ensemble(ctx))]


def _hybrid_epochs(ctx):
    from skhybrid.hybrid import StateSpaceHybridRegressor

    return [
        epoch_budget(StateSpaceHybridRegressor(None, **settings))
        for settings in _hybrids(ctx, {}).values()
    ]


def epochs_at_most(models, ctx, searched=()):
    """The most epochs the networks of ``models`` can train in one seed's run.

    A searched model fits every candidate on every fold, then refits one on the
    whole records; a model whose search was made at another seed (``searched``)
    only refits its choice. Early stopping usually ends sooner: this is an upper
    bound, the epoch bar's total.

    Parameters
    ----------
    models : dict of str to ZooModel
        The models still to fit.
    ctx : MeasuredContext
        The system, its estimation records and the settings.
    searched : collection of str, default=()
        Models that refit the choice of a search made at another seed.

    Returns
    -------
    n_epochs : int
        The upper bound (0 where no model trains a network).
    """
    n_folds = RecordBlockSplit(N_SPLITS, n_init=ctx.n_init).get_n_splits(list(ctx.U))
    total = 0
    for name, model in models.items():
        per_candidate = [] if model.epochs is None else model.epochs(ctx)
        if not per_candidate:
            continue
        refit = max(per_candidate)
        total += refit if name in searched else n_folds * sum(per_candidate) + refit
    return total


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
            _fit_physics, _segments, deterministic=True, choice="segment"
        ),
        "linear ARX": ZooModel(
            partial(_fit_narx, _arx_ridge),
            _arx_windows,
            deterministic=True,
            choice="n",
        ),
        "dense NARX": ZooModel(
            partial(_fit_narx, _dense_regressor),
            _linear_arx_window,
            requires=("linear ARX",),
            choice="n",
            notes={"window": "the linear ARX's"},
            epochs=_one_dense_epochs,
        ),
        "physics + linear": ZooModel(
            partial(_fit_correction, _correction_ridge),
            _correction_windows,
            requires=("physics",),
            deterministic=True,
            choice="n",
        ),
        "physics + dense": ZooModel(
            partial(_fit_correction, _dense_regressor),
            _correction_windows,
            requires=("physics",),
            choice="n",
            epochs=_correction_dense_epochs,
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
            epochs=_ensemble_epochs,
        ),
    }
    if system.has_hybrids(quick):
        # T and the architecture chosen by the folds, like every candidate.
        models["state-space hybrid"] = ZooModel(
            _fit_state_space_hybrid,
            _hybrids,
            requires=("physics",),
            epochs=_hybrid_epochs,
        )
    return models


# -- choose, refit, score --------------------------------------------------------------
#: Folds of every choice: blocks of each estimation record (fewer where a block
#: would be shorter than 8 initialisation windows).
N_SPLITS = 4


class _ZooCandidate(BaseEstimator):
    """One model of the zoo at one candidate setting, as the search fits it.

    :class:`~skhybrid.model_selection.SimulationSearchCV` clones it with each
    ``key`` of the model's candidates and the fold's ``random_state``, and calls
    ``fit(U, Y)`` on the fold's fit pieces. A deterministic model's fit is kept
    in the run's cache (``ctx.cache``), keyed by everything it depends on, so
    the same fit on the same records is never computed twice: a physics fitted
    for its own choice is the physics its corrections are built on, and a seed
    that cannot change a fit reuses another seed's.

    Parameters
    ----------
    model : ZooModel
        The model's fit and candidates.
    ctx : MeasuredContext
        The system and settings (its records are the whole estimation records).
    candidates : dict
        ``{key: candidate}`` of the model.
    key : object
        Which candidate.
    physics : object or None, default=None
        The fold's fitted physics, for a model that requires it.
    random_state : int or None, default=None
        Seed of the networks (the context's where None).
    """

    def __init__(
        self,
        model=None,
        ctx=None,
        candidates=None,
        key=None,
        physics=None,
        random_state=None,
    ):
        self.model = model
        self.ctx = ctx
        self.candidates = candidates
        self.key = key
        self.physics = physics
        self.random_state = random_state

    def fit(self, U, Y):
        """Fit the candidate on records ``U, Y``.

        Parameters
        ----------
        U, Y : list of ndarray
            Inputs and outputs of each record (a fold's fit pieces).

        Returns
        -------
        self : _ZooCandidate
            Fitted (``model_``).
        """
        ctx = self.ctx
        try:  # in a worker of the search: the user's __main__ functions by name
            expose_main_functions(ctx.system.spec)
        except AttributeError:  # a system whose spec is not bound
            pass
        if self.random_state is not None and not self.model.deterministic:
            ctx = replace(ctx, seed=int(self.random_state))
        physics = getattr(self.physics, "model_", self.physics)
        deps = {} if physics is None else {"physics": physics}
        candidate = self.candidates[self.key]
        # What the fit depends on, besides the run's spec (fixed for a run
        # folder): the model, its candidate, the records, the physics it is
        # built on and, for a network, its seed.
        self.cache_key_ = hashlib.sha256(
            repr(
                (
                    ctx.label,
                    repr(candidate),
                    records_digest(U, Y),
                    ctx.quick,
                    ctx.n_init,
                    ctx.dt,
                    getattr(self.physics, "cache_key_", None),
                    None if self.model.deterministic else ctx.seed,
                )
            ).encode()
        ).hexdigest()
        cached = _cache_path(ctx, self.cache_key_) if self.model.deterministic else None
        if cached is not None and cached.is_file():
            self.model_ = joblib.load(cached)
            return self
        self.model_ = self.model.fit(candidate, list(U), list(Y), ctx, deps, None)
        if cached is not None:
            _keep(self.model_, cached)
        return self

    def __sklearn_clone__(self):
        # The context is frozen and shared (it holds the run's progress sink,
        # which cannot be copied); the candidates and physics are not changed.
        return type(self)(**self.get_params(deep=False))

    def simulate(self, inputs, initial):
        """Free run of the fitted candidate (see the model's ``simulate``).

        Parameters
        ----------
        inputs : ndarray of shape (n_times, n_inputs)
            A record's inputs.
        initial : ndarray of shape (n_init, n_outputs)
            Its first measured outputs.

        Returns
        -------
        outputs : ndarray
            The simulated outputs.
        """
        return self.model_.simulate(inputs, initial)


def _cache_path(ctx, key):
    return None if ctx.cache is None else Path(ctx.cache) / f"{key}.joblib"


def _keep(model, path):
    """Keep a deterministic fit in the run's cache (best effort: a model that
    cannot be stored is fitted again where it is needed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        _write_atomic(path, lambda p: joblib.dump(model, p))
    except (OSError, pickle.PicklingError, AttributeError, TypeError) as exc:
        logger.info("not cached (%s): %s", path.name, exc)


def _on_physics(model, ctx, candidates, physics, key=None, random_state=None):
    """A candidate built on the fold's fitted physics (the search's factory)."""
    return _ZooCandidate(model, ctx, candidates, key, physics, random_state)


def _shared_physics(ctx, deps):
    """The physics the model's candidates are built on: the chosen one, unfitted.

    Fitted by the search on each fold's pieces and on the whole records; the
    run's cache hands back the fits the physics' own choice made.
    """
    physics = zoo(ctx.system, ctx.quick)["physics"]
    candidates = physics.candidates(ctx, {})
    key = deps["physics"]["fit"]["selection"][physics.choice]
    return _ZooCandidate(physics, replace(ctx, label="physics"), candidates, key)


def choose_and_refit(model, ctx, deps):
    """Choose a model's candidate by blocked cross-validation, then refit it.

    Every candidate is fitted on each fold's fit pieces of the estimation records
    (:class:`~skhybrid.model_selection.RecordBlockSplit`) and simulated in free
    run over the fold's held-out blocks, each from its own first ``n_init``
    measured outputs; the lowest mean RMSE over the folds wins and is refitted on
    the whole records (:class:`~skhybrid.model_selection.SimulationSearchCV`).
    A model built on the physics gets the fold's physics fit.

    Parameters
    ----------
    model : ZooModel
        The model's candidates and fit.
    ctx : MeasuredContext
        The system, the estimation records and the settings.
    deps : dict of str to dict
        For each required model: ``fit`` (its fit record, with its choice).

    Returns
    -------
    fitted : object or None
        The chosen candidate refitted on the whole records (None when every
        candidate failed).
    selection : dict
        Every candidate's CV RMSE (mean and by fold, official units), the
        choice, the folds used and why, and, under ``errors``, why a
        candidate's fold failed.
    runs : list of ndarray or None
        The chosen candidate's out-of-fold free runs: for each fold, its
        simulated samples of the held-out blocks after their first ``n_init``.
    """
    U, Y, n_init = list(ctx.U), list(ctx.Y), ctx.n_init
    scale = ctx.system.scale
    candidates = model.candidates(ctx, {k: d["fit"] for k, d in deps.items()})
    keys = list(candidates)
    if ctx.searched is not None:
        return _refit_searched(model, ctx, deps, candidates, ctx.searched)
    if "physics" in model.requires:
        estimator = partial(_on_physics, model, ctx, candidates)
        physics = _shared_physics(ctx, deps)
    else:
        estimator, physics = _ZooCandidate(model, ctx, candidates), None
    search = SimulationSearchCV(
        [(ctx.label or "model", estimator, {"key": keys})],
        physics=physics,
        cv=RecordBlockSplit(N_SPLITS, n_init=n_init),
        random_state=ctx.seed,
        n_jobs=ctx.n_jobs,
    )
    results, chosen, runs = None, None, None
    try:
        with warnings.catch_warnings():
            # Each failed fold is kept in the selection's errors below.
            warnings.simplefilter("ignore", FitFailedWarning)
            search.fit(U, Y)
        results = search.cv_results_
    except ValueError as exc:
        if not hasattr(search, "cv_results_"):
            raise
        results = search.cv_results_
        logger.info("%s: every candidate failed: %s", ctx.label, exc)
    n_splits = int(results["n_splits"][0])
    means = results["mean_test_score"]
    by_fold = np.column_stack(
        [results[f"split{k}_test_score"] for k in range(n_splits)]
    )
    errors = {}
    for i, key in enumerate(keys):
        reasons = [results[f"split{k}_error"][i] for k in range(n_splits)]
        reasons = [r for r in reasons if r is not None]
        if reasons:
            # The first fold's reason, short: an exception may quote its data.
            errors[str(key)] = reasons[0][:300]
    best = int(np.argmin(means))
    if np.isfinite(means[best]):
        chosen = getattr(search, "best_estimator_", None)
        chosen = None if chosen is None else chosen.model_
        runs = search.best_oof_runs_
    if chosen is None:
        logger.info("%s: no candidate scored", ctx.label)
    selection = {
        "validation_rmse_by_candidate": {
            str(k): scale * float(m) for k, m in zip(keys, means, strict=True)
        },
        "cv_rmse_by_fold": {
            str(k): [scale * float(v) for v in row]
            for k, row in zip(keys, by_fold, strict=True)
        },
        model.choice: keys[best],
        "chosen_candidate": str(keys[best]),
        "validation_rmse": scale * float(means[best]),
        "cv_rmse_std": scale * float(np.std(by_fold[best])),
        "cv_rmse_chosen_by_fold": [scale * float(v) for v in by_fold[best]],
        "cv_folds": n_splits,
        "cv_folds_reason": getattr(search, "n_splits_reason_", ""),
        "fitted_on": "the whole estimation records",
        "validation_start": int(n_init),
        "deterministic": bool(model.deterministic),
        **model.notes,
    }
    if errors:
        selection["errors"] = errors
    if isinstance(candidates[keys[best]], dict):
        selection["settings"] = {k: repr(v) for k, v in candidates[keys[best]].items()}
    return chosen, selection, runs


def _refit_searched(model, ctx, deps, candidates, searched):
    """Refit the candidate a search at another seed chose, at this run's seed.

    The search (every candidate on every fold) runs once, at the run's first
    seed; each further seed refits its choice on the whole records with its own
    networks' seed, which gives the spread over seeds. The refit is the one the
    search makes (:meth:`SimulationSearchCV.fit`'s ``refit``): the physics
    fitted on the whole records, then the candidate at ``random_state=seed``.

    Parameters
    ----------
    model : ZooModel
        The model's candidates and fit.
    ctx : MeasuredContext
        The system, the estimation records and the settings (this seed's).
    deps : dict of str to dict
        For each required model: ``fit`` (its fit record, with its choice).
    candidates : dict
        ``{key: candidate}`` of the model, the same as at the searched seed.
    searched : dict
        ``selection`` and ``runs`` of the search, and its ``seed``.

    Returns
    -------
    fitted, selection, runs
        As :func:`choose_and_refit`'s; ``selection`` and ``runs`` are the
        search's, with ``searched_at_seed``.
    """
    selection = {**searched["selection"], "searched_at_seed": int(searched["seed"])}
    selection.pop("failed", None)
    name = selection.get("chosen_candidate")
    keys = [key for key in candidates if str(key) == name]
    score = selection.get("validation_rmse")
    if not keys or score is None or not np.isfinite(score):
        return None, selection, None
    if "physics" in model.requires:
        physics = clone(_shared_physics(ctx, deps)).fit(list(ctx.U), list(ctx.Y))
        estimator = _on_physics(
            model, ctx, candidates, physics, key=keys[0], random_state=ctx.seed
        )
    else:
        estimator = _ZooCandidate(model, ctx, candidates, keys[0], None, ctx.seed)
    estimator.fit(list(ctx.U), list(ctx.Y))
    return estimator.model_, selection, searched["runs"]


def _n_epochs(model):
    """Epochs of the network inside ``model``, if any."""
    inner = getattr(model, "model_", None)
    for est in (model, getattr(inner, "steps", [[None, None]])[-1][1]):
        value = getattr(est, "n_epochs_", None)
        if value is not None:
            return int(value)
    return None


def _callables(value, seen=None):
    """Every function reachable through an estimator's parameters."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return
    seen.add(id(value))
    if hasattr(value, "get_params") and not isinstance(value, type):
        for v in value.get_params(deep=False).values():
            yield from _callables(v, seen)
    elif isinstance(value, dict):
        for v in value.values():
            yield from _callables(v, seen)
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _callables(v, seen)
    elif isinstance(value, functools.partial):
        yield from _callables(value.func, seen)
    elif callable(value):
        yield value


def expose_main_functions(spec):
    """Make the spec's functions written in the user's script findable by name.

    A worker process receives a physics written in the user's script
    (``__main__``) by value, but returns its fits with the standard pickle,
    which stores a function by module and name, and finds none of that name in
    the worker's own ``__main__``. Named there, they go back by name and load in
    the user's process, where they live.

    Parameters
    ----------
    spec : SystemSpec
        The system whose physics, inputs map and candidates are searched.
    """
    main = sys.modules["__main__"]
    for func in _callables([spec.physics, spec.physics_inputs]):
        name = getattr(func, "__qualname__", "")
        in_main = getattr(func, "__module__", None) == "__main__"
        if in_main and name.isidentifier() and not hasattr(main, name):
            setattr(main, name, func)


@contextlib.contextmanager
def _threads(n_threads):
    """At most ``n_threads`` threads in torch and the BLAS (None: as they are)."""
    if n_threads is None:
        yield
        return
    import torch
    from threadpoolctl import threadpool_limits

    before = torch.get_num_threads()
    torch.set_num_threads(n_threads)
    try:
        with threadpool_limits(limits=n_threads):
            yield
    finally:
        torch.set_num_threads(before)


def fit_model(name, model, ctx, deps, sink=None):
    """Choose and refit one model of the zoo.

    The run calls it in its own process, one model at a time; the model's
    search runs its candidates and folds on ``ctx.n_jobs`` workers.

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
        ``estimator``, ``extras`` (none),
        ``predictions`` (empty: no test record is simulated yet), ``fit_time``,
        ``n_epochs``, ``params``, ``warnings``, ``validation_rmse``,
        ``selection`` and ``validation_runs`` (the chosen candidate's free runs
        over the held-out blocks of each fold).
    """
    ctx = replace(ctx, sink=sink, label=name)
    try:
        expose_main_functions(ctx.system.spec)
    except AttributeError:  # a system whose spec is not bound: nothing to name
        pass
    with (
        warnings.catch_warnings(record=True) as caught,
        interrupts_raise(),
        _threads(ctx.n_threads),
    ):
        warnings.simplefilter("always")
        start = time.perf_counter()
        chosen, selection, runs = choose_and_refit(model, ctx, deps)
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
