"""The paper's one-step protocol, as a :class:`SystemSpec` states it.

A :class:`~skhybrid.experiments.SystemSpec` is judged by the free-run protocol
unless its ``protocol`` is a :class:`OneStepWindows`: then its ``records`` and
``tests`` are simulators, each row of their data a window of ``n_init`` time
steps, every model of the paper's zoo (section 6) predicts each row's next state
from its window, and each test set is scored by that one-step error against the
noise-free oracle's.
"""

import numbers
from dataclasses import dataclass, field, fields

__all__ = ["NOISE_TYPES", "OneStepWindows", "check_one_step_spec", "refuse_one_step"]

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


def refuse_one_step(spec, method):
    """Raise where ``spec`` is of the one-step protocol: it has no records to read."""
    if isinstance(spec.protocol, OneStepWindows):
        raise ValueError(  # noqa: TRY004 - the spec's protocol, not a type error
            f"{method} reads a free-run spec's records; {spec.name!r} has "
            "protocol=OneStepWindows, whose records and tests are simulators "
            "that its run calls at each seed."
        )


#: What only the free-run protocol reads (a one-step spec leaves them unset).
_FREE_RUN_ONLY = (
    "dt",
    "inputs",
    "outputs",
    "physics_inputs",
    "segments",
    "hybrids",
    "hybrid_records",
    "physics_starts",
    "starts_nfev",
    "score_from_estimation_start",
)


def _is_regressor(obj):
    return (
        hasattr(obj, "get_params") and hasattr(obj, "fit") and hasattr(obj, "predict")
    )


def check_one_step_spec(spec):
    """Raise unless ``spec`` (a SystemSpec) states a system of the one-step protocol."""
    defaults = {f.name: f.default for f in fields(spec)}
    set_ = [key for key in _FREE_RUN_ONLY if getattr(spec, key) != defaults[key]]
    if set_:
        raise ValueError(
            f"{', '.join(set_)} belong to the free-run protocol; a spec with "
            "protocol=OneStepWindows simulates windows and reads none of them: "
            "leave them unset."
        )
    if not callable(spec.records):
        raise TypeError(
            "records must be a simulator records(n_samples, *, random_state, "
            "n_steps, noise, noise_type) under protocol=OneStepWindows; got "
            f"{type(spec.records).__name__}."
        )
    tests = spec.tests
    if (
        not isinstance(tests, dict)
        or not tests
        or not all(isinstance(k, str) and callable(v) for k, v in tests.items())
    ):
        raise TypeError(
            "tests must be a non-empty dict of test set name to simulator under "
            f"protocol=OneStepWindows; got tests={tests!r}."
        )
    if "train" in tests:
        raise ValueError("tests must not name a test set 'train' (the records').")
    physics, proto = spec.physics, spec.protocol
    if isinstance(physics, dict):
        if not physics or not all(
            isinstance(k, str) and _is_regressor(v) for k, v in physics.items()
        ):
            raise TypeError(
                "physics must be a regressor on windows, or a non-empty dict of "
                f"label to regressor; got physics={physics!r}."
            )
        for key in ("hybrid_physics", "ensemble_physics"):
            label = getattr(proto, key)
            if label is None and len(physics) > 1:
                raise ValueError(
                    f"protocol.{key} must name one of the physics "
                    f"{sorted(physics)}: the spec has several."
                )
            if label is not None and label not in physics:
                raise ValueError(
                    f"protocol.{key}={label!r} is not a label of the physics "
                    f"{sorted(physics)}."
                )
    elif not _is_regressor(physics):
        raise TypeError(
            "physics must be a regressor on windows (fit and predict, a "
            "ParametricModel say) under protocol=OneStepWindows; got "
            f"{type(physics).__name__}."
        )
