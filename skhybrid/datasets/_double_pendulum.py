"""A large pendulum carrying a small one: an unmodelled degree of freedom."""

from numbers import Real

import numpy as np
from scipy.integrate import solve_ivp
from sklearn.utils import check_random_state

from skhybrid.datasets._base import (
    _check_int,
    _check_noise,
    _check_noise_type,
    _check_real,
    _episode_lengths,
    _newest_rows,
    _process_noise,
    _window_bunch,
)

__all__ = ["make_double_pendulum"]

_STATE_NAMES = ["theta", "theta_dot", "theta_ddot"]
_FULL_STATE_NAMES = ["theta1", "theta1_dot", "theta2", "theta2_dot"]
_RTOL = 1e-10
_ATOL = 1e-10

_DESCR = """\
Double pendulum with a small second pendulum (section 6.2 of the paper)
-----------------------------------------------------------------------

Two point masses on massless rods swing in a vertical plane without friction
or actuation: the large pendulum (mass m1, length l1) hangs from a fixed pivot
and carries the small pendulum (mass m2, length l2) at its end. Angles are
measured from the downward vertical. Each episode is released at rest with both
pendulums at 90 degrees (horizontal), each angle perturbed by a uniform draw in
[-perturbation, perturbation] rad. The equations of motion (Lagrange) are
integrated with scipy.integrate.solve_ivp (DOP853, rtol=atol=1e-10) and sampled
every dt seconds.

Only the large pendulum is observed: theta, theta_dot and its angular
acceleration theta_ddot (evaluated from the full state by the equations of
motion). With noise_type="measurement" (the paper's setting) each carries
Gaussian measurement noise of standard deviation `noise`. With
noise_type="process" a Gaussian disturbance enters theta and theta_dot after
every sample (the system evolves from the disturbed state, integrated sample by
sample) and the observations are exact; theta_ddot follows from the disturbed
state.
The small pendulum is the unmodelled degree of freedom: a single-pendulum
physics model (skhybrid.domain.single_pendulum_step) leaves an oscillating,
correlated residual that a neural stage can learn. There are no inputs.
"""


def _accelerations(th1, w1, th2, w2, m1, m2, l1, l2, g, xp=np):
    """Angular accelerations of the double pendulum (point masses, no friction)."""
    d = th1 - th2
    den = 2.0 * m1 + m2 - m2 * xp.cos(2.0 * d)
    a1 = (
        -g * (2.0 * m1 + m2) * xp.sin(th1)
        - m2 * g * xp.sin(th1 - 2.0 * th2)
        - 2.0 * xp.sin(d) * m2 * (w2**2 * l2 + w1**2 * l1 * xp.cos(d))
    ) / (l1 * den)
    a2 = (
        2.0
        * xp.sin(d)
        * (
            w1**2 * l1 * (m1 + m2)
            + g * (m1 + m2) * xp.cos(th1)
            + w2**2 * l2 * m2 * xp.cos(d)
        )
    ) / (l2 * den)
    return a1, a2


def _rhs(t, z, m1, m2, l1, l2, g):
    # z holds [theta1, theta1_dot, theta2, theta2_dot] of many pendulums, stacked
    # as four blocks, so that one solve_ivp call integrates them all.
    th1, w1, th2, w2 = z.reshape(4, -1)
    a1, a2 = _accelerations(th1, w1, th2, w2, m1, m2, l1, l2, g)
    return np.concatenate([w1, a1, w2, a2])


def _integrate(full_state, times, params, rtol=_RTOL, atol=_ATOL):
    """Integrate full states of shape (n, 4) and return shape (n, len(times), 4)."""
    n = full_state.shape[0]
    sol = solve_ivp(
        _rhs,
        (times[0], times[-1]),
        full_state.T.reshape(-1),
        method="DOP853",
        t_eval=times,
        rtol=rtol,
        atol=atol,
        args=(params["m1"], params["m2"], params["l1"], params["l2"], params["g"]),
    )
    if not sol.success:  # pragma: no cover - smooth, bounded dynamics
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return sol.y.reshape(4, n, len(times)).transpose(1, 2, 0)


