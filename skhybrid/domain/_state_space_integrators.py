"""The integrators of StateSpaceModel: its equations advanced one sample period.

``rhs`` bound to the parameters and the array namespace, the fixed-step Euler
and Runge-Kutta schemes (inputs held or read between samples with
``input_points``), :func:`scipy.integrate.solve_ivp`, and the free run over
records. A mixin of :class:`~skhybrid.domain.StateSpaceModel`, which holds the
settings they read (``time``, ``dt``, ``method``, ``n_substeps``, ...).
"""

import numpy as np
from scipy.integrate import solve_ivp
from sklearn.utils.validation import check_is_fitted

from skhybrid.utils._array_api import get_namespace, is_torch, takes_xp


class _IntegratorMixin:
    """Equations, integrators and the free run of a StateSpaceModel."""

    # -- the physics ---------------------------------------------------------------
    @staticmethod
    def _takes_xp(func):
        return takes_xp(func, default=True)

    def _rhs_fn(self, params, xp):
        """``f(x, u)``: the user's ``rhs`` bound to ``params`` and ``xp``, checked."""
        rhs = self.rhs
        kwargs = dict(params, xp=xp) if self._takes_xp(rhs) else dict(params)
        # The shape is checked at the first call: a free run calls f once per
        # step (or stage) on states of one shape, and the check would cost a
        # tenth of a cheap model's step.
        checked = []

        def f(x, u):
            out = rhs(x, u, **kwargs)
            if checked and checked[0] == x.shape:
                return out
            shape = tuple(int(d) for d in getattr(out, "shape", ()))
            if shape != tuple(x.shape):
                name = getattr(rhs, "__name__", repr(rhs))
                raise ValueError(
                    f"rhs {name} returned shape {shape} for a state of shape "
                    f"{tuple(x.shape)}; it must return one value per state and "
                    "sample, for example xp.stack([...], axis=1)."
                )
            checked[:] = [x.shape]
            return out

        return f

    def observe_in(self, x, params, xp, observed):
        """:meth:`observe` without its checks, the namespace and structure given.

        For a rollout that resolved them once (see :meth:`step_in`).

        Parameters
        ----------
        x : ndarray or torch.Tensor of shape (n, n_states)
            States.
        params : dict
            Parameter values by name (used by an ``output`` function).
        xp : module
            The array namespace of ``x``.
        observed : list of int or None
            The measured states' indices (:meth:`observed_indices`), or None
            where ``output`` gives the outputs.

        Returns
        -------
        y : ndarray or torch.Tensor of shape (n, n_outputs)
            Outputs of the states.
        """
        return self._output_fn(params, observed, xp)(x)

    def _output_fn(self, params, observed, xp):
        """``h(x)``: the observed states or the user's ``output``."""
        if observed is not None:
            return lambda x: x[:, observed]
        output = self.output
        kwargs = dict(params, xp=xp) if self._takes_xp(output) else dict(params)

        def h(x):
            out = output(x, **kwargs)
            return out[:, None] if out.ndim == 1 else out

        return h

    def _step(self, x, u, f):
        """State one sample period after ``x`` under the inputs ``u``.

        ``u`` is held over the period, or, with ``input_points > 1``, read at
        each stage's time (:meth:`_input_at`).
        """
        if self.time == "discrete":
            return f(x, u)
        dt = float(self.dt)
        at = self._input_at(u)
        if self.method == "solve_ivp":
            return self._step_ivp(x, at, f, dt)
        n = self.n_substeps
        h = dt / n
        for s in range(n):
            k1 = f(x, at(s / n))
            if self.method == "euler":
                x = x + h * k1
                continue
            middle = at((s + 0.5) / n)
            k2 = f(x + 0.5 * h * k1, middle)
            k3 = f(x + 0.5 * h * k2, middle)
            k4 = f(x + h * k3, at((s + 1) / n))
            x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return x

    def _input_at(self, u):
        """``at(tau)``: the inputs at the fraction ``tau`` of the sample period.

        With ``input_points=1`` the held ``u`` itself; otherwise each input's
        points (columns ``j * k + i``, :func:`band_limited_inputs`' layout)
        interpolated linearly at ``tau``.
        """
        k = int(self.input_points)
        if k == 1:
            return lambda tau: u
        width = u.shape[1]
        if width % k:
            raise ValueError(
                f"input_points={k} needs inputs of a multiple of {k} columns (each "
                f"input at {k} times a sample, as band_limited_inputs(u, "
                f"n_points={k}) makes them); got {width} column(s)."
            )

        def at(tau):
            position = tau * (k - 1)
            i = min(int(position), k - 2)
            w = position - i
            if w == 0.0:
                return u[:, i::k]
            return (1.0 - w) * u[:, i::k] + w * u[:, i + 1 :: k]

        return at

    def _step_ivp(self, x, at, f, dt):
        x = np.asarray(x, dtype=float)
        if not np.all(np.isfinite(x)):
            return np.full_like(x, np.nan)
        shape = x.shape
        options = {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12}
        options.update(self.solver_options or {})

        def fun(t, z):
            return np.asarray(f(z.reshape(shape), at(t / dt)), dtype=float).ravel()

        sol = solve_ivp(fun, (0.0, dt), x.ravel(), **options)
        if not sol.success:
            return np.full_like(x, np.nan)
        return sol.y[:, -1].reshape(shape)

    def _run(self, x0, U, params, observed, xp, n_times=None):
        """Outputs ``(n, n_times, n_outputs)`` from states ``x0`` under ``U``.

        ``U`` is ``(n, T, n_inputs)``; the output at time ``t`` is read before the
        input ``U[:, t]`` acts. Also returns the final state (after ``n_times``
        samples, ``n_times <= T + 1``). NumPy runs use ``numpy`` itself as ``xp``.
        """
        if not is_torch(xp):
            xp = np
        f = self._rhs_fn(params, xp)
        h = self._output_fn(params, observed, xp)
        n_times = U.shape[1] if n_times is None else n_times
        if xp is np and n_times:
            # Written into one array as they come: a list stacked at the end
            # would hold every output twice.
            x, first = x0, np.asarray(h(x0))
            out = np.empty((first.shape[0], n_times, *first.shape[1:]), first.dtype)
            out[:, 0] = first
            for t in range(n_times):
                if t:
                    out[:, t] = h(x)
                if t < U.shape[1]:
                    x = self._step(x, U[:, t], f)
            return out, x
        x, outs = x0, []
        for t in range(n_times):
            outs.append(h(x))
            if t < U.shape[1]:
                x = self._step(x, U[:, t], f)
        return xp.stack(outs, axis=1), x

    def step(self, x, u, params=None, *, correction=None):
        """Advance states by one sample period, in NumPy or torch.

        Applies the discretised state equations (``time="discrete"``: ``rhs``
        itself; ``"continuous"``: ``n_substeps`` Euler or RK4 steps over ``dt``
        with ``u`` held) in the namespace of ``x``, so that with torch tensors
        (the states and the parameter values) gradients reach both; the
        state-space hybrid trains through it.

        Parameters
        ----------
        x : ndarray or torch.Tensor of shape (n, n_states)
            States at the current sample.
        u : ndarray or torch.Tensor of shape (n, n_inputs)
            Inputs held over the sample period.
        params : dict or None, default=None
            Parameter values (floats, arrays or 0-d tensors) by name; ``None``
            uses the fitted ``params_``.
        correction : callable or None, default=None
            ``correction(x, u) -> (n, n_states)``, a term added to the state
            equations: to ``dx/dt`` with ``time="continuous"`` (evaluated at
            every stage of the integrator, so it is integrated with the
            physics), to the next state with ``time="discrete"``. The seam a
            hybrid uses to put a learned force inside the physics
            (:class:`~skhybrid.hybrid.StateSpaceHybridRegressor` with
            ``correction_form="rhs"``).

        Returns
        -------
        x_next : ndarray or torch.Tensor of shape (n, n_states)
            States one sample period later.
        """
        xp = get_namespace(x)
        if is_torch(xp) and self.time == "continuous" and self.method == "solve_ivp":
            raise ValueError(
                "step on torch tensors needs method='rk4' or 'euler'; got "
                f"method={self.method!r}."
            )
        if not is_torch(xp):
            xp = np
        if params is None:
            check_is_fitted(self)
            params = self.params_
        return self.step_in(x, u, params, xp, correction)

    def step_in(self, x, u, params, xp, correction=None):
        """:meth:`step` without its checks, the namespace and parameters given.

        The hot path of a rollout (one call per sample), such as the
        state-space hybrid's: no fitted check and no namespace lookup, both of
        which break a :func:`torch.compile` graph; the caller resolves them
        once, outside its compiled forward pass.

        Parameters
        ----------
        x, u : ndarray or torch.Tensor
            States and inputs, as in :meth:`step`.
        params : dict
            Parameter values by name (for example from :meth:`unpack_params_in`).
        xp : module
            The array namespace of ``x`` (NumPy, or the torch namespace).
        correction : callable or None, default=None
            As in :meth:`step`.

        Returns
        -------
        x_next : ndarray or torch.Tensor of shape (n, n_states)
            States one sample period later.
        """
        f = self._rhs_fn(params, xp)
        if correction is not None:
            rhs = f
            # The correction reads the sample's inputs as given (every point of
            # them with input_points > 1), as the network was sized for them.
            points = self.input_points > 1

            def f(z, v):
                return rhs(z, v) + correction(z, u if points else v)

        return self._step(x, u, f)
