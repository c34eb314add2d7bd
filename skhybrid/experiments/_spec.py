"""A system described once: :class:`SystemSpec`, of either protocol.

A user's machine and the built-in benchmarks take the same path: a spec names
the estimation records, the sample period, the initialisation window, the
physics and (optionally) the test records; :func:`~skhybrid.experiments.run_system`
fits the default candidate family on it, chooses by blocked cross-validation of
the estimation records, seals the selection and only then simulates the test
records. A spec of the paper's one-step protocol (``protocol=OneStepWindows(...)``,
:mod:`~skhybrid.experiments._protocol`) names simulators instead.
"""

import difflib
import inspect
import numbers
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from sklearn.base import clone

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments._protocol import (
    OneStepWindows,
    check_one_step_spec,
)
from skhybrid.hybrid import MIN_SUBSEQUENCES, StateSpaceHybridRegressor
from skhybrid.utils._validation import first_not_finite

__all__ = ["SystemSpec", "as_records", "records_digest"]

#: The default candidate family's initial horizon of the state-space hybrid
#: (samples); the grid is this and four times it, kept below the records' length.
DEFAULT_HORIZON = 50
#: The correction network of the family's state-space hybrids.
HYBRID_LAYERS = (64, 64)


def pieces_per_record(lengths, n_pieces):
    """Into how many pieces each record is cut, about ``n_pieces`` in all.

    In proportion to the records' lengths, at least one each: the cut of the
    state-space hybrid's training records (``SystemSpec.hybrid_records``).

    Parameters
    ----------
    lengths : list of int
        Samples of each record.
    n_pieces : int
        Pieces wanted in all.

    Returns
    -------
    pieces : list of int
        Pieces of each record.
    """
    total = sum(lengths)
    return [max(1, round(n_pieces * n / total)) for n in lengths]


def _is_frame(obj):
    return hasattr(obj, "columns") and hasattr(obj, "index")


def _frame_record(frame, inputs, outputs, where):
    missing = [c for c in (*inputs, *outputs) if c not in frame.columns]
    if missing:
        raise ValueError(
            f"{where} has no column(s) {missing}; its columns are "
            f"{list(frame.columns)} (inputs={list(inputs)}, outputs={list(outputs)})."
        )
    return (
        _numbers(frame[list(inputs)], where, "inputs"),
        _numbers(frame[list(outputs)], where, "outputs"),
    )


def _numbers(values, where, what):
    """``values`` as a float array, or a ValueError naming the record."""
    try:
        if hasattr(values, "to_numpy"):
            return values.to_numpy(dtype=float)
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"{where} must hold numbers; its {what} do not ({exc})."
        ) from None


def _frame_dt(frame, where):
    """The sample period of a DataFrame's index (seconds), or None if not uniform."""
    index = frame.index
    if len(index) < 2:
        return None
    if hasattr(index, "total_seconds"):  # TimedeltaIndex
        steps = np.diff(index.total_seconds())
    elif np.issubdtype(np.asarray(index).dtype, np.datetime64):
        steps = np.diff(np.asarray(index, dtype="datetime64[ns]")).astype(float) / 1e9
    elif np.issubdtype(np.asarray(index).dtype, np.number):
        steps = np.diff(np.asarray(index, dtype=float))
    else:
        return None
    if not np.all(np.isfinite(steps)) or steps.min() <= 0:
        raise ValueError(f"{where}'s time index must increase; it does not.")
    if np.ptp(steps) > 1e-6 * steps.mean():
        raise ValueError(
            f"{where}'s time index is not uniformly sampled (steps from "
            f"{steps.min():.6g} to {steps.max():.6g} s); resample it first."
        )
    return float(steps.mean())


def _names_fit(names, array):
    return isinstance(names, (list, tuple)) and len(names) == array.shape[1]


