"""A simulated system's run: its result, one model's fit, the scores of a split.

The paper's systems (section 6) are simulated: each model is fitted on the
training split's windows and predicts one step ahead on every test split and on
the validation split (:class:`ExperimentResult`). The pipeline,
:func:`~skhybrid.experiments.run_experiment`, calls the system's hooks
(:class:`~skhybrid.experiments.one_step._system.OneStepSystem`); this module holds
what they build.
"""

import time
import warnings

import numpy as np

from skhybrid.diagnostics import ljung_box_test, rmse_db
from skhybrid.experiments.one_step._report import simulated_report, simulated_settings
from skhybrid.experiments.one_step._stochastic import VALIDATION_SPLIT, paper_stochastic
from skhybrid.experiments.run._fitting import (
    interrupts_raise,
    n_epochs,
    physical_params,
)
from skhybrid.model_selection import in_convex_hull
from skhybrid.preprocessing import newest_step

__all__ = ["ExperimentResult", "fit_one", "hull_shares"]


class ExperimentResult:
    """Everything one run of one system produced.

    Parameters
    ----------
    system : OneStepSystem
        The system (a spec of the one-step protocol).
    settings : RunSettings
        The run's ``quick``, seed and noise type.
    splits : dict of str to Bunch
        The simulated data of each split.

    Attributes
    ----------
    system : OneStepSystem
        The system (a spec of the one-step protocol).
    settings : RunSettings
        The run's ``quick``, seed and noise type.
    sizes : OneStepSizes
        The data sizes, networks and budget the run used (the spec's).
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
        :func:`~skhybrid.experiments.one_step._stochastic.paper_stochastic`).
    wall_time : float
        Seconds for the whole run.
    searched : dict
        Empty: a simulated system makes no search (the runner's contract).
    validation_runs : dict
        Empty: a simulated system makes no out-of-fold free run.
    """

    def __init__(self, system, settings, splits):
        self.system = system
        self.settings = settings
        self.sizes = system.sizes(settings)
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
        self.searched = {}  # a simulated system makes no search
        self.validation_runs = {}  # nor out-of-fold free runs

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

    def restore(self, name, record, folder):
        """Take a model finished in an earlier run from the run folder.

        Parameters
        ----------
        name : str
            The model's name.
        record : dict
            Its record in the folder (fit, parameters, predictions).
        folder : RunFolder
            The run folder.
        """
        self.fits[name] = record["fit"]
        if record["params"]:
            self.params[name] = record["params"]
        for split, pred in folder.load_predictions(self.store_key, record).items():
            self.predictions[split][name] = pred

    def keep_estimator(self, name, estimator):
        """Keep nothing in memory: the run folder keeps each fitted model.

        Parameters
        ----------
        name : str
            The model's name.
        estimator : object
            The fitted model.
        """

    def score(self):
        """Score every model on every test split, then the chosen model's part.

        Fills :attr:`rows` (``results.csv``) and :attr:`stochastic`: the model
        chosen on the validation split, its residual tests and its band.
        """
        for split in self.test_splits:
            for model in self.predictions[split]:
                self.rows.extend(self.model_rows(split, model))
        self.stochastic = paper_stochastic(self)

    #: The report page's title for the paper's systems.
    report_title = "the paper's section 6"

    def report(self, out_dir):
        """Draw the figures; the report's section and ``results.json`` part.

        Parameters
        ----------
        out_dir : Path
            Where the figures go.

        Returns
        -------
        figures : list of Path
            The figures drawn.
        section : str
            The system's HTML section.
        summary : dict
            Its part of ``results.json``.
        """
        return simulated_report(self, out_dir)

    def report_settings(self):
        """The report's settings table: the run's settings and sizes.

        Returns
        -------
        settings : dict
            ``{setting: value}``.
        """
        return simulated_settings(self)

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
            model: rmse_db(y, pred, window=self.sizes.window)
            for model, pred in self.predictions[split].items()
        }


def fit_one(name, estimator, X, y, tests):
    """Fit one model and predict every test split (runs in a joblib worker).

    Parameters
    ----------
    name : str
        The model's name.
    estimator : estimator
        The unfitted model.
    X, y : ndarray
        The training split's windows and next states.
    tests : list of tuple
        ``(split, X)`` of each split to predict.

    Returns
    -------
    name : str
        The model's name.
    out : dict
        The fitted ``estimator``, its ``predictions`` by split, ``fit_time``,
        ``n_epochs``, physical ``params`` and the ``warnings`` it raised.
    """
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
    s, seed = result.sizes, result.settings.seed
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
            "seed": seed,
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


def hull_shares(splits, n_steps):
    """Share of each test split's newest steps outside the training hull.

    Parameters
    ----------
    splits : dict of str to Bunch
        The simulated splits, ``"train"`` among them.
    n_steps : int
        Time steps per row.

    Returns
    -------
    shares : dict of str to float
        ``{test split: share of its rows outside the hull}``.
    """
    reference = newest_step(splits["train"].X, n_steps)
    return {
        split: float(
            1 - np.mean(in_convex_hull(newest_step(data.X, n_steps), reference))
        )
        for split, data in splits.items()
        if split != "train"
    }
