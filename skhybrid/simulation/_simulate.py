"""Free-run simulation of any next-state predictor, batched over trajectories."""

import numpy as np
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from skhybrid.exceptions import SimulationDivergedError
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation._initial import fit_initial_states
from skhybrid.utils._docstrings import RECORD_INPUTS, fill_doc
from skhybrid.utils._simulate_checks import check_simulate_options
from skhybrid.utils._simulate_contract import SimulateContract

__all__ = ["SimulatorMixin", "check_trajectories", "pack_trajectories", "simulate"]

#: Sample paths drawn for ``return_std=True`` when ``n_samples`` is not given.
DEFAULT_STD_SAMPLES = 100


def _as_list(value, name):
    """``(arrays, form)``: a list of 2-D float arrays and the container form."""
    if isinstance(value, (list, tuple)):
        arrays, form = [np.asarray(a, dtype=np.float64) for a in value], "list"
        if not arrays:
            raise ValueError(
                f"{name} must hold at least one experiment; got {name}=[]."
            )
    else:
        array = np.asarray(value, dtype=np.float64)
        if array.ndim == 3:
            arrays, form = list(array), "3d"
        elif array.ndim in (1, 2):
            arrays, form = [array], "2d"
        else:
            raise ValueError(
                f"{name} must be a 2-D array (n_times, n_columns), a 3-D array "
                "(n_trajectories, n_times, n_columns) or a list of 2-D arrays; got "
                f"an array with shape {array.shape}."
            )
    arrays = [a[:, None] if a.ndim == 1 else a for a in arrays]
    for i, a in enumerate(arrays):
        if a.ndim != 2:
            raise ValueError(
                f"{name}[{i}] must be 2-D (n_times, n_columns); got shape {a.shape}."
            )
    return arrays, form


def _check_widths(arrays, name):
    widths = {a.shape[1] for a in arrays}
    if len(widths) > 1:
        raise ValueError(
            f"every experiment in {name} must have the same number of columns; got "
            f"{sorted(widths)}."
        )
    return widths.pop()


def _check_finite(arrays, name):
    """Raise a ValueError naming the first non-finite trajectory and time step."""
    for i, a in enumerate(arrays):
        bad = ~np.isfinite(a)
        if bad.any():
            t, j = np.argwhere(bad)[0]
            raise ValueError(
                f"{name}[{i}] holds a non-finite value ({a[t, j]!r}) at time step "
                f"{t}, column {j}; trajectory {i} must be finite everywhere (NaN "
                "or infinity would be returned or spread through the simulation)."
            )


def check_trajectories(
    inputs, initial, *, initial_name="initial", min_init=1, window_name="the model"
):
    """Validate the trajectories given to a ``simulate`` or initial-state estimate.

    The one validation of every estimator's :meth:`simulate` and of
    :meth:`~skhybrid.domain.StateSpaceModel.estimate_initial_state`: the
    containers match, every trajectory has the same numbers of columns, holds at
    least ``min_init`` measured time steps and no more than its inputs, and
    every value of both is finite.

    Parameters
    ----------
    inputs : array-like of shape (n_times, n_inputs), (n_trajectories, n_times, \
n_inputs) or list of (n_times_i, n_inputs) arrays
        Inputs over the whole experiment from time 0.
    initial : array-like of shape (n_init, n_states), (n_trajectories, n_init, \
n_states) or list of (n_init_i, n_states) arrays, or None
        Measured states (or outputs) of the first time steps; None checks the
        inputs alone.
    initial_name : str, default="initial"
        Name of ``initial`` in the error messages.
    min_init : int, default=1
        Fewest measured time steps a trajectory needs (the model's window).
    window_name : str, default="the model"
        What needs ``min_init`` steps, in the error message (for example
        ``"the model's window (n_steps=5)"``).

    Returns
    -------
    inputs : list of ndarray
        The inputs as float64 arrays ``(n_times_i, n_inputs)``.
    initial : list of ndarray or None
        The measured states as float64 arrays ``(n_init_i, n_states)`` (None
        where ``initial`` is None).
    form : {"2d", "3d", "list"}
        The container form of ``inputs``, for :func:`pack_trajectories`.

    Raises
    ------
    ValueError
        Naming the trajectory (and the time step of a non-finite value).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.simulation import check_trajectories
    >>> u, y0 = np.zeros((10, 1)), np.ones((3, 2))
    >>> inputs, initial, form = check_trajectories(u, y0)
    >>> len(inputs), initial[0].shape, form
    (1, (3, 2), '2d')
    """
    U_list, form = _as_list(inputs, "inputs")
    if initial is None:
        _check_widths(U_list, "inputs")
        _check_finite(U_list, "inputs")
        return U_list, None, form
    Y0_list, init_form = _as_list(initial, initial_name)
    if init_form != form or len(Y0_list) != len(U_list):
        raise ValueError(
            f"{initial_name} must match inputs: {len(U_list)} experiment(s) given "
            f"as a {form} container, but {initial_name} holds {len(Y0_list)} as a "
            f"{init_form} container."
        )
    _check_widths(U_list, "inputs")
    _check_widths(Y0_list, initial_name)
    for i, (u, y) in enumerate(zip(U_list, Y0_list, strict=True)):
        if len(y) < min_init:
            raise ValueError(
                f"{initial_name}[{i}] holds {len(y)} time steps; {window_name} "
                f"needs at least {min_init} measured steps to start trajectory {i}."
            )
        if len(y) > len(u):
            raise ValueError(
                f"{initial_name}[{i}] holds {len(y)} time steps but inputs[{i}] "
                f"only {len(u)}; inputs cover the whole experiment, initial window "
                "included."
            )
    _check_finite(Y0_list, initial_name)
    _check_finite(U_list, "inputs")
    return U_list, Y0_list, form


