"""The paper's one-step protocol, as a :class:`SystemSpec` states it.

A :class:`~skhybrid.experiments.SystemSpec` is judged by the free-run protocol
unless its ``protocol`` is a :class:`OneStepWindows`: then its ``records`` and
``tests`` are simulators, each row of their data a window of ``n_init`` time
steps, every model of the paper's zoo (section 6) predicts each row's next state
from its window, and each test set is scored by that one-step error against the
noise-free oracle's.
"""

import numbers
from dataclasses import dataclass, field

__all__ = ["NOISE_TYPES", "OneStepWindows"]

#: Where a simulator's noise enters.
NOISE_TYPES = ("measurement", "process")


@dataclass(frozen=True)
class OneStepWindows:
    """The paper's one-step protocol for a simulated system.

    Give it as a :class:`~skhybrid.experiments.SystemSpec`'s ``protocol``. The
    spec's ``records`` is then the simulator of the training episodes, a function
    ``records(n_samples, *, random_state, n_steps, noise, noise_type)`` returning
    a Bunch of windows (as :func:`~skhybrid.datasets.make_pendulum` does, with
    ``X``, ``y`` and the noise-free ``oracle``); ``tests`` maps each test set's
    name to a simulator of the same form, simulated at seeds 1000, 2000, ...
    away from the run's; ``physics`` is a regressor on windows (a
    :class:`~skhybrid.domain.ParametricModel`, say), or a dict of them by label;
    ``n_init`` is the window's time steps.

    Parameters
    ----------
    noise : float, default=0.01
        Standard deviation of the simulators' noise on every observed state.
    noise_type : {"measurement", "process"}, default="measurement"
        Where it enters unless a run says otherwise: on the measured states, or
        into the dynamics (the true equations' one-step residual is then white).
    hybrid_physics : str or None, default=None
        Label of the physics that starts every hybrid of the zoo; None where
        ``physics`` is one model.
    ensemble_physics : str or None, default=None
        Label of the physics trained jointly in the ensemble; None where
        ``physics`` is one model.
    descriptions : dict of str to str, default={}
        What each split holds, in words (``"train"`` and every test set).
    section : str, default=""
        The paper's section the system reproduces.
    claims : callable or None, default=None
        ``claims(result)`` returning the paper's claims checked on a finished
        run, a list of ``{"claim", "passed", "detail"}``; the report shows them.

    Examples
    --------
    >>> from functools import partial
    >>> from skhybrid.datasets import make_dc_motor
    >>> from skhybrid.experiments import OneStepWindows, SystemSpec
    >>> from skhybrid.domain import ParametricModel, dc_motor_step
    >>> spec = SystemSpec(
    ...     "my-motor",
    ...     records=partial(make_dc_motor, excitation_hz=10.0),
    ...     physics=ParametricModel(
    ...         partial(dc_motor_step, dt=0.001),
    ...         {"gain": 1.0, "time_constant": 0.05},
    ...     ),
    ...     n_init=4,
    ...     tests={"fast": partial(make_dc_motor, excitation_hz=100.0)},
    ...     protocol=OneStepWindows(),
    ... )
    >>> spec.protocol.noise_type
    'measurement'
    """

    noise: float = 0.01
    noise_type: str = "measurement"
    hybrid_physics: str = None
    ensemble_physics: str = None
    descriptions: dict = field(default_factory=dict)
    section: str = ""
    claims: object = None

    def __post_init__(self):
        noise = self.noise
        if (
            isinstance(noise, bool)
            or not isinstance(noise, numbers.Real)
            or not noise >= 0
            or noise == float("inf")
        ):
            raise ValueError(
                f"noise must be a finite number >= 0; got noise={noise!r}."
            )
        if self.noise_type not in NOISE_TYPES:
            raise ValueError(
                f"noise_type must be one of {NOISE_TYPES}; got "
                f"noise_type={self.noise_type!r}."
            )
        for key in ("hybrid_physics", "ensemble_physics"):
            value = getattr(self, key)
            if value is not None and not isinstance(value, str):
                raise TypeError(
                    f"{key} must be a label of the spec's physics or None; got "
                    f"{key}={value!r}."
                )
        descriptions = self.descriptions
        if not isinstance(descriptions, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in descriptions.items()
        ):
            raise TypeError(
                "descriptions must be a dict of split name to words; got "
                f"descriptions={descriptions!r}."
            )
        if not isinstance(self.section, str):
            raise TypeError(f"section must be a str; got section={self.section!r}.")
        if self.claims is not None and not callable(self.claims):
            raise TypeError(
                "claims must be a callable claims(result) or None; got "
                f"claims={self.claims!r}."
            )
