"""Transitions of gymnasium's ``Pendulum-v1`` under random held torques."""

import numpy as np
from sklearn.utils import check_random_state

from skhybrid.datasets._base import (
    _check_int,
    _check_noise,
    _check_noise_type,
    _check_range,
    _episode_lengths,
    _process_noise,
    _window_bunch,
)
from skhybrid.domain import pendulum_step

__all__ = ["make_pendulum"]

_STATE_NAMES = ["cos_theta", "sin_theta", "theta_dot"]
_INPUT_NAMES = ["torque"]

# gymnasium Pendulum-v1's constants, in PendulumModel's keyword names.
_PENDULUM_PARAMS = {
    "mass": 1.0,
    "length": 1.0,
    "g": 10.0,
    "dt": 0.05,
    "max_speed": 8.0,
    "max_torque": 2.0,
}

_DESCR = """\
Inverted pendulum (gymnasium Pendulum-v1 dynamics)
--------------------------------------------------

Simulated with the equations of gymnasium's Pendulum-v1 (g=10 m/s^2, m=1 kg,
l=1 m, dt=0.05 s, speed clipped to [-8, 8] rad/s, torque clipped to [-2, 2] N m),
the same equations as skhybrid.domain.PendulumModel:

    theta_dot(t+1) = clip(theta_dot + (3 g / (2 l) sin(theta) + 3 / (m l^2) u) dt)
    theta(t+1)     = theta + theta_dot(t+1) dt

Episodes of fixed length start at theta ~ U(-pi, pi), theta_dot ~ U(-1, 1)
(gymnasium's reset); the torque u is drawn uniformly from torque_range and held
for a random number of steps drawn uniformly from hold_steps. With
noise_type="measurement" (the paper's setting), Gaussian measurement noise of
standard deviation `noise` is added independently to the observed states
cos(theta), sin(theta) and theta_dot (not to the torque). With
noise_type="process", the same Gaussian disturbance is added to the state after
every step of the dynamics and the states are measured exactly: the true
equations' one-step residual is then white with standard deviation `noise`.

State columns: cos_theta, sin_theta, theta_dot. Input column: torque.
The paper trains and tests interpolation with torques in [-1, 1] and
extrapolates with torques in [-2, 2] (section 6.1).

Reference: G. Brockman et al., "OpenAI Gym", arXiv:1606.01540, 2016.
"""


