"""LinearStateSpaceModel: ``x(t+1) = A x(t) + B u(t) + c``, ``y(t) = C x(t)``."""

from numbers import Integral

import numpy as np

from skhybrid.domain._base import DomainModel
from skhybrid.preprocessing import WindowLayout
from skhybrid.utils._sklearn_compat import Interval, StrOptions, _fit_context

__all__ = ["LinearStateSpaceModel"]


class LinearStateSpaceModel(DomainModel):
    """Discrete-time linear state-space model ``x(t+1) = A x(t) + B u(t) + c``.

    With ``order=None`` the state ``x`` is the first ``n_outputs`` columns of the
    window's newest step (the state width is ``y``'s number of columns, ``C`` is
    the identity) and the inputs ``u`` are the rest of that step.

    With ``order=n`` the model has ``n`` internal states, whatever the number of
    outputs ``p``: it is an ARX model of ``L = n / p`` lags,
    ``y(t+1) = sum_i A_i y(t+1-i) + sum_i B_i u(t+1-i) + c`` (``i = 1..L``),
    realised in (block) observer canonical form::

        x(t+1) = A x(t) + B u(t) + [c, 0, ..., 0],    y(t) = C x(t)
        A = [[A_1, I, 0, ..., 0],        B = [B_1,     C = [I, 0, ..., 0]
             [A_2, 0, I, ..., 0],             B_2,
             ...                              ...
             [A_L, 0, 0, ..., 0]]             B_L]

    The newest ``L`` steps of a window determine the state exactly, so ``predict``
    on windows of ``n_steps >= L`` steps is the one-step prediction of the state
    space model, and free-run :meth:`simulate` is its simulation. A first-order
    model of a single output (the default) cannot represent an oscillator;
    ``order=2`` can.

    With ``objective="mse"`` the fit is closed-form linear least squares (the ARX
    fit, which is the one-step prediction-error fit); the other objectives and
    robust losses refine it with :func:`scipy.optimize.least_squares` started
    from the closed-form solution.

    Parameters
    ----------
    n_inputs : int or None, default=None
        Number of inputs per step; ``None`` infers it from ``X`` and ``y``. When set,
        data with another number of inputs is rejected.
    fit_intercept : bool, default=True
        Whether to fit the offset ``c`` (else ``c = 0``).
    fixed : tuple of str, default=()
        Among ``("A", "B", "c")``, matrices held at their initial values (zeros).
    bounds : dict or None, default=None
        Bounds applied to every entry of a named matrix.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        Least-squares objective.
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    jac : {"2-point", "3-point", "autograd"}, default="2-point"
        Jacobian of the residuals (non-MSE objectives).
    loss : str, default="linear"
        Robust loss of ``least_squares``; anything but ``"linear"`` goes through it.
    f_scale : float, default=1.0
        Soft margin of robust losses.
    max_nfev : int or None, default=None
        Most residual evaluations.
    n_steps : int, default=1
        Time steps per row; the model reads the newest (``order / n_outputs`` of
        them with ``order`` set, so ``n_steps`` must be at least that).
    order : int or None, default=None
        Number of internal states. ``None`` uses the outputs themselves as the
        state (``order = n_outputs``, one lag). Otherwise a multiple of
        ``n_outputs``: ``order / n_outputs`` lags of outputs and inputs.
    refine : {None, "simulation"}, default=None
        ``"simulation"`` refines the closed-form (one-step, ARX) fit by the
        simulation error inside each window: the oldest ``L`` steps set the
        state, the model runs through the rest of the window with its inputs,
        and :func:`scipy.optimize.least_squares` minimises the errors of every
        simulated output of the window and of the target. With noise on the
        measured outputs the ARX fit is biased (its equation error is coloured);
        the simulation error over windows much longer than ``L`` steps is far
        less so. Needs ``objective="mse"``; the longer the windows
        (``n_steps``), the stronger the effect.

    Attributes
    ----------
    A_ : ndarray of shape (n_states, n_states)
        State matrix; ``n_states`` is ``order`` (``n_outputs`` when ``order`` is
        None).
    B_ : ndarray of shape (n_states, n_inputs)
        Input matrix.
    C_ : ndarray of shape (n_outputs, n_states)
        Output matrix ``[I, 0, ..., 0]``.
    c_ : ndarray of shape (n_states,)
        Offset of the state equation.
    eigenvalues_ : ndarray of shape (n_states,)
        Eigenvalues of ``A_`` (the poles); the model is stable when all lie
        inside the unit circle.
    is_stable_ : bool
        Whether every eigenvalue has modulus below 1.
    n_states_ : int
        Number of internal states.
    params_ : dict
        The fitted parameters ``{"A", "B", "c"}``. With ``order=None`` they are
        ``A_``, ``B_`` and ``c_``; with ``order`` set, ``"A"`` is the free first
        block column ``[A_1; ...; A_L]`` of ``A_`` (shape ``(order, n_outputs)``),
        ``"B"`` is ``B_`` and ``"c"`` the offset of the output equation (shape
        ``(n_outputs,)``).
    params_std_ : dict
        Standard errors of every entry, same shapes.
    result_ : OptimizeResult or None
        What ``least_squares`` returned (``None`` for the closed form).
    n_features_in_ : int
        Number of columns of ``X``.
    n_outputs_ : int
        Number of states.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import LinearStateSpaceModel
    >>> rng = np.random.default_rng(0)
    >>> X = rng.standard_normal((200, 3))          # [x1, x2, u]
    >>> A = np.array([[0.9, 0.1], [-0.2, 0.8]])
    >>> y = X[:, :2] @ A.T + 0.5 * X[:, 2:] + [0.3, -0.1]
    >>> model = LinearStateSpaceModel().fit(X, y)
    >>> np.round(model.A_, 6)
    array([[ 0.9,  0.1],
           [-0.2,  0.8]])
    >>> np.round(model.c_, 6)
    array([ 0.3, -0.1])
    >>> bool(model.is_stable_)
    True

    A second-order model of one output, from windows of two steps:

    >>> from skhybrid.preprocessing import make_windows
    >>> u = rng.standard_normal(300)
    >>> y = np.zeros(300)
    >>> for t in range(2, 300):
    ...     y[t] = 1.6 * y[t - 1] - 0.9 * y[t - 2] + 0.5 * u[t - 1] + 0.2 * u[t - 2]
    >>> X, Y = make_windows(y[:, None], u[:, None], n_steps=2)
    >>> model = LinearStateSpaceModel(order=2, n_steps=2, fit_intercept=False)
    >>> model = model.fit(X, Y)
    >>> np.round(model.A_, 6)
    array([[ 1.6,  1. ],
           [-0.9,  0. ]])
    >>> np.round(model.B_, 6)
    array([[0.5],
           [0.2]])
    """

    _parameter_constraints = {
        **DomainModel._parameter_constraints,
        "n_inputs": [Interval(Integral, 0, None, closed="left"), None],
        "fit_intercept": ["boolean"],
        "order": [Interval(Integral, 1, None, closed="left"), None],
        "refine": [StrOptions({"simulation"}), None],
    }

    def __init__(
        self,
        n_inputs=None,
        *,
        fit_intercept=True,
        fixed=(),
        bounds=None,
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
        jac="2-point",
        loss="linear",
        f_scale=1.0,
        max_nfev=None,
        n_steps=1,
        order=None,
        refine=None,
    ):
        super().__init__(
            fixed=fixed,
            bounds=bounds,
            objective=objective,
            ljung_box_lags=ljung_box_lags,
            ljung_box_weight=ljung_box_weight,
            jac=jac,
            loss=loss,
            f_scale=f_scale,
            max_nfev=max_nfev,
            n_steps=n_steps,
        )
        self.n_inputs = n_inputs
        self.fit_intercept = fit_intercept
        self.order = order
        self.refine = refine

    def _n_lags(self, n_outputs):
        return 1 if self.order is None else self.order // n_outputs

    def _check_layout(self, n_step_features, n_outputs):
        n_inputs = n_step_features - n_outputs
        if n_inputs < 0:
            raise ValueError(
                f"LinearStateSpaceModel reads the state from the first {n_outputs} "
                f"columns of each step (one per output), but a step has only "
                f"{n_step_features} columns (n_steps={self.n_steps})."
            )
        if self.n_inputs is not None and n_inputs != self.n_inputs:
            raise ValueError(
                f"n_inputs={self.n_inputs} but X has {n_step_features} columns per "
                f"step and y has {n_outputs} outputs, that is {n_inputs} inputs."
            )
        if self.order is not None:
            if self.order % n_outputs:
                raise ValueError(
                    f"order={self.order} must be a multiple of the number of "
                    f"outputs, {n_outputs}: the model has order / n_outputs lags of "
                    "each output (observer canonical form)."
                )
            n_lags = self.order // n_outputs
            if n_lags > self.n_steps:
                raise ValueError(
                    f"order={self.order} needs windows of at least {n_lags} steps "
                    f"(order / n_outputs lags of {n_outputs} output(s)) but "
                    f"n_steps={self.n_steps}; build rows with n_steps >= {n_lags}."
                )
        if self.refine is not None and self.objective != "mse":
            raise ValueError(
                f"refine={self.refine!r} minimises the simulation error by least "
                f"squares; it needs objective='mse', got objective="
                f"{self.objective!r}."
            )

    def _layout(self, X, n_outputs):
        """The rows' :class:`~skhybrid.preprocessing.WindowLayout`: outputs, inputs."""
        return WindowLayout.from_shapes(X.shape[1], n_outputs, n_steps=self.n_steps)

    def _lagged_steps(self, X, n_lags, n_outputs):
        """``(outputs, inputs)`` of each row's newest ``n_lags`` steps, newest first."""
        outputs, inputs = self._layout(X, n_outputs).split(X)
        return [(outputs[:, -1 - i], inputs[:, -1 - i]) for i in range(n_lags)]

    def _closed_form(self, X, y):
        s = y.shape[1]
        n_lags = self._n_lags(s)
        steps = self._lagged_steps(X, n_lags, s)
        design = np.hstack([np.hstack(step) for step in steps])
        if self.fit_intercept:
            design = np.hstack([design, np.ones((X.shape[0], 1))])
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        w = sum(part.shape[1] for part in steps[0])
        A = np.vstack([coef[i * w : i * w + s].T for i in range(n_lags)])
        B = np.vstack([coef[i * w + s : (i + 1) * w].T for i in range(n_lags)])
        c = coef[-1] if self.fit_intercept else np.zeros(s)
        return A, B, c

    def _initial_params(self, X, y):
        s = y.shape[1]
        m = self._layout(X, s).n_inputs
        n = s * self._n_lags(s)
        if self.fixed:
            zeros = {"A": np.zeros((n, s)), "B": np.zeros((n, m)), "c": np.zeros(s)}
        else:
            A, B, c = self._closed_form(X, y)
            zeros = {"A": A, "B": B, "c": c}
        if not self.fit_intercept:
            zeros.pop("c")
        return zeros

    def _equations(self, X, params, xp):
        A, B = params["A"], params["B"]
        s = A.shape[1]
        out = None
        for i, (y_i, u_i) in enumerate(self._lagged_steps(X, A.shape[0] // s, s)):
            term = y_i @ A[i * s : (i + 1) * s].T + u_i @ B[i * s : (i + 1) * s].T
            out = term if out is None else out + term
        if "c" in params:
            out = out + params["c"]
        return out

    def _window_simulation(self, X, params):
        """Simulated outputs of every step after the oldest ``L``, and the target.

        Returns ``(measured, simulated)``, lists of ``(n_samples, n_outputs)``
        arrays of the in-window steps ``L..n_steps-1`` (``measured`` holds those
        only; ``simulated`` holds one more, the prediction of the target).
        """
        A, B = params["A"], params["B"]
        s = A.shape[1]
        n_lags = A.shape[0] // s
        outputs, inputs = self._layout(X, s).split(X)
        ys = [outputs[:, j] for j in range(self.n_steps)]
        us = [inputs[:, j] for j in range(self.n_steps)]
        sim = list(ys[:n_lags])
        for j in range(n_lags, self.n_steps + 1):
            out = None
            for i in range(1, n_lags + 1):
                term = (
                    sim[j - i] @ A[(i - 1) * s : i * s].T
                    + us[j - i] @ B[(i - 1) * s : i * s].T
                )
                out = term if out is None else out + term
            if "c" in params:
                out = out + params["c"]
            sim.append(out)
        return ys[n_lags:], sim[n_lags:]

    def _residual_vector(self, X, y, spec, xp):
        if self.refine is None:
            return super()._residual_vector(X, y, spec, xp)

        def residuals(theta):
            params = spec.to_dict(theta, xp=xp)
            measured, simulated = self._window_simulation(X, params)
            parts = [m - p for m, p in zip(measured, simulated[:-1], strict=True)]
            parts.append(y - simulated[-1])
            return xp.concat([xp.reshape(p, (-1,)) for p in parts])

        return residuals

    def _state_space(self, A, B, c):
        """Observer canonical form ``(A_, B_, C_, c_)`` of the ARX coefficients."""
        n, s = A.shape
        A_ss = np.zeros((n, n))
        A_ss[:, :s] = A
        A_ss[: n - s, s:] = np.eye(n - s)
        C = np.zeros((s, n))
        C[:, :s] = np.eye(s)
        c_ss = np.zeros(n)
        c_ss[:s] = c
        return A_ss, np.array(B, dtype=float), C, c_ss

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Fit ``A``, ``B`` and ``c`` (and realise the state-space form).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows; each step is ``[y(t), u(t)]``.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next outputs ``y(t+1)``.

        Returns
        -------
        self : object
            The fitted model.
        """
        super().fit(X, y)
        self.A_, self.B_, self.C_, self.c_ = self._state_space(
            np.asarray(self.params_["A"]),
            np.asarray(self.params_["B"]),
            np.asarray(self.params_.get("c", np.zeros(self.n_outputs_))),
        )
        self.n_states_ = self.A_.shape[0]
        self.eigenvalues_ = np.linalg.eigvals(self.A_)
        self.is_stable_ = bool(np.all(np.abs(self.eigenvalues_) < 1))
        return self

    def _least_squares(self, X, y, spec):
        if (
            self.refine is None
            and self.objective == "mse"
            and self.loss == "linear"
            and not self.fixed
            and not self.bounds
        ):
            # The initial values are the closed-form optimum: nothing to iterate.
            return spec.x0, None
        return super()._least_squares(X, y, spec)
