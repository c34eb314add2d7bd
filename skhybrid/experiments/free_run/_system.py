"""A measured system in the pipeline: its spec, settings and result.

A measured system, a user's or a built-in benchmark of :mod:`skhybrid.benchmarks`,
is a :class:`~skhybrid.experiments.SystemSpec` run through the pipeline
(:func:`~skhybrid.experiments.run_experiment`): its estimation records are loaded,
its zoo (:mod:`skhybrid.experiments.free_run._family`) fits every model on them only,
and its :class:`MeasuredResult` holds the fits, the selection and, once the
selection is sealed, the test records' free runs.
"""

import json
import pickle
from dataclasses import replace

import numpy as np
from joblib import delayed, effective_n_jobs

from skhybrid.experiments._protocol import OneStepWindows
from skhybrid.experiments._spec import SystemSpec, records_digest
from skhybrid.experiments.free_run._family import (
    N_SPLITS,
    MeasuredContext,
    _rmse,
    epochs_at_most,
    zoo,
)
from skhybrid.experiments.free_run._identity import spec_digest
from skhybrid.experiments.free_run._search import fit_model
from skhybrid.experiments.run._progress import Tagged
from skhybrid.experiments.run._store import VALIDATION_RUNS
from skhybrid.model_selection import RecordBlockSplit, take_pieces

__all__ = ["MeasuredResult", "MeasuredSystem", "check_picklable"]


#: Most residual evaluations of a physics' fit in a quick run.
QUICK_NFEV = 20


def check_picklable(spec):
    """Refuse, before any fit, a physics the run folder cannot store.

    The run folder stores fitted models with cloudpickle
    (:meth:`~skhybrid.experiments.run._store.RunFolder.save_model`): functions
    defined in ``__main__`` (a script, a notebook cell), lambdas and closures
    are stored by value and load in a new session. What cloudpickle cannot
    store either (an open file, a lock, a generator) is refused here.
    """
    import cloudpickle

    for name in ("physics", "physics_inputs"):
        try:
            cloudpickle.dumps(getattr(spec, name), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError, ValueError) as exc:
            raise TypeError(
                f"spec.{name} cannot be pickled ({type(exc).__name__}: {exc}), so "
                "its fitted models cannot be kept in the run folder: keep only "
                "numbers, arrays and functions in it (no open file, lock or "
                "generator)."
            ) from None