def make_pendulum(
    n_samples=25000,
    torque_range=(-1.0, 1.0),
    *,
    n_steps=1,
    noise=0.01,
    noise_type="measurement",
    episode_length=200,
    hold_steps=(1, 10),
    random_state=None,
):
    """Simulate the inverted pendulum of gymnasium ``Pendulum-v1``.

    Episodes start from random states and are driven by random torques held for a
    few steps; the observed states carry Gaussian measurement noise, or the
    dynamics a Gaussian disturbance (``noise_type``). Rows follow
    the data convention of :mod:`skhybrid.preprocessing`: a window of ``n_steps``
    time steps ``[cos_theta, sin_theta, theta_dot, torque]``, oldest first, and the
    target is the observed state one step after the window. Windows never cross
    episodes.

    Parameters
    ----------
    n_samples : int, default=25000
        Number of rows (windows) returned.
    torque_range : (float, float), default=(-1.0, 1.0)
        Range of the uniformly drawn torques (N m); the paper's extrapolative set
        uses ``(-2.0, 2.0)``. Torques beyond gymnasium's clip of 2 N m act as 2 N m.
    n_steps : int, default=1
        Time steps per window.
    noise : float or array-like of shape (3,), default=0.01
        Standard deviation of the Gaussian noise on the observed states
        ``cos_theta``, ``sin_theta``, ``theta_dot`` (one value for all, or one per
        state). The torque is noise free.
    noise_type : {"measurement", "process"}, default="measurement"
        Where the noise enters. ``"measurement"`` (the paper's setting): added to
        the measured states only, so a row's inputs are noisy too and even the true
        equations leave a one-step residual that is a moving average, not white.
        ``"process"``: added to the state after every step of the dynamics (a
        random disturbance the system then evolves from) and measured exactly, so
        the true equations' one-step residual is the disturbance itself: white,
        with standard deviation ``noise``.
    episode_length : int, default=200
        Time steps per episode (gymnasium's time limit); each episode gives
        ``episode_length - n_steps`` rows, the last episode fewer.
    hold_steps : (int, int), default=(1, 10)
        Each torque is held for a number of steps drawn uniformly from
        ``low..high`` (both included).
    random_state : int, RandomState instance or None, default=None
        Seed of the initial states, torques and noise.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        X : ndarray of shape (n_samples, 4 * n_steps)
            Noisy windows ``[cos_theta, sin_theta, theta_dot, torque]`` per step.
        y : ndarray of shape (n_samples, 3)
            Noisy observed state after each window.
        groups : ndarray of shape (n_samples,)
            Episode index of each row.
        X_clean, y_clean : ndarrays
            The same windows and targets without measurement noise: ``y_clean``
            is the true next state. Under process noise there is no measurement
            noise and they equal ``X`` and ``y``.
        oracle : ndarray of shape (n_samples, 3)
            The true equations applied to the noisy window (its newest step): the
            best any model of ``X`` can do; equal to
            ``PendulumModel(**true_params, fixed=("mass", "length")).fit(X, y)
            .predict(X)``.
        states, states_clean : list of ndarray of shape (n_times, 3)
            Observed states of each episode, with and without noise.
        inputs : list of ndarray of shape (n_times, 1)
            Torque of each episode; ``inputs[e][t]`` acts between ``t`` and
            ``t + 1``.
        feature_names : list of str
            Name of every column of ``X``, e.g. ``"theta_dot[t-1]"``,
            ``"torque[t]"``.
        target_names, state_names, input_names : list of str
            ``["cos_theta", "sin_theta", "theta_dot"]`` and ``["torque"]``.
        true_params : dict
            The simulator's constants as :class:`~skhybrid.domain.PendulumModel`
            keyword arguments (``mass``, ``length``, ``g``, ``dt``, ``max_speed``,
            ``max_torque``).
        dt : float
            Sample period (s).
        n_steps : int
            Time steps per window.
        noise : ndarray of shape (3,)
            Noise standard deviation of each state.
        noise_type : str
            ``"measurement"`` or ``"process"``.
        DESCR : str
            Description of the data.

    See Also
    --------
    skhybrid.domain.PendulumModel : The same equations as a fittable model.
    make_double_pendulum : A pendulum with an unmodelled second pendulum.
    make_dc_motor : A DC motor with gear backlash.

    Notes
    -----
    The simulation calls :func:`skhybrid.domain.pendulum_step`, so
    ``PendulumModel`` with ``true_params`` reproduces ``y_clean`` from ``X_clean``
    to rounding error; the test suite also checks the trajectories against
    gymnasium's own ``env.step``.

    Examples
    --------
    >>> from skhybrid.datasets import make_pendulum
    >>> data = make_pendulum(n_samples=1000, n_steps=2, random_state=0)
    >>> data.X.shape, data.y.shape
    ((1000, 8), (1000, 3))
    >>> data.feature_names[:4]
    ['cos_theta[t-1]', 'sin_theta[t-1]', 'theta_dot[t-1]', 'torque[t-1]']
    >>> extrapolative = make_pendulum(1000, torque_range=(-2.0, 2.0), random_state=1)
    """
    n_samples = _check_int(n_samples, "n_samples", 1)
    torque_range = _check_range(torque_range, "torque_range")
    n_steps = _check_int(n_steps, "n_steps", 1)
    noise = _check_noise(noise, 3, _STATE_NAMES)
    noise_type = _check_noise_type(noise_type)
    episode_length = _check_int(episode_length, "episode_length", 2)
    hold_steps = _check_range(hold_steps, "hold_steps", integer=True, minimum=1)
    rng = check_random_state(random_state)

    lengths = _episode_lengths(n_samples, episode_length, n_steps)
    n_episodes, n_times = len(lengths), lengths[0]
    p = _PENDULUM_PARAMS

    theta = rng.uniform(-np.pi, np.pi, n_episodes)
    theta_dot = rng.uniform(-1.0, 1.0, n_episodes)
    torque = np.empty((n_episodes, n_times))
    for e in range(n_episodes):
        # Enough held segments to fill the episode, then cut at n_times.
        n_holds = n_times // hold_steps[0] + 1
        durations = rng.randint(hold_steps[0], hold_steps[1] + 1, n_holds)
        values = rng.uniform(torque_range[0], torque_range[1], n_holds)
        torque[e] = np.repeat(values, durations)[:n_times]

    states = np.empty((n_episodes, n_times, 3))
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    for t in range(n_times):
        states[:, t] = np.column_stack([cos_t, sin_t, theta_dot])
        cos_t, sin_t, theta_dot = pendulum_step(
            cos_t, sin_t, theta_dot, torque[:, t], **p
        )
        if noise_type == "process":
            w = _process_noise(rng, noise, n_episodes)
            if w is not None:
                cos_t, sin_t, theta_dot = (
                    cos_t + w[:, 0],
                    sin_t + w[:, 1],
                    (theta_dot + w[:, 2]),
                )

    states_clean = [states[e, :n] for e, n in enumerate(lengths)]
    inputs = [torque[e, :n, None] for e, n in enumerate(lengths)]
    data = _window_bunch(
        states_clean,
        inputs,
        noise=noise,
        noise_type=noise_type,
        n_steps=n_steps,
        rng=rng,
        state_names=_STATE_NAMES,
        input_names=_INPUT_NAMES,
        true_params=dict(p),
        dt=p["dt"],
        DESCR=_DESCR,
    )
    newest = data.X[:, -4:]
    data.oracle = np.column_stack(pendulum_step(*newest.T, **p))
    return data
