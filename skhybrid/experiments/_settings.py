"""What makes two runs of a system the same: :class:`RunSettings`."""

import numbers
from dataclasses import asdict, dataclass, replace

from skhybrid.experiments._protocol import NOISE_TYPES

__all__ = ["DEVICES", "RunSettings", "check_settings", "on_device"]

#: Where a run's networks train (``--device``).
DEVICES = ("cpu", "cuda")


@dataclass(frozen=True)
class RunSettings:
    """The settings of one run of any system, as ``skhybrid run`` takes them.

    Every system, simulated or measured, runs under these three; what a system
    fits and how much (a one-step system's data sizes and networks, a
    free-run system's candidates) is its spec's, not the run's.

    Parameters
    ----------
    quick : bool, default=False
        The short form of the run (``--quick``): a one-step system's quick
        sizes (:class:`~skhybrid.experiments.OneStepWindows`'s
        ``quick_sizes``), a free-run system's shorter fits and fewer
        candidates.
    seed : int, default=0
        Seed of the networks (and of a one-step system's simulated splits).
    noise_type : {"measurement", "process"} or None, default=None
        Where a one-step system's simulators put their noise (``--noise-type``);
        None takes the spec's own. A free-run system reads measured records
        and takes None only.
    device : {"cpu", "cuda"}, default="cpu"
        Where every network of the run trains and simulates (``--device``);
        the physics' fits stay on the CPU, where they are fastest. A GPU's
        floating point differs from the CPU's, so a run on another device is
        another run (its identity says so; the CPU, the default, is left out
        of it, as in runs made before this setting existed).

    Examples
    --------
    >>> from skhybrid.experiments import RunSettings
    >>> RunSettings(quick=True).with_seed(3)
    RunSettings(quick=True, seed=3, noise_type=None, device='cpu')
    """

    quick: bool = False
    seed: int = 0
    noise_type: str | None = None
    device: str = "cpu"

    def __post_init__(self):
        if not isinstance(self.quick, bool):
            raise TypeError(f"quick must be a bool; got quick={self.quick!r}.")
        seed = self.seed
        message = f"seed must be an int in [0, 2**32 - 1]; got seed={seed!r}."
        if isinstance(seed, bool) or not isinstance(seed, numbers.Integral):
            raise TypeError(message)
        if not 0 <= seed < 2**32:
            raise ValueError(message)
        object.__setattr__(self, "seed", int(seed))  # numpy's ints as Python's
        if self.noise_type is not None and self.noise_type not in NOISE_TYPES:
            raise ValueError(
                f"noise_type must be one of {NOISE_TYPES} or None; got "
                f"noise_type={self.noise_type!r}."
            )
        if not isinstance(self.device, str) or self.device not in DEVICES:
            raise ValueError(
                f"device must be one of {DEVICES}; got device={self.device!r}."
            )

    def with_seed(self, seed):
        """The same settings with another seed.

        Parameters
        ----------
        seed : int
            Seed of the networks and the splits.

        Returns
        -------
        settings : RunSettings
            A copy with ``seed``.
        """
        return replace(self, seed=seed)

    def to_dict(self):
        """The settings as a JSON-ready dict.

        Returns
        -------
        settings : dict
            Every field; ``device`` only where it is not the CPU (a run's
            identity, and its ``results.json``, as before the setting).
        """
        settings = asdict(self)
        if settings["device"] == "cpu":
            del settings["device"]
        return settings


def check_settings(system, settings):
    """Raise unless ``settings`` can run ``system``.

    Parameters
    ----------
    system : OneStepSystem or MeasuredSystem
        The system.
    settings : object
        What the caller gave as its settings.

    Raises
    ------
    TypeError
        ``settings`` is not a :class:`RunSettings`.
    ValueError
        A noise type for a measured system, whose records hold their own noise.
    """
    if not isinstance(settings, RunSettings):
        raise TypeError(
            "settings must be a skhybrid.experiments.RunSettings (quick, seed, "
            f"noise_type); got {type(settings).__name__}: {settings!r}."
        )
    if system.measured and settings.noise_type is not None:
        raise ValueError(
            "noise_type (--noise-type) sets the simulators' noise; "
            f"{system.name} is a measured system, whose records hold their own: "
            f"leave it unset; got noise_type={settings.noise_type!r}."
        )


def on_device(estimator, device):
    """Put every network inside ``estimator`` on ``device``.

    Sets each ``device`` parameter of ``estimator`` and of the estimators it
    holds (``get_params(deep=True)``: a hybrid's stages, an ensemble's
    members), where it is not already ``device``.

    Parameters
    ----------
    estimator : estimator
        A model of a run's family.
    device : {"cpu", "cuda"}
        The run's device.

    Returns
    -------
    estimator : estimator
        ``estimator``, changed in place.
    """
    if not hasattr(estimator, "get_params"):
        return estimator
    params = estimator.get_params(deep=True)
    moved = {
        name: device
        for name, value in params.items()
        if (name == "device" or name.endswith("__device")) and value != device
    }
    if moved:
        estimator.set_params(**moved)
    return estimator