def _integrate_disturbed(full_state, times, params, noise, rng):
    """Like :func:`_integrate`, adding a Gaussian disturbance after every sample.

    ``noise`` (2,) is the standard deviation of the disturbance of ``theta1`` and
    ``theta1_dot``; the small pendulum is not disturbed.
    """
    n = full_state.shape[0]
    full = np.empty((n, len(times), 4))
    z = np.array(full_state, dtype=float)
    for t in range(len(times)):
        full[:, t] = z
        if t + 1 < len(times):
            z = _integrate(z, times[t : t + 2], params)[:, -1]
            w = _process_noise(rng, noise, n)
            if w is not None:
                z[:, :2] += w
    return full


def _observe(full, params):
    """Observed ``[theta1, theta1_dot, theta1_ddot]`` from full states (..., 4)."""
    a1, _ = _accelerations(
        full[..., 0],
        full[..., 1],
        full[..., 2],
        full[..., 3],
        params["m1"],
        params["m2"],
        params["l1"],
        params["l2"],
        params["g"],
    )
    return np.stack([full[..., 0], full[..., 1], a1], axis=-1)


def make_double_pendulum(
    n_samples=10000,
    *,
    n_steps=1,
    noise=0.01,
    noise_type="measurement",
    episode_length=1000,
    dt=0.01,
    masses=(1.0, 0.1),
    lengths=(1.0, 0.2),
    g=9.81,
    perturbation=0.05,
    random_state=None,
):
    """Simulate a large pendulum carrying a small pendulum, observing the large one.

    Each episode releases both pendulums at rest at 90 degrees (plus a small random
    perturbation), with no actuation, and integrates the full four-state system
    with :func:`scipy.integrate.solve_ivp` at tight tolerances. Only the large
    pendulum's ``theta``, ``theta_dot`` and ``theta_ddot`` are observed, with
    Gaussian measurement noise; the small pendulum is the unmodelled degree of
    freedom of the paper's section 6.2. Rows follow the window convention of
    :mod:`skhybrid.preprocessing` (no inputs).

    Parameters
    ----------
    n_samples : int, default=10000
        Number of rows (windows) returned.
    n_steps : int, default=1
        Time steps per window.
    noise : float or array-like of shape (3,), default=0.01
        Standard deviation of the Gaussian noise on ``theta`` (rad),
        ``theta_dot`` (rad/s) and ``theta_ddot`` (rad/s^2): one value for all, or
        one per state. Under process noise the disturbance enters ``theta`` and
        ``theta_dot`` only; ``theta_ddot`` follows from the disturbed state and
        the third value is not used (``data.noise`` reports it as 0).
    noise_type : {"measurement", "process"}, default="measurement"
        Where the noise enters. ``"measurement"`` (the paper's setting): added to
        the measured states only, so a row's inputs are noisy and even the true
        equations' one-step residual is a moving average, not white.
        ``"process"``: a disturbance added to the large pendulum's angle and
        speed after every sample, measured exactly, so the true equations'
        one-step residual on ``theta`` and ``theta_dot`` is white with standard
        deviation ``noise``. The episodes are then integrated sample by sample,
        about ten times slower.
    episode_length : int, default=1000
        Time steps per episode; each gives ``episode_length - n_steps`` rows, the
        last episode fewer.
    dt : float, default=0.01
        Sample period (s).
    masses : (float, float), default=(1.0, 0.1)
        Masses of the large and the small pendulum (kg).
    lengths : (float, float), default=(1.0, 0.2)
        Lengths of the large and the small pendulum (m).
    g : float, default=9.81
        Gravitational acceleration (m/s^2).
    perturbation : float, default=0.05
        Each episode's two release angles are ``pi / 2`` plus independent uniform
        draws in ``[-perturbation, perturbation]`` (rad); 0 makes every episode
        the same.
    random_state : int, RandomState instance or None, default=None
        Seed of the perturbations and the noise.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        X : ndarray of shape (n_samples, 3 * n_steps)
            Noisy windows ``[theta, theta_dot, theta_ddot]`` per step.
        y : ndarray of shape (n_samples, 3)
            Noisy observed state after each window.
        groups : ndarray of shape (n_samples,)
            Episode index of each row.
        X_clean, y_clean : ndarrays
            The same without noise: ``y_clean`` is the true next observed state.
            Under process noise they equal ``X`` and ``y``.
        oracle : ndarray of shape (n_samples, 3)
            The true equations applied to the noisy window: the full system
            started from the window's newest noisy ``theta`` and ``theta_dot`` and
            the true (hidden) small-pendulum state, integrated over ``dt`` and
            observed. The noisy ``theta_ddot`` is not needed by the equations.
        states, states_clean : list of ndarray of shape (n_times, 3)
            Observed states of each episode, with and without noise.
        inputs : None
            The system has no inputs.
        full_states : list of ndarray of shape (n_times, 4)
            Noise-free ``[theta1, theta1_dot, theta2, theta2_dot]`` of each
            episode (``full_state_names``); ``theta2`` is the small pendulum's
            absolute angle from the vertical.
        feature_names : list of str
            Name of every column of ``X``, e.g. ``"theta_ddot[t]"``.
        target_names, state_names : list of str
            ``["theta", "theta_dot", "theta_ddot"]``.
        input_names : list of str
            Empty.
        true_params : dict
            ``m1``, ``m2``, ``l1``, ``l2``, ``g`` and ``dt``.
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
    skhybrid.domain.single_pendulum_step : The single-pendulum physics to fit.
    make_pendulum : The actuated single pendulum.

    Examples
    --------
    >>> from skhybrid.datasets import make_double_pendulum
    >>> data = make_double_pendulum(n_samples=1000, n_steps=3, random_state=0)
    >>> data.X.shape, data.y.shape
    ((1000, 9), (1000, 3))
    >>> data.feature_names[-3:]
    ['theta[t]', 'theta_dot[t]', 'theta_ddot[t]']
    """
    n_samples = _check_int(n_samples, "n_samples", 1)
    n_steps = _check_int(n_steps, "n_steps", 1)
    noise = _check_noise(noise, 3, _STATE_NAMES)
    noise_type = _check_noise_type(noise_type)
    episode_length = _check_int(episode_length, "episode_length", 2)
    dt = _check_real(dt, "dt", low=0.0, low_closed=False)
    m1, m2 = _check_range_positive(masses, "masses")
    l1, l2 = _check_range_positive(lengths, "lengths")
    g = _check_real(g, "g", low=0.0, low_closed=False)
    perturbation = _check_real(perturbation, "perturbation", low=0.0)
    rng = check_random_state(random_state)

    params = {"m1": m1, "m2": m2, "l1": l1, "l2": l2, "g": g}
    lengths_ = _episode_lengths(n_samples, episode_length, n_steps)
    n_episodes, n_times = len(lengths_), lengths_[0]
    angles = np.pi / 2 + rng.uniform(-perturbation, perturbation, (n_episodes, 2))
    start = np.column_stack(
        [angles[:, 0], np.zeros(n_episodes), angles[:, 1], np.zeros(n_episodes)]
    )
    times = np.arange(n_times) * dt
    if noise_type == "process":
        full = _integrate_disturbed(start, times, params, noise[:2], rng)
        noise = np.array([noise[0], noise[1], 0.0])
    else:
        full = _integrate(start, times, params)

    full_states = [full[e, :n] for e, n in enumerate(lengths_)]
    states_clean = [_observe(f, params) for f in full_states]
    data = _window_bunch(
        states_clean,
        None,
        noise=noise,
        noise_type=noise_type,
        n_steps=n_steps,
        rng=rng,
        state_names=_STATE_NAMES,
        input_names=[],
        full_states=full_states,
        full_state_names=list(_FULL_STATE_NAMES),
        true_params={**params, "dt": dt},
        dt=dt,
        DESCR=_DESCR,
    )
    # The oracle: the true system from the noisy observed (theta, theta_dot) and the
    # true hidden small-pendulum state, one sample ahead. Tighter tolerances than
    # the simulation because solve_ivp's error norm is an RMS over all rows.
    hidden = _newest_rows(full_states, n_steps)
    newest = data.X[:, -3:]
    start = np.column_stack([newest[:, 0], newest[:, 1], hidden[:, 2], hidden[:, 3]])
    ahead = _integrate(start, np.array([0.0, dt]), params, rtol=1e-12, atol=1e-12)
    data.oracle = _observe(ahead[:, -1], params)
    return data


def _check_range_positive(value, name):
    # (large, small): two positive numbers, no ordering implied.
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a pair (large, small) of positive numbers; got "
            f"{name}={value!r}."
        ) from None
    for v in (a, b):
        if isinstance(v, bool) or not isinstance(v, Real) or not v > 0 or v == np.inf:
            raise ValueError(
                f"{name} must be a pair (large, small) of positive numbers; got "
                f"{name}={value!r}."
            )
    return float(a), float(b)
