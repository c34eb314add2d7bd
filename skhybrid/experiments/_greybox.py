"""Grey-box state-space physics of the measured benchmarks, fitted by simulation error.

Each physics model is a discrete-time state map ``x(t+1) = step(x(t), u(t); p)`` and
an output ``y(t) = output(x(t); p)``; unmeasured states (the EMPS velocity, the
upper tank's level, the Silverbox's derivative) are latent. :class:`OutputErrorModel`
fits the parameters and the initial state on a whole estimation record by least
squares on the free-run (simulation) error, with a forward-difference Jacobian
whose perturbed trajectories are simulated in one batch, and estimates the initial
state of a new experiment from its initialisation window.
"""

import numpy as np
from scipy.optimize import least_squares

from skhybrid.exceptions import SimulationDivergedError

__all__ = [
    "OutputErrorModel",
    "duffing_step",
    "emps_step",
    "tanks_step",
]


def tanks_step(x, u, p, *, dt=4.0, n_sub=4):
    """Two tanks with Torricelli outflow and the upper tank's overflow.

    ``x1' = -k1 sqrt(x1) - k5 x1 + k4 u`` (upper tank, overflowing at ``x1max``;
    a share ``kof`` of the overflow reaches the lower tank) and
    ``x2' = k2 sqrt(x1) + k5 x1 - k3 sqrt(x2) - k6 x2`` (lower tank), Euler with
    ``n_sub`` sub-steps per sample. ``x`` (batch, 2), ``p`` (batch, 9).
    """
    k1, k2, k3, k4, x1max, kof, k5, k6 = (p[:, i] for i in range(8))
    h = dt / n_sub
    x1, x2 = x[:, 0], x[:, 1]
    for _ in range(n_sub):
        s1 = np.sqrt(np.maximum(x1, 0.0))
        s2 = np.sqrt(np.maximum(x2, 0.0))
        x1_next = x1 + h * (-k1 * s1 - k5 * x1 + k4 * u)
        overflow = np.maximum(x1_next - x1max, 0.0)
        x2 = x2 + h * (k2 * s1 + k5 * x1 - k3 * s2 - k6 * x2) + kof * overflow
        x1 = x1_next - overflow
    return np.stack([x1, x2], axis=1)


def tanks_output(x, p):
    """Lower-tank sensor: level plus offset ``p[:, 8]``, clipping at 10 V."""
    return np.minimum(x[:, 1] + p[:, 8], 10.0)


def emps_step(x, u, p, *, dt=1e-3, gtau=35.15, eps=1e-4):
    """Rigid axis ``M q'' = gtau u - Fv q' - Fc sign(q') - offset`` (semi-implicit Euler).

    ``p`` columns: ``M`` (kg), ``Fv`` (N s/m), ``Fc`` (N), ``offset`` (N), and
    optionally ``Fv_neg``, ``Fc_neg`` (friction for negative velocities, the
    first two then hold for positive ones); the sign is smoothed as
    ``tanh(q'/eps)``.
    """
    M, Fv, Fc, offset = (p[:, i] for i in range(4))
    q, v = x[:, 0], x[:, 1]
    friction = Fv * v + Fc * np.tanh(v / eps)
    if p.shape[1] > 4:  # asymmetric friction: Fv-, Fc- for negative velocities
        w = 0.5 * (1.0 + np.tanh(v / eps))
        friction = w * friction + (1 - w) * (p[:, 4] * v + p[:, 5] * np.tanh(v / eps))
    acc = (gtau * u - friction - offset) / M
    v = v + dt * acc
    return np.stack([q + dt * v, v], axis=1)


def emps_output(x, p):
    """The measured position ``q`` (m)."""
    return x[:, 0]


def _duffing_rhs(x, u, p):
    k, d, a, b = (p[:, i] for i in range(4))
    y, v = x[:, 0], x[:, 1]
    return np.stack([v, k * u - d * v - a * y - b * y**3], axis=1)


def duffing_step(x, u, p, *, dt=2**14 / 1e7):
    """Duffing oscillator ``y'' = k u - d y' - a y - b y^3`` (RK4, input held).

    ``p`` columns: ``k`` (input gain per unit mass), ``d``, ``a``, ``b`` (damping,
    stiffness and cubic stiffness per unit mass), ``y0`` (output offset).
    """
    k1 = _duffing_rhs(x, u, p)
    k2 = _duffing_rhs(x + 0.5 * dt * k1, u, p)
    k3 = _duffing_rhs(x + 0.5 * dt * k2, u, p)
    k4 = _duffing_rhs(x + dt * k3, u, p)
    return x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def duffing_output(x, p):
    """The output voltage: ``y`` plus offset ``p[:, 4]``."""
    return x[:, 0] + p[:, 4]


def simulate_batch(step, output, P, x0, u):
    """Outputs ``(batch, n_times)`` of ``batch`` parameter sets and initial states."""
    P = np.atleast_2d(np.asarray(P, dtype=float))
    x = np.atleast_2d(np.asarray(x0, dtype=float)).copy()
    u = np.asarray(u, dtype=float).reshape(len(u), -1)[:, 0]
    Y = np.empty((len(x), len(u)))
    with np.errstate(all="ignore"):
        for t in range(len(u)):
            Y[:, t] = output(x, P)
            x = step(x, u[t], P)
    return Y


