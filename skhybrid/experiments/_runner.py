"""Fit the model zoo on one system and score it on its test sets."""

import contextlib
import logging
import os
import time
import warnings

import numpy as np
from joblib import Parallel, delayed, parallel_config
from joblib.parallel import get_active_backend

from skhybrid.diagnostics import ljung_box_test, rmse_db
from skhybrid.experiments._fitting import interrupts_raise, n_epochs, physical_params
from skhybrid.experiments._paper_stochastic import VALIDATION_SPLIT, paper_stochastic
from skhybrid.experiments._progress import (
    ProgressBars,
    attach_epoch_logger,
    epoch_budget,
)
from skhybrid.experiments._registry import get_system
from skhybrid.experiments._settings import ExperimentSettings
from skhybrid.experiments._spec import records_digest
from skhybrid.experiments._zoo import model_zoo

__all__ = ["ExperimentResult", "run_experiment"]

#: Prefix of a measured model's stored out-of-fold free runs.
VALIDATION = "validation/"

logger = logging.getLogger(__name__)


class ExperimentResult:
    """Everything one run of one system produced.

    Parameters
    ----------
    system : System
        The system.
    settings : ExperimentSettings
        Sizes, architectures and seed.
    splits : dict of str to Bunch
        The simulated data of each split.

    Attributes
    ----------
    system : System
        The system.
    settings : ExperimentSettings
        Sizes, architectures and seed.
    splits : dict of str to Bunch
        The simulated data of each split.
    predictions : dict of str to dict of str to ndarray
        ``predictions[split][model]``; the key ``"oracle"`` holds the true equations
        applied to the noisy inputs.
    rows : list of dict
        One row per model, split and output (the content of ``results.csv``).
    params : dict of str to dict
        Fitted physical parameters and standard errors of each model that has any.
    fits : dict of str to dict
        Fit time, epochs and warnings of each model.
    hull : dict of str to float
        Share of each test split's rows outside the convex hull of the training rows.
    validation : Bunch or None
        New episodes like the training split's, predicted by every model (its
        predictions under ``predictions["validation"]``), never scored as a test:
        the chosen model and its noise model come from them.
    stochastic : dict
        The chosen model's stochastic part (see
        :func:`~skhybrid.experiments._paper_stochastic.paper_stochastic`).
    wall_time : float
        Seconds for the whole run.
    """

    def __init__(self, system, settings, splits):
        self.system = system
        self.settings = settings
        self.splits = splits
        self.predictions = {name: {} for name in splits if name != "train"}
        self.predictions[VALIDATION_SPLIT] = {}
        self.rows = []
        self.params = {}
        self.fits = {}
        self.hull = {}
        self.validation = None
        self.stochastic = {}
        self.wall_time = float("nan")

    @property
    def test_splits(self):
        return [name for name in self.splits if name != "train"]

    @property
    def store_key(self):
        """The run folder's name for this system's models."""
        return self.system.name

    @property
    def target_names(self):
        return list(self.splits["train"].target_names)

    def model_rows(self, split, model):
        """The scores of one model on one test split, one row per output.

        Parameters
        ----------
        split : str
            A test split's name.
        model : str
            A model's name.

        Returns
        -------
        rows : list of dict
            The rows of ``results.csv``.
        """
        return _model_rows(self, split, model)

    def windowed_db(self, split):
        """RMSE in dB of every model over short windows of one test split.

        Parameters
        ----------
        split : str
            A test split's name.

        Returns
        -------
        rmse_db : dict of str to ndarray of shape (n_windows, n_outputs)
            ``{model: RMSE in dB per window and output}``."""
        y = self.splits[split].y
        return {
            model: rmse_db(y, pred, window=self.settings.window)
            for model, pred in self.predictions[split].items()
        }


def _fit_one(name, estimator, X, y, tests):
    """Fit one model and predict every test split (runs in a joblib worker)."""
    with warnings.catch_warnings(record=True) as caught, interrupts_raise():
        warnings.simplefilter("always")
        start = time.perf_counter()
        estimator.fit(X, y)
        fit_time = time.perf_counter() - start
        predictions = {split: estimator.predict(X_test) for split, X_test in tests}
    messages = sorted(
        {
            f"{w.category.__name__}: {w.message}"
            for w in caught
            if not issubclass(w.category, DeprecationWarning)
        }
    )
    return name, {
        "estimator": estimator,
        "predictions": predictions,
        "fit_time": fit_time,
        "n_epochs": n_epochs(estimator),
        "params": physical_params(estimator),
        "warnings": messages,
    }


