"""The inverted pendulum of gymnasium's ``Pendulum-v1`` as a domain model."""

from numbers import Real

import numpy as np

from skhybrid.domain._base import DomainModel
from skhybrid.preprocessing import WindowLayout
from skhybrid.utils._sklearn_compat import Interval

__all__ = ["PendulumModel", "pendulum_step", "single_pendulum_step"]


def pendulum_step(
    cos_theta,
    sin_theta,
    theta_dot,
    torque,
    *,
    mass,
    length,
    g,
    dt,
    max_speed=8.0,
    max_torque=2.0,
    xp=np,
):
    """One step of gymnasium's ``Pendulum-v1`` dynamics, in any array namespace.

    ``theta_dot(t+1) = clip(theta_dot + (3 g / (2 l) sin(theta) + 3 / (m l^2) u) dt,
    -max_speed, max_speed)`` and ``theta(t+1) = theta + theta_dot(t+1) dt``, with the
    torque clipped to ``[-max_torque, max_torque]``.

    Parameters
    ----------
    cos_theta, sin_theta, theta_dot, torque : ndarray or torch.Tensor
        Observed state and applied torque (1-D, same length).
    mass, length, g, dt : float or 0-d array
        Physical parameters and time step.
    max_speed, max_torque : float, default=8.0, 2.0
        Gymnasium's clips.
    xp : module, default=numpy
        Array namespace.

    Returns
    -------
    cos_theta, sin_theta, theta_dot : arrays
        The observed state one step later.
    """
    theta = xp.atan2(sin_theta, cos_theta)
    u = xp.clip(torque, -max_torque, max_torque)
    accel = 3.0 * g / (2.0 * length) * xp.sin(theta) + 3.0 / (mass * length**2) * u
    new_theta_dot = xp.clip(theta_dot + accel * dt, -max_speed, max_speed)
    new_theta = theta + new_theta_dot * dt
    return xp.cos(new_theta), xp.sin(new_theta), new_theta_dot


