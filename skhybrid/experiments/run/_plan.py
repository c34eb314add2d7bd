"""What a run fits into its folder: :class:`RunPlan`, the same for every entry.

``skhybrid run`` and :func:`~skhybrid.experiments.run_system` both run a plan
inside the run folder's transaction: its identity (what a resume must match),
its records' digests (checked before the folder changes), and its fit. A plan
holds the one-step protocol's systems at one seed (``skhybrid run all`` holds
the paper's three), or one free-run system at its seeds, searched at the first
and refitted at each, its selection sealed before the test records are read.
"""

import numpy as np

import skhybrid
from skhybrid.experiments._settings import RunSettings, check_settings
from skhybrid.experiments.free_run._identity import measured_identity, record_digests
from skhybrid.experiments.free_run._seeds import run_seeds
from skhybrid.experiments.run._runner import fit_seed

__all__ = [
    "DEFAULT_SEEDS",
    "MAX_SEED",
    "RunPlan",
    "check_seeds",
]

#: The seeds of a measured run: the first searches, each refits the choices.
DEFAULT_SEEDS = (0, 1, 2)
#: Largest seed: numpy's and scikit-learn's seeds are 32-bit unsigned integers.
MAX_SEED = 2**32 - 1


def check_seeds(seeds):
    """The seeds of a measured run, checked: distinct ints >= 0.

    Parameters
    ----------
    seeds : sequence of int
        The first seed searches; each refits the choices.

    Returns
    -------
    seeds : list of int
        The seeds.

    Raises
    ------
    ValueError
        An empty sequence, a seed that is not an int between 0 and
        ``2**32 - 1`` (numpy's seeds), or a repeated seed.
    """
    if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__iter__"):
        raise ValueError(
            "seeds must be a non-empty sequence of ints between 0 and 2**32 - 1; "
            f"got seeds={seeds!r}."
        )
    seeds = list(seeds)
    if not seeds or any(
        isinstance(s, bool)
        or not isinstance(s, (int, np.integer))
        or not 0 <= s <= MAX_SEED
        for s in seeds
    ):
        raise ValueError(
            "seeds must be a non-empty sequence of ints between 0 and 2**32 - 1 "
            f"(numpy's seeds); got seeds={seeds!r}."
        )
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must differ; got seeds={seeds!r}.")
    return [int(s) for s in seeds]


