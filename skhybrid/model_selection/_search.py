"""Choose a model of a dynamical system by cross-validated free-run error.

:class:`SimulationSearchCV` is scikit-learn's ``GridSearchCV`` for models judged
in simulation: every candidate, at every setting of its grid, is fitted on the
fit pieces of each fold of :class:`RecordBlockSplit` and simulated in free run
over the held-out blocks; the lowest mean RMSE over the folds wins and is refitted
on the whole records.
"""

import copy
import inspect
import threading
import time
import warnings
from numbers import Integral

import numpy as np
from joblib import effective_n_jobs
from scipy.stats import rankdata
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import FitFailedWarning
from sklearn.model_selection import ParameterGrid
from sklearn.utils.metaestimators import available_if
from sklearn.utils.parallel import Parallel, delayed
from sklearn.utils.validation import check_is_fitted

from skhybrid.model_selection._records import (
    RecordBlockSplit,
    _check_records,
    take_pieces,
)
from skhybrid.model_selection._simulation_fit import fit_records
from skhybrid.model_selection._stacking import (
    StackedSimulation,
    _as_2d,
    _cross_fitted_weights,
)
from skhybrid.utils._docstrings import RECORD_INPUTS_INITIAL, fill_doc
from skhybrid.utils._lockstep import run_in_lockstep
from skhybrid.utils._simulate_contract import SimulateContract
from skhybrid.utils._sklearn_compat import (
    HasMethods,
    Interval,
    StrOptions,
    _fit_context,
)

__all__ = ["SimulationSearchCV"]

#: The row of the stacked candidate in ``cv_results_``.
STACK_NAME = "stacked"


def _is_factory(obj):
    """A callable ``make(physics, **settings)`` rather than an estimator."""
    return callable(obj) and not isinstance(obj, type) and not hasattr(obj, "fit")


def _label(name, settings):
    if not settings:
        return name
    inner = ", ".join(f"{k}={v!r}" for k, v in settings.items())
    return f"{name}({inner})"


def _free_runs(model, U, Y, n_init):
    """Each block's free run from its first ``n_init`` outputs, as 2-D arrays."""
    runs = []
    for u, y in zip(U, Y, strict=True):
        run = _as_2d(model.simulate(u, y[:n_init]), len(y))
        y2 = np.asarray(y, dtype=float).reshape(len(y), -1)
        if run.shape != y2.shape:
            raise ValueError(
                f"simulate returned {run.shape[1]} output column(s) for a block "
                f"of {y2.shape[1]}."
            )
        runs.append(run)
    return runs


def _scored(arrays, n_init):
    """The samples after each block's first ``n_init``, flattened and joined."""
    return np.concatenate(
        [
            np.asarray(a, dtype=float).reshape(len(a), -1)[n_init:].ravel()
            for a in arrays
        ]
    )


def _keeping_warnings(func, *args):
    """``func(*args)`` and the warnings it raised, to raise again in the caller.

    A job run in a worker process (joblib's default backend) would otherwise
    lose them. In a thread (joblib's threading backend) the warnings reach the
    caller's own handlers, and ``warnings.catch_warnings`` is not thread-safe:
    nothing is kept there.
    """
    if threading.current_thread() is not threading.main_thread():
        return func(*args), []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = func(*args)
    return result, [(w.category, str(w.message)) for w in caught]


def _warn_again(kept):
    """Raise again, in the caller, the warnings a job kept."""
    for category, message in kept:
        warnings.warn(message, category, stacklevel=3)


def _fit_physics(physics, U, Y):
    """Fit a clone of the shared physics on a fold's fit pieces."""
    t0 = time.perf_counter()
    try:
        fitted = fit_records(clone(physics), U, Y)
    except Exception as exc:  # noqa: BLE001 - its candidates then score inf
        error = (f"{type(exc).__name__}: {exc}", type(exc).__name__)
        return None, error, time.perf_counter() - t0
    return fitted, None, time.perf_counter() - t0


def _takes_random_state(estimator, factory):
    if factory:
        try:
            return "random_state" in inspect.signature(estimator).parameters
        except (TypeError, ValueError):
            return False
    return "random_state" in getattr(estimator, "get_params", dict)()


def _build(estimator, settings, factory, physics, seed=None):
    seeded = {}
    if seed is not None and _takes_random_state(estimator, factory):
        seeded = {"random_state": seed}
    if factory:
        # A copy per candidate: one that altered the physics in place would
        # otherwise change the others' (and differ between n_jobs=1 and 2).
        return estimator(copy.deepcopy(physics), **settings, **seeded)
    return clone(estimator).set_params(**settings, **seeded)