def as_records(records, *, inputs=None, outputs=None, name="records", one=False):
    """Records in any of the spec's forms as lists of 2-D float arrays.

    Parameters
    ----------
    records : tuple, DataFrame, or list of them
        One record ``(u, y)`` (arrays of shape ``(n_times,)`` or ``(n_times,
        n)``) or a pandas DataFrame, or a list of such records (their lengths
        may differ).
    inputs, outputs : list of str or None, default=None
        The DataFrames' input and output columns (needed for DataFrames).
    name : str, default="records"
        The parameter's name in error messages.
    one : bool, default=False
        ``records`` is one record, named ``name`` itself in error messages
        (not ``name[0]``).

    Returns
    -------
    U, Y : list of ndarray of shape (n_times_i, n_inputs) and (n_times_i, n_outputs)
        Inputs and outputs of each record.
    dts : list of float or None
        Each DataFrame's sample period read from its time index (None for
        arrays).
    """
    if _is_frame(records) or (
        isinstance(records, tuple) and len(records) == 2 and not _is_frame(records[0])
    ):
        records = [records]
    if not isinstance(records, (list, tuple)) or not records:
        raise TypeError(
            f"{name} must be a (u, y) pair, a DataFrame, or a non-empty list of "
            f"them; got {type(records).__name__}."
        )
    U, Y, dts = [], [], []
    for i, record in enumerate(records):
        where = name if one else f"{name}[{i}]"
        if _is_frame(record):
            if not inputs or not outputs:
                raise ValueError(
                    f"{where} is a DataFrame: name its columns with inputs=[...] and "
                    f"outputs=[...]; got inputs={inputs!r}, outputs={outputs!r}."
                )
            u, y = _frame_record(record, inputs, outputs, where)
            dts.append(_frame_dt(record, where))
        elif isinstance(record, (tuple, list)) and len(record) == 2:
            u = _numbers(record[0], where, "inputs")
            y = _numbers(record[1], where, "outputs")
            dts.append(None)
        else:
            raise TypeError(
                f"{where} must be a (u, y) pair or a DataFrame; got "
                f"{type(record).__name__}."
            )
        u = u[:, None] if u.ndim == 1 else u
        y = y[:, None] if y.ndim == 1 else y
        if u.ndim != 2 or y.ndim != 2 or len(u) != len(y):
            raise ValueError(
                f"{where} must hold aligned inputs and outputs of shape (n_times,) "
                f"or (n_times, n); got {u.shape} and {y.shape}."
            )
        bad = first_not_finite(
            {
                "inputs": (u, inputs) if _names_fit(inputs, u) else u,
                "outputs": (y, outputs) if _names_fit(outputs, y) else y,
            }
        )
        if bad is not None:
            raise ValueError(
                f"{where} holds NaN or infinite values ({bad}); remove or "
                "interpolate them, or cut the record there into two records."
            )
        if U and (u.shape[1] != U[0].shape[1] or y.shape[1] != Y[0].shape[1]):
            raise ValueError(
                f"{where} has {u.shape[1]} input and {y.shape[1]} output columns; "
                f"{name}[0] has {U[0].shape[1]} and {Y[0].shape[1]}."
            )
        U.append(u)
        Y.append(y)
    return U, Y, dts


def records_digest(U, Y):
    """SHA-256 of records' values and shapes: what a resumed run must find again.

    Parameters
    ----------
    U, Y : list of ndarray
        Inputs and outputs of each record.

    Returns
    -------
    digest : str
        Hex digest.
    """
    import hashlib

    h = hashlib.sha256()
    for a in (*U, *Y):
        a = np.ascontiguousarray(a, dtype=np.float64)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _positive_real(value):
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, bool)
        and bool(np.isfinite(value))
        and value > 0
    )


def _check_published(published):
    """Raise unless ``published`` is ``{test: {label: (rmse, source)}}``."""
    problem = not isinstance(published, dict)
    if not problem:
        for figures in published.values():
            if not isinstance(figures, dict):
                problem = True
                break
            for pair in figures.values():
                if not (
                    isinstance(pair, (tuple, list))
                    and len(pair) == 2
                    and (
                        pair[0] is None
                        or (
                            isinstance(pair[0], numbers.Real)
                            and not isinstance(pair[0], bool)
                        )
                    )
                    and isinstance(pair[1], str)
                ):
                    problem = True
    if problem:
        raise TypeError(
            "published must be a dict {test name: {label: (rmse, source)}}, for "
            "example {'test': {'linear model': (0.59, 'Smith et al. 2020')}}; got "
            f"published={published!r}."
        )


#: The state-space hybrid's parameters the family sets itself, per run.
_HYBRID_SET_BY_RUN = ("physics", "n_init", "warm_start_physics", "random_state")


