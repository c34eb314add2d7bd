"""What a simulated system of the paper is: its splits and the physics fitted to each.

The systems themselves are modules of the catalogue, :mod:`skhybrid.benchmarks`.
"""

from dataclasses import replace

__all__ = ["System"]

#: Offset of the validation episodes' seed from the run's (the test splits of
#: the catalogue's systems use 1000 and 2000).
VALIDATION_SEED = 3000


class System:
    """A benchmark system: how to simulate its splits and which physics to fit.

    Subclasses set ``name``, ``title`` and ``section`` and implement
    :meth:`make_splits` and :meth:`physics`.
    """

    #: Simulated splits; a measured benchmark (``MeasuredSystem``) sets True.
    measured = False
    name = ""
    title = ""
    section = ""
    #: Label (in :meth:`physics`) of the physics used as first stage of hybrids.
    hybrid_physics = "physics"
    #: Label of the physics warm-started and trained jointly in the ensemble.
    ensemble_physics = "physics"
    #: Where the simulator's noise enters unless the settings say otherwise.
    default_noise_type = "measurement"
    #: Standard deviation of the simulator's noise on every observed state.
    noise = 0.01

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
            ``{"train": Bunch, "interpolation": Bunch, ...}``.
        """
        raise NotImplementedError

    def physics(self, settings):
        """The system's physics models, unfitted.

        Parameters
        ----------
        settings : ExperimentSettings
            Sizes and seed.

        Returns
        -------
        physics : dict of str to DomainModel
            ``{label: unfitted domain model}``.
        """
        raise NotImplementedError

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
        seed = (settings.seed + VALIDATION_SEED) % 2**32
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
        return {}