def stack_trajectories(arrays):
    """Stack 2-D trajectories of different lengths, zero-padded to the longest.

    The inverse of :func:`pack_trajectories` for the checked lists
    :func:`check_trajectories` returns.

    Parameters
    ----------
    arrays : list of ndarray of shape (n_times_i, n_columns)
        Trajectories with the same number of columns.

    Returns
    -------
    stacked : ndarray of shape (n_trajectories, max n_times_i, n_columns)
        Zeros past each trajectory's end.
    lengths : ndarray of int of shape (n_trajectories,)
        Time steps of each trajectory.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.simulation import stack_trajectories
    >>> stacked, lengths = stack_trajectories([np.ones((3, 1)), np.ones((2, 1))])
    >>> stacked.shape, lengths.tolist(), float(stacked[1, 2, 0])
    ((2, 3, 1), [3, 2], 0.0)
    """
    lengths = np.array([len(a) for a in arrays])
    stacked = np.zeros((len(arrays), int(lengths.max()), arrays[0].shape[1]))
    for i, a in enumerate(arrays):
        stacked[i, : len(a)] = a
    return stacked, lengths


def check_finite_runs(Y, lengths, hint=""):
    """Raise where a simulated trajectory reaches a non-finite output.

    Parameters
    ----------
    Y : ndarray of shape (n_trajectories, n_times, n_outputs)
        Simulated trajectories, padded past their lengths (not checked there).
    lengths : array-like of int of shape (n_trajectories,)
        Time steps of each trajectory.
    hint : str, default=""
        Appended to the message (what to check).

    Raises
    ------
    SimulationDivergedError
        Naming the first trajectory and time step that is not finite.
    """
    for i, n in enumerate(lengths):
        bad = np.flatnonzero(~np.all(np.isfinite(Y[i, :n]), axis=1))
        if bad.size:
            raise SimulationDivergedError(
                f"the simulation diverged at time step {bad[0]}: record {i} "
                f"reached a non-finite output.{' ' + hint if hint else ''}"
            )


def pack_trajectories(Y, lengths, form):
    """Return padded trajectories in the container form of the inputs.

    Parameters
    ----------
    Y : ndarray of shape (..., n_trajectories, n_times, n_columns)
        Trajectories padded to the longest; leading axes (sample paths) are kept.
    lengths : array-like of int of shape (n_trajectories,)
        Time steps of each trajectory.
    form : {"2d", "3d", "list"}
        The form :func:`check_trajectories` returned.

    Returns
    -------
    out : ndarray or list of ndarray
        ``Y`` itself (``"3d"``), its only trajectory (``"2d"``) or a list of the
        trajectories cut to their lengths (``"list"``).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.simulation import pack_trajectories
    >>> Y = np.zeros((2, 5, 1))
    >>> [a.shape for a in pack_trajectories(Y, [5, 3], "list")]
    [(5, 1), (3, 1)]
    """
    return _pack(Y, lengths, form)