def _model_rows(result, split, model):
    """Scores of one model on one test split, one row per output."""
    s = result.settings
    data = result.splits[split]
    y = np.asarray(data.y, dtype=float)
    oracle_rmse = np.sqrt(np.mean((y - data.oracle) ** 2, axis=0))
    pred = result.predictions[split][model]
    residual = y - pred
    rmse = np.sqrt(np.mean(residual**2, axis=0))
    whiteness = ljung_box_test(residual, s.lags)
    windowed = rmse_db(y, pred, window=s.window)
    fit = result.fits.get(model, {})
    return [
        {
            "system": result.system.name,
            "seed": s.seed,
            "model": model,
            "split": split,
            "output": output,
            "rmse": float(rmse[j]),
            "rmse_db": float(20 * np.log10(rmse[j])),
            "rmse_over_oracle": float(rmse[j] / oracle_rmse[j]),
            "median_window_rmse_db": float(np.median(windowed[:, j])),
            "residual_std": float(np.std(residual[:, j])),
            "ljung_box_stat": float(whiteness.statistic[j]),
            "ljung_box_pvalue": float(whiteness.pvalue[j]),
            "fit_time_s": fit.get("fit_time"),
            "n_epochs": fit.get("n_epochs"),
        }
        for j, output in enumerate(result.target_names)
    ]


def _score(result):
    """Fill ``result.rows`` from the predictions."""
    for split in result.test_splits:
        for model in result.predictions[split]:
            result.rows.extend(result.model_rows(split, model))


def _hull_shares(splits, n_steps):
    """Share of each test split's newest steps outside the training hull."""
    from skhybrid.model_selection import in_convex_hull
    from skhybrid.preprocessing import newest_step

    reference = newest_step(splits["train"].X, n_steps)
    return {
        split: float(
            1 - np.mean(in_convex_hull(newest_step(data.X, n_steps), reference))
        )
        for split, data in splits.items()
        if split != "train"
    }


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


def _is_measured(system):
    return getattr(system, "measured", False)


def _stages(zoo, todo):
    """``todo`` in stages: a model runs after the models it requires."""
    stages, placed = [], set()
    while len(placed) < len(todo):
        stage = [
            name
            for name in todo
            if name not in placed
            and all(
                dep in placed or dep not in todo
                for dep in getattr(zoo[name], "requires", ())
            )
        ]
        if not stage:
            raise ValueError(f"the zoo's requirements form a cycle among {todo}")
        stages.append(stage)
        placed.update(stage)
    return stages


