"""The runner's written contract: what it asks of a system and of its result.

:func:`~skhybrid.experiments.run._runner.fit_zoos` and
:class:`~skhybrid.experiments.run._plan.RunPlan` run any system that answers
:class:`ZooSystem`'s hooks, and keep what it fits in a result that answers
:class:`ZooResult`'s. Both protocols implement them: the one-step one
(:class:`~skhybrid.experiments.one_step._system.OneStepSystem` and its
:class:`~skhybrid.experiments.ExperimentResult`) and the free-run one
(:class:`~skhybrid.experiments.free_run._system.MeasuredSystem` and its
:class:`~skhybrid.experiments.free_run._system.MeasuredResult`). The runner
calls these hooks and inspects nothing else (no ``getattr`` or ``hasattr``);
``tests/experiments/test_system_protocol.py`` checks both systems against them,
signatures included.
"""

from typing import Protocol, runtime_checkable

__all__ = ["ZooResult", "ZooSystem"]


@runtime_checkable
class ZooSystem(Protocol):
    """A system the runner fits: its data, its zoo, and the call fitting a model.

    Attributes
    ----------
    name : str
        The system's name (the report's, the run folder's).
    measured : bool
        Whether it runs on measured records (the free-run protocol, several
        seeds, sealed before the test) or on simulated splits (the one-step
        protocol, one seed).
    parallel_folds : bool
        Whether each model searches over folds: the runner then fits the
        models one at a time, each search's (candidate, fold) fits on every
        worker; otherwise the models are single fits, run side by side.
    """

    name: str
    measured: bool
    parallel_folds: bool

    def bind(self, data=None, quick=False):
        """The system with everything a run reads resolved (its spec built).

        Called once per run, before its identity is taken: a built-in
        measured benchmark reads its estimation records here; a system that
        holds its spec already returns itself.

        Parameters
        ----------
        data : str or Path or None, default=None
            A built-in benchmark's data folder; None fetches its files.
        quick : bool, default=False
            The run's quick form.

        Returns
        -------
        system : ZooSystem
            The bound system.
        """

    def digest(self):
        """SHA-256 of what the system's spec says (part of the run's identity).

        The same spec gives the same digest in every session, however the
        run was started (a name on the command line or its spec in Python).

        Returns
        -------
        digest : str
            Hex digest.
        """

    def new_result(self, settings, data=None, searched=None):
        """A result holding the run's data at ``settings`` and no model yet.

        Parameters
        ----------
        settings : RunSettings
            The run's ``quick``, seed and noise type.
        data : str or Path or None, default=None
            A built-in benchmark's data folder (unused by a simulated system).
        searched : dict of str to dict or None, default=None
            Each model's search made at another seed, whose choices this
            seed refits (None: this seed searches).

        Returns
        -------
        result : ZooResult
            Its ``system`` is the bound system the runner uses from then on.
        """

    def model_zoo(self, settings):
        """The models to fit at ``settings``, unfitted, in the report's order.

        Parameters
        ----------
        settings : RunSettings
            The run's settings.

        Returns
        -------
        zoo : dict of str to object
            ``{name: model}``; each model is handed back to :meth:`job`.
        """

    def requirements(self, zoo):
        """The models each model of ``zoo`` needs fitted before it starts.

        Parameters
        ----------
        zoo : dict of str to object
            As :meth:`model_zoo` returns it.

        Returns
        -------
        requires : dict of str to tuple of str
            ``{name: names of the models it requires}``, every name of
            ``zoo`` a key (an empty tuple for a model that needs none).
        """

    def open_folder(self, result, folder):
        """Prepare the run folder for ``result``'s models before any is fitted.

        Parameters
        ----------
        result : ZooResult
            The run.
        folder : RunFolder
            Its folder (a measured system checks its records there).
        """

    def progress_label(self, settings):
        """What the progress bars call a run with ``settings``.

        Parameters
        ----------
        settings : RunSettings
            The run's settings.

        Returns
        -------
        label : str
            A few words.
        """

    def epochs_at_most(self, models, result):
        """The most epochs the networks of ``models`` can train (the epoch bar's total).

        Parameters
        ----------
        models : dict of str to object
            The models still to fit.
        result : ZooResult
            The run.

        Returns
        -------
        n_epochs : int
            An upper bound (0 where no network trains).
        """

    def job(self, name, model, result, deps, sink=None, n_jobs=1, n_threads=None):
        """The :func:`joblib.delayed` call that fits one model of the zoo.

        Parameters
        ----------
        name : str
            The model's name.
        model : object
            The model, as :meth:`model_zoo` gave it.
        result : ZooResult
            The run (its data).
        deps : dict of str to dict
            What each model it requires left: ``{"model", "validation_fit",
            "fit", "runs"}``.
        sink : object or None, default=None
            Where its networks report their epochs (the progress bars).
        n_jobs : int, default=1
            Workers of the model's own search.
        n_threads : int or None, default=None
            Threads of torch and the BLAS where the call runs; None leaves them.

        Returns
        -------
        call : tuple
            ``(function, args, kwargs)``, whose call returns ``(name, out)``:
            ``out`` holds ``"estimator"``, ``"predictions"``, ``"params"``,
            ``"fit_time"``, ``"n_epochs"`` and ``"warnings"`` (a measured
            model's search adds its own keys).
        """


@runtime_checkable
class ZooResult(Protocol):
    """One seed's run of a system as the runner fills it, model by model.

    Attributes
    ----------
    system : ZooSystem
        The bound system.
    settings : RunSettings
        The run's settings.
    store_key : str
        The run folder's name for this seed's models.
    test_splits : list of str
        The splits each model is scored on (a measured run's, once sealed).
    fits : dict of str to dict
        Each fitted model's fit record.
    params : dict of str to dict
        Each model's fitted physical parameters.
    predictions : dict of str to dict of str to ndarray
        ``predictions[split][model]``.
    validation_runs : dict of str to list of ndarray
        Each model's out-of-fold free runs (empty in the one-step protocol).
    searched : dict of str to dict
        Each model's search made at another seed, refitted here (empty where
        this seed searches).
    """

    system: ZooSystem
    settings: object
    store_key: str
    test_splits: list
    fits: dict
    params: dict
    predictions: dict
    validation_runs: dict
    searched: dict

    def restore(self, name, record, folder):
        """Take a model finished in an earlier run from the run folder.

        Parameters
        ----------
        name : str
            The model's name.
        record : dict
            Its record in the folder.
        folder : RunFolder
            The run folder.
        """

    def keep_estimator(self, name, estimator):
        """Keep (or not) a fitted model in memory, as the protocol needs it.

        Parameters
        ----------
        name : str
            The model's name.
        estimator : object
            The fitted model (the run folder keeps it in any case).
        """

    def model_rows(self, split, model):
        """One model's scores on one split, as rows of ``results.csv``.

        Parameters
        ----------
        split : str
            A test split.
        model : str
            A model's name.

        Returns
        -------
        rows : list of dict
            One row per output.
        """

    def score(self):
        """Score what was predicted, once every model is fitted."""
