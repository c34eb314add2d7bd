"""ParametricModel: a user's function ``func(X, **params)`` as a domain model."""

import inspect

import numpy as np

from skhybrid.domain._base import DomainModel
from skhybrid.preprocessing import infer_n_steps, step_width
from skhybrid.utils._array_api import takes_xp

__all__ = ["ParametricModel"]


class ParametricModel(DomainModel):
    """A user's function ``func(X, **params)`` fitted by least squares.

    The grey-box path: write the physics you know as a function of the rows and
    named parameters, give initial values, and fit. The function receives the whole
    row (every step of the window), so it can use older steps, for example a
    second-order difference equation.

    Write ``func`` with an ``xp`` keyword argument and array-API calls (``xp.sin``,
    ``xp.exp``) to make it run on torch too: that enables ``jac="autograd"`` and
    joint training in :class:`~skhybrid.hybrid.HybridEnsembleRegressor`. A function
    without ``xp`` runs on NumPy only. Define ``func`` at module level so that the
    model pickles.

    Parameters
    ----------
    func : callable
        ``func(X, **params)`` or ``func(X, *, xp, **params)`` returning predictions of
        shape ``(n_samples,)`` or ``(n_samples, n_outputs)``, or of a shape that
        broadcasts to ``y``'s (``(n_samples, 1)`` is shared by every output).
    params : dict of str to float or array-like
        Initial value of each parameter, by the name ``func`` takes it under.
    fixed : tuple of str, default=()
        Parameters held at their initial values.
    bounds : dict of str to (float, float) or None, default=None
        Bounds of named parameters.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        Least-squares objective (see :class:`DomainModel`).
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    jac : {"2-point", "3-point", "autograd"}, default="2-point"
        Jacobian of the residuals; ``"autograd"`` needs ``func`` to take ``xp``.
    loss : str, default="linear"
        Robust loss of ``least_squares``.
    f_scale : float, default=1.0
        Soft margin of robust losses.
    max_nfev : int or None, default=None
        Most residual evaluations.
    n_steps : int, default=1
        Time steps per row (``func`` sees them all). ``fit`` checks it against
        the rows: rows in time order that continue each other as windows of
        another length (see :func:`~skhybrid.preprocessing.infer_n_steps`) raise
        a ValueError saying which value to set.

    Attributes
    ----------
    params_ : dict
        Fitted value of each parameter.
    params_std_ : dict
        Standard errors (0 for fixed parameters).
    params_cov_ : ndarray of shape (n_free, n_free)
        Covariance of the free parameters, in the order of ``free_params_``.
    result_ : OptimizeResult or None
        What ``least_squares`` returned.
    n_features_in_ : int
        Number of columns of ``X``.
    n_outputs_ : int
        Number of outputs.

    See Also
    --------
    PendulumModel : A built-in physics model.

    Notes
    -----
    **When a one-step fit is biased.** ``fit`` minimises the one-step (equation)
    error: each row's prediction against the next measured output. Where the rows'
    inputs hold *noisy measured outputs* (a window of past positions from which
    ``func`` reads a velocity, say), the regressors are noisy too and the least
    squares are biased (errors-in-variables): a damping fitted several standard
    errors from the truth, with no warning, since ``params_std_`` assumes
    noise-free inputs; more data shrinks the standard errors, not the bias. Fit
    such physics by its simulation (free-run) error instead: write it as a
    :class:`~skhybrid.domain.StateSpaceModel` with the unmeasured states latent and
    use :meth:`~skhybrid.domain.StateSpaceModel.fit_simulation` (multiple shooting:
    on segments of long records), or describe the system as a
    :class:`~skhybrid.experiments.SystemSpec` and let
    :func:`~skhybrid.experiments.run_system` fit it so and choose on validation
    tails.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import ParametricModel
    >>> def decay(X, *, rate, xp=np):
    ...     return X[:, 0] * xp.exp(-rate * 0.1)
    >>> X = np.linspace(1, 2, 50)[:, None]
    >>> y = X[:, 0] * np.exp(-0.3)
    >>> model = ParametricModel(decay, {"rate": 1.0}).fit(X, y)
    >>> round(model.params_["rate"], 6)
    3.0
    """

    _parameter_constraints = {
        **DomainModel._parameter_constraints,
        "func": [callable],
        "params": [dict],
    }

    def __init__(
        self,
        func,
        params,
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
        self.func = func
        self.params = params

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # A user's function is a fixed functional form (the physics): it cannot fit
        # arbitrary random data the way a flexible regressor does.
        tags.regressor_tags.poor_score = True
        return tags

    def _set_up(self, X, y, start=None):
        # func reads whatever columns it likes, so a row of any width fits; the
        # window length shows only at simulate, where the wrong n_steps fails
        # late and points the wrong way. The rows tell it at fit: rows in time
        # order continue each other only under their true window length.
        inferred = infer_n_steps(X, y)
        if inferred is not None and inferred != self.n_steps:
            width = step_width(X.shape[1], inferred)
            raise ValueError(
                f"ParametricModel has n_steps={self.n_steps}, but the rows of X "
                f"({X.shape[1]} columns) are windows of {inferred} time steps of "
                f"{width} columns: each row continues the one before it shifted "
                f"by one step. Set n_steps={inferred} (func still receives the "
                f"whole row)."
            )
        return super()._set_up(X, y, start=start)

    def _takes_xp(self):
        return takes_xp(self.func, default=False)

    def _initial_params(self, X, y):
        if not self.params:
            raise ValueError(
                "params must name at least one parameter with its initial value; "
                f"got params={self.params!r}."
            )
        try:
            signature = inspect.signature(self.func)
        except (TypeError, ValueError):
            signature = None
        if signature is not None and not any(
            p.kind is inspect.Parameter.VAR_KEYWORD
            for p in signature.parameters.values()
        ):
            unknown = sorted(set(self.params) - set(signature.parameters))
            if unknown:
                name = getattr(self.func, "__name__", repr(self.func))
                raise ValueError(
                    f"params has keys {unknown} that {name}{signature} does not "
                    "take; rename them or add them to the function."
                )
        out = {}
        for name, value in self.params.items():
            array = np.asarray(value, dtype=float)
            if not np.all(np.isfinite(array)):
                raise ValueError(
                    f"initial value of parameter {name!r} must be finite; got "
                    f"{value!r}."
                )
            out[name] = array if array.ndim else float(array)
        return out

    def _check_autograd(self):
        if not self._takes_xp():
            name = getattr(self.func, "__name__", repr(self.func))
            raise ValueError(
                "torch evaluation (jac='autograd', torch_forward, joint training) "
                f"needs func to take an 'xp' keyword argument and "
                f"use it for array operations; {name} does not take xp."
            )

    def _equations(self, X, params, xp):
        if self._takes_xp():
            y_pred = self.func(X, xp=xp, **params)
        else:
            y_pred = self.func(X, **params)
        self._check_returned_shape(X, y_pred)
        return y_pred

    def _check_returned_shape(self, X, y_pred):
        """Raise a ValueError naming ``func`` when it returns the wrong shape."""
        n = X.shape[0]
        shape = getattr(y_pred, "shape", None)
        shape = None if shape is None else tuple(int(d) for d in shape)
        # Before fit has seen y, any number of outputs will do.
        n_outputs = getattr(self, "n_outputs_", None)
        if n_outputs is None:
            n_outputs = shape[1] if shape is not None and len(shape) == 2 else 1
        if n_outputs == 1:
            expected = f"({n},) or ({n}, 1)"
            ok = shape in ((n,), (n, 1))
        else:
            expected = (
                f"({n}, {n_outputs}), or ({n}, 1) to share one prediction across "
                "outputs"
            )
            ok = shape in ((n, n_outputs), (n, 1))
        if not ok:
            name = getattr(self.func, "__name__", repr(self.func))
            got = (
                f"a {type(y_pred).__name__} without a shape"
                if shape is None
                else f"shape {shape}"
            )
            raise ValueError(
                f"func {name} returned {got}, but y has {n_outputs} "
                f"output{'s' if n_outputs > 1 else ''} and {n} samples; expected "
                f"shape {expected}."
            )