def _predict_rows(predict, X, check, t, active):
    """``predict(X)``; where the model's own validation rejects a diverged row, NaN.

    A composite (a booster) validates the inputs of its inner stages, so a
    state that overflowed inside it surfaces as scikit-learn's "Input X contains
    infinity" rather than as a non-finite prediction. Row by row, the rows that
    fail are found and reported (``check``) or set to NaN.
    """
    try:
        return np.asarray(predict(X), dtype=np.float64).reshape(len(X), -1)
    except ValueError as exc:
        if "infinity" not in str(exc) and "NaN" not in str(exc):
            raise
        first = exc
    rows = []
    for i in range(len(X)):
        try:
            rows.append(np.asarray(predict(X[i : i + 1]), dtype=np.float64).ravel())
        except ValueError:
            if check:
                raise SimulationDivergedError(
                    f"the simulation diverged at time step {t}: trajectory "
                    f"{active[i]} reached a state the model cannot evaluate "
                    f"({str(first).rstrip('.')}). The model is unstable in free "
                    "run from this initial window (check the inputs' range "
                    "against the training data)."
                ) from first
            rows.append(None)
    width = next((len(r) for r in rows if r is not None), 1)
    return np.stack([np.full(width, np.nan) if r is None else r for r in rows])


def _layout(estimator, n_states, n_inputs):
    """The window layout the fitted estimator reads, from its shapes."""
    n_features = getattr(estimator, "n_features_in_", None)
    if n_features is None:
        raise TypeError(
            f"{type(estimator).__name__} has no n_features_in_; simulate needs a "
            "fitted estimator that maps windows of history to the next state."
        )
    n_outputs = getattr(estimator, "n_outputs_", n_states)
    if n_outputs != n_states:
        raise ValueError(
            f"initial has {n_states} state columns but the estimator predicts "
            f"{n_outputs} outputs; give the measured states it was fitted on."
        )
    n_steps = estimator.get_params(deep=False).get("n_steps")
    try:
        layout = WindowLayout.from_shapes(n_features, n_states, n_inputs=n_inputs)
    except ValueError as exc:
        raise ValueError(
            f"the estimator reads rows of {n_features} columns, which are no whole "
            f"number of steps of {n_states} states and n_inputs={n_inputs} inputs: "
            f"give inputs with the input columns it was fitted on ({exc})"
        ) from None
    if n_steps is not None and layout.n_steps != n_steps:
        raise ValueError(
            f"inputs has {n_inputs} columns, which makes windows of "
            f"{layout.n_steps} steps, but the estimator has n_steps={n_steps}: "
            f"its rows of {n_features} columns are {layout.n_steps} steps of "
            f"{n_states} states and {n_inputs} inputs. Set n_steps="
            f"{layout.n_steps} on the estimator and fit it again (or give the "
            "inputs it was fitted on)."
        )
    return layout


def _noise_draws(noise, n_paths, n_traj, n_times, n_states, random_state):
    """Noise of every path, trajectory and time step, ``(P, T, N, s)``."""
    rng = check_random_state(random_state)
    out = np.empty((n_paths, n_traj, n_times, n_states))
    for p in range(n_paths):
        for i in range(n_traj):
            draw = np.asarray(noise.sample(n_times, random_state=rng))
            out[p, i] = draw.reshape(n_times, n_states)
    return out


def _rollout(
    predict, layout, U, Y, n_init, lengths, noise=None, check=True, n_traj=None
):
    """Fill ``Y[:, t]``, ``n_init <= t < lengths``, by one batched prediction per step.

    ``U`` is ``(n, N, m)``, ``Y`` is ``(n, N, s)`` holding the measured initial
    windows; ``noise`` (the same shape as ``Y`` or None) is added to each
    simulated state before it is fed back. With ``check=False`` non-finite states
    are left in place instead of raising. ``n_traj``: rows are sample paths of
    that many trajectories, one path after the other (for the error message).
    """
    n_traj = len(Y) if n_traj is None else n_traj
    k = layout.n_steps
    start = int(n_init.min())
    for t in range(start, Y.shape[1]):
        active = np.flatnonzero((t >= n_init) & (t < lengths))
        if active.size == 0:
            continue
        states = Y[active, t - k : t]
        inputs = U[active, t - k : t]
        X = layout.join(states, inputs)
        pred = _predict_rows(predict, X, check, t, active % n_traj)
        if noise is not None:
            pred = pred + noise[active, t]
        if check and not np.all(np.isfinite(pred)):
            bad = active[~np.all(np.isfinite(pred), axis=1)][0] % n_traj
            raise SimulationDivergedError(
                f"the simulation diverged at time step {t}: trajectory {bad} reached "
                "a non-finite state. The model is unstable in free run from this "
                "initial window (check the inputs' range against the training data)."
            )
        Y[active, t] = pred
    return Y


