"""A system of the paper's one-step protocol in the pipeline.

A :class:`~skhybrid.experiments.SystemSpec` whose ``protocol`` is a
:class:`~skhybrid.experiments.OneStepWindows` (the built-in pendulum, double
pendulum and DC motor of :mod:`skhybrid.benchmarks`, or a user's) runs as a
:class:`OneStepSystem`: its simulators give the splits at each seed, its physics
the zoo's physics models. It answers the pipeline's hooks
(:func:`~skhybrid.experiments.run_experiment` calls the same ones on a
free-run system): its default settings, a new result, its model zoo, the joblib
call that fits one model, and the most epochs its networks can train.
"""

import hashlib
from dataclasses import fields as dataclass_fields
from dataclasses import replace

import numpy as np
from joblib import delayed
from sklearn.base import clone

from skhybrid.experiments._describe import canonical, describe
from skhybrid.experiments._paper_stochastic import VALIDATION_SPLIT
from skhybrid.experiments._progress import attach_epoch_logger, epoch_budget
from skhybrid.experiments._protocol import OneStepWindows
from skhybrid.experiments._settings import ExperimentSettings
from skhybrid.experiments._simulated import ExperimentResult, fit_one, hull_shares
from skhybrid.experiments._spec import SystemSpec
from skhybrid.experiments._zoo import model_zoo

__all__ = ["OneStepSystem"]

#: Offset of the validation episodes' seed from the run's (the test splits use
#: 1000, 2000, ... in the spec's order).
VALIDATION_SEED = 3000
#: Offset of the k-th test split's seed from the run's (k = 1, 2, ...).
TEST_SEED_STEP = 1000


