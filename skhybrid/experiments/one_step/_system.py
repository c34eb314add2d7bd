"""A system of the paper's one-step protocol in the pipeline.

A :class:`~skhybrid.experiments.SystemSpec` whose ``protocol`` is a
:class:`~skhybrid.experiments.OneStepWindows` (the built-in pendulum, double
pendulum and DC motor of :mod:`skhybrid.benchmarks`, or a user's) runs as a
:class:`OneStepSystem`: its simulators give the splits at each seed, its physics
the family's physics models. It answers the pipeline's hooks
(:func:`~skhybrid.experiments.run_experiment` calls the same ones on a
free-run system): a new result, its model zoo (:func:`model_zoo`, the
protocol's family of models), the joblib call that fits one model, and the most
epochs its networks can train.
"""

import hashlib
from dataclasses import fields as dataclass_fields

import numpy as np
from joblib import delayed
from sklearn.base import clone

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.experiments._describe import canonical, describe
from skhybrid.experiments._protocol import OneStepWindows
from skhybrid.experiments._settings import on_device
from skhybrid.experiments._spec import SystemSpec
from skhybrid.experiments.one_step._result import ExperimentResult, fit_one, hull_shares
from skhybrid.experiments.one_step._stochastic import VALIDATION_SPLIT
from skhybrid.experiments.run._progress import attach_epoch_logger, epoch_budget
from skhybrid.hybrid import HybridBoostingRegressor, HybridEnsembleRegressor
from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor

__all__ = ["OneStepSystem", "model_zoo"]

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
        #: Time steps per row: the spec's window.
        self.n_steps = spec.n_init
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
        settings : RunSettings
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
        settings : RunSettings
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

    def sizes(self, settings):
        """The data sizes, networks and budget of a run with ``settings``.

        Parameters
        ----------
        settings : RunSettings
            Its ``quick``.

        Returns
        -------
        sizes : OneStepSizes
            The protocol's ``quick_sizes`` or ``sizes``.
        """
        return self.spec.protocol.sizes_for(settings.quick)

    def settings_table(self, settings):
        """What the report and ``results.json`` show of a run's settings.

        Parameters
        ----------
        settings : RunSettings
            The run's settings.

        Returns
        -------
        table : dict
            The sizes, the window's time steps, the seed and the noise type.
        """
        sizes = self.sizes(settings).to_dict()
        first = {k: sizes.pop(k) for k in ("n_train", "n_test")}
        return {
            **first,
            "n_steps": self.n_steps,
            **sizes,
            "seed": settings.seed,
            "noise_type": settings.noise_type,
        }

    def _common(self, settings):
        return {
            "n_steps": self.n_steps,
            "noise": self.noise,
            "noise_type": self.noise_type(settings),
        }

    def make_splits(self, settings):
        """Simulate the system's training and test splits.

        Parameters
        ----------
        settings : RunSettings
            The run's seed, and ``quick`` for the sizes.

        Returns
        -------
        splits : dict of str to Bunch
            ``{"train": Bunch, <test set>: Bunch, ...}``: the spec's ``records``
            at the run's seed, its ``tests`` at seeds 1000, 2000, ... away.
        """
        common, sizes = self._common(settings), self.sizes(settings)
        splits = {
            "train": self.spec.records(
                sizes.n_train, random_state=settings.seed, **common
            )
        }
        for k, (name, simulate) in enumerate(self.spec.tests.items(), start=1):
            seed = self.split_seed(settings, TEST_SEED_STEP * k)
            splits[name] = simulate(sizes.n_test, random_state=seed, **common)
        return splits

    def physics(self, settings):
        """The system's physics models, unfitted, on the run's windows.

        Parameters
        ----------
        settings : RunSettings
            The run's seed, and ``quick`` for the sizes.

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
                model.set_params(n_steps=self.n_steps)
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
        settings : RunSettings
            The run's seed, and ``quick`` for the sizes.

        Returns
        -------
        validation : Bunch
            As a split of :meth:`make_splits`.
        """
        seed = self.split_seed(settings, VALIDATION_SEED)
        return self.spec.records(
            self.sizes(settings).n_test, random_state=seed, **self._common(settings)
        )

    def split_descriptions(self):
        """What each split of the system holds, in words.

        Returns
        -------
        descriptions : dict of str to str
            ``{split: description}``.
        """
        return dict(self.spec.protocol.descriptions)

    # -- the pipeline's hooks (the runner's contract, ZooSystem) ---------------
    def bind(self, data=None, quick=False):
        """The system itself: its spec is its own, and it reads no file.

        Parameters
        ----------
        data : None
            Unused: a simulated system reads no files.
        quick : bool, default=False
            Unused: the sizes are chosen per run (:meth:`sizes`).

        Returns
        -------
        system : OneStepSystem
            ``self``.
        """
        return self

    def new_result(self, settings, data=None, searched=None):
        """Simulate the splits and return an :class:`ExperimentResult` without models.

        Parameters
        ----------
        settings : RunSettings
            The run's seed, and ``quick`` for the sizes.
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
        result.hull = hull_shares(splits, self.n_steps)
        return result

    def model_zoo(self, settings):
        """The zoo of the paper's section 6 for this system (unfitted estimators).

        Parameters
        ----------
        settings : RunSettings
            The run's seed, and ``quick`` for the sizes.

        Returns
        -------
        zoo : dict of str to estimator
            In the order the report lists them.
        """
        return model_zoo(self, settings)

    def requirements(self, zoo):
        """The models each model requires: none (each is fitted on its own).

        Parameters
        ----------
        zoo : dict of str to estimator
            As :meth:`model_zoo` returns it.

        Returns
        -------
        requires : dict of str to tuple
            An empty tuple for every model.
        """
        return {name: () for name in zoo}

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
        settings : RunSettings
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
            The sum of their :func:`~skhybrid.experiments.run._progress.epoch_budget`.
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
            :func:`~skhybrid.experiments.one_step._result.fit_one`.
        """
        if sink is not None:
            attach_epoch_logger(model, sink, name)
        train = result.splits["train"]
        tests = [(split, result.splits[split].X) for split in result.test_splits]
        tests.append((VALIDATION_SPLIT, result.validation.X))
        return delayed(fit_one)(name, model, train.X, train.y, tests)