def _least_squares_windows(predict, layout, U, Y, n_init):
    """``Y`` with each record's first window fitted by :func:`fit_initial_states`.

    The states of the first ``n_steps`` steps are chosen so that the model's
    free run through the measured record ``Y[i, :n_init[i]]`` (the window
    included) matches it in least squares; ``Y[i, :n_init[i]]`` then holds that
    free run. A trajectory whose free run from its measured window is not finite
    keeps its measured record, as a separate call would.
    """
    k, (n, _, s) = layout.n_steps, Y.shape
    n0 = int(n_init.max())
    Y_rec, U_rec = Y[:, :n0], U[:, :n0]
    mask = (np.arange(n0)[None, :] < n_init[:, None])[:, :, None]

    def run(Z, index):
        Y_run = Y_rec[index].copy()
        Y_run[:, :k] = Z.reshape(len(index), k, s)
        first = np.full(len(index), k)
        with np.errstate(all="ignore"):
            return _rollout(
                predict, layout, U_rec[index], Y_run, first, n_init[index], check=False
            )

    def residuals(Z, index):
        with np.errstate(all="ignore"):
            r = run(Z, index) - Y_rec[index]
        return np.where(mask[index], r, 0.0).reshape(len(index), -1)

    # Central differences need a step near the cube root of the precision the
    # model computes in (float32 networks, float64 physics).
    probe = np.asarray(predict(layout.join(Y[:1, :k], U[:1, :k])))
    dtype = probe.dtype if np.issubdtype(probe.dtype, np.floating) else np.float64
    rel_step = float(np.finfo(dtype).eps) ** (1 / 3)
    Z, _ = fit_initial_states(residuals, Y[:, :k].reshape(n, k * s), rel_step=rel_step)
    fitted = run(Z, np.arange(n))
    finite = np.all(np.isfinite(np.where(mask, fitted, 0.0)), axis=(1, 2))
    Y = Y.copy()
    Y[finite, :n0] = np.where(mask[finite], fitted[finite], Y[finite, :n0])
    return Y


def _measured_window(Y, Y0_list):
    """``Y`` with each trajectory's measured initial window put back (last axes)."""
    for i, y0 in enumerate(Y0_list):
        Y[..., i, : len(y0), :] = y0
    return Y


def _pack(Y, lengths, form):
    """Return ``Y`` in the container form of the inputs."""
    if form == "3d":
        return Y
    if form == "2d":
        return Y[..., 0, :, :]
    return [Y[..., i, : lengths[i], :] for i in range(len(lengths))]