def _fit_and_score(
    estimator, settings, factory, physics, U_fit, Y_fit, U_test, Y_test, n_init, seed
):
    """Fit one candidate setting on a fold, simulate its held-out blocks, score."""
    out = {
        "fit_time": 0.0,
        "score_time": 0.0,
        "score": np.inf,
        "error": None,
        "failed_at": None,
        "runs": None,
    }
    fitted_physics, physics_error = physics
    if factory and fitted_physics is None:
        out["error"] = f"the shared physics' fit failed: {physics_error[0]}"
        out["failed_at"] = ("the shared physics' fit", physics_error[1])
        return out
    t0 = time.perf_counter()
    try:
        model = fit_records(
            _build(estimator, settings, factory, fitted_physics, seed), U_fit, Y_fit
        )
    except Exception as exc:  # noqa: BLE001 - scored inf, reason in cv_results_
        out["fit_time"] = time.perf_counter() - t0
        out["error"] = f"fit: {type(exc).__name__}: {exc}"
        out["failed_at"] = ("fit", type(exc).__name__)
        return out
    out["fit_time"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            runs = _free_runs(model, U_test, Y_test, n_init)
            pred = _scored(runs, n_init)
            err = pred - _scored(Y_test, n_init)
            score = float(np.sqrt(np.mean(err**2)))
    except Exception as exc:  # noqa: BLE001 - scored inf, reason in cv_results_
        out["error"] = f"simulate: {type(exc).__name__}: {exc}"
    else:
        if np.isfinite(score):
            out["score"], out["runs"] = score, pred
        else:
            out["error"] = "simulate: the free run is not finite"
    out["score_time"] = time.perf_counter() - t1
    return out


def _in_lockstep(estimator, factory):
    """Whether a candidate's folds are fitted side by side, simulated as one.

    An estimator whose ``fits_in_lockstep`` is true (a
    :class:`~skhybrid.domain.StateSpaceModel`, a :class:`SimulationFit` of
    one) spends its fit in free runs whose cost hardly grows with the rows
    run at once.
    """
    return not factory and bool(getattr(estimator, "fits_in_lockstep", False))


def _fold_groups(n_splits, n_jobs, n_tasks):
    """The folds of each of ``n_tasks`` tasks in lockstep, split into groups.

    As few groups as keep every worker busy: one per task where the tasks are
    at least as many as the workers, else the workers shared out among them
    (a group's fits cost little more than one, so fewer, larger groups finish
    sooner where the workers have other jobs to run).
    """
    workers = max(1, effective_n_jobs(n_jobs))
    n_groups = min(n_splits, max(1, -(-workers // max(1, n_tasks))))
    return [[int(k) for k in g] for g in np.array_split(np.arange(n_splits), n_groups)]


def _in_lockstep_on_folds(func, calls):
    """``func(*args)`` for each of ``calls``, run in lockstep (one batch a step).

    The fits run in threads of this process, their free runs simulated in one
    batch (:func:`~skhybrid.domain.run_in_lockstep`); each returns what
    ``func`` returns. An interrupt or error ``func`` does not catch is raised.
    """
    outcomes = run_in_lockstep(calls, lambda args: func(*args))
    for outcome in outcomes:
        if isinstance(outcome, BaseException):
            raise outcome
    return outcomes


def _best_has(attr):
    def check(self):
        if hasattr(self, "best_estimator_"):
            getattr(self.best_estimator_, attr)  # AttributeError where it lacks it
            return True
        if hasattr(self, "best_index_"):
            raise AttributeError(
                f"SimulationSearchCV(refit=False) has no {attr}: refit the best "
                "candidate, or fit with refit=True."
            )
        return True

    return check


class SimulationSearchCV(SimulateContract, BaseEstimator):
    """Choose among models by their cross-validated free-run RMSE, then refit.

    Like :class:`~sklearn.model_selection.GridSearchCV`, for models of dynamical
    systems judged in simulation. Every candidate, at every setting of its grid,
    is fitted on the fit pieces of each fold of ``cv`` (by default
    :class:`RecordBlockSplit`) and simulated in free run over the fold's
    held-out blocks, each from its own first ``n_init`` measured outputs; the
    fold's score is the RMSE pooled over every held-out sample after those. The
    candidate setting with the lowest mean RMSE over the folds wins (the first
    one on a tie) and, with ``refit=True``, is refitted on the whole records.

    Parameters
    ----------
    candidates : list of tuple
        ``(name, estimator)`` or ``(name, estimator, param_grid)``.
        ``estimator`` is either a model of records with
        ``simulate(inputs, initial)``, cloned and given each setting by
        ``set_params``; or a factory ``make(physics, **settings)`` returning
        such a model, given the fold's fitted ``physics`` (see Notes). A model
        with ``fit_simulation(inputs, outputs)`` (a
        :class:`~skhybrid.domain.StateSpaceModel`, a
        :class:`~skhybrid.hybrid.StateSpaceHybridRegressor`) is fitted by it on
        whole records, as :class:`SimulationFit` fits it; any other by
        ``fit(U, Y)`` on lists of records.
        ``param_grid`` is a dict of lists, expanded by
        :class:`~sklearn.model_selection.ParameterGrid`.
    physics : estimator, default=None
        The physics shared by the factory candidates: a model of records
        (fitted as a candidate is: by ``fit_simulation`` where it has one),
        fitted once on each fold's fit pieces and once on the
        whole records for the refit. Required when a candidate is a factory.
    cv : int, RecordBlockSplit or None, default=None
        The folds: ``None`` for ``RecordBlockSplit(n_splits=4)``, an int for
        that many blocks, or a splitter whose ``split(U, Y)`` yields
        ``(fit, test)`` lists of ``(record_index, start, stop)`` slices.
    n_init : int, default=None
        Measured samples that start each free run (not scored). ``None`` takes
        ``cv.n_init`` where ``cv`` has one, else 1. It must agree with
        ``cv.n_init``.
    scoring : {"rmse"}, default="rmse"
        The free-run RMSE, pooled over the held-out samples of a fold. Lower is
        better (see Notes on the sign).
    stack : bool, default=False
        Also score a :class:`StackedSimulation` of the candidates, a row named
        ``"stacked"``, whose weights for each fold are fitted on the other
        folds' out-of-fold free runs. It wins only where it lowers the mean
        RMSE.
    refit : bool, default=True
        Refit the best candidate setting on the whole records as
        ``best_estimator_``.
    n_jobs : int, default=None
        Jobs run in parallel over the (candidate setting, fold) pairs, through
        joblib (so any joblib backend, Dask's included, runs them). ``None``
        means 1 unless in a :func:`joblib.parallel_config` context; -1 uses
        every processor.
    verbose : int, default=0
        Progress messages of joblib; 0 is silent.
    random_state : int or None, default=None
        Seed of the candidates that take a ``random_state`` (a parameter, or a
        keyword of a factory): fold ``k``'s fits get ``random_state + k`` and the
        refit ``random_state``, so the folds' networks differ as independent
        fits would. None leaves the candidates' own.

    Attributes
    ----------
    cv_results_ : dict of ndarray
        One row per candidate setting (and the stack, last, with
        ``stack=True``), in GridSearchCV's layout: ``params`` (each setting,
        with its ``candidate`` name), ``param_candidate`` and ``param_<key>``
        (masked arrays), ``split{k}_test_score``, ``mean_test_score``,
        ``std_test_score``, ``rank_test_score`` (1 for the lowest RMSE),
        ``mean_fit_time``, ``std_fit_time``, ``mean_score_time``,
        ``std_score_time``; also ``split{k}_error`` (why the fold scored inf,
        else None) and ``n_splits``.
    best_index_ : int
        The row of ``cv_results_`` that won.
    best_candidate_ : str
        Its candidate's name (``"stacked"`` for the stack).
    best_params_ : dict
        Its setting (without the name).
    best_score_ : float
        Its mean cross-validated RMSE (positive; lower is better).
    best_estimator_ : estimator
        The winner refitted on the whole records (with ``refit=True``).
    physics_ : estimator or None
        The physics fitted on the whole records for the refit, where the winner
        needed it.
    best_oof_runs_ : list of ndarray
        The best row's out-of-fold free runs: for each fold, its simulated
        samples of the held-out blocks after their first ``n_init``, flattened
        and joined block after block (the samples its score is computed on).
        The residuals of a model no fit of which saw them; ``None`` for the
        stack.
    n_splits_ : int
        The folds used.
    n_splits_reason_ : str
        Why that many, for a run record.
    refit_time_ : float
        Seconds taken by the refit.
    stack_weights_ : ndarray of shape (n_candidate_settings,)
        With ``stack=True``: the stack's weights fitted on every fold's
        out-of-fold runs (used by the refitted stack), aligned with the rows of
        ``cv_results_`` before the stack's; 0 for a setting not run on every
        fold.
    stack_fold_weights_ : ndarray of shape (n_splits, n_candidate_settings)
        With ``stack=True``: row ``k`` holds the weights that scored fold ``k``,
        fitted on the other folds only.

    See Also
    --------
    RecordBlockSplit : The default folds.
    StackedSimulation : The stacked candidate.
    sklearn.model_selection.GridSearchCV : The same search for ``(X, y)``
        estimators.

    Notes
    -----
    **Sign.** ``scoring="rmse"``: every ``*_test_score`` and ``best_score_``
    is an RMSE, positive, and lower is better, so ``best_score_ ==
    cv_results_["mean_test_score"][best_index_]`` is the minimum and
    ``rank_test_score`` ranks upwards from it. (scikit-learn's scores are
    "greater is better"; its ``neg_root_mean_squared_error`` would be the
    negative of these.)

    **Failures.** A fit that raises, a free run that raises, or one that is not
    finite scores ``inf`` on its fold, its reason kept in ``split{k}_error``,
    and a :class:`~sklearn.exceptions.FitFailedWarning` says how many did. If
    every row has an infinite mean, ``fit`` raises a ``ValueError`` with the
    reasons. A candidate whose fit raised the same exception on every fold
    (of every setting of its grid), or whose shared physics did, is broken
    rather than outranked: ``fit`` raises a ``ValueError`` naming it, its
    error and what to do, as ``GridSearchCV`` raises where every fit fails.

    **Fit on records.** A candidate's ``fit(X, y)`` may be scikit-learn's
    one-step fit on 2-D windows (a domain model's is, as ``check_estimator``
    tests it). The search therefore fits a model that has
    ``fit_simulation(inputs, outputs)`` by that method, on each fold's fit
    pieces (:class:`SimulationFit` with ``segment=None``), and any other by
    ``fit(U, Y)``. ``SimulationFit(model)`` as a candidate searches the
    segment length of multiple shooting as well, ``{"segment": [None, 500]}``.

    **Shared physics.** Candidates built on a fitted physics (a correction of
    its free run, a hybrid warm-started from it) must not fit the same physics
    again: give it as ``physics`` and give those candidates as factories
    ``make(physics, **settings) -> model``. The search fits a clone of
    ``physics`` once on each fold's fit pieces, hands it fitted to every
    factory candidate of that fold (a copy each, so none can alter another's),
    and calls ``fit(U, Y)`` on the model returned; for the refit it fits the
    physics once on the whole records. The physics alone is a candidate as
    ``lambda physics: FrozenEstimator(physics)``
    (:class:`sklearn.frozen.FrozenEstimator`, whose ``fit`` does nothing).

    **Stacking.** With ``stack=True`` the candidate settings run on every fold
    are averaged with non-negative weights summing to one
    (:func:`scipy.optimize.nnls` with the sum as a constraint row), fitted to
    the measured outputs of the held-out samples. Fold ``k``'s weights are
    fitted on the other folds' out-of-fold runs only, and applied to fold
    ``k``'s, so the stack's score is cross-fitted like the others'. The
    refitted stack applies the weights fitted on every fold to the candidates
    refitted on the whole records (those with a positive weight).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.base import BaseEstimator
    >>> from skhybrid.model_selection import SimulationSearchCV
    >>> class Gain(BaseEstimator):
    ...     '''y = gain * u, fitted by least squares.'''
    ...     def __init__(self, scale=1.0):
    ...         self.scale = scale
    ...     def fit(self, U, Y):
    ...         u, y = np.concatenate(U).ravel(), np.concatenate(Y).ravel()
    ...         self.gain_ = self.scale * (u @ y) / (u @ u)
    ...         return self
    ...     def simulate(self, inputs, initial):
    ...         return self.gain_ * np.asarray(inputs)
    >>> rng = np.random.default_rng(0)
    >>> U = [rng.normal(size=(200, 1))]
    >>> Y = [2.0 * U[0] + 0.1 * rng.normal(size=(200, 1))]
    >>> search = SimulationSearchCV(
    ...     [("gain", Gain(), {"scale": [0.5, 1.0]})], n_init=2
    ... ).fit(U, Y)
    >>> search.best_candidate_, search.best_params_, search.n_splits_
    ('gain', {'scale': 1.0}, 4)
    >>> bool(search.best_score_ < 0.2)
    True
    """

    _parameter_constraints = {
        "candidates": [list],
        "physics": [HasMethods(["fit"]), None],
        "cv": [
            Interval(Integral, 2, None, closed="left"),
            HasMethods(["split", "get_n_splits"]),
            None,
        ],
        "n_init": [Interval(Integral, 1, None, closed="left"), None],
        "scoring": [StrOptions({"rmse"})],
        "stack": ["boolean"],
        "refit": ["boolean"],
        "n_jobs": [Integral, None],
        "verbose": ["verbose"],
        "random_state": [Interval(Integral, 0, 2**32 - 1 - 64, closed="both"), None],
    }

    def __init__(
        self,
        candidates,
        *,
        physics=None,
        cv=None,
        n_init=None,
        scoring="rmse",
        stack=False,
        refit=True,
        n_jobs=None,
        verbose=0,
        random_state=None,
    ):
        self.candidates = candidates
        self.physics = physics
        self.cv = cv
        self.n_init = n_init
        self.scoring = scoring
        self.stack = stack
        self.refit = refit
        self.n_jobs = n_jobs
        self.verbose = verbose
        self.random_state = random_state

    # -- settings ----------------------------------------------------------------
    def _resolve_cv(self):
        cv_init = getattr(self.cv, "n_init", None)
        if self.n_init is not None and cv_init is not None and cv_init != self.n_init:
            raise ValueError(
                f"n_init={self.n_init!r} differs from cv.n_init={cv_init!r}; the "
                "free runs must start from the window the folds were cut for: set "
                "one of them only."
            )
        n_init = self.n_init or cv_init or 1
        if self.cv is None or isinstance(self.cv, Integral):
            return RecordBlockSplit(self.cv or 4, n_init=n_init), n_init
        return self.cv, n_init

    def _rows(self):
        """Every candidate setting: (name, estimator, settings, is_factory)."""
        if not self.candidates:
            raise ValueError(
                "candidates must hold at least one (name, estimator) pair; got "
                "candidates=[]."
            )
        rows, names = [], []
        for i, entry in enumerate(self.candidates):
            if not isinstance(entry, (tuple, list)) or len(entry) not in (2, 3):
                raise ValueError(
                    f"candidates[{i}] must be (name, estimator) or (name, "
                    f"estimator, param_grid); got {entry!r}."
                )
            name, est, grid = (*entry, {}) if len(entry) == 2 else entry
            if not isinstance(name, str) or not name:
                raise ValueError(
                    f"candidates[{i}] has name {name!r}; names must be non-empty str."
                )
            if name in names or (self.stack and name == STACK_NAME):
                taken = "names the stack" if name == STACK_NAME else "is repeated"
                raise ValueError(
                    f"candidates[{i}] has name {name!r}, which {taken}; give each "
                    "candidate its own name."
                )
            names.append(name)
            factory = _is_factory(est)
            if not factory and not (hasattr(est, "fit") and hasattr(est, "simulate")):
                raise ValueError(
                    f"candidates[{i}] ({name!r}) has estimator {est!r}; expected an "
                    "instance with fit(U, Y) and simulate(inputs, initial), or a "
                    "factory make(physics, **settings)."
                )
            if factory and self.physics is None:
                raise ValueError(
                    f"candidates[{i}] ({name!r}) is a factory of a fitted physics, "
                    "but physics=None; give the shared physics as physics=."
                )
            if not isinstance(grid, dict):
                raise ValueError(  # noqa: TRY004 (a parameter value, not a type)
                    f"candidates[{i}] ({name!r}) has param_grid {grid!r}; expected "
                    "a dict of lists."
                )
            if "candidate" in grid:
                raise ValueError(
                    f"candidates[{i}] ({name!r}) has a setting named 'candidate', "
                    "which cv_results_ keeps for the candidate's name; rename it."
                )
            self._check_grid_keys(i, name, est, grid, factory)
            try:
                settings = list(ParameterGrid(grid))
            except (TypeError, ValueError) as exc:
                raise ValueError(
                    f"candidates[{i}] ({name!r}) has param_grid {grid!r}: {exc}"
                ) from exc
            rows.extend((name, est, s, factory) for s in settings)
        return rows

    @staticmethod
    def _check_grid_keys(i, name, est, grid, factory):
        if factory:
            try:
                inspect.signature(est).bind(None, **dict.fromkeys(grid))
            except TypeError as exc:
                raise ValueError(
                    f"candidates[{i}] ({name!r}) is a factory that cannot take "
                    f"(physics, {', '.join(f'{k}=...' for k in grid)}): {exc}."
                ) from exc
            except ValueError:  # no signature (a builtin): let the call decide
                pass
            return
        if hasattr(est, "get_params"):
            valid = est.get_params()
            unknown = sorted(set(grid) - set(valid))
            if unknown:
                raise ValueError(
                    f"candidates[{i}] ({name!r}) has param_grid keys {unknown} that "
                    f"are not parameters of {type(est).__name__}; expected some of "
                    f"{sorted(valid)}."
                )

    # -- fit ---------------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, U, Y):
        """Score every candidate setting on every fold, choose, and refit.

        Parameters
        ----------
        U : list of array-like of shape (n_times_i, n_inputs)
            Inputs of each estimation record.
        Y : list of array-like of shape (n_times_i, n_outputs)
            Measured outputs of each record, aligned with ``U``.

        Returns
        -------
        self : SimulationSearchCV
            The fitted search.
        """
        splitter, n_init = self._resolve_cv()
        rows = self._rows()
        U, Y = _check_records(U, Y)
        folds = list(splitter.split(U, Y))
        n_splits = len(folds)
        if hasattr(splitter, "get_n_splits_reason"):
            reason = splitter.get_n_splits_reason(U, Y)
        else:
            reason = f"{n_splits} folds from {splitter!r}."
        pieces = [
            (take_pieces(U, Y, fit), take_pieces(U, Y, test)) for fit, test in folds
        ]
        parallel = Parallel(n_jobs=self.n_jobs, verbose=self.verbose)
        if any(factory for *_, factory in rows):
            physics = self._run_on_folds(
                parallel,
                [(_fit_physics, _in_lockstep(self.physics, False))],
                lambda row, k: (self.physics, *pieces[k][0]),
                n_splits,
            )[0]
        else:
            physics = [(None, None, 0.0)] * n_splits
        self.physics_fit_time_ = np.array([t for *_, t in physics])

        def arguments(i, k):
            _, est, settings, factory = rows[i]
            seed = None if self.random_state is None else self.random_state + k
            return (
                est,
                settings,
                factory,
                physics[k][:2],
                *pieces[k][0],
                *pieces[k][1],
                n_init,
                seed,
            )

        out = self._run_on_folds(
            parallel,
            [(_fit_and_score, _in_lockstep(est, f)) for _, est, _, f in rows],
            arguments,
            n_splits,
        )
        params = [{"candidate": name, **settings} for name, _, settings, _ in rows]
        if self.stack:
            targets = [_scored(y_test, n_init) for _, (_, y_test) in pieces]
            out.append(self._stack_row(out, targets))
            params.append({"candidate": STACK_NAME})
        self.n_splits_ = n_splits
        self.n_splits_reason_ = reason
        self.cv_results_ = self._results(params, out, n_splits)
        self._n_init = n_init
        means = self.cv_results_["mean_test_score"]
        self.best_index_ = int(np.argmin(means))  # the first on a tie
        self._raise_if_a_candidate_never_fits(out)
        self._warn_failures(out)
        if not np.isfinite(means[self.best_index_]):
            raise ValueError(
                "every candidate setting failed on some fold, so none has a "
                "finite mean RMSE:\n" + self._error_summary(out)
            )
        best = params[self.best_index_]
        self.best_candidate_ = best["candidate"]
        self.best_params_ = {k: v for k, v in best.items() if k != "candidate"}
        self.best_score_ = float(means[self.best_index_])
        self.best_oof_runs_ = (
            [r["runs"] for r in out[self.best_index_]]
            if self.best_candidate_ != STACK_NAME
            else None
        )
        if self.refit:
            t0 = time.perf_counter()
            self.best_estimator_ = self._refit(rows, U, Y)
            self.refit_time_ = time.perf_counter() - t0
        return self

    def _run_on_folds(self, parallel, tasks, arguments, n_splits):
        """Every task on every fold, through joblib; ``out[task][fold]``.

        ``tasks`` holds ``(func, lockstep)`` pairs and ``arguments(task,
        fold)`` gives ``func``'s arguments. A task in lockstep runs its folds
        as one job per group (:func:`_fold_groups`), their fits side by side
        with their free runs simulated as one batch; any other runs one job
        per fold.
        """
        groups = _fold_groups(
            n_splits, self.n_jobs, sum(lockstep for _, lockstep in tasks)
        )
        jobs, slots = [], []
        for i, (func, lockstep) in enumerate(tasks):
            if lockstep:
                for group in groups:
                    calls = [arguments(i, k) for k in group]
                    jobs.append(
                        delayed(_keeping_warnings)(_in_lockstep_on_folds, func, calls)
                    )
                    slots.append([(i, k) for k in group])
            else:
                for k in range(n_splits):
                    jobs.append(delayed(_keeping_warnings)(func, *arguments(i, k)))
                    slots.append([(i, k)])
        out = [[None] * n_splits for _ in tasks]
        for slot, (result, warned) in zip(slots, parallel(jobs), strict=True):
            _warn_again(warned)
            results = result if len(slot) > 1 or tasks[slot[0][0]][1] else [result]
            for (i, k), value in zip(slot, results, strict=True):
                out[i][k] = value
        return out

    def _stack_row(self, out, targets):
        """Cross-fitted scores of the stack of the settings run on every fold."""
        n_rows, n_splits = len(out), len(targets)
        eligible = [
            i for i in range(n_rows) if all(r["runs"] is not None for r in out[i])
        ]
        self.stack_weights_ = np.zeros(n_rows)
        self.stack_fold_weights_ = np.zeros((n_splits, n_rows))
        row = [
            {
                "fit_time": 0.0,
                "score_time": 0.0,
                "score": np.inf,
                "error": None,
                "runs": None,
            }
            for _ in range(n_splits)
        ]
        if len(eligible) < 2:
            for r in row:
                r["error"] = (
                    f"stack: {len(eligible)} candidate setting(s) ran on every "
                    "fold; a stack needs two."
                )
            return row
        t0 = time.perf_counter()
        oof = [[out[i][k]["runs"] for k in range(n_splits)] for i in eligible]
        fold_w, w = _cross_fitted_weights(oof, targets)
        elapsed = (time.perf_counter() - t0) / n_splits
        self.stack_weights_[eligible] = w
        self.stack_fold_weights_[:, eligible] = fold_w
        for k in range(n_splits):
            P = np.column_stack([runs[k] for runs in oof])
            err = P @ fold_w[k] - targets[k]
            row[k]["score"] = float(np.sqrt(np.mean(err**2)))
            row[k]["fit_time"] = elapsed
        return row

    @staticmethod
    def _results(params, out, n_splits):
        n_rows = len(params)
        scores = np.array([[r["score"] for r in o] for o in out], dtype=float)
        fit_t = np.array([[r["fit_time"] for r in o] for o in out], dtype=float)
        score_t = np.array([[r["score_time"] for r in o] for o in out], dtype=float)
        results = {}
        keys = sorted({k for p in params for k in p} - {"candidate"})
        for key in ["candidate", *keys]:
            values = np.empty(n_rows, dtype=object)
            mask = np.ones(n_rows, dtype=bool)
            for i, p in enumerate(params):
                if key in p:
                    values[i], mask[i] = p[key], False
            results[f"param_{key}"] = np.ma.MaskedArray(values, mask=mask)
        results["params"] = params
        for k in range(n_splits):
            results[f"split{k}_test_score"] = scores[:, k]
        with np.errstate(invalid="ignore"):
            results["mean_test_score"] = scores.mean(axis=1)
            results["std_test_score"] = scores.std(axis=1)
        results["rank_test_score"] = rankdata(
            results["mean_test_score"], method="min"
        ).astype(np.int32)
        results["mean_fit_time"] = fit_t.mean(axis=1)
        results["std_fit_time"] = fit_t.std(axis=1)
        results["mean_score_time"] = score_t.mean(axis=1)
        results["std_score_time"] = score_t.std(axis=1)
        for k in range(n_splits):
            errors = np.empty(n_rows, dtype=object)
            errors[:] = [o[k]["error"] for o in out]
            results[f"split{k}_error"] = errors
        results["n_splits"] = np.full(n_rows, n_splits)
        return results

    def _error_summary(self, out):
        lines = []
        for i, o in enumerate(out):
            label = _label(
                self.cv_results_["params"][i]["candidate"],
                {
                    k: v
                    for k, v in self.cv_results_["params"][i].items()
                    if k != "candidate"
                },
            )
            for k, r in enumerate(o):
                if r["error"] is not None:
                    lines.append(f"  {label}, fold {k}: {r['error']}")
        return "\n".join(lines)

    def _raise_if_a_candidate_never_fits(self, out):
        """Raise where a candidate's fit failed alike on every fold.

        A candidate whose every setting failed to fit on every fold with the
        same exception is broken, not outranked (scikit-learn's GridSearchCV
        raises where every fit fails): another candidate winning in its place
        would hide it.
        """
        params = self.cv_results_["params"]
        by_name = {}
        for p, o in zip(params, out, strict=False):
            by_name.setdefault(p["candidate"], []).extend(o)
        for name, fits in by_name.items():
            if name == STACK_NAME:
                continue
            kinds = {r.get("failed_at") for r in fits}
            if len(kinds) != 1 or None in kinds:
                continue
            (stage, exc_name) = kinds.pop()
            if stage == "fit":
                what = (
                    f"fit(U, Y) raised {exc_name} on every fold. The search "
                    "fits a candidate on lists of records (each fold's fit "
                    "pieces): by fit_simulation(inputs, outputs) where it has "
                    "one (as SimulationFit does), else by fit(U, Y); a model "
                    "fitted on (X, y) windows needs a fit(U, Y) that takes "
                    "records. Reproduce the error with clone(estimator).fit(U, "
                    "Y) on the records, fix the candidate, or leave it out of "
                    "candidates."
                )
            else:
                what = (
                    f"its shared physics' fit raised {exc_name} on every fold; "
                    "check that physics fits on these records (fit_simulation "
                    "where it has one, else fit(U, Y))."
                )
            raise ValueError(
                f"candidate {name!r} failed on all {len(fits)} of its fold fits: "
                f"{what} The first fold's error: {fits[0]['error']}"
            )

    def _warn_failures(self, out):
        n_failed = sum(r["error"] is not None for o in out for r in o)
        if n_failed:
            warnings.warn(
                f"{n_failed} of {sum(len(o) for o in out)} fold fits scored inf "
                "(their reasons are in cv_results_['split{k}_error']):\n"
                + self._error_summary(out),
                FitFailedWarning,
                stacklevel=3,
            )

    def _refit(self, rows, U, Y):
        if self.best_candidate_ == STACK_NAME:
            chosen = [i for i, w in enumerate(self.stack_weights_) if w > 0]
        else:
            chosen = [self.best_index_]
        self.physics_ = None
        if any(rows[i][3] for i in chosen):
            self.physics_ = fit_records(clone(self.physics), U, Y)
        fitted = []
        for i in chosen:
            name, est, settings, factory = rows[i]
            model = fit_records(
                _build(est, settings, factory, self.physics_, self.random_state),
                U,
                Y,
            )
            fitted.append((_label(name, settings), model))
        if self.best_candidate_ != STACK_NAME:
            return fitted[0][1]
        return StackedSimulation._from_fitted(fitted, self.stack_weights_[chosen])

    # -- delegation --------------------------------------------------------------
    @available_if(_best_has("simulate"))
    @fill_doc(record_inputs_initial=RECORD_INPUTS_INITIAL)
    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Simulate the refitted best model in free run.

        Parameters
        ----------
        %(record_inputs_initial)s
        init : {"measured", "least_squares"}, default="measured"
            How the simulation starts; passed on where it is not the default.
        n_samples : int, default=None
            Sample paths, for a best model with a noise model; passed on where
            given.
        random_state : int, RandomState instance or None, default=None
            Passed on where given.
        return_std : bool, default=False
            Passed on where True.

        Returns
        -------
        outputs : ndarray
            What ``best_estimator_.simulate`` returns.
        """
        check_is_fitted(self, "best_estimator_")
        kwargs = {}
        if init != "measured":
            kwargs["init"] = init
        if n_samples is not None:
            kwargs["n_samples"] = n_samples
        if random_state is not None:
            kwargs["random_state"] = random_state
        if return_std:
            kwargs["return_std"] = return_std
        return self.best_estimator_.simulate(inputs, initial, **kwargs)

    @available_if(_best_has("predict"))
    def predict(self, X):
        """Predict with the refitted best model.

        Parameters
        ----------
        X : array-like
            What ``best_estimator_.predict`` takes.

        Returns
        -------
        y_pred : ndarray
            What ``best_estimator_.predict`` returns.
        """
        check_is_fitted(self, "best_estimator_")
        return self.best_estimator_.predict(X)
