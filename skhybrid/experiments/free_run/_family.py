"""The model zoo of measured systems: its models, their candidates and fits.

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
(:mod:`skhybrid.experiments.free_run._seal`). That rule is written once, in
:mod:`skhybrid.experiments.free_run._search`; each model of the zoo is a
:class:`ZooModel`: its candidates, how one is fitted, and what it needs from
models fitted before it.
"""

import itertools
import logging
import sys
import time
import warnings
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import Ridge

from skhybrid.domain import StateSpaceModel, fit_progress
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.experiments._pickling import main_objects
from skhybrid.experiments._settings import on_device
from skhybrid.experiments._spec import pieces_per_record
from skhybrid.experiments.free_run._stack import STACK, choose_stack
from skhybrid.experiments.run._fitting import (
    fit_segments,
)
from skhybrid.experiments.run._progress import (
    Tagged,
    attach_epoch_logger,
    epoch_budget,
    physics_hook,
)
from skhybrid.hybrid import (
    NARXSimulator,
    PhysicsCorrection,
    TransformedInputSimulator,
)
from skhybrid.model_selection import RecordBlockSplit

__all__ = [
    "N_SPLITS",
    "MeasuredContext",
    "ZooModel",
    "epochs_at_most",
    "expose_main_functions",
    "fit_pieces_label",
    "pooled_rmse",
    "simulate_records",
    "zoo",
]

logger = logging.getLogger(__name__)

#: Folds of every choice: blocks of each estimation record (fewer where a block
#: would be shorter than 8 initialisation windows).
N_SPLITS = 4

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