def simulate(
    estimator,
    inputs,
    initial,
    *,
    init="measured",
    n_samples=None,
    random_state=None,
    return_std=False,
    noise_model=None,
):
    """Simulate a fitted next-state predictor in free run.

    From the measured initial window of each experiment, the estimator predicts
    the next state, the window shifts one step (the prediction and the next
    input enter, the oldest step leaves) and so on to the end of the inputs. All
    trajectories advance together: one ``predict`` call per time step.

    Parameters
    ----------
    estimator : fitted estimator
        Maps rows of history (see :class:`~skhybrid.preprocessing.WindowLayout`)
        to the next state; its window length follows from ``n_features_in_`` and
        the number of input columns.
    inputs : array-like of shape (n_times, n_inputs), (n_trajectories, n_times, \
n_inputs) or list of (n_times_i, n_inputs) arrays
        Inputs over the whole experiment from time 0, including the initial
        window. ``n_inputs`` may be 0 for an autonomous system.
    initial : array-like of shape (n_init, n_states), (n_trajectories, n_init, \
n_states) or list of (n_init_i, n_states) arrays
        Measured states of the first ``n_init >= n_steps`` time steps.
    init : {"measured", "least_squares"}, default="measured"
        How the simulation starts. ``"measured"``: from the newest ``n_steps``
        measured steps of ``initial`` as they are. ``"least_squares"``: the
        states of the first window are fitted so that the model's own free run
        through all ``n_init`` measured steps matches them in least squares
        (the initial-state estimate of prediction-error methods), and the
        simulation continues from that fitted run; with ``n_init`` well above
        ``n_steps`` this averages the measurement noise out of the starting
        state. Fitted separately for each trajectory by
        :func:`fit_initial_states` (the package's one initial-state solver),
        all trajectories evaluated in one batch; a trajectory's fit never
        depends on the others in the batch. A ``ConvergenceWarning`` says how
        many did not converge.
    n_samples : int or None, default=None
        Number of sample paths through ``noise_model``: the noise is added to
        each simulated state and fed back. None simulates the deterministic path.
    random_state : int, RandomState instance or None, default=None
        Seed of the noise draws.
    return_std : bool, default=False
        Return the mean and the standard deviation over sample paths
        (``n_samples`` defaults to 100 then).
    noise_model : fitted noise model or None, default=None
        Supplies ``sample(n, random_state)``; needed for ``n_samples`` and
        ``return_std``.

    Returns
    -------
    states : ndarray or list of ndarray
        The simulated states over all time steps, in the container form of
        ``inputs``; the first ``n_init`` steps are the measured ones. With
        ``n_samples`` a leading axis of size ``n_samples`` (for each array of a
        list). With ``return_std=True`` the tuple ``(mean, std)``.
    """
    check_is_fitted(estimator)
    stochastic = check_simulate_options(
        estimator,
        init,
        n_samples,
        return_std,
        noise_model=noise_model,
        remedy="fit a hybrid with noise_model='gaussian' or 'ar'",
    )
    U_list, Y0_list, form = check_trajectories(inputs, initial)
    n_inputs, n_states = U_list[0].shape[1], Y0_list[0].shape[1]
    layout = _layout(estimator, n_states, n_inputs)
    lengths = np.array([len(u) for u in U_list])
    n_init = np.array([len(y) for y in Y0_list])
    for i, ni in enumerate(n_init):
        if ni < layout.n_steps:
            raise ValueError(
                f"initial[{i}] holds {ni} time steps; the estimator reads windows "
                f"of n_steps={layout.n_steps}, so at least {layout.n_steps} measured "
                "steps must start the simulation."
            )

    n_traj, n_max = len(U_list), int(lengths.max())
    U = np.zeros((n_traj, n_max, n_inputs))
    Y = np.zeros((n_traj, n_max, n_states))
    for i in range(n_traj):
        U[i, : lengths[i]] = U_list[i]
        Y[i, : n_init[i]] = Y0_list[i]
    if init == "least_squares":
        Y = _least_squares_windows(estimator.predict, layout, U, Y, n_init)

    if not stochastic:
        Y = _rollout(estimator.predict, layout, U, Y, n_init, lengths)
        return _pack(_measured_window(Y, Y0_list), lengths, form)

    n_paths = n_samples or DEFAULT_STD_SAMPLES
    noise = _noise_draws(noise_model, n_paths, n_traj, n_max, n_states, random_state)
    # All paths of all trajectories in one batch: (P * T) rows per step.
    Yp = _rollout(
        estimator.predict,
        layout,
        np.tile(U, (n_paths, 1, 1)),
        np.tile(Y, (n_paths, 1, 1)),
        np.tile(n_init, n_paths),
        np.tile(lengths, n_paths),
        noise=noise.reshape(n_paths * n_traj, n_max, n_states),
        n_traj=n_traj,
    ).reshape(n_paths, n_traj, n_max, n_states)
    Yp = _measured_window(Yp, Y0_list)
    if return_std:
        return (
            _pack(Yp.mean(axis=0), lengths, form),
            _pack(Yp.std(axis=0), lengths, form),
        )
    return _pack(Yp, lengths, form)


@fill_doc(record_inputs=RECORD_INPUTS)
class SimulatorMixin(SimulateContract):
    """Adds :meth:`simulate` to an estimator that predicts the next state."""

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Simulate the fitted model in free run from measured initial windows.

        See :func:`skhybrid.simulation.simulate` for the contract; sample paths
        and bands use the estimator's fitted noise model (``noise_model_``),
        where it has one.

        Parameters
        ----------
        %(record_inputs)s
        initial : array-like of shape (n_init, n_states), (n_trajectories, \
n_init, n_states) or list of 2-D arrays
            Measured states of the first ``n_init`` time steps.
        init : {"measured", "least_squares"}, default="measured"
            Start from the measured window as it is, or from the first window
            fitted by least squares to the whole measured initial record (see
            :func:`skhybrid.simulation.simulate`).
        n_samples : int or None, default=None
            Number of sample paths through the noise model.
        random_state : int, RandomState instance or None, default=None
            Seed of the noise draws.
        return_std : bool, default=False
            Return the mean and standard deviation over sample paths.

        Returns
        -------
        states : ndarray or list of ndarray
            Simulated states in the container form of ``inputs``; see
            :func:`skhybrid.simulation.simulate`.
        """
        return simulate(
            self,
            inputs,
            initial,
            n_samples=n_samples,
            random_state=random_state,
            return_std=return_std,
            noise_model=getattr(self, "noise_model_", None),
            init=init,
        )