class PendulumModel(DomainModel):
    """Gymnasium ``Pendulum-v1`` one-step equations with fitted mass and length.

    Each time step of a row is ``[cos(theta), sin(theta), theta_dot, torque]``; the
    outputs are ``[cos(theta), sin(theta), theta_dot]`` one step after the window's
    newest step. The angle is recovered with ``atan2``, so noisy ``(cos, sin)``
    pairs are projected onto the unit circle. The fitted parameters are ``mass`` and
    ``length``; ``g``, ``dt`` and the clips are known constants (only ``g / length``
    and ``mass * length ** 2`` are identifiable, so fitting ``g`` too would be
    ill-posed).

    Parameters
    ----------
    mass : float, default=1.0
        Initial value of the pendulum's mass (kg).
    length : float, default=1.0
        Initial value of the pendulum's length (m).
    g : float, default=10.0
        Gravitational acceleration (m/s^2), held fixed.
    dt : float, default=0.05
        Time step (s), held fixed.
    max_speed : float, default=8.0
        Clip of the angular speed (rad/s).
    max_torque : float, default=2.0
        Clip of the torque (N m).
    fixed : tuple of str, default=()
        Parameters among ``("mass", "length")`` held at their initial values; the
        paper's deliberately wrong physics is ``PendulumModel(mass=5, length=10,
        fixed=("mass", "length"))``.
    bounds : dict or None, default=None
        Bounds of ``mass`` and ``length``; by default both stay positive.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        Least-squares objective (see :class:`DomainModel`).
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    jac : {"2-point", "3-point", "autograd"}, default="2-point"
        Jacobian of the residuals.
    loss : str, default="linear"
        Robust loss of ``least_squares``.
    f_scale : float, default=1.0
        Soft margin of robust losses.
    max_nfev : int or None, default=None
        Most residual evaluations.
    n_steps : int, default=1
        Time steps per row; the equations read the newest.

    Attributes
    ----------
    params_ : dict of str to float
        Fitted ``mass`` and ``length``.
    params_std_ : dict of str to float
        Standard errors (0 for fixed parameters).
    params_cov_ : ndarray of shape (n_free, n_free)
        Covariance of the free parameters.
    result_ : OptimizeResult or None
        What ``least_squares`` returned (``None`` when every parameter is fixed).
    n_features_in_ : int
        Number of columns of ``X``.
    n_outputs_ : int
        Number of outputs (3).

    See Also
    --------
    ParametricModel : A domain model from a user's function.
    skhybrid.datasets.make_pendulum : Transitions simulated with these equations.

    Notes
    -----
    scikit-learn's common checks feed random data of arbitrary shapes, which this
    model rejects by design (its equations need 4 columns per step and 3 outputs);
    the project's test suite lists those checks with that reason.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import PendulumModel, pendulum_step
    >>> rng = np.random.default_rng(0)
    >>> theta = rng.uniform(-np.pi, np.pi, 500)
    >>> X = np.column_stack([np.cos(theta), np.sin(theta),
    ...                      rng.uniform(-8, 8, 500), rng.uniform(-2, 2, 500)])
    >>> y = np.column_stack(pendulum_step(*X.T, mass=1.0, length=1.0, g=10.0, dt=0.05))
    >>> model = PendulumModel(mass=5.0, length=10.0).fit(X, y)
    >>> {k: round(v, 6) for k, v in model.params_.items()}
    {'mass': 1.0, 'length': 1.0}
    """

    _parameter_constraints = {
        **DomainModel._parameter_constraints,
        "mass": [Interval(Real, 0, None, closed="neither")],
        "length": [Interval(Real, 0, None, closed="neither")],
        "g": [Real],
        "dt": [Interval(Real, 0, None, closed="neither")],
        "max_speed": [Interval(Real, 0, None, closed="neither")],
        "max_torque": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        mass=1.0,
        length=1.0,
        g=10.0,
        dt=0.05,
        *,
        max_speed=8.0,
        max_torque=2.0,
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
        self.mass = mass
        self.length = length
        self.g = g
        self.dt = dt
        self.max_speed = max_speed
        self.max_torque = max_torque

    def _initial_params(self, X, y):
        return {"mass": float(self.mass), "length": float(self.length)}

    def _default_bounds(self):
        return {"mass": (1e-9, np.inf), "length": (1e-9, np.inf)}

    def _check_layout(self, n_step_features, n_outputs):
        if n_step_features != 4 or n_outputs != 3:
            raise ValueError(
                "PendulumModel needs 4 columns per time step [cos(theta), "
                "sin(theta), theta_dot, torque] and 3 outputs [cos(theta), "
                f"sin(theta), theta_dot]; got {n_step_features} columns per step "
                f"(n_steps={self.n_steps}) and {n_outputs} outputs."
            )

    def _equations(self, X, params, xp):
        states, inputs = WindowLayout(3, 1, self.n_steps).split(X)
        cos_t, sin_t, theta_dot = pendulum_step(
            states[:, -1, 0],
            states[:, -1, 1],
            states[:, -1, 2],
            inputs[:, -1, 0],
            mass=params["mass"],
            length=params["length"],
            g=self.g,
            dt=self.dt,
            max_speed=self.max_speed,
            max_torque=self.max_torque,
            xp=xp,
        )
        return xp.stack([cos_t, sin_t, theta_dot], axis=1)


def single_pendulum_step(X, *, length, damping=0.0, g=9.81, dt=0.01, xp=np):
    """One step of a single pendulum, the physics fitted to the double pendulum.

    Reads the newest time step ``[theta, theta_dot, theta_ddot]`` of each row
    (the last three columns), integrates ``theta_ddot = -(g / length) sin(theta) -
    damping theta_dot`` from ``(theta, theta_dot)`` over ``dt`` with one classical
    Runge-Kutta (RK4) step, and returns the next ``[theta, theta_dot,
    theta_ddot]``. The observed ``theta_ddot`` of the row is not used: for a single
    pendulum it follows from ``theta`` and ``theta_dot``.

    Written against the array namespace ``xp``, so it serves
    :class:`~skhybrid.domain.ParametricModel` on NumPy (least squares) and on torch
    (``jac="autograd"``, joint training). Bind ``dt`` (and ``g``) with
    :func:`functools.partial` when the data use another sample period.

    Parameters
    ----------
    X : ndarray or torch.Tensor of shape (n_samples, 3 * n_steps)
        Windows of ``[theta, theta_dot, theta_ddot]`` steps, oldest first.
    length : float or 0-d array
        Effective pendulum length (m), the parameter to fit.
    damping : float or 0-d array, default=0.0
        Viscous damping rate (1/s); fit it too to let the model lose energy.
    g : float, default=9.81
        Gravitational acceleration (m/s^2).
    dt : float, default=0.01
        Sample period (s), :func:`~skhybrid.datasets.make_double_pendulum`'s default.
    xp : module, default=numpy
        Array namespace.

    Returns
    -------
    y_pred : ndarray or torch.Tensor of shape (n_samples, 3)
        Predicted ``[theta, theta_dot, theta_ddot]`` one sample later.

    See Also
    --------
    skhybrid.datasets.make_double_pendulum : Data this model is meant to be fitted to.

    Examples
    --------
    >>> from skhybrid.datasets import make_double_pendulum
    >>> from skhybrid.domain import ParametricModel, single_pendulum_step
    >>> data = make_double_pendulum(n_samples=500, random_state=0)
    >>> model = ParametricModel(single_pendulum_step, {"length": 2.0})
    >>> model = model.fit(data.X, data.y)
    >>> 0.9 < model.params_["length"] < 1.3
    True
    """
    step = X[:, X.shape[1] - 3 :]
    theta, omega = step[:, 0], step[:, 1]
    k = g / length

    def accel(th, w):
        return -k * xp.sin(th) - damping * w

    k1_th, k1_w = omega, accel(theta, omega)
    k2_th = omega + 0.5 * dt * k1_w
    k2_w = accel(theta + 0.5 * dt * k1_th, k2_th)
    k3_th = omega + 0.5 * dt * k2_w
    k3_w = accel(theta + 0.5 * dt * k2_th, k3_th)
    k4_th = omega + dt * k3_w
    k4_w = accel(theta + dt * k3_th, k4_th)
    new_theta = theta + dt / 6.0 * (k1_th + 2.0 * k2_th + 2.0 * k3_th + k4_th)
    new_omega = omega + dt / 6.0 * (k1_w + 2.0 * k2_w + 2.0 * k3_w + k4_w)
    return xp.stack([new_theta, new_omega, accel(new_theta, new_omega)], axis=1)
