"""Free-run simulation of any next-state predictor, batched over trajectories."""

import numpy as np
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from skhybrid.exceptions import SimulationDivergedError
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation._initial import fit_initial_windows

__all__ = ["SimulatorMixin", "simulate"]

INITS = ("measured", "least_squares")

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
            f"{layout.n_steps} steps, but the estimator has n_steps={n_steps}."
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


def _rollout(predict, layout, U, Y, n_init, lengths, noise=None, check=True):
    """Fill ``Y[:, t]``, ``n_init <= t < lengths``, by one batched prediction per step.

    ``U`` is ``(n, N, m)``, ``Y`` is ``(n, N, s)`` holding the measured initial
    windows; ``noise`` (the same shape as ``Y`` or None) is added to each
    simulated state before it is fed back. With ``check=False`` non-finite states
    are left in place instead of raising.
    """
    k = layout.n_steps
    start = int(n_init.min())
    for t in range(start, Y.shape[1]):
        active = np.flatnonzero((t >= n_init) & (t < lengths))
        if active.size == 0:
            continue
        states = Y[active, t - k : t]
        inputs = U[active, t - k : t]
        X = layout.join(states, inputs)
        pred = np.asarray(predict(X), dtype=np.float64).reshape(active.size, -1)
        if noise is not None:
            pred = pred + noise[active, t]
        if check and not np.all(np.isfinite(pred)):
            bad = active[~np.all(np.isfinite(pred), axis=1)][0]
            raise SimulationDivergedError(
                f"the simulation diverged at time step {t}: trajectory {bad} reached "
                "a non-finite state. The model is unstable in free run from this "
                "initial window (check the inputs' range against the training data)."
            )
        Y[active, t] = pred
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
    n_samples=None,
    random_state=None,
    return_std=False,
    noise_model=None,
    init="measured",
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
    init : {"measured", "least_squares"}, default="measured"
        How the simulation starts. ``"measured"``: from the newest ``n_steps``
        measured steps of ``initial`` as they are. ``"least_squares"``: the
        states of the first window are fitted so that the model's own free run
        through all ``n_init`` measured steps matches them in least squares
        (the initial-state estimate of prediction-error methods), and the
        simulation continues from that fitted run; with ``n_init`` well above
        ``n_steps`` this averages the measurement noise out of the starting
        state. Fitted separately for each trajectory (Levenberg-Marquardt,
        central differences, all trajectories advanced in one batch); a
        ``ConvergenceWarning`` names those that did not converge.

    Returns
    -------
    states : ndarray or list of ndarray
        The simulated states over all time steps, in the container form of
        ``inputs``; the first ``n_init`` steps are the measured ones. With
        ``n_samples`` a leading axis of size ``n_samples`` (for each array of a
        list). With ``return_std=True`` the tuple ``(mean, std)``.
    """
    check_is_fitted(estimator)
    if not isinstance(init, str) or init not in INITS:
        raise ValueError(f"init must be one of {INITS}; got init={init!r}.")
    U_list, form = _as_list(inputs, "inputs")
    Y0_list, init_form = _as_list(initial, "initial")
    if init_form != form or len(Y0_list) != len(U_list):
        raise ValueError(
            f"initial must match inputs: {len(U_list)} experiment(s) given as a "
            f"{form} container, but initial holds {len(Y0_list)} as a {init_form} "
            "container."
        )
    n_inputs = _check_widths(U_list, "inputs")
    n_states = _check_widths(Y0_list, "initial")
    layout = _layout(estimator, n_states, n_inputs)
    lengths = np.array([len(u) for u in U_list])
    n_init = np.array([len(y) for y in Y0_list])
    for i, (ni, n) in enumerate(zip(n_init, lengths, strict=True)):
        if ni < layout.n_steps:
            raise ValueError(
                f"initial[{i}] holds {ni} time steps; the estimator reads windows "
                f"of n_steps={layout.n_steps}, so at least {layout.n_steps} measured "
                "steps must start the simulation."
            )
        if ni > n:
            raise ValueError(
                f"initial[{i}] holds {ni} time steps but inputs[{i}] only {n}; "
                "inputs cover the whole experiment, initial window included."
            )
    if n_samples is not None:
        if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)):
            raise TypeError(f"n_samples must be an int or None; got {n_samples!r}.")
        if n_samples < 1:
            raise ValueError(f"n_samples must be >= 1; got n_samples={n_samples}.")
    stochastic = n_samples is not None or return_std
    if stochastic and noise_model is None:
        raise ValueError(
            f"n_samples={n_samples!r} and return_std={return_std!r} need a noise "
            f"model; {type(estimator).__name__} has none (fit a hybrid with "
            "noise_model='gaussian' or 'ar')."
        )

    n_traj, n_max = len(U_list), int(lengths.max())
    U = np.zeros((n_traj, n_max, n_inputs))
    Y = np.zeros((n_traj, n_max, n_states))
    for i in range(n_traj):
        U[i, : lengths[i]] = U_list[i]
        Y[i, : n_init[i]] = Y0_list[i]
    if init == "least_squares":
        first = np.full(n_traj, layout.n_steps)

        def window_run(Y_run):
            return _rollout(
                estimator.predict, layout, U, Y_run, first, n_init, check=False
            )

        # Central differences need a step near the cube root of the precision
        # the model computes in (float32 networks, float64 physics).
        k = layout.n_steps
        probe = np.asarray(estimator.predict(layout.join(Y[:1, :k], U[:1, :k])))
        dtype = probe.dtype if np.issubdtype(probe.dtype, np.floating) else float
        rel_step = float(np.finfo(dtype).eps) ** (1 / 3)
        Y = fit_initial_windows(window_run, Y, n_init, k, rel_step=rel_step)

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
    ).reshape(n_paths, n_traj, n_max, n_states)
    Yp = _measured_window(Yp, Y0_list)
    if return_std:
        return (
            _pack(Yp.mean(axis=0), lengths, form),
            _pack(Yp.std(axis=0), lengths, form),
        )
    return _pack(Yp, lengths, form)


class SimulatorMixin:
    """Adds :meth:`simulate` to an estimator that predicts the next state."""

    def simulate(
        self,
        inputs,
        initial,
        *,
        n_samples=None,
        random_state=None,
        return_std=False,
        init="measured",
    ):
        """Simulate the fitted model in free run from measured initial windows.

        See :func:`skhybrid.simulation.simulate` for the contract; sample paths
        and bands use the estimator's fitted noise model (``noise_model_``),
        where it has one.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), (n_trajectories, \
n_times, n_inputs) or list of 2-D arrays
            Inputs over the whole experiment, initial window included.
        initial : array-like of shape (n_init, n_states), (n_trajectories, \
n_init, n_states) or list of 2-D arrays
            Measured states of the first ``n_init`` time steps.
        n_samples : int or None, default=None
            Number of sample paths through the noise model.
        random_state : int, RandomState instance or None, default=None
            Seed of the noise draws.
        return_std : bool, default=False
            Return the mean and standard deviation over sample paths.
        init : {"measured", "least_squares"}, default="measured"
            Start from the measured window as it is, or from the first window
            fitted by least squares to the whole measured initial record (see
            :func:`skhybrid.simulation.simulate`).

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
