"""DomainModel: physics models with named parameters fitted by least squares."""

import warnings
from numbers import Integral, Real

import numpy as np
from scipy.optimize import least_squares
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils.validation import check_is_fitted

from skhybrid.domain._identifiability import (
    warn_if_underdetermined,
    warn_if_unidentifiable,
)
from skhybrid.domain._progress import counting
from skhybrid.losses import OBJECTIVES, objective_residuals
from skhybrid.preprocessing import step_width
from skhybrid.simulation import SimulatorMixin
from skhybrid.utils._array_api import get_namespace
from skhybrid.utils._lockstep import FORWARD_MODE
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    Interval,
    StrOptions,
    _fit_context,
    validate_data,
)
from skhybrid.utils._transaction import TransactionalFitMixin
from skhybrid.utils._validation import check_known_names

__all__ = ["DomainModel"]


class DomainModel(
    SimulatorMixin,
    TransactionalFitMixin,
    VersionedPickleMixin,
    RegressorMixin,
    BaseEstimator,
):
    """Base class of domain (physics) models fitted with ``least_squares``.

    A subclass declares its parameters and writes its equations once against an
    array namespace ``xp``, so that the same code evaluates on NumPy arrays (for
    :func:`scipy.optimize.least_squares`) and on torch tensors (for exact Jacobians
    with ``jac="autograd"`` and for joint training with a network in
    :class:`~skhybrid.hybrid.HybridEnsembleRegressor`). A subclass implements:

    - ``_initial_params(X, y)``: dict of parameter name to initial value (a float or
      an array), in a fixed order;
    - ``_equations(X, params, xp)``: predictions of shape ``(n_samples, n_outputs)``
      from rows ``X`` and a dict of parameters;
    - optionally ``_default_bounds()`` and ``_check_layout(n_step_features,
      n_outputs)``, which raises a ValueError for data of the wrong shape.

    Parameters
    ----------
    fixed : tuple of str, default=()
        Parameters held at their initial values during ``fit``.
    bounds : dict of str to (float, float) or None, default=None
        Lower and upper bound of named parameters; ``None`` uses the model's
        defaults. Use ``-numpy.inf`` / ``numpy.inf`` for a one-sided bound.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        What ``least_squares`` minimises (see :mod:`skhybrid.losses.base`). A
        Ljung-Box term assumes the training rows are in time order.
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    jac : {"2-point", "3-point", "autograd"}, default="2-point"
        Jacobian of the residual vector: finite differences, or exact by torch's
        automatic differentiation of the same equations.
    loss : {"linear", "soft_l1", "huber", "cauchy", "arctan"}, default="linear"
        Robust loss of ``least_squares``.
    f_scale : float, default=1.0
        Soft margin of robust losses (``least_squares``'s ``f_scale``).
    max_nfev : int or None, default=None
        Most evaluations of the residual vector (``least_squares``'s default when
        ``None``).
    n_steps : int, default=1
        Time steps per row; built-in models read the newest step.
    """

    _parameter_constraints = {
        "fixed": [tuple, list],
        "bounds": [dict, None],
        "objective": [StrOptions(set(OBJECTIVES))],
        "ljung_box_lags": [Interval(Integral, 1, None, closed="left")],
        "ljung_box_weight": [Interval(Real, 0, None, closed="left")],
        "jac": [StrOptions({"2-point", "3-point", "autograd"})],
        "loss": [StrOptions({"linear", "soft_l1", "huber", "cauchy", "arctan"})],
        "f_scale": [Interval(Real, 0, None, closed="neither")],
        "max_nfev": [Interval(Integral, 1, None, closed="left"), None],
        "n_steps": [Interval(Integral, 1, None, closed="left")],
    }

    # Set on the base class only: discovery skips it as an abstract base.
    _is_abstract_base = True

    def __init__(
        self,
        *,
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
        self.fixed = fixed
        self.bounds = bounds
        self.objective = objective
        self.ljung_box_lags = ljung_box_lags
        self.ljung_box_weight = ljung_box_weight
        self.jac = jac
        self.loss = loss
        self.f_scale = f_scale
        self.max_nfev = max_nfev
        self.n_steps = n_steps

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

    # -- what subclasses provide -------------------------------------------------
    def _initial_params(self, X, y):
        raise NotImplementedError

    def _equations(self, X, params, xp):
        raise NotImplementedError

    def _default_bounds(self):
        return {}

    def _check_layout(self, n_step_features, n_outputs):
        """Raise a ValueError when the data shape does not fit the equations."""

    # -- public API ----------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Fit the free parameters by least squares.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps (see :mod:`skhybrid.preprocessing`).
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next states.

        Returns
        -------
        self : object
            The fitted model.
        """
        return self._fit_least_squares(X, y)

    def _fit_least_squares(self, X, y, start=None):
        """:meth:`fit`'s body, from ``start`` (see :meth:`_set_up`)."""
        X, y = validate_data(
            self, X, y, multi_output=True, y_numeric=True, dtype=np.float64
        )
        y2, spec = self._set_up(X, y, start=start)
        if self.objective != "mse" and self.ljung_box_lags >= X.shape[0]:
            raise ValueError(
                f"ljung_box_lags={self.ljung_box_lags} must be smaller than the "
                f"number of samples, {X.shape[0]}."
            )

        theta_hat, result = self._least_squares(X, y2, spec)
        self.result_ = result
        self.params_ = spec.to_dict(theta_hat)
        self.params_std_, self.params_cov_ = self._standard_errors(
            X, y2, spec, theta_hat
        )
        return self

    def initialize(self, X, y):
        """Set the parameters to their initial values, without fitting them.

        A fit with zero iterations: the data's layout is checked as in
        :meth:`fit` and ``params_`` are the initial values (``params_std_`` and
        ``params_cov_`` are NaN, ``result_`` is None). The model then predicts,
        and :meth:`torch_forward` runs, from there; joint training in
        :class:`~skhybrid.hybrid.HybridEnsembleRegressor` with
        ``warm_start_domain=False`` starts this way.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next states (their shape sets ``n_outputs_``; some models derive
            initial values from them).

        Returns
        -------
        self : object
            The model at its initial parameters.
        """
        self._validate_params()
        X, y = validate_data(
            self, X, y, multi_output=True, y_numeric=True, dtype=np.float64
        )
        _, spec = self._set_up(X, y)
        return self._at_initial_params(spec)

    def _at_initial_params(self, spec):
        """Publish ``spec``'s initial values as an unfitted (zero-iteration) fit."""
        self.result_ = None
        self.params_ = spec.to_dict(spec.x0)
        self.params_std_ = spec.to_dict(np.full(spec.n_free, np.nan), fixed_value=0.0)
        self.params_cov_ = np.full((spec.n_free, spec.n_free), np.nan)
        return self

    def _set_up(self, X, y, start=None):
        """Layout check and parameter spec from validated ``X`` and ``y``.

        ``start`` (a dict of every parameter's value, for models that take
        one: a start chosen by earlier fits) replaces the initial values.
        """
        y2 = y if y.ndim == 2 else y[:, None]
        self._y_1d = y.ndim == 1
        self.n_outputs_ = y2.shape[1]
        self._check_layout(step_width(X.shape[1], self.n_steps), self.n_outputs_)
        if start is None:
            init = self._initial_params(X, y2)
        else:
            init = self._initial_params(X, y2, start=start)
        spec = _ParameterSpec(init, self.fixed, self.resolved_bounds(init))
        self._spec = spec
        return y2, spec

    def predict(self, X):
        """Predict with the fitted parameters.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Float64 predictions, 1-D when ``y`` was 1-D in ``fit``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        y_pred = self.predict_with(X, self.params_)
        return y_pred[:, 0] if self._y_1d else y_pred

    def predict_with(self, X, params):
        """Evaluate the equations with given parameters, in ``X``'s namespace.

        Parameters
        ----------
        X : ndarray or torch.Tensor of shape (n_samples, n_features)
            Already validated rows.
        params : dict
            Parameter name to value (floats, arrays or tensors).

        Returns
        -------
        y_pred : ndarray or torch.Tensor of shape (n_samples, n_outputs)
            The equations' next state, in ``X``'s namespace (differentiable in
            torch).
        """
        xp = get_namespace(X)
        y_pred = self._equations(X, params, xp)
        if y_pred.ndim == 1:
            y_pred = y_pred[:, None]
        if y_pred.shape[1] != self.n_outputs_:
            y_pred = xp.broadcast_to(y_pred, (y_pred.shape[0], self.n_outputs_))
        return y_pred

    @property
    def free_params_(self):
        """Names of the parameters that ``fit`` adjusted (not in ``fixed``)."""
        check_is_fitted(self)
        return list(self._spec.free)

    @property
    def free_bounds_(self):
        """Lower and upper bounds of the free-parameter vector.

        A pair of float arrays of the length of :meth:`pack_params`'s vector
        (``-inf`` / ``inf`` where a side is unbounded).
        """
        check_is_fitted(self)
        return self._spec.lower.copy(), self._spec.upper.copy()

    # -- the free-parameter vector and the torch forward ---------------------------
    def pack_params(self, params):
        """Pack the free parameters of a dict into one flat float64 vector.

        Parameters
        ----------
        params : dict
            Parameter name to value, as ``params_`` (fixed parameters, when
            present, are ignored).

        Returns
        -------
        theta : ndarray of shape (n_free_values,)
            The free parameters in the order of ``free_params_``, array-valued
            ones flattened (C order).
        """
        check_is_fitted(self)
        spec = self._spec
        missing = [k for k in spec.free if k not in params]
        if missing:
            raise ValueError(
                f"params is missing the free parameters {missing}; expected the "
                f"keys {spec.free}."
            )
        parts = []
        for name in spec.free:
            value = np.asarray(params[name], dtype=float)
            if value.shape != spec.shapes[name]:
                raise ValueError(
                    f"params[{name!r}] has shape {value.shape}; expected "
                    f"{spec.shapes[name]}."
                )
            parts.append(value.ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def unpack_params(self, theta):
        """Unpack a free-parameter vector into ``{name: value}``, fixed ones included.

        Parameters
        ----------
        theta : ndarray or torch.Tensor of shape (n_free_values,)
            Free parameters laid out as :meth:`pack_params` returns them.

        Returns
        -------
        params : dict
            Every parameter; fixed ones at their ``params_`` values. For a torch
            ``theta`` the values are tensors of its dtype and device (views of
            ``theta``, so gradients flow); otherwise floats and NumPy arrays.
        """
        check_is_fitted(self)
        spec = self._spec
        n = int(theta.shape[0]) if theta.ndim == 1 else -1
        if n != spec.n_free:
            raise ValueError(
                f"theta has shape {tuple(theta.shape)}; expected ({spec.n_free},), "
                f"the free parameters {spec.free} flattened."
            )
        if hasattr(theta, "detach"):
            return spec.to_dict(theta, xp=get_namespace(theta))
        return spec.to_dict(np.asarray(theta, dtype=float))

    def unpack_params_in(self, theta, xp):
        """:meth:`unpack_params` without its checks, the namespace given.

        For a rollout that checked the model once (see
        :meth:`~skhybrid.domain.StateSpaceModel.step_in`): no fitted check, no
        shape check and no namespace lookup, which break a
        :func:`torch.compile` graph.

        Parameters
        ----------
        theta : ndarray or torch.Tensor of shape (n_free_values,)
            Free parameters laid out as :meth:`pack_params` returns them.
        xp : module
            The array namespace of ``theta``.

        Returns
        -------
        params : dict
            Every parameter, as :meth:`unpack_params` returns them.
        """
        return self._spec.to_dict(theta, xp=xp)

    def torch_forward(self, X, theta):
        """The equations on torch tensors, differentiable in the free parameters.

        The public contract for training the physics inside a torch model (as
        :class:`~skhybrid.hybrid.HybridEnsembleRegressor` does): ``theta`` may be
        a tensor that requires gradients (an unconstrained parameter mapped into
        the bounds, for example), and the result is differentiable with respect
        to it. Fixed parameters are held at their ``params_`` values. The model
        must be fitted (or :meth:`initialize`-d) so that the parameters' names,
        shapes and ``n_outputs_`` are known.

        Parameters
        ----------
        X : torch.Tensor of shape (n_samples, n_features)
            Windows of time steps, unscaled, in the dtype and on the device of
            ``theta``.
        theta : torch.Tensor of shape (n_free_values,)
            Free parameters laid out as :meth:`pack_params` returns them.

        Returns
        -------
        y_pred : torch.Tensor of shape (n_samples, n_outputs)
            The equations' next state.

        Raises
        ------
        ValueError
            When the model's equations cannot run on torch.
        """
        check_is_fitted(self)
        self._check_autograd()
        return self.predict_with(X, self.unpack_params(theta))

    # -- fitting internals ---------------------------------------------------------
    def resolved_bounds(self, params=None):
        """The bounds a fit checks: the model's own defaults, updated by ``bounds``.

        Parameters
        ----------
        params : dict or None, default=None
            The parameters to bound (``self.params`` when None); a default bound
            of a parameter not among them is left out.

        Returns
        -------
        bounds : dict of str to tuple
            ``{name: (low, high)}``.
        """
        params = self.params if params is None else params
        bounds = {k: v for k, v in self._default_bounds().items() if k in params}
        bounds.update(self.bounds or {})
        return bounds

    def _residual_vector(self, X, y, spec, xp):
        """Function of the free-parameter vector giving the objective's residuals."""

        def residuals(theta):
            params = spec.to_dict(theta, xp=xp)
            y_pred = self.predict_with(X, params)
            return objective_residuals(
                y - y_pred,
                self.objective,
                lags=self.ljung_box_lags,
                ljung_box_weight=self.ljung_box_weight,
            )

        return residuals

    def _autograd_jacobian(self, X, y, spec, objective_fn=True):
        import torch

        Xt = torch.as_tensor(X, dtype=torch.float64)
        yt = torch.as_tensor(y, dtype=torch.float64)
        xp = get_namespace(Xt)
        if objective_fn:
            fun = self._residual_vector(Xt, yt, spec, xp)
        else:

            def fun(theta):
                params = spec.to_dict(theta, xp=xp)
                return xp.reshape(yt - self.predict_with(Xt, params), (-1,))

        def jac(theta):
            t = torch.as_tensor(np.asarray(theta, dtype=np.float64))
            # Forward mode: one pass per parameter, far fewer than residuals.
            with FORWARD_MODE:
                return torch.func.jacfwd(fun)(t).detach().numpy()

        return jac

    def _least_squares(self, X, y, spec):
        if spec.n_free == 0:
            return spec.x0, None
        warn_if_underdetermined(
            self, int(np.size(y)), spec.n_free, remedy="hold some with fixed"
        )
        xp = get_namespace(X)
        fun = self._residual_vector(X, y, spec, xp)
        jac = self.jac
        if jac == "autograd":
            self._check_autograd()
            jac = self._autograd_jacobian(X, y, spec)
        else:
            batched = self._batched_jacobian(spec)
            jac = jac if batched is None else batched
        # least_squares stops when the gradient J^T f falls below an absolute
        # gtol, and steps its finite differences by absolute amounts: both depend
        # on the units of the data and of the parameters. It therefore works on
        # dimensionless residuals (divided by their size at the start) and
        # parameters (divided by their starting values), so a fit gives the same
        # answer whatever the units.
        f0 = np.asarray(fun(spec.x0), dtype=float)
        r_scale = self._residual_scale(f0, y)
        p_scale = spec.scale

        def scaled_fun(z):
            return np.asarray(fun(z * p_scale), dtype=float) / r_scale

        # Records as a list, or stacked (records, times, inputs) by a fit on
        # whole records; a 2-D X holds the rows of one.
        several = isinstance(X, (list, tuple)) or np.ndim(X) == 3
        n_records = len(X) if several else 1
        # scipy's max_nfev counts no evaluation made for a finite-difference
        # Jacobian; each of its evaluations is followed by at most one such
        # Jacobian of n_free evaluations: the progress shows that bound.
        limit = self.max_nfev
        if limit is not None and not callable(jac):
            limit = limit * (1 + spec.n_free)
        scaled_fun = counting(scaled_fun, limit, n_records)

        scaled_jac = jac
        if callable(jac):

            def scaled_jac(z):
                return jac(z * p_scale) * (p_scale / r_scale)

        kwargs = {}
        if self.max_nfev is not None:
            kwargs["max_nfev"] = self.max_nfev
        z0, z_lower, z_upper = (
            spec.x0 / p_scale,
            spec.lower / p_scale,
            spec.upper / p_scale,
        )
        # A trial step can make a simulation grow large but finite; least_squares
        # then meets an infinite cost, rejects the step and shrinks its region,
        # so numpy's overflow warning on the way is no news to a user.
        with np.errstate(over="ignore"):
            result = least_squares(
                scaled_fun,
                z0,
                jac=scaled_jac,
                bounds=(z_lower, z_upper),
                loss=self.loss,
                f_scale=self.f_scale / r_scale,
                x_scale="jac",
                **kwargs,
            )
        moved = bool(np.any(result.x != z0))
        stationary = _stationary_at(result, z0, z_lower, z_upper)
        # Back to the units of the data and the parameters.
        result.x = result.x * p_scale
        result.fun = result.fun * r_scale
        result.cost = result.cost * r_scale**2
        result.jac = result.jac * (r_scale / p_scale)
        result.grad = result.grad * (r_scale**2 / p_scale)
        name = type(self).__name__
        if result.status == 0:
            warnings.warn(
                f"{name}: least_squares stopped after "
                f"max_nfev={result.nfev} evaluations without converging; increase "
                "max_nfev, start closer to the solution, or rescale X.",
                ConvergenceWarning,
                stacklevel=3,
            )
        elif not result.success:
            warnings.warn(
                f"{name}: least_squares failed: {result.message}",
                ConvergenceWarning,
                stacklevel=3,
            )
        elif not moved and not stationary:
            params = spec.to_dict(result.x)
            warnings.warn(
                f"{name}: least_squares stopped at the starting values "
                f"{params} after {result.nfev} evaluation(s) ({result.message}) "
                "although they are not a stationary point of the objective: the "
                "fit did not move. Check that the parameters change the "
                "predictions, and start closer to the solution.",
                ConvergenceWarning,
                stacklevel=3,
            )
        return result.x, result

    def _residual_scale(self, f0, y):
        """Size of the objective's residual vector ``f0`` at the starting values.

        Not the target's spread: a one-step model of a slow state (a position
        sampled at 1 kHz) leaves residuals a millionth of the target's size, and
        the optimiser must see them at order 1. Falls back to the target's spread
        where the start fits perfectly.
        """
        candidates = [np.linalg.norm(f0)]
        if self.objective != "ljung_box":  # autocorrelations have no units
            candidates.append(np.sqrt(np.mean(np.var(y, axis=0))))
        for scale in candidates:
            if np.isfinite(scale) and scale > 0:
                return float(scale)
        return 1.0
        for scale in (np.sqrt(np.mean(np.var(y, axis=0))), np.sqrt(np.mean(y**2))):
            if np.isfinite(scale) and scale > 0:
                return float(scale)
        return 1.0

    def _check_autograd(self):
        """Hook: models whose equations cannot run on torch raise here."""

    def _raw_jacobian(self, X, y, spec, theta):
        """Plain residuals ``y - f(X; theta)`` (flattened) and their Jacobian."""
        xp = get_namespace(X)

        def raw(t):
            return np.reshape(y - self.predict_with(X, spec.to_dict(t, xp=xp)), -1)

        base = raw(theta)
        if self.jac == "autograd":
            return self._autograd_jacobian(X, y, spec, objective_fn=False)(theta), base
        return _central_differences(raw, theta, spec, base.size), base

    def _batched_jacobian(self, spec):
        """A callable Jacobian that evaluates all its steps in one batch, or None."""
        return

    def _standard_errors(self, X, y, spec, theta):
        """Standard errors from the Gauss-Newton covariance ``s^2 (J^T J)^-1``.

        ``J`` is the Jacobian of the plain residuals at the optimum and ``s^2`` the
        residual variance with ``n_residuals - n_free`` degrees of freedom, whatever
        the objective: the errors describe the parameters' sensitivity to the data.
        """
        if spec.n_free == 0:
            cov = np.zeros((0, 0))
        else:
            J, r = self._raw_jacobian(X, y, spec, theta)
            warn_if_unidentifiable(
                self, J, spec, theta, getattr(self, "identifiability_tol", 1e-6)
            )
            dof = r.size - spec.n_free
            if dof > 0:
                cov = np.linalg.pinv(J.T @ J) * (float(r @ r) / dof)
            else:  # as many parameters as residuals: no estimate of the noise
                cov = np.full((spec.n_free, spec.n_free), np.inf)
        std_free = np.sqrt(np.clip(np.diag(cov), 0, None))
        return spec.to_dict(std_free, fixed_value=0.0), cov


def _central_differences(raw, theta, spec, n_residuals):
    """Jacobian of ``raw`` at ``theta`` by central differences inside the bounds.

    Steps on each parameter's own scale, not on 1 (which is huge for a parameter
    of order 1e-7); near zero, on a fraction of its start's.
    """
    size = np.maximum(np.abs(theta), 1e-3 * spec.scale)
    step = np.finfo(float).eps ** (1 / 3) * size
    J = np.zeros((n_residuals, theta.size))
    for j in range(theta.size):
        up, down = theta.copy(), theta.copy()
        hi = min(step[j], spec.upper[j] - theta[j])
        lo = min(step[j], theta[j] - spec.lower[j])
        if hi + lo > 0:
            up[j] += hi
            down[j] -= lo
            J[:, j] = (raw(up) - raw(down)) / (hi + lo)
    return J


class _ParameterSpec:
    """Named (possibly array-valued) parameters packed into one free vector."""

    def __init__(self, init, fixed, bounds):
        fixed = tuple(fixed)
        names = list(init)
        check_known_names(
            fixed,
            names,
            "fixed names {unknown} that are not parameters; expected a subset "
            "of {known}.",
        )
        check_known_names(
            bounds,
            names,
            "bounds has keys {unknown} that are not parameters; expected a "
            "subset of {known}.",
        )
        self.names = names
        self.init = {k: np.asarray(v, dtype=float) for k, v in init.items()}
        self.shapes = {k: v.shape for k, v in self.init.items()}
        self.fixed = fixed
        self.free = [k for k in names if k not in fixed]
        lower, upper = [], []
        for name in self.free:
            lo, hi = self._bound(bounds, name)
            value = self.init[name]
            if np.any(value < lo) or np.any(value > hi):
                raise ValueError(
                    f"initial value of parameter {name!r} is {_fmt(value)}, outside "
                    f"its bounds ({lo}, {hi}); change the initial value or bounds."
                )
            size = value.size
            lower.append(np.full(size, lo, dtype=float))
            upper.append(np.full(size, hi, dtype=float))
        self.lower = np.concatenate(lower) if lower else np.zeros(0)
        self.upper = np.concatenate(upper) if upper else np.zeros(0)
        self.x0 = (
            np.concatenate([self.init[k].ravel() for k in self.free])
            if self.free
            else np.zeros(0)
        )
        # Start strictly inside the bounds: least_squares requires it.
        span = self.upper - self.lower
        inside = np.isfinite(span) & (span > 0)
        eps = 1e-10 * np.where(inside, span, 1.0)
        self.x0 = np.clip(self.x0, self.lower + eps, self.upper - eps)
        self.n_free = self.x0.size
        # Typical size of each free parameter: its starting value (1 at zero).
        self.scale = np.where(self.x0 != 0, np.abs(self.x0), 1.0)

    @staticmethod
    def _bound(bounds, name):
        if name not in bounds:
            return -np.inf, np.inf
        pair = bounds[name]
        try:
            lo, hi = (float(v) for v in pair)
        except (TypeError, ValueError):
            raise ValueError(
                f"bounds[{name!r}] must be a pair (lower, upper); got {pair!r}."
            ) from None
        if not lo < hi:
            raise ValueError(
                f"bounds[{name!r}] = {pair!r} has lower >= upper; expected "
                "lower < upper."
            )
        return lo, hi

    def to_dict(self, theta, xp=None, fixed_value=None):
        """Unpack a free vector into ``{name: value}``, fixed values included.

        With ``xp`` (the namespace of ``theta`` or of the data), values are arrays of
        that namespace; without it, floats (scalars) and NumPy arrays.
        """
        out, start = {}, 0
        torch_theta = hasattr(theta, "detach")
        for name in self.names:
            shape = self.shapes[name]
            if name in self.fixed:
                value = (
                    self.init[name]
                    if fixed_value is None
                    else np.full(shape, fixed_value)
                )
                if torch_theta:
                    import torch

                    value = torch.as_tensor(
                        value, dtype=theta.dtype, device=theta.device
                    )
                out[name] = value if (xp is not None or shape) else float(value)
                continue
            size = int(np.prod(shape)) if shape else 1
            chunk = theta[start : start + size]
            start += size
            if shape:
                out[name] = chunk.reshape(shape)
            elif xp is not None or torch_theta:
                out[name] = chunk[0]
            else:
                out[name] = float(chunk[0])
        return out


def _stationary_at(result, z0, lower, upper, tol=1e-6):
    """Whether ``least_squares`` judged a start ``z0`` it never left optimal.

    A start is stationary when no free parameter's Jacobian column (a parameter
    that changes the residuals) correlates with the residuals beyond ``tol``, in a
    measure free of the units of both (the cosine of their angle); parameters held
    at a bound by the gradient are not counted.
    """
    J = np.asarray(result.jac, dtype=float)
    f = np.asarray(result.fun, dtype=float)
    f_norm = np.linalg.norm(f)
    if f_norm == 0:
        return True  # a perfect fit
    col_norm = np.linalg.norm(J, axis=0)
    if np.any(col_norm == 0):
        return False  # a parameter that does not change the residuals
    cos = (J.T @ f) / (col_norm * f_norm)
    # Descent moves along -cos: blocked where that leaves the bounds.
    span = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    at_lower = (z0 - lower) <= 1e-8 * span
    at_upper = (upper - z0) <= 1e-8 * span
    blocked = (at_lower & (cos > 0)) | (at_upper & (cos < 0))
    return bool(np.all(np.abs(cos[~blocked]) < tol))


def _fmt(value):
    return repr(float(value)) if np.ndim(value) == 0 else np.array2string(value)