class MeasuredSystem:
    """A measured system in the pipeline: its :class:`SystemSpec`, the runner's hooks.

    The runner calls :meth:`new_result`,
    :meth:`model_zoo` and :meth:`job`; the zoo reads the physics and the
    candidates through the system. A user's system wraps a spec
    (:meth:`from_spec`); a built-in benchmark builds its spec from its files
    (:meth:`make_spec`).

    Parameters
    ----------
    spec : SystemSpec or None, default=None
        The system; None for a built-in benchmark, whose spec is built from
        its files.
    module : module or None, default=None
        A built-in measured benchmark of :mod:`skhybrid.benchmarks`: its
        ``NAME``, ``TITLE``, ``UNIT``, ``SCALE``, ``make_spec(data, *, quick)``
        and, where its zoo holds no state-space hybrid, ``HYBRIDS = False``
        (known before its files are read). Its spec is built when a run binds it.
    """

    #: Runs on measured records, not on simulated splits.
    measured = True
    name = ""
    title = ""
    unit = ""
    #: Factor from the data's units to the official reporting units.
    scale = 1.0
    #: Whether the zoo holds state-space hybrids (without reading any record).
    hybrids = True

    def __init__(self, spec=None, *, module=None):
        self._spec = spec
        self._module = module
        if module is not None:
            self.name = module.NAME
            self.title = module.TITLE
            self.unit = module.UNIT
            self.scale = float(module.SCALE)
            self.hybrids = getattr(module, "HYBRIDS", True)
        if spec is not None:
            self.name = spec.name
            self.title = spec.title or spec.name
            self.unit = spec.unit
            self.scale = float(spec.scale)
            self.hybrids = spec.has_hybrids()

    @classmethod
    def from_spec(cls, spec):
        """The system of a user's spec.

        Parameters
        ----------
        spec : SystemSpec
            The system.

        Returns
        -------
        system : MeasuredSystem
            Bound to ``spec``.
        """
        if not isinstance(spec, SystemSpec):
            raise TypeError(f"spec must be a SystemSpec; got {type(spec).__name__}.")
        if isinstance(spec.protocol, OneStepWindows):
            raise ValueError(  # noqa: TRY004 - a value of the right type
                f"{spec.name!r} is a spec of the one-step protocol "
                "(protocol=OneStepWindows): skhybrid.experiments.get_system runs "
                "it as a simulated system, not a measured one."
            )
        check_picklable(spec)
        return cls(spec)

    def make_spec(self, data=None, quick=False):
        """The system's spec (a built-in benchmark builds it from its files).

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            A built-in benchmark's quick form (a shorter Silverbox record).

        Returns
        -------
        spec : SystemSpec
            The system.
        """
        if self._spec is not None:
            return self._spec
        module = self._module
        if module is None:
            raise NotImplementedError(
                f"{type(self).__name__} has no spec: build it with from_spec(spec)"
            )
        return module.make_spec(data, quick=quick)

    @property
    def spec(self):
        """The spec the system is bound to (after :meth:`new_result`)."""
        if self._spec is None:
            raise AttributeError(f"{self.name}: no spec bound yet (call new_result)")
        return self._spec

    def bind(self, data=None, quick=False):
        """A copy of the system bound to its spec.

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            A built-in benchmark's quick form.

        Returns
        -------
        system : MeasuredSystem
            With :attr:`spec` set.
        """
        if self._spec is not None:
            return self
        return type(self)(self.make_spec(data, quick))

    def check_files(self, data=None, quick=False):
        """Load and check the estimation records (a bad file raises here).

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            The quick form.
        """
        self.bind(data, quick).spec.estimation_records()

    # -- what the zoo reads --------------------------------------------------------
    @property
    def physics_inputs(self):
        return self.spec.physics_inputs

    @property
    def hybrid_records(self):
        return self.spec.hybrid_records

    def physics(self, U, Y, dt, quick=False):
        """An unfitted physics for the records (its fit shortened when quick)."""
        model = self.spec.make_physics(U, Y, dt)
        if quick and "max_nfev" in model.get_params(deep=False):
            limit = model.get_params(deep=False)["max_nfev"]
            model.set_params(
                max_nfev=QUICK_NFEV if limit is None else min(limit, QUICK_NFEV)
            )
        return model

    def segment_candidates(self, ctx):
        """The physics' segment lengths to try on the fitting parts of ``ctx``."""
        segments = self.spec.segment_candidates(_fit_lengths(ctx))
        return segments[:1] if ctx.quick else segments

    def has_hybrids(self, quick=False):
        """Whether the zoo holds state-space hybrids."""
        return bool(self.hybrids)

    def hybrid_candidates(self, ctx):
        """The state-space hybrids to try, by label (quick: the first, shortened)."""
        candidates = self.spec.hybrid_candidates(_fit_lengths(ctx))
        if ctx.quick and candidates:
            label, settings = next(iter(candidates.items()))
            quick = dict(settings, max_epochs=min(settings.get("max_epochs", 6), 6))
            quick["hidden_layer_sizes"] = (16, 16)
            return {label: quick}
        return candidates

    def published(self):
        """The published test figures, ``{split: {label: (rmse, source)}}``."""
        if self._spec is not None:
            return self._spec.published
        return getattr(self._module, "PUBLISHED", {})

    # -- the runner's hooks (its contract, ZooSystem) ---------------------------
    def digest(self):
        """SHA-256 of what the bound spec says before its records are read.

        A built-in benchmark and its spec in Python
        (:func:`~skhybrid.benchmarks.benchmark_spec`) give the same digest.

        Returns
        -------
        digest : str
            Hex digest (:func:`~skhybrid.experiments.free_run._identity.spec_digest`).
        """
        return spec_digest(self.spec)

    def requirements(self, zoo):
        """The models each model of ``zoo`` needs fitted before it starts.

        Parameters
        ----------
        zoo : dict of str to ZooModel
            As :meth:`model_zoo` returns it.

        Returns
        -------
        requires : dict of str to tuple of str
            Each model's ``requires``.
        """
        return {name: tuple(model.requires) for name, model in zoo.items()}

    def store_key(self, settings):
        """The run folder's name for this system's models at ``settings``' seed."""
        return f"{self.name}-seed-{settings.seed}"

    def new_result(self, settings, data=None, searched=None):
        """Load the estimation records and return an empty :class:`MeasuredResult`.

        No test record is read: they are read once the selection is sealed.

        Parameters
        ----------
        settings : RunSettings
            ``quick`` and ``seed``.
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        searched : dict of str to dict or None, default=None
            Each model's search made at another seed, whose choice this seed
            refits (see :func:`~skhybrid.experiments.free_run._seeds.run_seeds`).

        Returns
        -------
        result : MeasuredResult
            The bound system, the records, ``n_init`` and ``dt``; no model yet.
        """
        system = self.bind(data, settings.quick)
        U, Y = system.spec.estimation_records()
        result = MeasuredResult(
            system, settings, (U, Y), system.spec.n_init, system.spec.sample_period()
        )
        result.searched = dict(searched or {})
        return result

    def open_folder(self, result, folder):
        """Check the folder's records and keep the deterministic fits there.

        Deterministic fits are computed once per records and kept in the
        folder's ``cache``: every seed, and every model built on the physics,
        reads them.

        Parameters
        ----------
        result : MeasuredResult
            The run (its estimation records).
        folder : RunFolder
            Its folder; refused where it holds models of other records.
        """
        result.cache_dir = str(folder.path / "cache")
        folder.check_records(result.store_key, records_digest(*result.train))

    def progress_label(self, settings):
        """What the progress bars call this run: the system and its seed.

        Parameters
        ----------
        settings : RunSettings
            The run's settings (its seed).

        Returns
        -------
        label : str
            ``"NAME seed S"``.
        """
        return f"{self.name} seed {settings.seed}"

    def model_zoo(self, settings):
        """The zoo's models (see :func:`skhybrid.experiments.free_run._family.zoo`).

        Parameters
        ----------
        settings : RunSettings
            ``quick`` gives fewer candidates.

        Returns
        -------
        zoo : dict of str to ZooModel
            In the order the report lists them.
        """
        return zoo(self, settings.quick)

    #: Each model searches over folds: the runner fits the models one at a
    #: time, each search's (candidate, fold) fits on every worker.
    parallel_folds = True

    def job(self, name, model, result, deps, sink=None, n_jobs=1, n_threads=None):
        """The joblib call that chooses and refits one model.

        Parameters
        ----------
        name : str
            The model's name.
        model : ZooModel
            Its candidates and fit.
        result : MeasuredResult
            The records and settings (its system is bound to the spec).
        deps : dict of str to dict
            The fits of the models it requires.
        sink : object or None, default=None
            Where networks report their epochs.
        n_jobs : int, default=1
            Workers of the model's search (its candidates and folds).
        n_threads : int or None, default=None
            Threads of torch and the BLAS in the process that refits the chosen
            candidate, as in each worker; None leaves them.

        Returns
        -------
        call : tuple
            A :func:`joblib.delayed` call of
            :func:`~skhybrid.experiments.free_run._search.fit_model`.
        """
        ctx = _context(result, searched=result.searched.get(name))
        ctx = replace(ctx, n_jobs=n_jobs, n_threads=n_threads)
        return delayed(_announce_and_fit)(name, model, ctx, deps, sink)

    def epochs_at_most(self, models, result):
        """The most epochs the networks of ``models`` can train at this seed.

        Parameters
        ----------
        models : dict of str to ZooModel
            The models still to fit.
        result : MeasuredResult
            The records and settings, and which models refit a search made at
            another seed.

        Returns
        -------
        n_epochs : int
            The epoch bar's total (see
            :func:`~skhybrid.experiments.free_run._family.epochs_at_most`).
        """
        return epochs_at_most(models, _context(result), searched=set(result.searched))


