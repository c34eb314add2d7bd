"""The measured zoo's one choose-refit rule: the search, its cache, one model's fit.

Every model of the zoo (:mod:`skhybrid.experiments.free_run._family`) is chosen by
blocked cross-validation of the estimation records
(:class:`~skhybrid.model_selection.SimulationSearchCV` over
:class:`~skhybrid.model_selection.RecordBlockSplit`) and its choice refitted on
the whole records: :func:`choose_and_refit`, written once. :func:`fit_model`
runs it for one model, in the run's own process, the search's (candidate, fold)
fits on the run's joblib workers; a deterministic fit is computed once per
records and kept in the run folder's cache.
"""

import contextlib
import hashlib
import logging
import pickle
import time
import warnings
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import FitFailedWarning

from skhybrid.experiments._pickling import dump_fit, load_fit
from skhybrid.experiments._spec import records_digest
from skhybrid.experiments.free_run._family import (
    N_SPLITS,
    expose_main_functions,
    zoo,
)
from skhybrid.experiments.run._fitting import interrupts_raise, physical_params
from skhybrid.experiments.run._store import _write_atomic
from skhybrid.model_selection import RecordBlockSplit, SimulationSearchCV

__all__ = ["choose_and_refit", "fit_model"]

logger = logging.getLogger(__name__)


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

    @property
    def fits_in_lockstep(self):
        """Whether the search fits this model's folds side by side.

        Their free runs are then simulated as one batch
        (:class:`~skhybrid.model_selection.SimulationSearchCV`); the model's
        ``lockstep`` says so (the physics, where it is a StateSpaceModel).
        """
        lockstep = getattr(self.model, "lockstep", None)
        return lockstep is not None and bool(lockstep(self.ctx))

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
            model = _read(cached)
            if model is not None:
                self.model_ = model
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
    return None if ctx.cache is None else Path(ctx.cache) / f"{key}.pickle"


def _keep(model, path):
    """Keep a deterministic fit in the run's cache (best effort: a model that
    cannot be stored is fitted again where it is needed).

    Written in whichever process fitted it, a worker of a search included: the
    functions and classes of the user's script are stored by name
    (:func:`~skhybrid.experiments._pickling.dump_fit`), which a worker's copies
    of them, received by value, allow.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        _write_atomic(path, lambda p: dump_fit(model, p))
    except (OSError, pickle.PicklingError, AttributeError, TypeError) as exc:
        logger.info("not cached (%s): %s", path.name, exc)


def _read(path):
    """A fit kept in the run's cache, or None where it cannot be read here.

    The functions and classes of the user's script it names are this
    process's ``__main__``'s (in a worker, those the spec named there).
    """
    try:
        return load_fit(path)
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError) as exc:
        logger.info("cached fit not read (%s): %s", path.name, exc)
        return None


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
    if model.choose is not None:  # the family's stack: a choice of its own
        return model.choose(model, ctx, deps)
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
        # What the search cost (fit_model moves it out of the selection, whose
        # hash must not depend on it): a fold's fit and free runs by candidate
        # (the wall time of its group where folds run side by side), the refit.
        "fold_seconds_by_candidate": {
            str(k): float(f + t)
            for k, f, t in zip(
                keys,
                results["mean_fit_time"],
                results["mean_score_time"],
                strict=True,
            )
        },
        "refit_seconds": float(getattr(search, "refit_time_", 0.0)),
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


@contextlib.contextmanager
def _threads(n_threads):
    """At most ``n_threads`` threads in torch and the BLAS (None: as they are)."""
    if n_threads is None:
        yield
        return
    import torch
    from threadpoolctl import threadpool_limits

    before = torch.get_num_threads()
    n_threads = min(n_threads, before)  # a limit only: never more than before
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
    choice is sealed (:func:`skhybrid.experiments.free_run._scoring.score_tests`).

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
        ``timing`` (a fold's seconds by candidate and the refit's, where the
        model was searched), ``n_epochs``, ``params``, ``warnings``,
        ``validation_rmse``,
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
    timing = {
        key: selection.pop(key)
        for key in ("fold_seconds_by_candidate", "refit_seconds")
        if key in selection
    }
    if chosen is None:
        selection.setdefault("failed", "every candidate's fit failed")
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
        "timing": timing,
        "n_epochs": None if chosen is None else _n_epochs(chosen),
        "params": params,
        "warnings": messages,
        "validation_rmse": selection["validation_rmse"],
        "selection": selection,
        "validation_runs": runs,
    }
