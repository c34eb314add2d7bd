"""The pipeline's fit: a system's model zoo, each model once, in parallel.

:func:`run_experiment` runs a simulated system of the paper and a measured one
through the same steps, under the same :class:`RunSettings`, calling the
system's hooks (``new_result``, ``model_zoo``, ``job``, ``epochs_at_most``):
restore the models
an earlier run finished, fit the others in stages (a model after the models it
requires), write each to the run folder as it finishes, and score.
:func:`fit_zoos` does it for several seeds at once, in one pool of workers (a
measured run's further seeds, which only refit).
"""

import contextlib
import logging
import os
import time

import numpy as np
from joblib import Parallel, delayed, parallel_config
from joblib.parallel import get_active_backend

from skhybrid.experiments._registry import get_system
from skhybrid.experiments._settings import RunSettings, check_settings
from skhybrid.experiments.one_step._result import ExperimentResult
from skhybrid.experiments.run._progress import ProgressBars
from skhybrid.experiments.run._store import VALIDATION_RUNS
from skhybrid.experiments.run._workers import worker_restarts_explained

__all__ = ["ExperimentResult", "fit_seed", "fit_zoos", "run_experiment"]

logger = logging.getLogger(__name__)


def _threads_per_worker(client, cores, workers):
    """Threads of each worker: a Dask worker's own, or ``cores / workers`` locally.

    A model fitted in the run's own process (a measured model's refit) is given
    as many, so it computes what a worker would.
    """
    if client is not None:
        try:
            return max(1, min(client.nthreads().values()))
        except (AttributeError, ValueError):  # no worker yet
            return 1
    return max(1, cores // max(workers, 1))


def _dask_client(backend):
    """The Dask client of joblib's active backend, or None."""
    if type(backend).__name__ == "DaskDistributedBackend":
        return backend.client
    return None


@contextlib.contextmanager
def _local_threads(backend, n_threads):
    """Give each of joblib's local worker processes ``n_threads`` threads.

    joblib's ``inner_max_num_threads`` sets the thread count of torch and the BLAS
    libraries in the workers it starts. Only the default (loky) backend is
    configured here: another backend chosen by the caller (Dask, threads) keeps
    its own settings.
    """
    from joblib.parallel import LokyBackend

    if isinstance(backend, LokyBackend) and backend.inner_max_num_threads is None:
        with parallel_config(backend="loky", inner_max_num_threads=n_threads):
            yield
    else:
        yield


def _stages(requires, todo):
    """``todo`` in stages: a model runs after the models it ``requires``."""
    stages, placed = [], set()
    while len(placed) < len(todo):
        stage = [
            name
            for name in todo
            if name not in placed
            and all(dep in placed or dep not in todo for dep in requires[name])
        ]
        if not stage:
            raise ValueError(f"the zoo's requirements form a cycle among {todo}")
        stages.append(stage)
        placed.update(stage)
    return stages


def _dependency(result, folder, name, record=None, out=None):
    """What a model that requires ``name`` reads of it: its fits, record and runs."""
    # Its out-of-fold free runs (a measured model's), as stored or restored.
    runs = result.validation_runs.get(name)
    if out is not None:
        return {
            "model": out["estimator"],
            "validation_fit": out.get("extras", {}).get("validation_fit"),
            "fit": result.fits[name],
            "runs": runs,
        }
    key = result.store_key
    return {
        "model": folder.load_estimator(key, record),
        "validation_fit": folder.load_estimator(key, record, "validation_fit"),
        "fit": record["fit"],
        "runs": runs,
    }


def run_experiment(
    system,
    *,
    settings=None,
    quick=False,
    seed=0,
    n_jobs=1,
    progress=False,
    folder=None,
    data=None,
    searched=None,
):
    """Fit a system's model zoo and score it: a paper system or a measured one.

    Models are fitted with joblib, on the active backend: local processes by
    default, or a Dask cluster inside ``joblib.parallel_config(backend="dask")``.
    A paper system (section 6) is simulated and its zoo scored on interpolative
    and extrapolative test sets. A measured system's estimation records are
    loaded (a built-in benchmark's from ``data``) and its zoo fitted, every
    candidate chosen by blocked cross-validation of the records; no test record is read
    here: :func:`~skhybrid.experiments.run_system` seals the selections of its
    seeds first, then scores the test records. Models that need another's fit
    (the measured physics' corrections) run after it.

    Parameters
    ----------
    system : str or SystemSpec
        A built-in system by name: ``"pendulum"``, ``"double-pendulum"``,
        ``"dc-motor"`` (see ``skhybrid list``), a measured benchmark:
        ``"cascaded-tanks"``, ``"emps"``, ``"silverbox"``; or a
        :class:`~skhybrid.experiments.SystemSpec`, of the one-step protocol
        (:class:`~skhybrid.experiments.OneStepWindows`: simulated and scored
        here) or of the free-run one (a measured system).
    settings : RunSettings or None, default=None
        The run's ``quick``, seed and noise type; ``None`` takes
        ``RunSettings(quick=quick, seed=seed)``. A one-step system's sizes are
        its spec's (:class:`~skhybrid.experiments.OneStepWindows`'s ``sizes``
        and ``quick_sizes``).
    quick : bool, default=False
        Small data and few epochs (used only when ``settings`` is None).
    seed : int, default=0
        Seed of the data and the models (used only when ``settings`` is None).
    n_jobs : int, default=1
        Models fitted in parallel with joblib (-1: all cores, or every worker of a
        Dask cluster).
    progress : bool, default=False
        Show progress bars on standard error: models fitted (of the zoo's total),
        and epochs of all networks (counted across joblib workers, or Dask
        workers).
    folder : RunFolder or None, default=None
        Where each model's fitted estimator, predictions and scores are written as
        soon as it finishes; models already finished there are loaded, not fitted
        again.
    data : str, Path or None, default=None
        Folder holding a built-in measured benchmark's files (None fetches
        them).
    searched : dict of str to dict or None, default=None
        A measured system's searches made at another seed, by model:
        ``{"selection": ..., "runs": ..., "seed": ...}`` (see
        :func:`~skhybrid.experiments.free_run._seeds.run_seeds`). Each model then refits
        the candidate its search chose at this seed instead of searching again.

    Returns
    -------
    result : ExperimentResult or MeasuredResult
        The fitted models' predictions, scores, parameters and fit records (a
        measured system's: its selection and fitted models, not yet scored).
    """
    system = get_system(system)
    if settings is None:
        settings = RunSettings(quick=bool(quick), seed=seed)
    check_settings(system, settings)
    return fit_seed(
        system,
        settings,
        n_jobs=n_jobs,
        progress=progress,
        folder=folder,
        data=data,
        searched=searched,
    )


def fit_seed(system, settings, **kwargs):
    """Fit a resolved system's zoo at one seed; the result, timed.

    Parameters
    ----------
    system : ZooSystem
        The system, resolved once for the run (by the run's plan, or by
        :func:`run_experiment`).
    settings : RunSettings
        The seed's settings, checked.
    **kwargs
        ``n_jobs``, ``progress``, ``folder``, ``data`` and ``searched``, as
        :func:`run_experiment`'s.

    Returns
    -------
    result : ExperimentResult or MeasuredResult
        With its ``wall_time``.
    """
    start = time.perf_counter()
    (result,) = fit_zoos(system, [settings], **kwargs)
    result.wall_time = time.perf_counter() - start
    return result


class _SeedFit:
    """One seed's zoo to fit: its result, the models left, and their stages."""

    def __init__(self, system, settings, data, searched, folder):
        result = system.new_result(settings, data, searched=searched)
        self.result = result
        self.system = system = result.system  # a measured system bound to its spec
        self.settings = settings
        self.zoo = zoo = system.model_zoo(settings)
        self.requires = requires = system.requirements(zoo)
        key = result.store_key
        if folder is not None:
            system.open_folder(result, folder)
        done = {} if folder is None else folder.finished(key)
        done = {name: record for name, record in done.items() if name in zoo}
        for name, record in done.items():
            result.restore(name, record, folder)
        self.n_done = len(done)
        # The slowest fits (recurrent and state-space hybrids) first, so parallel
        # workers finish together.
        order = sorted(
            zoo,
            key=lambda name: (
                "rnn" not in name,
                "ensemble" not in name,
                "hybrid" not in name,
            ),
        )
        self.todo = [name for name in order if name not in done]
        self.stages = _stages(requires, self.todo)
        # The fits that models still to run require, as each finished or was stored.
        self.needed = {dep for name in self.todo for dep in requires[name]}
        self.deps = {
            name: _dependency(result, folder, name, record=done[name])
            for name in self.needed
            if name in done
        }

    def job(self, name, sink, n_jobs, n_threads):
        """The joblib call that fits ``name`` (its requirements' fits handed in)."""
        needs = {k: self.deps[k] for k in self.requires[name]}
        return self.system.job(
            name,
            self.zoo[name],
            self.result,
            needs,
            sink,
            n_jobs=n_jobs,
            n_threads=n_threads,
        )

    def record(self, name, out, folder):
        """Keep a finished model: in the result, the folder, and for its dependants."""
        _record(self.result, name, out, folder)
        if name in self.needed:
            self.deps[name] = _dependency(self.result, folder, name, out=out)

    def finish(self):
        """Order the fits as the zoo lists them and score what was predicted."""
        result, zoo = self.result, self.zoo
        # Keep the zoo's order (and the oracle first) whatever order fits finished in.
        result.fits = {k: result.fits[k] for k in zoo if k in result.fits}
        result.params = {k: result.params[k] for k in zoo if k in result.params}
        for split in result.test_splits:
            preds = result.predictions[split]
            result.predictions[split] = {
                k: preds[k] for k in ["oracle", *zoo] if k in preds
            }
        result.score()
        return result


def _tagged(index, call):
    """Run a joblib call and return it with ``index`` (which seed it fitted)."""
    func, args, kwargs = call
    return index, func(*args, **kwargs)


def fit_zoos(
    system,
    settings,
    *,
    n_jobs=1,
    progress=False,
    folder=None,
    data=None,
    searched=None,
):
    """Fit the zoo of a system at one or several seeds, in one pool of workers.

    Each seed's models run in stages (a model after those it requires); the
    stages of every seed run together. A measured system's search fits its
    models one at a time, each model's (candidate, fold) fits on every worker.
    Its refits at further seeds (``searched``: every choice made already) are
    single fits, so they run side by side, as a simulated system's models do,
    each with the threads a search's worker has: a refit computes the same
    numbers whether it runs alone or beside another.

    Parameters
    ----------
    system : ZooSystem
        The system, resolved once for the run (see
        :mod:`~skhybrid.experiments.run._contract`).
    settings : list of RunSettings
        Each seed's settings.
    n_jobs, progress, folder, data, searched
        As :func:`run_experiment`'s.

    Returns
    -------
    results : list of ExperimentResult or MeasuredResult
        One per entry of ``settings``, in its order.
    """
    seeds = [_SeedFit(system, s, data, searched, folder) for s in settings]
    system = seeds[0].system
    backend, _ = get_active_backend()
    client = _dask_client(backend)
    cores = os.cpu_count() or 1
    widest = max(
        (
            sum(len(fit.stages[i]) for fit in seeds if i < len(fit.stages))
            for i in range(max(len(fit.stages) for fit in seeds))
        ),
        default=1,
    )
    if n_jobs in (-1, None):
        workers = -1 if client is not None else cores
    elif system.parallel_folds:
        workers = max(1, n_jobs)
    else:
        workers = max(1, min(n_jobs, widest))
    n_threads = _threads_per_worker(client, cores, workers)
    model_workers, fold_workers = workers, 1
    # With workers, a fit in this process takes their threads; alone, it keeps
    # this process's own.
    job_threads = None
    if system.parallel_folds and searched is None:
        # Searches over folds: the models one at a time, each search running
        # its (candidate, fold) fits on every worker, so a long search never
        # leaves a core idle; its refit in this process as in a worker.
        model_workers, fold_workers = 1, workers
        job_threads = n_threads if workers != 1 else None
    elif system.parallel_folds and workers != 1:
        # Refits only: side by side, each as a search's worker computes.
        job_threads = n_threads
    bars = None
    if progress:
        budget = sum(
            system.epochs_at_most({n: fit.zoo[n] for n in fit.todo}, fit.result) or 0
            for fit in seeds
        )
        bars = ProgressBars(
            sum(len(fit.zoo) for fit in seeds),
            "; ".join(system.progress_label(fit.settings) for fit in seeds),
            client=client,
            n_done=sum(fit.n_done for fit in seeds),
            n_epochs=budget or None,
        )
    sink = None if bars is None else bars.sink

    def jobs(stage):
        for index, fit in enumerate(seeds):
            for name in fit.stages[stage] if stage < len(fit.stages) else ():
                call = fit.job(name, sink, fold_workers, job_threads)
                yield delayed(_tagged)(index, call)

    try:
        # loky may replace a worker between jobs, with a warning that reads as
        # if work were lost; it is said once, in a line that says none was.
        with worker_restarts_explained():
            for stage in range(max(len(fit.stages) for fit in seeds)):
                with _local_threads(backend, n_threads):
                    outputs = Parallel(
                        n_jobs=model_workers, return_as="generator_unordered"
                    )(jobs(stage))
                    for index, (name, out) in outputs:
                        seeds[index].record(name, out, folder)
                        if bars is not None:
                            bars.model_done(
                                name,
                                out["fit_time"],
                                out["n_epochs"],
                                **_whose(seeds, index, name),
                            )
    finally:
        if bars is not None:
            bars.close()
    return [fit.finish() for fit in seeds]


def _whose(seeds, index, name):
    """The seed a finished model names (with several seeds), and whose search
    chose what it refits (a measured system's further seeds)."""
    fit = seeds[index]
    searched = fit.result.searched.get(name)
    return {
        "seed": fit.settings.seed if len(seeds) > 1 else None,
        "searched_at": None if searched is None else searched.get("seed"),
    }


def _record(result, name, out, folder):
    """Add one finished model to ``result`` and, with a folder, write it there."""
    fit = {
        "fit_time": out["fit_time"],
        "n_epochs": out["n_epochs"],
        "warnings": out["warnings"],
    }
    # A measured model's choice by cross-validation, and what its search cost.
    for key in ("validation_rmse", "selection", "timing"):
        if key in out:
            fit[key] = out[key]
    predictions = {
        split: np.asarray(pred, dtype=float)
        for split, pred in out["predictions"].items()
    }
    stored = dict(predictions)
    if out.get("validation_runs") is not None:
        # A measured model's out-of-fold free runs: the
        # stochastic part of the report reads them, and a resume restores them.
        runs = [np.asarray(run, dtype=float) for run in out["validation_runs"]]
        result.validation_runs[name] = runs
        stored.update({f"{VALIDATION_RUNS}{i}": run for i, run in enumerate(runs)})
    result.fits[name] = fit
    result.keep_estimator(name, out["estimator"])
    if out["params"]:
        result.params[name] = out["params"]
    for split, pred in predictions.items():
        result.predictions[split][name] = pred
    if folder is not None:
        scores = [
            row
            for split in predictions
            if split in result.test_splits
            for row in result.model_rows(split, name)
        ]
        folder.save_model(
            result.store_key,
            name,
            out["estimator"],
            stored,
            {"fit": fit, "params": out["params"], "scores": scores},
            extras=out.get("extras"),
        )