def search_event(name, model, ctx, deps):
    """The progress event of a model's search as it begins.

    Parameters
    ----------
    name : str
        The model.
    model : ZooModel
        Its candidates (none searched for a model chosen otherwise, such as
        the stack, or for a refit of a choice made at another seed).
    ctx : MeasuredContext
        The records, the seed, the search's workers and, for a refit, the
        search it refits (``searched``).
    deps : dict of str to dict
        The fits of the models it requires (their choices).

    Returns
    -------
    event : dict
        ``kind`` ``"search"``, ``model``, ``n_candidates``, ``n_folds``,
        ``n_workers`` and ``searched_at`` (the seed whose choice is refitted,
        or None).
    """
    n_folds = RecordBlockSplit(N_SPLITS, n_init=ctx.n_init).get_n_splits(list(ctx.U))
    searched_at, n_candidates = None, 0
    if ctx.searched is not None:
        searched_at = ctx.searched.get("seed")
    elif model.choose is None:
        records = {k: d["fit"] for k, d in deps.items()}
        n_candidates = len(model.candidates(ctx, records))
    return {
        "kind": "search",
        "model": name,
        "n_candidates": n_candidates,
        "n_folds": n_folds,
        "n_workers": effective_n_jobs(ctx.n_jobs),
        "searched_at": searched_at,
    }