def _check_hybrids(hybrids):
    """Raise unless every candidate's settings are the hybrid's parameters."""
    allowed = sorted(
        set(inspect.signature(StateSpaceHybridRegressor.__init__).parameters)
        - {"self", *_HYBRID_SET_BY_RUN}
    )
    for label, settings in hybrids.items():
        if not isinstance(settings, dict):
            raise TypeError(
                f"hybrids[{label!r}] must be a dict of StateSpaceHybridRegressor "
                f"parameters; got {settings!r}."
            )
        unknown = sorted(set(settings) - set(allowed), key=str)
        if unknown:
            hint = ""
            close = difflib.get_close_matches(str(unknown[0]), allowed, n=1)
            if close:
                hint = f" (did you mean {close[0]!r}?)"
            raise ValueError(
                f"hybrids[{label!r}] has settings {unknown} that are not "
                f"StateSpaceHybridRegressor parameters{hint}; expected some of "
                f"{allowed} ({', '.join(_HYBRID_SET_BY_RUN)} are set by the run)."
            )


def _not_a_class(physics):
    """``physics``, refused where it is a class rather than a model."""
    if isinstance(physics, type):
        raise TypeError(
            f"physics is the class {physics.__name__}, not a model: pass an "
            f"unfitted instance, physics={physics.__name__}(...) with its "
            "equations and starting parameters (see 'Model your own machine'), "
            "or a callable physics(U, Y, dt) returning one."
        )
    return physics