# -- the protocol's family of models ---------------------------------------------
def _network_kwargs(sizes, seed, seed_offset, target_scaling="per_output"):
    return {
        "target_scaling": target_scaling,
        "max_epochs": sizes.max_epochs,
        "patience": sizes.patience,
        "batch_size": sizes.batch_size,
        "random_state": seed + seed_offset,
    }


def model_zoo(system, settings):
    """The one-step protocol's family of models for ``system`` (the paper's zoo).

    Every model is unfitted; the order is the report's. The protocol's sizes
    (:class:`~skhybrid.experiments.OneStepSizes`) give the networks and their
    training budget, the spec's ``n_init`` the window.

    Parameters
    ----------
    system : OneStepSystem
        The system (gives its physics models and sizes).
    settings : RunSettings
        The run's seed, noise type and ``quick``.

    Returns
    -------
    zoo : dict of str to estimator
        Physics alone, a linear state-space model, dense, RNN and cyclic networks,
        the hybrids physics+linear, physics+dense, physics+RNN (MSE),
        physics+RNN (Ljung-Box), physics+cyclic, and the joint ensemble.
    """
    s, seed, n_steps = system.sizes(settings), settings.seed, system.n_steps
    physics = system.physics(settings)
    base = physics[system.hybrid_physics]

    # Standalone networks predict states in different units: scale per output.
    # Residual stages scale all outputs alike, so their loss weighs errors in the
    # outputs' units like the physics stage's least squares (outputs the physics
    # already explains hold only noise, which per-output scaling would inflate).
    def dense(offset, scaling="per_output"):
        return DenseRegressor(
            s.dense_layers, **_network_kwargs(s, seed, offset, scaling)
        )

    def rnn(offset, objective="mse", scaling="per_output", lr=0.01, **lb):
        return RNNRegressor(
            "gru",
            hidden_size=s.rnn_hidden,
            num_layers=s.rnn_layers,
            n_steps=n_steps,
            objective=objective,
            ljung_box_lags=s.lags,
            lr=lr,
            **lb,
            **_network_kwargs(s, seed, offset, scaling),
        )

    def cyclic(offset, scaling="per_output"):
        return CyclicRegressor(
            s.dense_layers, **_network_kwargs(s, seed, offset, scaling)
        )

    def boost(name, stage, **kwargs):
        return HybridBoostingRegressor(
            [("physics", clone(base)), (name, stage)],
            n_steps=n_steps,
            ljung_box_lags=s.lags,
            random_state=seed,
            **kwargs,
        )

    zoo = dict(physics)
    zoo["linear"] = LinearStateSpaceModel(n_steps=n_steps)
    zoo["dense"] = dense(1)
    zoo["rnn"] = rnn(2)
    zoo["cyclic"] = cyclic(3)
    # A linear stage reads the state from the window itself, not from added columns.
    zoo["physics+linear"] = boost(
        "linear", LinearStateSpaceModel(n_steps=n_steps), stage_input="window"
    )
    zoo["physics+dense"] = boost("dense", dense(4, "shared"))
    # The recurrent residual stages learn at lr 0.003, chosen on a validation
    # loss (docs/experiments.md, "How the settings were chosen").
    zoo["physics+rnn (mse)"] = boost("rnn", rnn(5, "mse", "shared", 0.003))
    # The Ljung-Box stage is the MSE stage fine-tuned: it trains on the MSE
    # first (the same network, seed and batches as the MSE stage), then goes on
    # from its best weights with batch normalisation frozen, on batches of
    # shuffled rows (the MSE) plus segments of 32 rows in time order (the
    # Ljung-Box term), weight 0.1, keeping the MSE weights unless the validation
    # objective improves. Under process noise, where the true equations leave a
    # white residual on every state, each output's term is on its own scale so
    # that the small states' whiteness counts; under measurement noise no
    # model's residual is white and that only cost RMSE. All chosen on the
    # validation slice of the training rows (seed 0), see docs/losses.md
    # ("Training a stage with a Ljung-Box term").
    process = system.noise_type(settings) == "process"
    zoo["physics+rnn (ljung-box)"] = boost(
        "rnn",
        rnn(
            5,
            "mse+ljung_box",
            "shared",
            0.003,
            ljung_box_segment_length=max(32, s.lags + 1),
            ljung_box_weight=0.1,
            ljung_box_scaling="per_output" if process else "target",
            mse_pretraining=True,
        ),
    )
    zoo["physics+cyclic"] = boost("cyclic", cyclic(6, "shared"))
    zoo["ensemble"] = HybridEnsembleRegressor(
        clone(physics[system.ensemble_physics]),
        dense(7),
        max_epochs=s.max_epochs,
        patience=s.patience,
        batch_size=s.batch_size,
        random_state=seed + 7,
    )
    return {name: on_device(model, settings.device) for name, model in zoo.items()}