def _announce_and_fit(name, model, ctx, deps, sink=None):
    """:func:`fit_model`, its events tagged with the seed, its search announced."""
    if sink is not None:
        sink = Tagged(sink, seed=ctx.seed)
        sink.emit(search_event(name, model, ctx, deps))
    return fit_model(name, model, ctx, deps, sink)


def _context(result, searched=None):
    """What every fit of ``result``'s run reads (its records, settings, cache)."""
    U, Y = result.train
    return MeasuredContext(
        result.system,
        U,
        Y,
        int(result.n_init),
        float(result.dt),
        result.settings.quick,
        result.settings.seed,
        cache=result.cache_dir,
        searched=searched,
        device=result.settings.device,
    )


def _fit_lengths(ctx):
    """Samples of each record's fitting part: three quarters, as each fold fits."""
    return [int(0.75 * len(u)) for u in ctx.U]


class MeasuredResult:
    """One seed's run of one measured system: the selection, then its test scores.

    Parameters
    ----------
    system : MeasuredSystem
        The system, bound to its spec.
    settings : RunSettings
        ``quick`` and ``seed``.
    train : tuple of list of ndarray
        The estimation records ``(U, Y)``.
    n_init : int
        Samples of the initialisation window.
    dt : float
        Sample period.

    Attributes
    ----------
    tests : dict of str to tuple of ndarray
        ``{split: (u, y)}``: the test records, empty until the selection is
        sealed (:func:`~skhybrid.experiments.free_run._scoring.score_tests`).
    predictions : dict of str to dict of str to ndarray
        ``predictions[split][model]``: the free run over each test record (NaN
        where it failed), in the data's units.
    rows : list of dict
        One row per model and test record (``results.csv``).
    params : dict of str to dict
        Fitted physical parameters and standard errors.
    fits : dict of str to dict
        Fit time, epochs, warnings, validation RMSE and the choices of each
        model.
    estimators : dict of str to object
        The fitted models (loaded from the run folder where resumed).
    hull : dict
        On the Silverbox arrow: the first test sample whose window leaves the
        training hull, and how many do.
    validation_runs : dict of str to list of ndarray
        Each model's chosen candidate's out-of-fold free runs, by fold.
    stochastic : dict
        The chosen model's stochastic part once scored (see
        :mod:`skhybrid.experiments._stochastic`).
    cache_dir : Path or None
        Where the deterministic fits are kept (the run folder's cache).
    bands : dict of str to tuple of ndarray
        ``{split: (lower, upper)}``: the chosen model's simulation band on each
        test record.
    wall_time : float
        Seconds for the selection.
    searched : dict of str to dict
        Each model's search made at the run's first seed (its ``selection``,
        out-of-fold ``runs`` and ``seed``), refitted here at this seed; empty
        where this result's own seed searches.
    """

    def __init__(self, system, settings, train, n_init, dt):
        self.system = system
        self.settings = settings
        self.train = train
        self.tests = {}
        self.n_init = int(n_init)
        self.dt = float(dt)
        self.predictions = {}
        self.rows = []
        self.params = {}
        self.fits = {}
        self.estimators = {}
        self.hull = {}
        #: First scored sample of each test record (default: ``n_init``).
        self.score_start = {}
        self.validation_runs = {}
        self.stochastic = {}
        self.bands = {}
        self.cache_dir = None
        self.wall_time = float("nan")
        self.searched = {}

    @property
    def store_key(self):
        return self.system.store_key(self.settings)

    @property
    def test_splits(self):
        return list(self.tests)

    def restore(self, name, record, folder):
        """Take a model finished in an earlier run from the run folder.

        Its fit record, parameters, fitted estimator (its test records are
        simulated once the selection is sealed) and out-of-fold free runs.

        Parameters
        ----------
        name : str
            The model's name.
        record : dict
            Its record in the folder.
        folder : RunFolder
            The run folder.
        """
        key = self.store_key
        self.fits[name] = record["fit"]
        if record["params"]:
            self.params[name] = record["params"]
        self.estimators[name] = folder.load_estimator(key, record)
        runs = {}
        for split, pred in folder.load_predictions(key, record).items():
            if split.startswith(VALIDATION_RUNS):
                runs[int(split[len(VALIDATION_RUNS) :])] = pred
            else:
                self.predictions.setdefault(split, {})[name] = pred
        if runs:
            self.validation_runs[name] = [runs[i] for i in sorted(runs)]

    def keep_estimator(self, name, estimator):
        """Keep a fitted model in memory: the test records are run once sealed.

        Parameters
        ----------
        name : str
            The model's name.
        estimator : object
            The fitted model.
        """
        self.estimators[name] = estimator

    def score(self):
        """Nothing to score yet: the test records are scored once sealed.

        They are read and scored once the selection of every seed is sealed
        (:func:`~skhybrid.experiments.free_run._scoring.score_tests`).
        """

    def validation_blocks(self):
        """The held-out blocks of each fold every choice is made on.

        Returns
        -------
        folds : list of tuple
            For each fold, ``(U, Y)``: its held-out blocks of the estimation
            records (:class:`~skhybrid.model_selection.RecordBlockSplit`).
        """
        U, Y = self.train
        splitter = RecordBlockSplit(N_SPLITS, n_init=self.n_init)
        return [take_pieces(U, Y, test) for _, test in splitter.split(U, Y)]

    def test_rmse(self, split, model):
        """Free-run RMSE of ``model`` on the test record ``split`` (official units).

        Parameters
        ----------
        split : str
            A test record's name.
        model : str
            A model's name.

        Returns
        -------
        rmse : float
            NaN where the free run failed.
        """
        y = self.tests[split][1]
        start = self.score_start.get(split, self.n_init)
        return self.system.scale * _rmse(y, self.predictions[split][model], start)

    def validation_rmse(self):
        """``{model: mean CV RMSE}`` (official units) of the quoted models."""
        return {
            model: fit["validation_rmse"]
            for model, fit in self.fits.items()
            if fit.get("validation_rmse") is not None
            and np.isfinite(fit["validation_rmse"])
        }

    def selected_model(self):
        """The model to quote: the lowest mean CV free-run RMSE."""
        validation = self.validation_rmse()
        return min(validation, key=validation.get) if validation else None

    def model_rows(self, split, model):
        """The scores of one model on one test record, as rows of results.csv.

        Parameters
        ----------
        split : str
            A test record's name.
        model : str
            A model's name.

        Returns
        -------
        rows : list of dict
            One row (one output).
        """
        fit = self.fits.get(model, {})
        return [
            {
                "system": self.system.name,
                "seed": self.settings.seed,
                "model": model,
                "split": split,
                "output": "y",
                "rmse": self.test_rmse(split, model),
                "unit": self.system.unit,
                "validation_rmse": fit.get("validation_rmse"),
                "chosen": model == self.selected_model(),
                "fit_time_s": fit.get("fit_time"),
                "n_epochs": fit.get("n_epochs"),
            }
        ]

    def selection(self):
        """What was chosen at this seed, before any test record was read.

        Returns
        -------
        selection : dict
            The settings, each model's candidates with their validation RMSE
            and choice, the validation RMSE of each model, the chosen model and
            the physics' fitted parameters.
        """
        physics = self.params.get("physics", {})
        return {
            "seed": self.settings.seed,
            # What a measured run's choices depend on (its records hold their
            # own noise: no noise type).
            "settings": {"quick": self.settings.quick, "seed": self.settings.seed},
            "models": {
                model: _jsonable(fit.get("selection"))
                for model, fit in self.fits.items()
            },
            "validation_rmse": self.validation_rmse(),
            "chosen_model": self.selected_model(),
            "physics_params": {k: p["value"] for k, p in physics.items()},
        }


def _jsonable(value):
    """``value`` with floats that JSON writes the same way every time."""
    return json.loads(json.dumps(value, default=str))
