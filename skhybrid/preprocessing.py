"""Windows of history: the data convention of skhybrid.

A row of ``X`` is a window of ``n_steps`` consecutive time steps, oldest first; each
step is laid out as ``[state_1..state_s, input_1..input_m]``. The target row is the
state at the step after the window's newest step. With ``n_steps=1`` this is the
one-step map ``x(t), u(t) -> x(t+1)``.

Because a row carries its own history, predictions never depend on row order:
shuffled cross-validation, joblib and scikit-learn's estimator checks all work.
"""

from numbers import Integral

import numpy as np

__all__ = ["make_windows", "newest_step", "split_steps", "step_width"]


def _check_n_steps(n_steps):
    if isinstance(n_steps, bool) or not isinstance(n_steps, Integral) or n_steps < 1:
        raise ValueError(
            f"n_steps must be a positive integer; got n_steps={n_steps!r}."
        )


def step_width(n_features, n_steps):
    """Number of columns of one time step in a row of ``n_features`` columns.

    Raises a ValueError when ``n_features`` is not a multiple of ``n_steps``.

    Examples
    --------
    >>> from skhybrid.preprocessing import step_width
    >>> step_width(12, n_steps=3)
    4
    """
    _check_n_steps(n_steps)
    if n_features % n_steps:
        raise ValueError(
            f"X has {n_features} columns, which is not a multiple of "
            f"n_steps={n_steps}; a row must hold n_steps equally wide time steps."
        )
    return n_features // n_steps


def newest_step(X, n_steps):
    """The newest time step of each row: the last ``step_width`` columns.

    Works on NumPy arrays and torch tensors.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.preprocessing import newest_step
    >>> newest_step(np.arange(6.0).reshape(1, 6), n_steps=3)
    array([[4., 5.]])
    """
    width = step_width(X.shape[1], n_steps)
    return X[:, X.shape[1] - width :]


def split_steps(X, n_steps):
    """Reshape rows into ``(n_samples, n_steps, step_width)``, oldest step first.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.preprocessing import split_steps
    >>> split_steps(np.arange(6.0).reshape(1, 6), n_steps=3)[0, -1]
    array([4., 5.])
    """
    width = step_width(X.shape[1], n_steps)
    return X.reshape(X.shape[0], n_steps, width)


def _as_episodes(array, name):
    if array is None:
        return None
    if isinstance(array, (list, tuple)):
        episodes = [np.asarray(a, dtype=float) for a in array]
    else:
        episodes = [np.asarray(array, dtype=float)]
    episodes = [a[:, None] if a.ndim == 1 else a for a in episodes]
    for a in episodes:
        if a.ndim != 2:
            raise ValueError(
                f"{name} must be 2-D (n_times, n_columns) or a list of such arrays; "
                f"got an array with shape {a.shape}."
            )
    return episodes


def make_windows(states, inputs=None, *, n_steps=1, return_groups=False):
    """Build rows of history and next-state targets from raw sequences.

    Parameters
    ----------
    states : array-like of shape (n_times, n_states) or list of such arrays
        Measured states in time order; a list holds separate episodes, and no
        window crosses from one episode into the next.
    inputs : array-like of shape (n_times, n_inputs), list of such arrays or None, \
            default=None
        Inputs applied at each time step, aligned with ``states`` (the input at time
        ``t`` acts between ``t`` and ``t + 1``). ``None`` for an autonomous system.
    n_steps : int, default=1
        Time steps per window.
    return_groups : bool, default=False
        Also return the episode index of every row (for CV that keeps episodes
        whole).

    Returns
    -------
    X : ndarray of shape (n_windows, n_steps * (n_states + n_inputs))
        Windows, oldest step first, each step ``[states, inputs]``.
    y : ndarray of shape (n_windows, n_states)
        The state after each window's newest step.
    groups : ndarray of shape (n_windows,)
        Episode index of each row; only with ``return_groups=True``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.preprocessing import make_windows
    >>> states = np.arange(5.0)[:, None]
    >>> X, y = make_windows(states, n_steps=2)
    >>> X
    array([[0., 1.],
           [1., 2.],
           [2., 3.]])
    >>> y.ravel()
    array([2., 3., 4.])
    """
    _check_n_steps(n_steps)
    state_eps = _as_episodes(states, "states")
    input_eps = _as_episodes(inputs, "inputs")
    if input_eps is not None and len(input_eps) != len(state_eps):
        raise ValueError(
            f"states has {len(state_eps)} episodes but inputs has {len(input_eps)}."
        )
    X_parts, y_parts, g_parts = [], [], []
    for i, s in enumerate(state_eps):
        if input_eps is not None:
            u = input_eps[i]
            if u.shape[0] != s.shape[0]:
                raise ValueError(
                    f"episode {i}: states has {s.shape[0]} time steps but inputs has "
                    f"{u.shape[0]}; they must be aligned."
                )
            steps = np.hstack([s, u])
        else:
            steps = s
        n_windows = s.shape[0] - n_steps
        if n_windows < 1:
            continue
        idx = np.arange(n_windows)[:, None] + np.arange(n_steps)[None, :]
        X_parts.append(steps[idx].reshape(n_windows, -1))
        y_parts.append(s[n_steps : n_steps + n_windows])
        g_parts.append(np.full(n_windows, i))
    if not X_parts:
        raise ValueError(
            f"no episode is longer than n_steps={n_steps}; no window can be built."
        )
    X, y = np.vstack(X_parts), np.vstack(y_parts)
    if return_groups:
        return X, y, np.concatenate(g_parts)
    return X, y