class RunPlan:
    """What a run fits: one-step systems at one seed, or a free-run one at its seeds.

    Parameters
    ----------
    systems : list of OneStepSystem or MeasuredSystem
        One free-run system, or one or more of the one-step protocol.
    seeds : sequence of int or None, default=None
        The seeds (None: the free-run default, ``(0, 1, 2)``, or seed 0); a
        one-step plan takes one.
    quick : bool, default=False
        Small data, few epochs, short fits.
    data : str or Path or None, default=None
        A built-in measured benchmark's files.
    noise_type : {"measurement", "process"} or None, default=None
        Where a one-step system's simulators put their noise (None: its own).
    device : {"cpu", "cuda"}, default="cpu"
        Where every network of the run trains (see :class:`RunSettings`).

    Raises
    ------
    ValueError
        Systems of both protocols, several free-run systems, a one-step plan
        given several seeds, or seeds that are not distinct ints in numpy's
        range; ``noise_type`` for a free-run system.
    """

    def __init__(
        self,
        systems,
        *,
        seeds=None,
        quick=False,
        data=None,
        noise_type=None,
        device="cpu",
    ):
        systems = list(systems)
        self.measured = systems[0].measured
        if any(system.measured != self.measured for system in systems):
            raise ValueError("a run holds systems of one protocol")
        if self.measured and len(systems) != 1:
            raise ValueError("a run of the free-run protocol holds one system")
        if seeds is None:
            seeds = DEFAULT_SEEDS if self.measured else (0,)
        self.seeds = check_seeds(seeds)
        if not self.measured and len(self.seeds) != 1:
            names = ", ".join(system.name for system in systems)
            raise ValueError(
                f"{names} is simulated and runs one seed (the one-step protocol "
                f"simulates its splits at it); got seeds {self.seeds}: give one, "
                "and a run per seed for a spread (a measured run makes a "
                "selection at each of several)"
            )
        self.systems = systems
        self.quick = bool(quick)
        self.data = data
        self.noise_type = noise_type
        self.device = device
        self._bound = None
        for system in systems:
            check_settings(system, self.settings(self.seeds[0]))

    @property
    def bound(self):
        """The systems, each bound once for the run (a benchmark's files read).

        The identity, the records' digests and the fit all use these: a run
        resolves its systems once.
        """
        if self._bound is None:
            self._bound = [
                system.bind(self.data, self.quick) for system in self.systems
            ]
        return self._bound

    @property
    def names(self):
        """The systems' names."""
        return [system.name for system in self.systems]

    def settings(self, seed):
        """The run's settings at ``seed``.

        Parameters
        ----------
        seed : int
            One of the run's seeds.

        Returns
        -------
        settings : RunSettings
            The run's ``quick``, noise type and device at ``seed``.
        """
        return RunSettings(
            quick=self.quick, seed=seed, noise_type=self.noise_type, device=self.device
        )

    @property
    def identity(self):
        """What a resumed run must match (:class:`RunFolder`'s ``run.json``)."""
        identity = self.settings_identity()
        if self.measured:
            identity["spec"] = self.bound[0].digest()
        else:
            # What each spec says (its simulators, physics and protocol by name).
            identity["specs"] = {system.name: system.digest() for system in self.bound}
        return identity

    def settings_identity(self):
        """The part of :attr:`identity` known before any record is read.

        Returns
        -------
        identity : dict
            :attr:`identity` without the specs' digests (which a built-in
            benchmark knows once its files are read): a folder holding a run
            of other settings is refused before them.
        """
        if self.measured:
            identity = measured_identity(
                self.systems[0],
                self.quick,
                self.seeds,
                digest=False,
                device=self.device,
            )
            del identity["spec"]
            return identity
        return {
            "skhybrid": skhybrid.__version__,
            "systems": self.names,
            "quick": self.quick,
            "seed": self.seeds[0],
            "settings": self.settings(self.seeds[0]).to_dict(),
        }

    @property
    def n_models(self):
        """Models the run fits: each system's zoo, at each seed."""
        return len(self.seeds) * sum(
            len(system.model_zoo(self.settings(self.seeds[0])))
            for system in self.systems
        )

    def record_digests(self):
        """Read and check a free-run system's records (or raise); their SHA-256.

        Returns
        -------
        records : dict of str to str or None
            ``{name of a seed's models: SHA-256 of the records}``, for
            :meth:`RunFolder.start`; None for simulated systems.
        """
        if not self.measured:
            return None
        return record_digests(
            self.bound[0], self.seeds, quick=self.quick, data=self.data
        )

    def fit(self, folder, *, n_jobs=1, progress=False):
        """Fit every system into ``folder``: the results to report.

        Parameters
        ----------
        folder : RunFolder
            The started run folder.
        n_jobs : int, default=1
            Workers of joblib (-1: every core, or every Dask worker).
        progress : bool, default=False
            Progress on standard error.

        Returns
        -------
        results : list of ExperimentResult or MeasuredRun
            One per system, for :func:`~skhybrid.experiments.write_report`.
        """
        if self.measured:
            run = run_seeds(
                self.bound[0],
                seeds=self.seeds,
                quick=self.quick,
                n_jobs=n_jobs,
                progress=progress,
                folder=folder,
                data=self.data,
                device=self.device,
            )
            return [run]
        return [
            fit_seed(
                system,
                self.settings(self.seeds[0]),
                n_jobs=n_jobs,
                progress=progress,
                folder=folder,
                data=self.data,
            )
            for system in self.bound
        ]
