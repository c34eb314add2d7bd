"""A DC motor's rigid-gear physics, written for any array namespace."""

import numpy as np

__all__ = ["dc_motor_step"]


def dc_motor_step(X, *, gain, time_constant, dt=0.001, xp=np):
    """One sample of a rigid DC drive: the physics model of the motor data.

    Neglecting the armature inductance and the backlash, the load speed ``w`` of a
    DC drive obeys ``time_constant * dw/dt = gain * V - w`` and the load angle
    integrates ``w``. This function applies the exact zero-order-hold solution over
    one sample ``dt`` to the newest time step ``[load_angle, load_speed, voltage]``
    of each row (its last three columns):

    ``w(t+1) = a w + (1 - a) gain V`` and ``theta(t+1) = theta + gain V dt +
    (w - gain V) time_constant (1 - a)``, with ``a = exp(-dt / time_constant)``.

    Both parameters have a physical meaning: ``gain = n Kt / (R b)`` (steady
    load speed per volt) and ``time_constant = (Jl + n^2 Jm) / b``, with the
    total friction ``b = bl + n^2 (bm + Kt Ke / R)``.
    :func:`~skhybrid.datasets.make_dc_motor` returns their true values as
    ``rigid_params``. Written against the array namespace ``xp`` for
    :class:`~skhybrid.domain.ParametricModel`; bind ``dt`` with
    :func:`functools.partial` for another sample period.

    Parameters
    ----------
    X : ndarray or torch.Tensor of shape (n_samples, 3 * n_steps)
        Windows of ``[load_angle, load_speed, voltage]`` steps, oldest first.
    gain : float or 0-d array
        Steady-state load speed per volt (rad/s/V).
    time_constant : float or 0-d array
        Mechanical time constant (s).
    dt : float, default=0.001
        Sample period (s), :func:`~skhybrid.datasets.make_dc_motor`'s default.
    xp : module, default=numpy
        Array namespace.

    Returns
    -------
    y_pred : ndarray or torch.Tensor of shape (n_samples, 2)
        Predicted ``[load_angle, load_speed]`` one sample later.

    See Also
    --------
    skhybrid.datasets.make_dc_motor : Data this model is meant to be fitted to.
    skhybrid.domain.LinearStateSpaceModel : The unstructured linear alternative.

    Examples
    --------
    >>> from skhybrid.datasets import make_dc_motor
    >>> from skhybrid.domain import ParametricModel, dc_motor_step
    >>> data = make_dc_motor(n_samples=1000, episode_length=250, random_state=0)
    >>> model = ParametricModel(dc_motor_step, {"gain": 1.0, "time_constant": 0.1})
    >>> model = model.fit(data.X, data.y)
    >>> sorted(model.params_)
    ['gain', 'time_constant']
    """
    step = X[:, X.shape[1] - 3 :]
    theta, w, v = step[:, 0], step[:, 1], step[:, 2]
    # Broadcast against a column first so that float parameters work on torch too.
    a = xp.exp(-dt / time_constant * xp.ones_like(w))
    w_ss = gain * v
    new_w = a * w + (1.0 - a) * w_ss
    new_theta = theta + w_ss * dt + (w - w_ss) * time_constant * (1.0 - a)
    return xp.stack([new_theta, new_w], axis=1)
