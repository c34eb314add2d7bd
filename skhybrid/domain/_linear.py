"""LinearStateSpaceModel: ``x(t+1) = A x(t) + B u(t) + c``."""

from numbers import Integral

import numpy as np

from skhybrid.domain._base import DomainModel
from skhybrid.preprocessing import step_width
from skhybrid.utils._sklearn_compat import Interval, _fit_context

__all__ = ["LinearStateSpaceModel"]


class LinearStateSpaceModel(DomainModel):
    """Discrete-time linear state-space model ``x(t+1) = A x(t) + B u(t) + c``.

    The state ``x`` is the first ``n_outputs`` columns of the window's newest step
    (the state width is ``y``'s number of columns) and the inputs ``u`` are the rest
    of that step. With ``objective="mse"`` the fit is closed-form linear least
    squares; the other objectives go through :func:`scipy.optimize.least_squares`
    started from the closed-form solution.

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
        Time steps per row; the model reads the newest.

    Attributes
    ----------
    A_ : ndarray of shape (n_outputs, n_outputs)
        State matrix.
    B_ : ndarray of shape (n_outputs, n_inputs)
        Input matrix.
    c_ : ndarray of shape (n_outputs,)
        Offset.
    eigenvalues_ : ndarray of shape (n_outputs,)
        Eigenvalues of ``A_``; the model is stable when all lie inside the unit
        circle.
    is_stable_ : bool
        Whether every eigenvalue has modulus below 1.
    params_ : dict
        ``{"A": A_, "B": B_, "c": c_}``.
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
    >>> A = np.array([[0.9, 0.1], [0.0, 0.8]])
    >>> y = X[:, :2] @ A.T + 0.5 * X[:, 2:]
    >>> model = LinearStateSpaceModel().fit(X, y)
    >>> np.round(model.A_, 6)
    array([[0.9, 0.1],
           [0. , 0.8]])
    >>> bool(model.is_stable_)
    True
    """

    _parameter_constraints = {
        **DomainModel._parameter_constraints,
        "n_inputs": [Interval(Integral, 0, None, closed="left"), None],
        "fit_intercept": ["boolean"],
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

    def _closed_form(self, X, y):
        step = X[:, X.shape[1] - step_width(X.shape[1], self.n_steps) :]
        design = (
            np.hstack([step, np.ones((X.shape[0], 1))]) if self.fit_intercept else step
        )
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        s = y.shape[1]
        A, B = coef[:s].T, coef[s : step.shape[1]].T
        c = coef[-1] if self.fit_intercept else np.zeros(s)
        return A, B, c

    def _initial_params(self, X, y):
        s = y.shape[1]
        m = step_width(X.shape[1], self.n_steps) - s
        if self.fixed:
            zeros = {"A": np.zeros((s, s)), "B": np.zeros((s, m)), "c": np.zeros(s)}
        else:
            A, B, c = self._closed_form(X, y)
            zeros = {"A": A, "B": B, "c": c}
        if not self.fit_intercept:
            zeros.pop("c")
        return zeros

    def _equations(self, X, params, xp):
        s = params["A"].shape[0]
        step = X[:, X.shape[1] - step_width(X.shape[1], self.n_steps) :]
        out = step[:, :s] @ params["A"].T + step[:, s:] @ params["B"].T
        if "c" in params:
            out = out + params["c"]
        return out

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Fit ``A``, ``B`` and ``c``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows; the newest step is ``[x(t), u(t)]``.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next states ``x(t+1)``.

        Returns
        -------
        self : object
            The fitted model.
        """
        super().fit(X, y)
        self.A_ = np.asarray(self.params_["A"])
        self.B_ = np.asarray(self.params_["B"])
        self.c_ = np.asarray(self.params_.get("c", np.zeros(self.n_outputs_)))
        self.eigenvalues_ = np.linalg.eigvals(self.A_)
        self.is_stable_ = bool(np.all(np.abs(self.eigenvalues_) < 1))
        return self

    def _least_squares(self, X, y, spec):
        if (
            self.objective == "mse"
            and self.loss == "linear"
            and not self.fixed
            and not self.bounds
        ):
            # The initial values are the closed-form optimum: nothing to iterate.
            return spec.x0, None
        return super()._least_squares(X, y, spec)
