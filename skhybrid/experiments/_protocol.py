"""The paper's one-step protocol, as a :class:`SystemSpec` states it.

A :class:`~skhybrid.experiments.SystemSpec` is judged by the free-run protocol
unless its ``protocol`` is a :class:`OneStepWindows`: then its ``records`` and
``tests`` are simulators, each row of their data a window of ``n_init`` time
steps, every model of the paper's zoo (section 6) predicts each row's next state
from its window, and each test set is scored by that one-step error against the
noise-free oracle's.
"""

import numbers
from dataclasses import asdict, dataclass, field, fields

__all__ = [
    "NOISE_TYPES",
    "OneStepSizes",
    "OneStepWindows",
    "check_one_step_spec",
]

#: Where a simulator's noise enters.
NOISE_TYPES = ("measurement", "process")


def _check_positive_int(name, value):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an int >= 1; got {name}={value!r}.")
    if value < 1:
        raise ValueError(f"{name} must be an int >= 1; got {name}={value!r}.")


@dataclass(frozen=True)
class OneStepSizes:
    """Data sizes, architectures and training budget of a one-step run.

    The defaults are the paper's appendix A scaled to a CPU budget, chosen
    before any test set was seen; every network stops early on a validation
    slice taken from the end of its own training rows. A
    :class:`OneStepWindows` holds one for the full run (``sizes``) and one for
    ``--quick`` (``quick_sizes``); every row of the data is a window of the
    spec's ``n_init`` time steps.

    Parameters
    ----------
    n_train : int, default=25_000
        Training rows.
    n_test : int, default=25_000
        Rows of each test set (and of the validation episodes).
    max_epochs : int, default=200
        Most epochs of any network.
    patience : int, default=30
        Epochs without validation improvement before early stopping.
    dense_layers : tuple of int, default=(128, 128, 128)
        Hidden layers of the dense and cyclic networks.
    rnn_hidden : int, default=50
        Hidden units per recurrent layer.
    rnn_layers : int, default=2
        Recurrent layers.
    batch_size : int, default=512
        Mini-batch size.
    window : int, default=200
        Samples per short window of the RMSE-in-dB box plots.
    lags : int, default=20
        Ljung-Box lags of the losses and the whiteness tests.

    Examples
    --------
    >>> from skhybrid.experiments import OneStepSizes
    >>> OneStepSizes.quick().n_train
    3000
    """

    n_train: int = 25_000
    n_test: int = 25_000
    max_epochs: int = 200
    patience: int = 30
    dense_layers: tuple = (128, 128, 128)
    rnn_hidden: int = 50
    rnn_layers: int = 2
    batch_size: int = 512
    window: int = 200
    lags: int = 20

    def __post_init__(self):
        for f in fields(self):
            if f.name != "dense_layers":
                _check_positive_int(f.name, getattr(self, f.name))
        layers = self.dense_layers
        if not isinstance(layers, tuple) or not layers:
            raise TypeError(
                "dense_layers must be a non-empty tuple of ints; got "
                f"dense_layers={layers!r}."
            )
        for i, width in enumerate(layers):
            _check_positive_int(f"dense_layers[{i}]", width)

    @classmethod
    def quick(cls):
        """The ``--quick`` sizes: a run that finishes within a minute on two cores.

        Returns
        -------
        sizes : OneStepSizes
            3,000 training and 2,000 test rows, 2 x 32 and 16-unit networks,
            12 epochs.
        """
        return cls(
            n_train=3_000,
            n_test=2_000,
            max_epochs=12,
            patience=5,
            dense_layers=(32, 32),
            rnn_hidden=16,
            rnn_layers=1,
            batch_size=256,
            window=100,
        )

    def to_dict(self):
        """The sizes as a JSON-ready dict.

        Returns
        -------
        sizes : dict
            Every field, tuples as lists.
        """
        out = asdict(self)
        out["dense_layers"] = list(self.dense_layers)
        return out


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
        run, a list of ``{"claim", "passed", "detail"}``; the report shows them
        (a ``--quick`` run's as not evaluated).
    sizes : OneStepSizes, default=OneStepSizes()
        Data sizes, networks and training budget of the full run.
    quick_sizes : OneStepSizes, default=OneStepSizes.quick()
        Those of ``--quick`` (:class:`~skhybrid.experiments.RunSettings`'s
        ``quick``).

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
    sizes: OneStepSizes = field(default_factory=OneStepSizes)
    quick_sizes: OneStepSizes = field(default_factory=OneStepSizes.quick)

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
        for key in ("sizes", "quick_sizes"):
            value = getattr(self, key)
            if not isinstance(value, OneStepSizes):
                raise TypeError(f"{key} must be a OneStepSizes; got {key}={value!r}.")

    def sizes_for(self, quick):
        """The sizes of a full run or of ``--quick``.

        Parameters
        ----------
        quick : bool
            The run's ``quick``.

        Returns
        -------
        sizes : OneStepSizes
            ``quick_sizes`` or ``sizes``.
        """
        return self.quick_sizes if quick else self.sizes


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
