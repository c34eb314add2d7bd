"""Windows of history: the data convention of skhybrid.

A row of ``X`` is a window of ``n_steps`` consecutive time steps, oldest first; each
step is laid out as ``[state_1..state_s, input_1..input_m]``. The target row is the
state at the step after the window's newest step. With ``n_steps=1`` this is the
one-step map ``x(t), u(t) -> x(t+1)``.

Because a row carries its own history, predictions never depend on row order:
shuffled cross-validation, joblib and scikit-learn's estimator checks all work.
"""

from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np

__all__ = [
    "WindowLayout",
    "infer_n_steps",
    "make_windows",
    "newest_step",
    "split_steps",
    "step_width",
]


def _check_n_steps(n_steps):
    if isinstance(n_steps, bool) or not isinstance(n_steps, Integral) or n_steps < 1:
        raise ValueError(
            f"n_steps must be a positive integer; got n_steps={n_steps!r}."
        )


def step_width(n_features, n_steps):
    """Number of columns of one time step in a row of ``n_features`` columns.

    Raises a ValueError when ``n_features`` is not a multiple of ``n_steps``.

    Parameters
    ----------
    n_features : int
        Columns of a row.
    n_steps : int
        Time steps per row.

    Returns
    -------
    width : int
        Columns per time step.

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

    Parameters
    ----------
    X : ndarray or torch.Tensor of shape (n_samples, n_features)
        Rows of ``n_steps`` time steps.
    n_steps : int
        Time steps per row.

    Returns
    -------
    newest : ndarray or torch.Tensor of shape (n_samples, n_features // n_steps)
        The newest step of each row.

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

    Parameters
    ----------
    X : ndarray or torch.Tensor of shape (n_samples, n_features)
        Rows of ``n_steps`` time steps.
    n_steps : int
        Time steps per row.

    Returns
    -------
    steps : ndarray or torch.Tensor of shape (n_samples, n_steps, step_width)
        The steps of each row, oldest first.

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


def _concat(parts, axis):
    """Concatenate NumPy arrays or torch tensors (whichever ``parts`` holds)."""
    if type(parts[0]).__module__.startswith("torch"):
        import torch

        return torch.cat(parts, dim=axis)
    return np.concatenate(parts, axis=axis)


def _namespace_name(array):
    """``"NumPy array"``, ``"torch tensor"`` or None for anything else."""
    if isinstance(array, np.ndarray):
        return "NumPy array"
    kind = type(array)
    if kind.__module__.startswith("torch") and kind.__name__ in (
        "Tensor",
        "Parameter",
    ):
        return "torch tensor"
    return None


def _check_same_namespace(reference, reference_name, **arrays):
    """Raise a TypeError unless every array is of ``reference``'s kind.

    Concatenating a tensor with an array would either fail deep in torch or
    give NumPy silently, cutting the gradient of a differentiable step.
    """
    expected = _namespace_name(reference)
    for name, array in arrays.items():
        got = _namespace_name(array)
        if array is not None and got != expected:
            got = got or type(array).__name__
            raise TypeError(
                f"{name} is a {got} but {reference_name} a {expected}; give them "
                "in one namespace (np.asarray(...) or torch.as_tensor(..., "
                f"device={reference_name}.device))."
            )


def _check_count(value, name, minimum):
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise ValueError(
            f"{name} must be an integer >= {minimum}; got {name}={value!r}."
        )
    return int(value)


@dataclass(frozen=True)
class WindowLayout:
    """How a row of ``X`` is built from sequences: the window convention, explicit.

    A row holds ``n_steps`` consecutive time steps, oldest first; each step is laid
    out as ``[state_1..state_s, input_1..input_m]`` and the target is the state at
    the step after the window. "State" means whatever the model predicts and
    feeds back: the full state of a simulator, or only the measured outputs of a
    real system, in which case the window of past outputs and inputs is the NARX
    form. Both are the same layout.

    Every component reads this object instead of re-deriving widths: building
    rows (:meth:`make_rows`), splitting them (:meth:`split`), shifting a window
    one step forward in free-run simulation (:meth:`shift`, NumPy or torch), and
    naming the features (:meth:`feature_names`). Estimators never store it as a
    parameter: they derive it from the data (:meth:`from_shapes`), so cloning is
    unaffected.

    Parameters
    ----------
    n_states : int
        Columns of the state (or measured output) in each step; also the width of
        the target.
    n_inputs : int, default=0
        Columns of the input in each step; 0 for an autonomous system.
    n_steps : int, default=1
        Time steps per row.
    state_names : sequence of str or None, default=None
        Names of the state columns; ``x0, x1, ...`` when None. A list or tuple,
        not a single string; every state and input name must be unique.
    input_names : sequence of str or None, default=None
        Names of the input columns; ``u0, u1, ...`` when None.

    Notes
    -----
    Arguments are checked as a scikit-learn estimator checks its data: a
    ``next_state``, ``next_input``, ``y``, ``states`` or ``inputs`` of the wrong
    shape, a negative or NaN ``atol``, a string or repeated names each raise a
    ValueError that names the argument and the shape or value received, instead
    of returning rows of the wrong width.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.preprocessing import WindowLayout
    >>> layout = WindowLayout(n_states=1, n_inputs=1, n_steps=2)
    >>> layout.feature_names()
    ['x0[t-1]', 'u0[t-1]', 'x0[t]', 'u0[t]']
    >>> X, y = layout.make_rows(np.arange(4.0), 10 + np.arange(4.0))
    >>> X[0], y[0]
    (array([ 0., 10.,  1., 11.]), array([2.]))
    >>> layout.shift(X[:1], np.array([[2.0]]), np.array([[12.0]]))
    array([[ 1., 11.,  2., 12.]])
    """

    n_states: int
    n_inputs: int = 0
    n_steps: int = 1
    state_names: tuple = None
    input_names: tuple = None

    def __post_init__(self):
        _check_count(self.n_states, "n_states", 1)
        _check_count(self.n_inputs, "n_inputs", 0)
        _check_n_steps(self.n_steps)
        counts = (("state_names", self.n_states), ("input_names", self.n_inputs))
        seen = {}
        for attr, count in counts:
            names = getattr(self, attr)
            if names is None:
                continue
            # A string is a sequence of characters: "ab" would name two states
            # "a" and "b" without the caller meaning it.
            if isinstance(names, (str, bytes)) or not hasattr(names, "__iter__"):
                raise ValueError(
                    f"{attr} must be a sequence of {count} names (a list or tuple "
                    f"of str), not a single {type(names).__name__}; got "
                    f"{attr}={names!r}."
                )
            names = tuple(str(n) for n in names)
            if len(names) != count:
                raise ValueError(
                    f"{attr} must hold {count} names; got {attr}={names!r}."
                )
            for name in names:
                if name in seen:
                    raise ValueError(
                        f"{attr} repeats the name {name!r} (already in "
                        f"{seen[name]}); a row's feature names must be unique. "
                        f"Got {attr}={names!r}."
                    )
                seen[name] = attr
            object.__setattr__(self, attr, names)

    @classmethod
    def from_shapes(cls, n_features, n_states, *, n_steps=None, n_inputs=None, **names):
        """The layout of rows with ``n_features`` columns and ``n_states`` targets.

        Give ``n_steps`` or ``n_inputs``; the other follows from
        ``n_features = n_steps * (n_states + n_inputs)``.

        Parameters
        ----------
        n_features : int
            Columns of a row.
        n_states : int
            Columns of the target.
        n_steps : int or None, default=None
            Time steps per row.
        n_inputs : int or None, default=None
            Input columns per step.
        **names : dict
            ``state_names`` and ``input_names``, passed on.

        Returns
        -------
        layout : WindowLayout
            The layout; a ValueError names the mismatch when none fits.
        """
        if n_steps is None and n_inputs is None:
            raise ValueError("give n_steps or n_inputs to derive a window layout.")
        if n_steps is not None:
            width = step_width(n_features, n_steps)
            if width < n_states:
                raise ValueError(
                    f"a row of {n_features} columns in n_steps={n_steps} steps has "
                    f"{width} columns per step, fewer than the {n_states} states."
                )
            layout = cls(n_states, width - n_states, n_steps, **names)
        else:
            width = n_states + n_inputs
            if n_features % width:
                raise ValueError(
                    f"a row of {n_features} columns is not a whole number of steps "
                    f"of {n_states} states and {n_inputs} inputs ({width} columns)."
                )
            layout = cls(n_states, n_inputs, n_features // width, **names)
        if n_inputs is not None and layout.n_inputs != n_inputs:
            raise ValueError(
                f"rows of {n_features} columns with n_steps={n_steps} and "
                f"{n_states} states hold {layout.n_inputs} inputs per step, not "
                f"n_inputs={n_inputs}."
            )
        return layout

    @property
    def step_width(self):
        """Columns of one time step: ``n_states + n_inputs``."""
        return self.n_states + self.n_inputs

    @property
    def n_features(self):
        """Columns of a row: ``n_steps * step_width``."""
        return self.n_steps * self.step_width

    def _names(self):
        states = self.state_names or tuple(f"x{i}" for i in range(self.n_states))
        inputs = self.input_names or tuple(f"u{i}" for i in range(self.n_inputs))
        return states, inputs

    def feature_names(self):
        """Names of a row's columns, ``name[t-k]`` for the step k before the newest.

        Returns
        -------
        names : list of str
            One name per column of a row.
        """
        states, inputs = self._names()
        out = []
        for k in range(self.n_steps - 1, -1, -1):
            lag = "[t]" if k == 0 else f"[t-{k}]"
            out.extend(f"{n}{lag}" for n in (*states, *inputs))
        return out

    def check(self, X, name="X"):
        """Raise when ``X`` is not rows of this layout's width.

        A TypeError when ``X`` is neither a NumPy array nor a torch tensor (the
        result of every method follows ``X``'s namespace), a ValueError when
        its shape is not ``(n_samples, n_features)``.

        Parameters
        ----------
        X : ndarray or tensor of shape (n_samples, n_features)
            Rows to check.
        name : str, default="X"
            How to name ``X`` in the error.

        Returns
        -------
        X : array-like or tensor
            ``X`` itself.
        """
        if _namespace_name(X) is None:
            raise TypeError(
                f"{name} must be a NumPy array or a torch tensor of shape "
                f"(n_samples, {self.n_features}); got a {type(X).__name__}. Convert "
                f"it with np.asarray({name})."
            )
        if X.ndim != 2 or X.shape[1] != self.n_features:
            raise ValueError(
                f"{name} must have {self.n_features} columns ({self.n_steps} steps of "
                f"{self.n_states} states and {self.n_inputs} inputs); got shape "
                f"{tuple(X.shape)}."
            )
        return X

    def split(self, X):
        """Split rows into states and inputs, each ``(n_samples, n_steps, width)``.

        Works on NumPy arrays and torch tensors.

        Parameters
        ----------
        X : array or tensor of shape (n_samples, n_features)
            Rows in this layout.

        Returns
        -------
        states : array or tensor of shape (n_samples, n_steps, n_states)
            The state of each step, oldest first.
        inputs : array or tensor of shape (n_samples, n_steps, n_inputs)
            The input of each step, oldest first.
        """
        steps = self.check(X).reshape(X.shape[0], self.n_steps, self.step_width)
        return steps[:, :, : self.n_states], steps[:, :, self.n_states :]

    def join(self, states, inputs=None):
        """Rows from states ``(n, n_steps, n_states)`` and inputs; inverse of split.

        Parameters
        ----------
        states : array or tensor of shape (n_samples, n_steps, n_states)
            The state of each step, oldest first.
        inputs : array or tensor of shape (n_samples, n_steps, n_inputs) or None
            The input of each step; None when ``n_inputs == 0``.

        Returns
        -------
        X : array or tensor of shape (n_samples, n_features)
            Rows in this layout.
        """
        if _namespace_name(states) is None:
            raise TypeError(
                "states must be a NumPy array or a torch tensor of shape (n_samples, "
                f"{self.n_steps}, {self.n_states}); got a {type(states).__name__}."
            )
        _check_same_namespace(states, "states", inputs=inputs)
        n = self._check_shape(states, "states", (None, self.n_steps, self.n_states))
        if self.n_inputs:
            if inputs is None:
                raise ValueError(
                    f"inputs is needed: the layout has n_inputs={self.n_inputs} "
                    f"input columns per step; got inputs=None."
                )
            self._check_shape(inputs, "inputs", (n, self.n_steps, self.n_inputs))
            steps = _concat([states, inputs], axis=2)
        else:
            if inputs is not None:
                self._check_shape(inputs, "inputs", (n, self.n_steps, 0))
            steps = states
        return steps.reshape(n, self.n_features)

    def _check_shape(self, array, name, expected):
        """Raise a ValueError naming ``name`` unless ``array`` has this shape.

        ``None`` in ``expected`` accepts any length; returns the first axis.
        """
        shape = tuple(getattr(array, "shape", ()))
        if len(shape) != len(expected) or any(
            e is not None and s != e for s, e in zip(shape, expected, strict=True)
        ):
            wanted = ", ".join("n_samples" if e is None else str(e) for e in expected)
            raise ValueError(
                f"{name} must have shape ({wanted}) for this layout (n_states="
                f"{self.n_states}, n_inputs={self.n_inputs}, n_steps={self.n_steps})"
                f"; got shape {shape}."
            )
        return shape[0]

    def newest_states(self, X):
        """The state of the newest step of each row, ``(n_samples, n_states)``.

        Parameters
        ----------
        X : array or tensor of shape (n_samples, n_features)
            Rows in this layout.

        Returns
        -------
        states : array or tensor of shape (n_samples, n_states)
            The newest step's state.
        """
        start = self.n_features - self.step_width
        return self.check(X)[:, start : start + self.n_states]

    def shift(self, X, next_state, next_input=None):
        """Drop each row's oldest step and append ``[next_state, next_input]``.

        The step of free-run simulation: the window moves one step forward with
        the predicted state and the next measured input. Works on NumPy arrays and
        torch tensors (differentiably).

        Parameters
        ----------
        X : array or tensor of shape (n_samples, n_features)
            Rows in this layout.
        next_state : array or tensor of shape (n_samples, n_states)
            The state of the new newest step.
        next_input : array or tensor of shape (n_samples, n_inputs) or None
            The input of the new newest step; None when ``n_inputs == 0``.

        Returns
        -------
        X_next : array or tensor of shape (n_samples, n_features)
            The shifted rows.
        """
        n = self.check(X).shape[0]
        _check_same_namespace(X, "X", next_state=next_state, next_input=next_input)
        self._check_shape(next_state, "next_state", (n, self.n_states))
        parts = [X[:, self.step_width :], next_state]
        if self.n_inputs:
            if next_input is None:
                raise ValueError(
                    f"next_input is needed: the layout has {self.n_inputs} inputs."
                )
            self._check_shape(next_input, "next_input", (n, self.n_inputs))
            parts.append(next_input)
        elif next_input is not None:
            self._check_shape(next_input, "next_input", (n, 0))
        return _concat(parts, axis=1)

    def continues(self, X, y, *, atol=0.0):
        """Whether row ``i + 1`` continues row ``i`` in the same experiment.

        Row ``i + 1`` continues row ``i`` when it is row ``i`` shifted one step
        forward with the target ``y[i]`` as its newest state: its older steps
        equal row ``i``'s newer steps, and its newest state equals ``y[i]``. Rows
        built by :meth:`make_rows` from one episode continue each other; the last
        row of an episode is not continued by the first of the next. This is what
        lets a loss over simulated horizons run on rows: the rows themselves say
        where the sequences are.

        Parameters
        ----------
        X : array of shape (n_samples, n_features)
            Rows in this layout, in time order.
        y : array of shape (n_samples, n_states) or (n_samples,)
            The targets of the rows (1-D only when ``n_states == 1``); another
            width raises a ValueError.
        atol : float, default=0.0
            Absolute tolerance of the comparison, finite and >= 0 (0: exact, as
            for rows cut from the same sequence).

        Returns
        -------
        continues : ndarray of bool of shape (n_samples - 1,)
            ``continues[i]`` is True when row ``i + 1`` continues row ``i``.
        """
        X = np.asarray(self.check(X))
        y = np.asarray(y)
        if y.ndim == 1 and self.n_states == 1:
            y = y[:, None]
        self._check_shape(y, "y", (len(X), self.n_states))
        if (
            isinstance(atol, bool)
            or not isinstance(atol, Real)
            or not np.isfinite(atol)
            or atol < 0
        ):
            raise ValueError(f"atol must be a finite number >= 0; got atol={atol!r}.")
        if len(X) < 2:
            return np.zeros(0, dtype=bool)
        older = np.abs(X[1:, : -self.step_width] - X[:-1, self.step_width :])
        newest = np.abs(self.newest_states(X[1:]) - y[:-1])
        return np.all(older <= atol, axis=1) & np.all(newest <= atol, axis=1)

    def horizon_starts(self, X, y, horizon, *, atol=0.0):
        """Rows from which ``horizon`` contiguous rows follow in one experiment.

        Parameters
        ----------
        X : array of shape (n_samples, n_features)
            Rows in this layout, in time order.
        y : array of shape (n_samples, n_states) or (n_samples,)
            The targets of the rows (1-D only when ``n_states == 1``).
        horizon : int
            Rows per sub-sequence (1: every row).
        atol : float, default=0.0
            Passed to :meth:`continues`.

        Returns
        -------
        starts : ndarray of int
            Indices ``i`` such that rows ``i .. i + horizon - 1`` each continue
            the one before; simulating ``horizon`` steps from row ``i`` then
            meets the targets ``y[i : i + horizon]``. Empty when fewer than
            ``horizon`` rows are given.

        Examples
        --------
        >>> import numpy as np
        >>> from skhybrid.preprocessing import WindowLayout, make_windows
        >>> X, y = make_windows([np.arange(5.0), np.arange(4.0)], n_steps=1)
        >>> WindowLayout(1).horizon_starts(X, y, horizon=3)
        array([0, 1, 4])
        """
        horizon = _check_count(horizon, "horizon", 1)
        ok = self.continues(X, y, atol=atol).astype(int)
        n = len(X)
        if horizon == 1:
            return np.arange(n)
        if n < horizon:  # too few rows for a single sub-sequence
            return np.zeros(0, dtype=np.intp)
        # A start i needs ok[i .. i + horizon - 2] all true: a window sum.
        run = np.convolve(ok, np.ones(horizon - 1, dtype=int), mode="valid")
        return np.flatnonzero(run == horizon - 1)

    def make_rows(self, states, inputs=None, *, return_groups=False):
        """Rows and next-state targets from sequences; see :func:`make_windows`.

        Parameters
        ----------
        states : array-like of shape (n_times, n_states) or list of such arrays
            States in time order, one array per episode.
        inputs : array-like of shape (n_times, n_inputs), list of such arrays or None
            Inputs aligned with ``states``.
        return_groups : bool, default=False
            Also return the episode index of each row.

        Returns
        -------
        X : ndarray of shape (n_windows, n_features)
            Rows in this layout.
        y : ndarray of shape (n_windows, n_states)
            The state after each row's newest step.
        groups : ndarray of shape (n_windows,)
            Episode index of each row; only with ``return_groups=True``.
        """
        out = make_windows(
            states, inputs, n_steps=self.n_steps, return_groups=return_groups
        )
        if out[0].shape[1] != self.n_features or out[1].shape[1] != self.n_states:
            raise ValueError(
                f"the sequences have {out[1].shape[1]} state and "
                f"{out[0].shape[1] // self.n_steps - out[1].shape[1]} input columns; "
                f"the layout expects {self.n_states} and {self.n_inputs}."
            )
        return out


#: Rows read by :func:`infer_n_steps`: continuity is local, so the start of a
#: long record tells as much as all of it, at a bounded cost.
_INFER_MAX_ROWS = 2000


def infer_n_steps(X, y):
    """The window length under which the rows of ``X`` continue each other.

    Rows cut from sequences in time order by :func:`make_windows` continue each
    other (:meth:`WindowLayout.continues`: row ``i + 1`` is row ``i`` shifted one
    step, with the target ``y[i]`` as its newest state) under their true
    ``n_steps`` only. Every ``n_steps`` that divides the row into steps at least
    ``n_outputs`` wide is tried on the first 2000 rows; one is returned when most
    rows continue under it and fewer than half as many under any other.

    Estimators use it at ``fit`` to tell a user which ``n_steps`` to set when the
    rows say another than the one given.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_features)
        Rows, in time order for the answer to be found.
    y : array-like of shape (n_samples,) or (n_samples, n_outputs)
        Their targets, the state after each row.

    Returns
    -------
    n_steps : int or None
        The window length the rows follow; None when they do not tell (shuffled
        rows, too few rows, or rows that continue under several lengths, as a
        state that does not change does).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.preprocessing import infer_n_steps, make_windows
    >>> rng = np.random.default_rng(0)
    >>> X, y = make_windows(rng.normal(size=50), rng.normal(size=50), n_steps=3)
    >>> infer_n_steps(X, y)
    3
    >>> print(infer_n_steps(X[::-1], y[::-1]))  # not in time order
    None
    """
    X = np.asarray(X)[: _INFER_MAX_ROWS + 1]
    y = np.asarray(y)[: _INFER_MAX_ROWS + 1]
    if X.ndim != 2 or len(X) < 3 or len(y) != len(X):
        return None
    Y = y.reshape(len(X), -1)
    n_features, n_outputs = X.shape[1], Y.shape[1]
    counts = {}
    for n_steps in range(1, n_features + 1):
        if n_features % n_steps or n_features // n_steps < n_outputs:
            continue
        layout = WindowLayout.from_shapes(n_features, n_outputs, n_steps=n_steps)
        counts[n_steps] = int(np.sum(layout.continues(X, Y)))
    if not counts:
        return None
    best = max(counts, key=counts.get)
    others = [c for k, c in counts.items() if k != best]
    if counts[best] > (len(X) - 1) / 2 and all(c < counts[best] / 2 for c in others):
        return best
    return None
