"""Fit the model zoo on one system and score it on its test sets."""

import logging
import os
import time
import warnings

import numpy as np
from joblib import Parallel, delayed

from skhybrid.diagnostics import ljung_box_test, rmse_db
from skhybrid.experiments._progress import ProgressBars, attach_epoch_logger
from skhybrid.experiments._settings import ExperimentSettings
from skhybrid.experiments._systems import SYSTEMS
from skhybrid.experiments._zoo import model_zoo

__all__ = ["ExperimentResult", "run_experiment"]

logger = logging.getLogger(__name__)


class ExperimentResult:
    """Everything one run of one system produced.

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
    wall_time : float
        Seconds for the whole run.
    """

    def __init__(self, system, settings, splits):
        self.system = system
        self.settings = settings
        self.splits = splits
        self.predictions = {name: {} for name in splits if name != "train"}
        self.rows = []
        self.params = {}
        self.fits = {}
        self.hull = {}
        self.wall_time = float("nan")

    @property
    def test_splits(self):
        return [name for name in self.splits if name != "train"]

    @property
    def target_names(self):
        return list(self.splits["train"].target_names)

    def windowed_db(self, split):
        """``{model: (n_windows, n_outputs) RMSE in dB}`` over short windows."""
        y = self.splits[split].y
        return {
            model: rmse_db(y, pred, window=self.settings.window)
            for model, pred in self.predictions[split].items()
        }


def _physical_params(estimator):
    """``{name: (value, std)}`` of the physics inside ``estimator``, if any."""
    candidates = [estimator]
    stages = getattr(estimator, "stages_", None)
    if stages:
        candidates.append(stages[0][1])
    for est in candidates:
        params = getattr(est, "params_", None)
        if isinstance(params, dict):
            std = getattr(est, "params_std_", None) or {}
            return {
                name: {
                    "value": np.asarray(value).tolist(),
                    "std": None if name not in std else np.asarray(std[name]).tolist(),
                }
                for name, value in params.items()
            }
    return {}


def _n_epochs(estimator):
    for est in [estimator, *(s for _, s in getattr(estimator, "stages_", []))]:
        if hasattr(est, "n_epochs_"):
            return int(est.n_epochs_)
    return None


def _fit_one(name, estimator, X, y, tests, n_threads):
    """Fit one model and predict every test split (runs in a joblib worker)."""
    import torch

    torch.set_num_threads(n_threads)
    with warnings.catch_warnings(record=True) as caught:
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
        "predictions": predictions,
        "fit_time": fit_time,
        "n_epochs": _n_epochs(estimator),
        "params": _physical_params(estimator),
        "warnings": messages,
    }


def _score(result):
    """Fill ``result.rows`` from the predictions."""
    s = result.settings
    for split in result.test_splits:
        data = result.splits[split]
        y = np.asarray(data.y, dtype=float)
        oracle_rmse = np.sqrt(np.mean((y - data.oracle) ** 2, axis=0))
        for model, pred in result.predictions[split].items():
            residual = y - pred
            rmse = np.sqrt(np.mean(residual**2, axis=0))
            whiteness = ljung_box_test(residual, s.lags)
            windowed = rmse_db(y, pred, window=s.window)
            fit = result.fits.get(model, {})
            for j, output in enumerate(result.target_names):
                result.rows.append(
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
                )


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


def run_experiment(
    system, *, settings=None, quick=False, seed=0, n_jobs=1, progress=False
):
    """Fit the model zoo of the paper's section 6 on one system and score it.

    Parameters
    ----------
    system : str or System
        ``"pendulum"``, ``"double-pendulum"`` or ``"dc-motor"`` (see
        ``skhybrid list``).
    settings : ExperimentSettings or None, default=None
        Sizes and budgets; ``None`` takes :meth:`ExperimentSettings.quick` or
        :meth:`ExperimentSettings.full` with ``seed``.
    quick : bool, default=False
        Small data and few epochs (used only when ``settings`` is None).
    seed : int, default=0
        Seed of the data and the models (used only when ``settings`` is None).
    n_jobs : int, default=1
        Models fitted in parallel with joblib (-1: all cores).
    progress : bool, default=False
        Show progress bars on standard error: models fitted, and epochs of all
        networks (counted across joblib workers).

    Returns
    -------
    result : ExperimentResult
    """
    start = time.perf_counter()
    if isinstance(system, str):
        if system not in SYSTEMS:
            raise ValueError(
                f"system must be one of {sorted(SYSTEMS)}; got system={system!r}."
            )
        system = SYSTEMS[system]
    if settings is None:
        settings = (ExperimentSettings.quick if quick else ExperimentSettings.full)(
            seed
        )
    splits = system.make_splits(settings)
    result = ExperimentResult(system, settings, splits)
    for split in result.test_splits:
        result.predictions[split]["oracle"] = np.asarray(splits[split].oracle)
    result.hull = _hull_shares(splits, settings.n_steps)

    zoo = model_zoo(system, settings)
    cores = os.cpu_count() or 1
    workers = cores if n_jobs in (-1, None) else max(1, min(n_jobs, len(zoo)))
    n_threads = max(1, cores // workers)
    train = splits["train"]
    tests = [(split, splits[split].X) for split in result.test_splits]
    # The slowest fits (recurrent hybrids) first, so parallel workers finish together.
    order = sorted(zoo, key=lambda name: ("rnn" not in name, "ensemble" not in name))
    bars = ProgressBars(len(zoo), system.name) if progress else None
    if bars is not None:
        for name in order:
            attach_epoch_logger(zoo[name], bars.path, name)
    jobs = (
        delayed(_fit_one)(name, zoo[name], train.X, train.y, tests, n_threads)
        for name in order
    )
    outputs = Parallel(n_jobs=workers, return_as="generator_unordered")(jobs)
    for name, out in outputs:
        result.fits[name] = {
            "fit_time": out["fit_time"],
            "n_epochs": out["n_epochs"],
            "warnings": out["warnings"],
        }
        if out["params"]:
            result.params[name] = out["params"]
        for split, pred in out["predictions"].items():
            result.predictions[split][name] = np.asarray(pred, dtype=float)
        if bars is not None:
            bars.model_done(name, out["fit_time"], out["n_epochs"])
    if bars is not None:
        bars.close()
    # Keep the zoo's order (and the oracle first) whatever order fits finished in.
    for split in result.test_splits:
        preds = result.predictions[split]
        result.predictions[split] = {
            k: preds[k] for k in ["oracle", *zoo] if k in preds
        }
    _score(result)
    result.wall_time = time.perf_counter() - start
    return result