def _records(U, Y, n, origins=None):
    """About ``n`` consecutive pieces cut from the records, in proportion to length.

    Each record gives at least one piece; within a record the pieces have equal
    length (the rest joins its last). ``origins``, a list, receives each
    piece's ``(record, start, stop)``.
    """
    pieces_U, pieces_Y = [], []
    lengths = [len(u) for u in U]
    for r, (u, y, k) in enumerate(
        zip(U, Y, pieces_per_record(lengths, n), strict=True)
    ):
        size = len(u) // k
        edges = [i * size for i in range(k)] + [len(u)]
        for a, b in itertools.pairwise(edges):
            pieces_U.append(u[a:b])
            pieces_Y.append(y[a:b])
            if origins is not None:
                origins.append((r, a, b))
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
    device : {"cpu", "cuda"}, default="cpu"
        Where the networks train (the run's ``--device``).
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
    device: str = "cpu"


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
    for name, obj in main_objects(spec.physics, spec.physics_inputs).items():
        if not hasattr(main, name):
            setattr(main, name, obj)


def _watch(estimator, ctx):
    """Put ``estimator``'s networks on the run's device; report their epochs."""
    on_device(estimator, ctx.device)
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
        train (:func:`~skhybrid.experiments.run._progress.epoch_budget` of its
        networks), in the order of its candidates; None for a model without
        networks. The progress bar's total (:func:`epochs_at_most`).
    choose : callable or None, default=None
        ``choose(model, ctx, deps)`` returns ``(fitted, selection, runs)`` as
        :func:`~skhybrid.experiments.free_run._search.choose_and_refit` does,
        for a model chosen otherwise than by searching its candidates (the
        family's stack, from the other models' out-of-fold runs); None
        searches ``candidates`` with ``fit``.
    lockstep : callable or None, default=None
        ``lockstep(ctx)`` says whether the model's fits on a search's folds
        gain from running side by side, their free runs simulated as one
        batch (a physics that is a
        :class:`~skhybrid.domain.StateSpaceModel`) or their networks' steps
        computed as one (on a GPU); None: they do not.
    """

    fit: object
    candidates: object
    requires: tuple = ()
    deterministic: bool = False
    choice: str = "chosen"
    notes: dict = field(default_factory=dict)
    epochs: object = None
    choose: object = None
    lockstep: object = None


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


def _count(n, noun):
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _same_pieces(U, pieces):
    """Whether the arrays ``U`` are the slices ``pieces`` (arrays) one for one."""
    return len(U) == len(pieces) and all(
        np.shape(u) == np.shape(p) and np.array_equal(u, p)
        for u, p in zip(U, pieces, strict=True)
    )


def fit_pieces_label(ctx, U):
    """What records a fit is given, in words: a fold's fit pieces or the records.

    A search fits each candidate on every fold's fit pieces of the estimation
    records, then refits the chosen one on the whole records; a fit learns
    which by comparing what it is given with the folds of ``ctx``'s records.

    Parameters
    ----------
    ctx : MeasuredContext
        The run's context (its whole estimation records).
    U : list of ndarray
        The inputs of the records the fit is given.

    Returns
    -------
    label : str
        ``"fold 2 of 4 (6 fit pieces)"``, ``"the whole records (3 records)"``,
        or ``"3 records"`` for records that are neither.
    """
    whole = [np.asarray(u) for u in ctx.U]
    if _same_pieces(U, whole):
        return f"the whole records ({_count(len(U), 'record')})"
    lengths = [len(u) for u in U]
    try:
        folds = list(RecordBlockSplit(N_SPLITS, n_init=ctx.n_init).split(whole))
    except ValueError:  # records too short to cut: not a search's fold
        folds = []
    for k, (fit, _) in enumerate(folds):
        if [b - a for _, a, b in fit] != lengths:
            continue
        if _same_pieces(U, [whole[r][a:b] for r, a, b in fit]):
            return f"fold {k + 1} of {len(folds)} ({_count(len(U), 'fit piece')})"
    return _count(len(U), "record")


def _candidate_label(choice, candidate, ctx):
    """A candidate in words: ``"n=4"``, ``"segments of 500"``, a hybrid's label."""
    if isinstance(candidate, dict):
        try:
            labels = ctx.system.hybrid_candidates(ctx)
        except (AttributeError, TypeError, ValueError):
            labels = {}
        for label, settings in labels.items():
            if settings == candidate:
                return str(label)
        return "candidate"
    if choice == "segment":
        return "unsegmented" if candidate is None else f"segments of {candidate}"
    return f"{choice}={candidate}"


def _fit_and_report(fit, choice, candidate, U, Y, ctx, deps, start):
    """``fit(candidate, U, Y, ctx, deps, start)``, its start and end reported.

    The fit's events (its start, its end with the seconds it took, and its
    networks' epochs and physics evaluations through the tagged sink) name the
    model, the candidate and what the fit is given: a search's fold or the
    refit on the whole records (:func:`fit_pieces_label`).
    """
    if ctx.sink is None:
        return fit(candidate, U, Y, ctx, deps, start)
    where = fit_pieces_label(ctx, U)
    sink = Tagged(
        ctx.sink,
        model=ctx.label or "model",
        where=where,
        fold=int(where.split()[1]) if where.startswith("fold ") else None,
        candidate=_candidate_label(choice, candidate, ctx),
    )
    sink.emit({"kind": "fit", "state": "start"})
    began = time.perf_counter()
    try:
        fitted = fit(candidate, U, Y, replace(ctx, sink=sink), deps, start)
    except BaseException:
        seconds = time.perf_counter() - began
        sink.emit({"kind": "fit", "state": "failed", "seconds": seconds})
        raise
    seconds = time.perf_counter() - began
    sink.emit({"kind": "fit", "state": "done", "seconds": seconds})
    return fitted


def _fit_physics(segment, U, Y, ctx, deps, start):
    """The system's physics fitted on the records, over segments of them."""
    system = ctx.system
    U_model = _model_inputs(system, U)
    model = system.physics(U_model, Y, ctx.dt, quick=ctx.quick)
    pieces = "whole records" if segment is None else f"segments of {segment} samples"
    hook = None
    if ctx.sink is not None:  # the run's progress shows its evaluations
        # Which fold (or the refit), and what the fit simulates: each record
        # (or fold piece) whole, or segments cut from them.
        where = fit_pieces_label(ctx, U)
        unit = "record" if segment is None else "segment"
        if segment is None and where.startswith("fold"):
            unit = "fit piece"
        span = "each whole" if segment is None else f"in segments of {segment} samples"
        hook = physics_hook(
            ctx.sink, f"{ctx.label or 'physics'}, {where}, {span}", unit=unit
        )
    with warnings.catch_warnings(record=True) as caught, fit_progress(hook):
        warnings.simplefilter("always")
        model = fit_segments(model, U_model, Y, segment)
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


def _physics_in_lockstep(ctx):
    """Whether the system's physics fits in lockstep (built on the first record)."""
    U_model = _model_inputs(ctx.system, ctx.U[:1])
    model = ctx.system.physics(U_model, ctx.Y[:1], ctx.dt, quick=ctx.quick)
    return bool(getattr(model, "fits_in_lockstep", False))


def _fit_narx(make_regressor, n, U, Y, ctx, deps, start):
    model = _watch(NARXSimulator(make_regressor(ctx), n), ctx)
    return model.fit(list(U), list(Y))


def _fit_correction(make_regressor, n, U, Y, ctx, deps, start):
    model = PhysicsCorrection(
        deps["physics"], make_regressor(ctx), n_steps=n, n_init=ctx.n_init
    )
    return _watch(model, ctx).fit(list(U), list(Y))


def _on_a_gpu(ctx):
    """Whether a model's networks train their folds in lockstep: on a GPU.

    The rule of the networks' own ``fits_in_lockstep`` (the state-space
    hybrid's, :attr:`skhybrid.neural.DenseRegressor.fits_in_lockstep`).
    """
    return ctx.device == "cuda"


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
    origins = []
    U, Y = _records(_model_inputs(system, U), Y, system.hybrid_records, origins)
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
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.fit_simulation(U, Y)
    # A piece too short to train on is said in terms of the records the fit
    # was given (the pieces are the run's own); other warnings stay quiet. The
    # model says which (the warnings caught may be other folds' where folds
    # train side by side in threads).
    del caught
    short = [
        f"samples {a}-{b} of record {i}"
        for i, a, b in (origins[k] for k in model.unused_records_)
    ]
    if short:
        warnings.warn(
            f"the state-space hybrid trains on none of {', '.join(short)} of "
            "the records it was fitted on (the estimation records at the "
            "refit, a fold's fit pieces in the search): each holds fewer than "
            "n_init + horizon samples. Lower the horizon or n_init, or give "
            "longer records.",
            UserWarning,
            stacklevel=2,
        )
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
        (the dense one's window), where the system has candidates the
        state-space hybrid, and last the stack of them all (``"stacked"``).
    """
    models = {
        "physics": ZooModel(
            _fit_physics,
            _segments,
            deterministic=True,
            choice="segment",
            lockstep=_physics_in_lockstep,
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
            lockstep=_on_a_gpu,
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
            lockstep=_on_a_gpu,
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
            lockstep=_on_a_gpu,
        ),
    }
    if system.has_hybrids(quick):
        # T and the architecture chosen by the folds, like every candidate.
        models["state-space hybrid"] = ZooModel(
            _fit_state_space_hybrid,
            _hybrids,
            requires=("physics",),
            epochs=_hybrid_epochs,
            lockstep=_on_a_gpu,
        )
    # Every fit reports its start and end to the run's progress.
    models = {
        name: replace(model, fit=partial(_fit_and_report, model.fit, model.choice))
        for name, model in models.items()
    }
    # Last: the weighted average of the others' free runs, its weights fitted on
    # their out-of-fold runs and its CV score cross-fitted.
    models[STACK] = ZooModel(
        None,
        None,
        requires=tuple(models),
        choose=partial(choose_stack, n_splits=N_SPLITS),
        notes={"weights": "non-negative, summing to one, fitted on the folds"},
    )
    return models