class OutputErrorModel:
    """A state-space physics model fitted by its free-run (output) error.

    Parameters
    ----------
    step, output : callable
        ``step(x, u, p)`` and ``output(x, p)`` on batches (see :func:`tanks_step`).
    params : dict of str to float
        Initial parameter values, in ``step``'s column order.
    bounds : dict of str to (float, float)
        Bounds of the parameters (others are unbounded).
    x0 : sequence of float
        Initial guess of the state at the start of a record.
    state_names : sequence of str
        Names of the states (the first is not necessarily measured).
    x0_from_y : callable or None
        ``x0_from_y(y_init)`` a guess of the initial state from measured outputs;
        None uses ``x0``.
    max_nfev : int
        Most residual evaluations of the parameter fit.

    Attributes
    ----------
    params_ : dict of str to float
        Fitted parameters.
    params_std_ : dict of str to float
        Standard errors from the Gauss-Newton covariance of the simulation error.
    x0_ : ndarray
        Estimated initial state of the estimation record.
    rmse_ : float
        Free-run RMSE on the estimation record.
    """

    def __init__(
        self, step, output, params, *, bounds=None, x0, state_names, x0_from_y=None,
        max_nfev=100,
    ):
        self.step = step
        self.output = output
        self.params = dict(params)
        self.bounds = dict(bounds or {})
        self.x0 = np.asarray(x0, dtype=float)
        self.state_names = list(state_names)
        self.x0_from_y = x0_from_y
        self.max_nfev = max_nfev

    def _p(self, params=None):
        params = self.params_ if params is None else params
        return np.array([params[k] for k in self.params], dtype=float)

    def fit(self, u, y):
        """Fit parameters and initial state on one record ``u``, ``y`` (n_times, 1)."""
        y = np.asarray(y, dtype=float).ravel()
        names = list(self.params)
        n_p = len(names)
        x0 = self.x0 if self.x0_from_y is None else self.x0_from_y(y[:20])
        z0 = np.r_[self._p(self.params), x0]
        scale = np.abs(z0) + 1e-3
        lo = np.r_[[self.bounds.get(k, (-np.inf, np.inf))[0] for k in names],
                   -np.inf * np.ones(len(x0))] / scale
        hi = np.r_[[self.bounds.get(k, (-np.inf, np.inf))[1] for k in names],
                   np.inf * np.ones(len(x0))] / scale

        def residuals(Z):
            theta = Z * scale
            Y = simulate_batch(self.step, self.output, theta[:, :n_p], theta[:, n_p:], u)
            R = Y - y
            return np.where(np.isfinite(R), R, 1e3)

        def fun(z):
            return residuals(z[None])[0]

        def jac(z):
            e = 1e-6 * np.maximum(1.0, np.abs(z))
            Z = np.vstack([z, z + np.diag(e)])
            R = residuals(Z)
            return ((R[1:] - R[0]) / e[:, None]).T

        start = np.clip(z0 / scale, lo + 1e-12, hi - 1e-12)
        result = least_squares(
            fun, start, jac=jac, bounds=(lo, hi), max_nfev=self.max_nfev
        )
        theta = result.x * scale
        self.params_ = dict(zip(names, theta[:n_p].tolist(), strict=True))
        self.x0_ = theta[n_p:]
        self.rmse_ = float(np.sqrt(np.mean(result.fun**2)))
        J = result.jac * (1.0 / scale)  # derivatives w.r.t. theta
        dof = max(len(y) - len(theta), 1)
        sigma2 = 2 * result.cost / dof
        with np.errstate(all="ignore"):
            cov = np.linalg.pinv(J.T @ J) * sigma2
        std = np.sqrt(np.abs(np.diag(cov)))
        self.params_std_ = dict(zip(names, std[:n_p].tolist(), strict=True))
        self.result_ = result
        return self

    def initial_state(self, u_init, y_init):
        """Least-squares initial state from the initialisation window."""
        y_init = np.asarray(y_init, dtype=float).ravel()
        guess = self.x0_ if self.x0_from_y is None else self.x0_from_y(y_init)
        p = self._p()[None]

        def fun(x0):
            r = simulate_batch(self.step, self.output, p, x0[None], u_init)[0] - y_init
            return np.where(np.isfinite(r), r, 1e3)

        return least_squares(fun, guess).x

    def simulate(self, inputs, initial):
        """Free-run outputs ``(n_times, 1)`` from the inputs and a measured window.

        The initial state is estimated from ``initial`` (the first ``n_init``
        measured outputs) and the inputs over it; the returned first ``n_init``
        samples are the model's own outputs.
        """
        inputs = np.asarray(inputs, dtype=float)
        n_init = len(initial)
        x0 = self.initial_state(inputs[:n_init], initial)
        Y = simulate_batch(self.step, self.output, self._p()[None], x0[None], inputs)[0]
        bad = np.flatnonzero(~np.isfinite(Y))
        if bad.size:
            raise SimulationDivergedError(
                f"the physics simulation became non-finite at step {bad[0]}."
            )
        return Y[:, None]