class OneStepSystem:
    """A spec of the one-step protocol, as the pipeline runs it.

    Parameters
    ----------
    spec : SystemSpec
        With ``protocol=OneStepWindows(...)``.
    """

    #: Simulated splits, not measured records.
    measured = False

    def __init__(self, spec):
        if not isinstance(spec, SystemSpec) or not isinstance(
            spec.protocol, OneStepWindows
        ):
            raise TypeError(
                f"spec must be a SystemSpec with protocol=OneStepWindows; got {spec!r}."
            )
        self.spec = spec
        protocol = spec.protocol
        self.name = spec.name
        self.title = spec.title or spec.name
        self.section = protocol.section
        self.default_noise_type = protocol.noise_type
        self.noise = protocol.noise
        labels = list(spec.physics) if isinstance(spec.physics, dict) else ["physics"]
        #: Label (in :meth:`physics`) of the physics used as first stage of hybrids.
        self.hybrid_physics = protocol.hybrid_physics or labels[0]
        #: Label of the physics warm-started and trained jointly in the ensemble.
        self.ensemble_physics = protocol.ensemble_physics or labels[0]

    def __repr__(self):
        return f"OneStepSystem({self.name!r})"

    def digest(self):
        """SHA-256 of what the spec says: simulators, physics, window, protocol.

        Functions are named by their module and qualified name and estimators
        by class and parameters, never by memory address: the same spec gives
        the same digest in every session (a resumed run must match it).

        Returns
        -------
        digest : str
            Hex digest.
        """
        spec, protocol = self.spec, self.spec.protocol
        fields = {
            "name": spec.name,
            "records": describe(spec.records),
            "tests": describe(spec.tests),
            "physics": describe(spec.physics),
            "n_init": spec.n_init,
            "protocol": {
                f.name: describe(getattr(protocol, f.name))
                for f in dataclass_fields(protocol)
            },
        }
        return hashlib.sha256(canonical(fields).encode()).hexdigest()

    def noise_type(self, settings):
        """Where the noise enters in a run with ``settings``.

        Parameters
        ----------
        settings : ExperimentSettings
            Its ``noise_type``, or the system's default when that is None.

        Returns
        -------
        noise_type : {"measurement", "process"}
            The simulators' ``noise_type``.
        """
        return settings.noise_type or self.default_noise_type

    @staticmethod
    def split_seed(settings, offset):
        """The seed of a split ``offset`` away from the run's, within numpy's range.

        Parameters
        ----------
        settings : ExperimentSettings
            The run's seed.
        offset : int
            The split's offset (the catalogue's test splits use 1000 and 2000,
            the validation split 3000).

        Returns
        -------
        seed : int
            ``(seed + offset) % 2**32``: the run's seed may be any of numpy's.
        """
        return (settings.seed + offset) % 2**32

    def _common(self, settings):
        return {
            "n_steps": settings.n_steps,
            "noise": self.noise,
            "noise_type": self.noise_type(settings),
        }

    def make_splits(self, settings):
        """Simulate the system's training and test splits.

        Parameters
        ----------
        settings : ExperimentSettings
            Sizes and seed.

        Returns
        -------
        splits : dict of str to Bunch
            ``{"train": Bunch, <test set>: Bunch, ...}``: the spec's ``records``
            at the run's seed, its ``tests`` at seeds 1000, 2000, ... away.
        """
        common = self._common(settings)
        splits = {
            "train": self.spec.records(
                settings.n_train, random_state=settings.seed, **common
            )
        }
        for k, (name, simulate) in enumerate(self.spec.tests.items(), start=1):
            seed = self.split_seed(settings, TEST_SEED_STEP * k)
            splits[name] = simulate(settings.n_test, random_state=seed, **common)
        return splits

    def physics(self, settings):
        """The system's physics models, unfitted, on the run's windows.

        Parameters
        ----------
        settings : ExperimentSettings
            Sizes and seed.

        Returns
        -------
        physics : dict of str to estimator
            ``{label: unfitted regressor}`` (``"physics"`` for one model).
        """
        physics = self.spec.physics
        if not isinstance(physics, dict):
            physics = {"physics": physics}
        out = {}
        for label, model in physics.items():
            model = clone(model)
            if "n_steps" in model.get_params(deep=False):
                model.set_params(n_steps=settings.n_steps)
            out[label] = model
        return out

    def claims(self, result):
        """The paper's claims checked on a finished run (the spec's, or none).

        Parameters
        ----------
        result : ExperimentResult
            A finished run of this system.

        Returns
        -------
        claims : list of dict
            ``{"claim", "passed", "detail"}`` each.
        """
        check = self.spec.protocol.claims
        return [] if check is None else list(check(result))

    def validation_split(self, settings):
        """New episodes like the training split's, which no fit reads.

        The chosen model's noise model is fitted on its residuals there (the
        report's stochastic part); ``make_splits``'s training split at another
        seed, as long as a test split.

        Parameters
        ----------
        settings : ExperimentSettings
            Sizes and seed.

        Returns
        -------
        validation : Bunch
            As a split of :meth:`make_splits`.
        """
        seed = self.split_seed(settings, VALIDATION_SEED)
        return self.make_splits(replace(settings, seed=seed, n_train=settings.n_test))[
            "train"
        ]

    def split_descriptions(self):
        """What each split of the system holds, in words.

        Returns
        -------
        descriptions : dict of str to str
            ``{split: description}``.
        """
        return dict(self.spec.protocol.descriptions)

    # -- the pipeline's hooks ---------------------------------------------------
    def default_settings(self, quick=False, seed=0):
        """The run's settings: the full run's or ``--quick``'s, at ``seed``.

        Parameters
        ----------
        quick : bool, default=False
            Small data and few epochs.
        seed : int, default=0
            Seed of the data and the models.

        Returns
        -------
        settings : ExperimentSettings
            Sizes, architectures and seed; windows of the spec's ``n_init``
            time steps.
        """
        make = ExperimentSettings.quick if quick else ExperimentSettings.full
        return replace(make(seed), n_steps=self.spec.n_init)

    def new_result(self, settings, data=None, searched=None):
        """Simulate the splits and return an :class:`ExperimentResult` without models.

        Parameters
        ----------
        settings : ExperimentSettings
            Sizes and seed.
        data : None
            Unused: a simulated system reads no files.
        searched : None
            Unused: a simulated system makes no search.

        Returns
        -------
        result : ExperimentResult
            The splits, the validation split, the oracle's predictions and the
            share of each test split outside the training hull.
        """
        splits = self.make_splits(settings)
        result = ExperimentResult(self, settings, splits)
        result.validation = self.validation_split(settings)
        for split in result.test_splits:
            result.predictions[split]["oracle"] = np.asarray(splits[split].oracle)
        result.hull = hull_shares(splits, settings.n_steps)
        return result

    def model_zoo(self, settings):
        """The zoo of the paper's section 6 for this system (unfitted estimators).

        Parameters
        ----------
        settings : ExperimentSettings
            Sizes, architectures and seed.

        Returns
        -------
        zoo : dict of str to estimator
            In the order the report lists them.
        """
        return model_zoo(self, settings)

    def open_folder(self, result, folder):
        """Prepare a run folder for this system's models (nothing to prepare).

        Parameters
        ----------
        result : ExperimentResult
            The run.
        folder : RunFolder
            Its folder.
        """

    def progress_label(self, settings):
        """What the progress bars call this run.

        Parameters
        ----------
        settings : ExperimentSettings
            The run's settings.

        Returns
        -------
        label : str
            The system's name.
        """
        return self.name

    def epochs_at_most(self, models, result):
        """The most epochs the networks of ``models`` can train.

        Parameters
        ----------
        models : dict of str to estimator
            The models still to fit.
        result : ExperimentResult
            The run.

        Returns
        -------
        n_epochs : int
            The sum of their :func:`~skhybrid.experiments._progress.epoch_budget`.
        """
        return sum(epoch_budget(model) for model in models.values())

    #: Whether each model searches over folds (the runner then fits the models
    #: one at a time, each search on every worker): a simulated system's
    #: models are single fits, run side by side.
    parallel_folds = False

    def job(self, name, model, result, deps, sink=None, n_jobs=1, n_threads=None):
        """The joblib call that fits one model and predicts every split.

        Parameters
        ----------
        name : str
            The model's name.
        model : estimator
            The unfitted model.
        result : ExperimentResult
            The splits.
        deps : dict
            Unused: no model of the zoo requires another.
        sink : object or None, default=None
            Where its networks report their epochs.
        n_jobs, n_threads : int or None
            Unused: the model is one fit, in its own worker.

        Returns
        -------
        call : tuple
            A :func:`joblib.delayed` call of
            :func:`~skhybrid.experiments._simulated.fit_one`.
        """
        if sink is not None:
            attach_epoch_logger(model, sink, name)
        train = result.splits["train"]
        tests = [(split, result.splits[split].X) for split in result.test_splits]
        tests.append((VALIDATION_SPLIT, result.validation.X))
        return delayed(fit_one)(name, model, train.X, train.y, tests)