def _dependency(result, folder, name, record=None, out=None):
    """What a model that requires ``name`` reads of it: its fits and record."""
    if out is not None:
        return {
            "model": out["estimator"],
            "validation_fit": out.get("extras", {}).get("validation_fit"),
            "fit": result.fits[name],
        }
    key = result.store_key
    return {
        "model": folder.load_estimator(key, record),
        "validation_fit": folder.load_estimator(key, record, "validation_fit"),
        "fit": record["fit"],
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
    system : str, System or MeasuredSystem
        ``"pendulum"``, ``"double-pendulum"``, ``"dc-motor"`` (see
        ``skhybrid list``), a measured benchmark: ``"cascaded-tanks"``,
        ``"emps"``, ``"silverbox"``, or a measured system of a user's spec
        (``MeasuredSystem.from_spec``).
    settings : ExperimentSettings, MeasuredSettings or None, default=None
        Sizes and budgets; ``None`` takes the system's default for ``quick``
        and ``seed``.
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
        :func:`~skhybrid.experiments._sealed.run_seeds`). Each model then refits
        the candidate its search chose at this seed instead of searching again.

    Returns
    -------
    result : ExperimentResult or MeasuredResult
        The fitted models' predictions, scores, parameters and fit records (a
        measured system's: its selection and fitted models, not yet scored).
    """
    start = time.perf_counter()
    system = get_system(system)
    measured = _is_measured(system)
    if settings is None:
        if measured:
            settings = system.default_settings(quick, seed)
        else:
            settings = (ExperimentSettings.quick if quick else ExperimentSettings.full)(
                seed
            )
    if measured:
        result = system.new_result(settings, data)
        result.searched = dict(searched or {})
        system = result.system  # bound to its spec
        if folder is not None:
            # Deterministic fits are computed once per records and kept here:
            # every seed, and every model built on the physics, reads them.
            result.cache_dir = str(folder.path / "cache")
        zoo = system.model_zoo(settings)
    else:
        splits = system.make_splits(settings)
        result = ExperimentResult(system, settings, splits)
        result.validation = system.validation_split(settings)
        for split in result.test_splits:
            result.predictions[split]["oracle"] = np.asarray(splits[split].oracle)
        result.hull = _hull_shares(splits, settings.n_steps)
        zoo = model_zoo(system, settings)

    key = result.store_key
    if measured and folder is not None:
        folder.check_records(key, records_digest(*result.train))
    done = {} if folder is None else folder.finished(key)
    done = {name: record for name, record in done.items() if name in zoo}
    for name, record in done.items():
        result.fits[name] = record["fit"]
        if record["params"]:
            result.params[name] = record["params"]
        if measured:  # its test records are simulated once the selection is sealed
            result.estimators[name] = folder.load_estimator(key, record)
        runs = {}
        for split, pred in folder.load_predictions(key, record).items():
            if split.startswith(VALIDATION):
                runs[int(split[len(VALIDATION) :])] = pred
            else:
                result.predictions[split][name] = pred
        if runs:
            result.validation_runs[name] = [runs[i] for i in sorted(runs)]

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
    todo = [name for name in order if name not in done]
    stages = _stages(zoo, todo)
    # The fits that models still to run require, as each finished or was stored.
    needed = {dep for name in todo for dep in getattr(zoo[name], "requires", ())}
    deps = {
        name: _dependency(result, folder, name, record=done[name])
        for name in needed
        if name in done
    }
    backend, _ = get_active_backend()
    client = _dask_client(backend)
    cores = os.cpu_count() or 1
    widest = max((len(stage) for stage in stages), default=1)
    if n_jobs in (-1, None):
        workers = -1 if client is not None else cores
    else:
        workers = max(1, min(n_jobs, widest))
    n_threads = max(1, cores // max(workers, 1))
    bars = None
    if progress:
        if measured:  # its networks are built in each model's search
            budget = system.epochs_at_most({name: zoo[name] for name in todo}, result)
        else:
            budget = sum(epoch_budget(zoo[name]) for name in todo)
        bars = ProgressBars(
            len(zoo),
            f"{system.name} seed {settings.seed}" if measured else system.name,
            client=client,
            n_done=len(done),
            n_epochs=budget or None,
        )
        if not measured:  # a measured model's networks are built in its job
            for name in todo:
                attach_epoch_logger(zoo[name], bars.sink, name)
    sink = None if bars is None else bars.sink

    def jobs(stage):
        for name in stage:
            if measured:
                needs = {k: deps[k] for k in getattr(zoo[name], "requires", ())}
                yield system.job(name, zoo[name], result, needs, sink)
            else:
                train = result.splits["train"]
                tests = [
                    (split, result.splits[split].X) for split in result.test_splits
                ]
                tests.append((VALIDATION_SPLIT, result.validation.X))
                yield delayed(_fit_one)(name, zoo[name], train.X, train.y, tests)

    try:
        for stage in stages:
            with _local_threads(backend, n_threads):
                outputs = Parallel(n_jobs=workers, return_as="generator_unordered")(
                    jobs(stage)
                )
                for name, out in outputs:
                    _record(result, name, out, folder)
                    if name in needed:
                        deps[name] = _dependency(result, folder, name, out=out)
                    if bars is not None:
                        bars.model_done(name, out["fit_time"], out["n_epochs"])
    finally:
        if bars is not None:
            bars.close()
    # Keep the zoo's order (and the oracle first) whatever order fits finished in.
    result.fits = {k: result.fits[k] for k in zoo if k in result.fits}
    result.params = {k: result.params[k] for k in zoo if k in result.params}
    for split in result.test_splits:
        preds = result.predictions[split]
        result.predictions[split] = {
            k: preds[k] for k in ["oracle", *zoo] if k in preds
        }
    _score(result)
    if not measured:
        result.stochastic = paper_stochastic(result)
    result.wall_time = time.perf_counter() - start
    return result


def _record(result, name, out, folder):
    """Add one finished model to ``result`` and, with a folder, write it there."""
    fit = {
        "fit_time": out["fit_time"],
        "n_epochs": out["n_epochs"],
        "warnings": out["warnings"],
    }
    # A measured model's choice by cross-validation.
    for key in ("validation_rmse", "selection"):
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
        stored.update({f"{VALIDATION}{i}": run for i, run in enumerate(runs)})
    result.fits[name] = fit
    if hasattr(result, "estimators"):
        result.estimators[name] = out["estimator"]
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