def _check_starts_values(physics, starts):
    """Raise unless every start names the physics' parameters, finite, in bounds."""
    params = physics.get_params(deep=False).get("params") or {}
    bounds = physics.get_params(deep=False).get("bounds") or {}
    for i, start in enumerate(starts):
        for name, value in start.items():
            where = f"physics_starts[{i}][{name!r}]"
            if name not in params:
                close = difflib.get_close_matches(str(name), list(params), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ValueError(
                    f"{where}: {name!r} is not a parameter of the physics{hint}; "
                    f"its parameters are {sorted(params)}."
                )
            if (
                isinstance(value, bool)
                or not isinstance(value, numbers.Real)
                or not np.isfinite(value)
            ):
                raise ValueError(f"{where} must be a finite number; got {value!r}.")
            if name in bounds:
                low, high = bounds[name]
                low = -np.inf if low is None else low
                high = np.inf if high is None else high
                if not low <= value <= high:
                    raise ValueError(
                        f"{where}={value!r} is outside the physics' bounds "
                        f"[{low}, {high}] for {name!r}; start inside them."
                    )


def _check_takes_starts(physics):
    """Raise unless ``physics`` takes ``physics_starts``: its own ``starts``, unset."""
    if "starts" not in physics.get_params(deep=False):
        raise TypeError(
            "physics_starts needs a physics that takes starts (a "
            f"StateSpaceModel); got {type(physics).__name__}."
        )
    if physics.starts is not None:
        raise ValueError(
            "give the starts on the spec (physics_starts) or on the physics (its "
            f"starts), not both; the physics has starts={physics.starts!r}."
        )


@dataclass
class SystemSpec:
    """A system, described once: records, sample period, physics, tests.

    :func:`~skhybrid.experiments.run_system` (or ``skhybrid run --system
    module:object``) fits the default candidate family on it: the physics by
    simulation error (multiple shooting over segments), a linear ARX and a dense
    NARX as black-box baselines, the physics with a linear and a dense static
    correction and with the mean of three dense corrections, and state-space
    hybrids over a small horizon grid. Every choice
    (segment length, windows, horizon, the model quoted) is made by blocked
    cross-validation of the estimation records
    (:class:`~skhybrid.model_selection.SimulationSearchCV`), the selection is
    sealed (written with its
    hash), and only then are the test records read and simulated.

    Parameters
    ----------
    name : str
        The system's name (the run folder's and the report's).
    records : tuple, DataFrame, list of them, or callable
        The estimation records: one ``(u, y)`` pair, a DataFrame, or a list of
        them (lengths may differ); or a function of no argument returning
        them. Each record's first ``n_init`` samples start its free run.
    physics : estimator or callable
        The physics: an unfitted :class:`~skhybrid.domain.StateSpaceModel`
        (fitted by :meth:`~skhybrid.domain.StateSpaceModel.fit_simulation`),
        any estimator with ``fit(inputs, outputs)`` on lists of records and
        ``simulate(inputs, initial)`` (cloned for each fit), or a callable
        ``physics(U, Y, dt)`` returning one (a start computed from the data).
    n_init : int
        Samples of the initialisation window: every free run (validation and
        test) starts from a record's first ``n_init`` measured outputs.
    dt : float or None, default=None
        Sample period in seconds; None reads it from the DataFrames' uniform
        time index. A physics that takes a ``dt`` and was given none (a
        continuous-time :class:`~skhybrid.domain.StateSpaceModel` written
        without one) gets this one: say it once, here.
    tests : dict or callable or None, default=None
        ``{name: record}`` of test records, or a function of no argument
        returning it; read only after the selection is sealed.
    inputs, outputs : list of str or None, default=None
        The DataFrames' input and output columns.
    title : str, default=""
        The report's title (default: ``name``).
    unit : str, default=""
        Unit of the reported RMSE.
    scale : float, default=1.0
        Factor from the records' units to ``unit`` (``1e3`` for V to mV).
    published : dict, default={}
        ``{test name: {label: (rmse, source)}}`` shown beside the figures.
    physics_inputs : callable or None, default=None
        Maps a record's inputs to the physics' (None: the same), applied to
        every record the physics and the state-space hybrid meet; for example
        :func:`~skhybrid.domain.band_limited_inputs`, for a physics with
        ``input_points=3`` that reads a smooth input between its samples.
    segments : "auto" or tuple, default="auto"
        Samples per segment of the physics' multiple-shooting fit to try
        (``None`` in the tuple: whole records). ``"auto"``: whole records and
        a quarter and a sixteenth of the shortest fitting part, where longer
        than ten initialisation windows.
    hybrids : "auto", dict or None, default="auto"
        The state-space hybrids to try, ``{label: StateSpaceHybridRegressor
        parameters}``; ``"auto"``: horizons ``T`` of 50 and 200 samples (below
        half the shortest fitting part), a (64, 64) correction of every state
        trained with :func:`hybrid_settings` on sub-sequences that start every
        half horizon, or closer (down to every sample) where the records are
        too short to give about 500 of them, where the physics is a
        :class:`~skhybrid.domain.StateSpaceModel` (none for another physics);
        None: no state-space hybrid.
    hybrid_records : int, default=4
        Pieces the hybrid's training records are cut into (sub-sequences are
        drawn within pieces).
    notes : str, default=""
        Why the spec departs from the default family, shown in the report.
    physics_starts : list of dict or None, default=None
        Several starts of the physics' parameters, each a dict of values that
        override its own (``[{"w": 5.0}, {"w": 30.0}]``): a simulation-error fit
        from a poor start can stop in a local minimum. The physics' ``params``
        become the first start and its ``starts`` the others
        (:class:`~skhybrid.domain.StateSpaceModel`'s several starts): each of
        a segment candidate's fits first fits every start briefly
        (``starts_nfev`` evaluations) on its segments and goes on from the
        lowest cost, never chosen on a held-out or test record; every fold's
        fit and the refit on the whole records run the starts alike. Needs a
        physics that takes ``starts`` and has none of its own.
    starts_nfev : int, default=15
        Residual evaluations of each start's short fit (the physics'
        ``starts_nfev``).
    score_from_estimation_start : bool, default=False
        Also score every test record under a second protocol, ``<test>_original
        _protocol``: the free run starts from the initial state estimated on the
        first estimation record's initialisation window (the state is the same
        at the start of both records) and every sample is scored. Defined for
        models whose physics is a :class:`~skhybrid.domain.StateSpaceModel`
        (the physics, its static corrections and the state-space hybrid, whose
        corrected run starts from the physics' state); the others score NaN
        there.
    protocol : "free-run" or OneStepWindows, default="free-run"
        How the system's models are judged. ``"free-run"``: the records are
        measured (or simulated once), every model simulates each held-out block
        and test record freely from its first ``n_init`` outputs, as above. A
        :class:`~skhybrid.experiments.OneStepWindows`: the paper's protocol for
        a simulated system (section 6); ``records`` and ``tests`` are then
        simulators of windows of ``n_init`` time steps, ``physics`` a regressor
        on them (or a dict of them by label), the paper's model zoo is fitted
        and each model's one-step prediction scored on every test set; the
        fields above that only the free run reads stay unset. The built-in
        pendulum, double pendulum and DC motor are specs of this protocol.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.experiments import SystemSpec
    >>> from skhybrid.domain import StateSpaceModel
    >>> def step(x, u, *, xp, a, b):
    ...     return a * x + b * u
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((300, 1))
    >>> spec = SystemSpec(
    ...     "first-order",
    ...     records=[(u, u)],
    ...     physics=StateSpaceModel(
    ...         step, {"a": 0.5, "b": 1.0}, state_names=["y"], time="discrete"
    ...     ),
    ...     n_init=5,
    ...     dt=0.1,
    ... )
    >>> U, Y = spec.estimation_records()
    >>> len(U), U[0].shape
    (1, (300, 1))
    """

    name: str
    records: object
    physics: object
    n_init: int
    dt: float = None
    tests: object = None
    inputs: list = None
    outputs: list = None
    title: str = ""
    unit: str = ""
    scale: float = 1.0
    published: dict = field(default_factory=dict)
    physics_inputs: object = None
    segments: object = "auto"
    hybrids: object = "auto"
    hybrid_records: int = 4
    notes: str = ""
    physics_starts: list = None
    starts_nfev: int = 15
    score_from_estimation_start: bool = False
    protocol: object = "free-run"

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name must be a non-empty str; got name={self.name!r}.")
        n_init = self.n_init
        if isinstance(n_init, bool) or not isinstance(n_init, numbers.Integral):
            raise TypeError(f"n_init must be an int >= 1; got n_init={n_init!r}.")
        if n_init < 1:
            raise ValueError(f"n_init must be an int >= 1; got n_init={n_init!r}.")
        if self.dt is not None and not _positive_real(self.dt):
            raise ValueError(
                f"dt must be a positive number; got dt={self.dt!r} (seconds, or "
                "None to read it from the records' time index)."
            )
        if not _positive_real(self.scale):
            raise ValueError(
                f"scale must be positive; got scale={self.scale!r} (a finite number)."
            )
        for key in ("title", "unit", "notes"):
            if not isinstance(getattr(self, key), str):
                raise TypeError(
                    f"{key} must be a str; got {key}={getattr(self, key)!r}."
                )
        for key in ("inputs", "outputs"):
            columns = getattr(self, key)
            if columns is not None and (
                isinstance(columns, str)
                or not isinstance(columns, (list, tuple))
                or not columns
            ):
                raise TypeError(
                    f"{key} must be a non-empty list of column names or None; got "
                    f"{key}={columns!r}."
                )
        _check_published(self.published)
        if isinstance(self.protocol, OneStepWindows):
            check_one_step_spec(self)
            return
        if not (isinstance(self.protocol, str) and self.protocol == "free-run"):
            raise TypeError(
                "protocol must be 'free-run' or a OneStepWindows (the paper's "
                f"one-step protocol); got protocol={self.protocol!r}."
            )
        if self.physics_inputs is not None and not callable(self.physics_inputs):
            raise TypeError(
                "physics_inputs must be a callable mapping a record's inputs to the "
                f"physics' (or None); got physics_inputs={self.physics_inputs!r}."
            )
        hybrid_records = self.hybrid_records
        if (
            isinstance(hybrid_records, bool)
            or not isinstance(hybrid_records, numbers.Integral)
            or hybrid_records < 1
        ):
            raise ValueError(
                "hybrid_records must be an int >= 1; got "
                f"hybrid_records={hybrid_records!r}."
            )
        if not isinstance(self.score_from_estimation_start, (bool, np.bool_)):
            raise TypeError(
                "score_from_estimation_start must be a bool; got "
                f"score_from_estimation_start={self.score_from_estimation_start!r}."
            )
        physics = _not_a_class(self.physics)
        is_factory = callable(physics) and not hasattr(physics, "get_params")
        if not is_factory and not (
            hasattr(physics, "fit") and hasattr(physics, "simulate")
        ):
            raise TypeError(
                "physics must be an estimator with fit and simulate (a "
                "StateSpaceModel, say) or a callable physics(U, Y, dt) "
                f"returning one; got {type(physics).__name__}."
            )
        if self.physics_starts is not None:
            starts = self.physics_starts
            if (
                not isinstance(starts, (list, tuple))
                or not starts
                or not all(isinstance(st, dict) for st in starts)
            ):
                raise TypeError(
                    "physics_starts must be a non-empty list of dicts of parameter "
                    f"values, or None; got physics_starts={starts!r}."
                )
            if not is_factory:
                _check_takes_starts(physics)
                _check_starts_values(physics, starts)
        if (
            isinstance(self.starts_nfev, bool)
            or not isinstance(self.starts_nfev, numbers.Integral)
            or self.starts_nfev < 1
        ):
            raise ValueError(
                "starts_nfev must be an int >= 1; got "
                f"starts_nfev={self.starts_nfev!r}."
            )
        if not (isinstance(self.segments, str) and self.segments == "auto"):
            segments = self.segments
            if isinstance(segments, (str, dict)) or not isinstance(segments, Iterable):
                segments = [0]  # refused below
            segments = list(segments)
            if not segments or any(
                s is not None
                and (
                    isinstance(s, bool) or not isinstance(s, numbers.Integral) or s < 1
                )
                for s in segments
            ):
                raise ValueError(
                    "segments must be 'auto' or a tuple of ints >= 1 (or None); "
                    f"got segments={self.segments!r}."
                )
        if not (
            (isinstance(self.hybrids, str) and self.hybrids == "auto")
            or self.hybrids is None
            or isinstance(self.hybrids, dict)
        ):
            raise TypeError(
                "hybrids must be 'auto', None or a dict of label to settings; "
                f"got hybrids={self.hybrids!r}."
            )
        if isinstance(self.hybrids, dict):
            _check_hybrids(self.hybrids)
        if (
            isinstance(self.hybrids, dict)
            and self.hybrids
            and not is_factory
            and not isinstance(physics, StateSpaceModel)
        ):
            raise ValueError(
                "hybrids needs a StateSpaceModel physics (the state-space hybrid "
                f"trains through its equations); got a {type(physics).__name__}. "
                "Set hybrids=None, or 'auto', which tries none for this physics."
            )
        if self.tests is not None and not (
            callable(self.tests) or isinstance(self.tests, dict)
        ):
            raise TypeError(
                "tests must be a dict of name to record, a callable returning it, "
                f"or None; got {type(self.tests).__name__}."
            )
        if not callable(self.records):
            # Records given as data are read now: a bad one is refused when the
            # spec is built, naming it (a callable's are read when the run starts).
            self.estimation_records()

    # -- records ----------------------------------------------------------------
    def _refuse_one_step(self, method):
        """Raise where this spec is of the one-step protocol: no records to read."""
        if isinstance(self.protocol, OneStepWindows):
            raise ValueError(  # noqa: TRY004 - the spec's protocol, not a type error
                f"{method} reads a free-run spec's records; {self.name!r} has "
                "protocol=OneStepWindows, whose records and tests are simulators "
                "that its run calls at each seed."
            )

    def estimation_records(self):
        """The estimation records, checked: ``(U, Y)`` lists of 2-D arrays.

        Returns
        -------
        U, Y : list of ndarray
            Inputs and outputs of each record.

        Raises
        ------
        ValueError
            A record too short for its initialisation window and a validation
            tail, no sample period (``dt``), or a test record given as data
            that does not fit them (:meth:`test_records`).
        """
        self._refuse_one_step("estimation_records")
        records = self.records() if callable(self.records) else self.records
        U, Y, dts = as_records(
            records, inputs=self.inputs, outputs=self.outputs, name="records"
        )
        self._dt = self._check_dt(dts)
        shortest = min(len(u) for u in U)
        longest = max(len(u) for u in U)
        # A held-out block holds its own window and some samples to score
        # (RecordBlockSplit: at least 8 n_init), and some record two blocks.
        if shortest < 8 * self.n_init or longest < 16 * self.n_init:
            raise ValueError(
                f"every estimation record needs at least 8 * n_init = "
                f"{8 * self.n_init} samples, and the longest 16 * n_init = "
                f"{16 * self.n_init} (the folds hold out blocks of at least "
                f"8 * n_init); the records hold {sorted(len(u) for u in U)}."
            )
        if self.tests is not None and not callable(self.tests):
            # Test records given as data are checked with the estimation records,
            # before any fit (a callable's are read once the selection is sealed).
            self.test_records(U, Y)
        return U, Y

    def sample_period(self):
        """The sample period ``dt``: given, or read from the records' time index.

        Returns
        -------
        dt : float
            Seconds between samples.
        """
        if self.dt is not None:
            return float(self.dt)
        if getattr(self, "_dt", None) is None:
            self.estimation_records()
        return self._dt

    def _check_dt(self, dts):
        read = [d for d in dts if d is not None]
        if read and self.dt is not None:
            for d in read:
                if abs(d - self.dt) > 1e-6 * self.dt:
                    raise ValueError(
                        f"dt={self.dt!r} disagrees with a record's time index "
                        f"(sample period {d:.6g} s)."
                    )
        if self.dt is not None:
            return float(self.dt)
        if not read:
            raise ValueError(
                "dt is None and the records carry no time index: give dt=..."
            )
        if np.ptp(read) > 1e-6 * np.mean(read):
            raise ValueError(
                "dt is None and the records' time indexes give different sample "
                f"periods ({', '.join(f'{d:.6g}' for d in read)} s); resample them "
                "to one period, or give dt=... and records sampled at it."
            )
        return float(read[0])

    def test_records(self, U=None, Y=None):
        """The test records, ``{name: (u, y)}``, checked (a callable's read now).

        Test records given as data are checked when the spec is built; a
        callable's are read only once the selection is sealed, and checked then,
        before any model is simulated on them.

        Parameters
        ----------
        U, Y : list of ndarray or None, default=None
            The estimation records: each test record must have as many input
            and output columns.

        Returns
        -------
        tests : dict of str to tuple of ndarray
            ``(u, y)`` of each test record, 2-D; empty without tests.

        Raises
        ------
        ValueError
            A test record that is not finite numbers, holds no more than
            ``n_init`` samples, or whose columns differ from the estimation
            records'; the message names it.
        """
        self._refuse_one_step("test_records")
        tests = self.tests() if callable(self.tests) else self.tests
        if tests is None:
            return {}
        if not isinstance(tests, dict):
            raise TypeError(
                f"tests must give a dict of name to record; got {type(tests).__name__}."
            )
        out = {}
        for key, record in tests.items():
            where = f"tests[{key!r}]"
            u, y = as_records(
                [record], inputs=self.inputs, outputs=self.outputs, name=where, one=True
            )[0:2]
            u, y = u[0], y[0]
            if len(u) <= self.n_init:
                raise ValueError(
                    f"{where} holds {len(u)} samples, not more than "
                    f"n_init={self.n_init}."
                )
            if U is not None and (
                u.shape[1] != U[0].shape[1] or y.shape[1] != Y[0].shape[1]
            ):
                raise ValueError(
                    f"{where} has inputs of shape {u.shape} and outputs of shape "
                    f"{y.shape}; the estimation records have {U[0].shape[1]} input "
                    f"and {Y[0].shape[1]} output column(s) (records[0]: "
                    f"{U[0].shape} and {Y[0].shape})."
                )
            out[str(key)] = (u, y)
        return out

    # -- the candidate family ---------------------------------------------------
    def make_physics(self, U, Y, dt):
        """An unfitted physics for the records ``U, Y`` (a clone, or the callable's).

        Parameters
        ----------
        U, Y : list of ndarray
            The records it will be fitted on (in the physics' inputs).
        dt : float
            Sample period.

        Returns
        -------
        physics : estimator
            Unfitted; with the spec's ``dt`` and ``n_init`` where it takes them
            and has none, and, with ``physics_starts``, its ``params`` updated by the
            first start and its ``starts`` the others.
        """
        if callable(self.physics) and not hasattr(self.physics, "get_params"):
            base = self.physics(U, Y, dt)
        else:
            base = clone(self.physics)
        # The sample period and the initialisation window are said once, on the
        # spec: a physics that takes a ``dt`` or an ``n_init`` and was given
        # none gets the spec's.
        given = base.get_params(deep=False)
        if given.get("dt", 0) is None:
            base = clone(base).set_params(dt=float(dt))
        if given.get("n_init", 0) is None:
            base = clone(base).set_params(n_init=int(self.n_init))
        if not self.physics_starts:
            return base
        _check_takes_starts(base)  # a callable's physics is seen only now
        _check_starts_values(base, self.physics_starts)
        # The spec's starts replace the physics' parameters: the first is the
        # model's params, the others its starts (StateSpaceModel's several starts).
        first, *others = self.physics_starts
        return clone(base).set_params(
            params={**base.params, **first},
            starts=others or None,
            starts_nfev=self.starts_nfev,
        )

    def segment_candidates(self, fit_lengths):
        """Segment lengths of the physics' fit to try on fitting parts of these lengths.

        Parameters
        ----------
        fit_lengths : list of int
            Lengths of the records the candidates are fitted on.

        Returns
        -------
        segments : tuple
            ``None`` (whole records) and lengths in samples.
        """
        if self.segments != "auto":
            return tuple(self.segments)
        shortest = min(fit_lengths)
        lengths = [shortest // 4, shortest // 16]
        return (None, *[s for s in lengths if s > 10 * self.n_init])

    def has_hybrids(self):
        """Whether the family holds state-space hybrids (read from the spec alone).

        ``"auto"`` tries them only where the physics is a
        :class:`~skhybrid.domain.StateSpaceModel` (or a callable, which returns
        one): the hybrid trains through its equations.

        Returns
        -------
        has_hybrids : bool
            False where ``hybrids`` is None or empty, or ``"auto"`` with a
            physics that is not a ``StateSpaceModel``.
        """
        if not self.hybrids:
            return False
        if self.hybrids != "auto":
            return True
        physics = _not_a_class(self.physics)
        is_factory = callable(physics) and not hasattr(physics, "get_params")
        return is_factory or isinstance(physics, StateSpaceModel)

    def hybrid_candidates(self, fit_lengths):
        """The state-space hybrids to try, ``{label: parameters}``.

        Parameters
        ----------
        fit_lengths : list of int
            Lengths of the records the candidates are fitted on.

        Returns
        -------
        candidates : dict of str to dict
            Empty where ``hybrids`` is None.
        """
        if not self.has_hybrids():
            return {}
        if self.hybrids != "auto":
            return dict(self.hybrids)
        pieces = pieces_per_record(fit_lengths, max(1, self.hybrid_records))
        longest_piece = max(n // k for n, k in zip(fit_lengths, pieces, strict=True))
        # A sub-sequence every half horizon, or closer where the records are too
        # short to give MIN_SUBSEQUENCES of them per epoch (as the hybrid's own
        # stride="auto" does from a quarter horizon).
        dense = sum(fit_lengths) // MIN_SUBSEQUENCES
        out = {}
        for T in (DEFAULT_HORIZON, 4 * DEFAULT_HORIZON):
            T = min(T, longest_piece // 2 - self.n_init)
            if T < 2 or f"T={T}, {HYBRID_LAYERS}" in out:
                continue
            out[f"T={T}, {HYBRID_LAYERS}"] = hybrid_settings(
                T, HYBRID_LAYERS, stride=max(1, min(T // 2, dense))
            )
        return out


def hybrid_settings(horizon, hidden, **extra):
    """Settings of one state-space hybrid candidate of the family.

    The training settings are written out (``lr=0.01``, ``batch_size=256``,
    at most 200 epochs, patience 30 and 10 for the learning rate, no
    augmented states, the encoder correcting the
    physics' state estimate, a tanh correction), chosen on validation only on
    ``benchmarks/bench_state_space_defaults.py`` and the built-in benchmarks
    (the benchmark log, ``benchmarks/LOG.md``, has the figures); the hybrid's
    own defaults, since set on the missing-physics suite, do not move the
    family's candidates.

    Parameters
    ----------
    horizon : int
        Samples per simulated sub-sequence ``T``.
    hidden : tuple of int
        The correction network's hidden layers.
    **extra
        Other :class:`~skhybrid.hybrid.StateSpaceHybridRegressor` parameters.

    Returns
    -------
    settings : dict
        Parameters of the hybrid.
    """
    settings = {
        "horizon": horizon,
        "hidden_layer_sizes": hidden,
        "encoder_hidden_layer_sizes": (32,),
        "lr": 0.01,
        "batch_size": 256,
        "max_epochs": 200,
        "patience": 30,
        "lr_patience": 10,
        "validation_fraction": 0.2,
        "n_augmented_states": 0,
        "physics_initial_state": True,
        "activation": "tanh",
    }
    settings.update(extra)
    return settings
