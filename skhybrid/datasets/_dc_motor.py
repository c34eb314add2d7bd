"""A DC motor driving a load through a gear with backlash, under a random PWM."""

import math

import numpy as np
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
from skhybrid.utils._validation import check_known_names

__all__ = ["make_dc_motor"]

_STATE_NAMES = ["load_angle", "load_speed"]
_INPUT_NAMES = ["voltage"]
_FULL_STATE_NAMES = [
    "current",
    "motor_angle",
    "motor_speed",
    "load_angle",
    "load_speed",
]

# Physical constants of the simulated drive (SI units). The electrical time
# constant is L / R = 0.5 ms, the rigid mechanical one about 10 ms, and the
# engaged shaft resonates near 22 Hz, between the 10 Hz and 100 Hz excitations.
_DC_MOTOR_PARAMS = {
    "resistance": 2.0,  # armature resistance R (ohm)
    "inductance": 1e-3,  # armature inductance L (H)
    "back_emf": 0.02,  # back-EMF constant Ke (V s/rad)
    "torque_constant": 0.02,  # torque constant Kt (N m/A)
    "motor_inertia": 1e-6,  # rotor inertia Jm (kg m^2)
    "motor_friction": 1e-6,  # rotor viscous friction bm (N m s/rad)
    "gear_ratio": 10.0,  # motor turns per load turn, n
    "load_inertia": 1e-4,  # load inertia Jl (kg m^2)
    "load_friction": 5e-4,  # load viscous friction bl (N m s/rad)
    "stiffness": 1.0,  # shaft stiffness k when engaged (N m/rad)
    "damping": 2e-3,  # shaft damping c when engaged (N m s/rad)
    "backlash": 0.05,  # half-width of the dead zone at the load (rad)
    "max_voltage": 12.0,  # supply voltage: 100 % duty (V)
}

# Fixed-step RK4 sub-step: a fifth of the electrical time constant.
_MAX_SUBSTEP = 1e-4

_DESCR = """\
DC motor with gear backlash under random PWM (section 6.3 of the paper)
----------------------------------------------------------------------

A permanent-magnet DC motor drives an inertial load through a gear whose shaft
coupling has backlash. With armature current i, motor angle and speed
(theta_m, w_m), load angle and speed (theta_l, w_l) and voltage V:

    L di/dt         = V - R i - Ke w_m
    Jm dw_m/dt      = Kt i - bm w_m - tau / n
    Jl dw_l/dt      = tau - bl w_l
    tau = k dz(theta_m / n - theta_l) + c (w_m / n - w_l)   when engaged
    tau = 0                                                   inside the gap
    dz(x) = x - b (x > b), x + b (x < -b), 0 otherwise (engaged when |x| > b)

The motor is driven by a PWM voltage whose duty cycle (uniform in [0, 1]) and
polarity (+/- with equal probability) are drawn at random every
1 / excitation_hz seconds; the PWM carrier is averaged over the sample period
(mean-value model), so the voltage is piecewise constant at
+/- duty * max_voltage. Training and interpolation use 10 Hz excitation,
extrapolation 100 Hz, as in the paper. Each episode starts at rest in the
middle of the gap. The equations are integrated with a fixed-step classical
Runge-Kutta scheme (RK4, at most 0.1 ms per step, an integer number of steps
per sample; checked against scipy.integrate.solve_ivp in the test suite).

Observed: load angle (rad) and load speed (rad/s), with Gaussian measurement
noise (noise_type="measurement") or measured exactly after a Gaussian
disturbance of the load angle and speed at every step (noise_type="process");
input: the voltage (V), noise free. The paper's physics model of the
real drive is a linear state-space model (skhybrid.domain.LinearStateSpaceModel);
skhybrid.domain.dc_motor_step is its physically parametrised rigid-gear form.
"""


def _check_motor_params(motor_params):
    params = dict(_DC_MOTOR_PARAMS)
    if motor_params is None:
        return params
    if not isinstance(motor_params, dict):
        raise TypeError(
            f"motor_params must be a dict or None; got {type(motor_params).__name__}."
        )
    check_known_names(
        motor_params,
        sorted(params),
        "motor_params has unknown keys {unknown}; expected a subset of {known}.",
    )
    for name, value in motor_params.items():
        low_closed = name in {"motor_friction", "load_friction", "damping", "backlash"}
        params[name] = _check_real(
            value, f"motor_params[{name!r}]", low=0.0, low_closed=low_closed
        )
    return params


def _coefficients(p):
    """Constants of the equations, grouped once so the integrator loop stays lean."""
    n = p["gear_ratio"]
    return (
        1.0 / n,
        p["backlash"],
        p["stiffness"],
        p["damping"],
        p["resistance"] / p["inductance"],
        p["back_emf"] / p["inductance"],
        1.0 / p["inductance"],
        p["torque_constant"] / p["motor_inertia"],
        p["motor_friction"] / p["motor_inertia"],
        1.0 / (n * p["motor_inertia"]),
        p["load_friction"] / p["load_inertia"],
        1.0 / p["load_inertia"],
    )


def _rhs(x, voltage, c):
    """Time derivative of full states ``x`` of shape (5, n) under ``voltage`` (n,)."""
    inv_n, b, k, damp, r_l, ke_l, inv_l, kt_j, bm_j, inv_nj, bl_j, inv_jl = c
    i, theta_m, w_m, theta_l, w_l = x
    twist = theta_m * inv_n - theta_l
    # Shaft torque: spring on the dead-zone twist plus damping, zero inside the gap.
    dead_zone = twist - np.clip(twist, -b, b)
    tau = k * dead_zone + (dead_zone != 0.0) * (damp * (w_m * inv_n - w_l))
    return np.stack(
        [
            voltage * inv_l - r_l * i - ke_l * w_m,
            w_m,
            kt_j * i - bm_j * w_m - inv_nj * tau,
            w_l,
            inv_jl * tau - bl_j * w_l,
        ]
    )


def _advance(z, voltage, dt, p):
    """Advance full states ``z`` (n, 5) by ``dt`` under constant ``voltage`` (n,)."""
    n_sub = max(1, math.ceil(dt / _MAX_SUBSTEP - 1e-9))
    h = dt / n_sub
    c = _coefficients(p)
    x = z.T
    for _ in range(n_sub):
        k1 = _rhs(x, voltage, c)
        k2 = _rhs(x + 0.5 * h * k1, voltage, c)
        k3 = _rhs(x + 0.5 * h * k2, voltage, c)
        k4 = _rhs(x + h * k3, voltage, c)
        x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x.T


def _simulate(voltage, dt, p, start=None, disturbance=None):
    """Full states of shape (n_episodes, n_times, 5) under voltages (n_ep, n_times).

    ``voltage[:, t]`` acts between samples ``t`` and ``t + 1``. ``disturbance(n)``,
    if given, returns an array of shape ``(n, 2)`` (or None) added to the load
    angle and speed after each step: process noise.
    """
    n_episodes, n_times = voltage.shape
    z = np.zeros((n_episodes, 5)) if start is None else np.array(start, dtype=float)
    full = np.empty((n_episodes, n_times, 5))
    for t in range(n_times):
        full[:, t] = z
        z = _advance(z, voltage[:, t], dt, p)
        w = None if disturbance is None else disturbance(n_episodes)
        if w is not None:
            z[:, 3:5] += w
    return full


def _rigid_motor_params(params, dt):
    """Gain and time constant of the rigid, inductance-free reduction of the drive."""
    n, r = params["gear_ratio"], params["resistance"]
    friction = params["load_friction"] + n**2 * (
        params["motor_friction"] + params["torque_constant"] * params["back_emf"] / r
    )
    inertia = params["load_inertia"] + n**2 * params["motor_inertia"]
    return {
        "gain": n * params["torque_constant"] / r / friction,
        "time_constant": inertia / friction,
        "dt": dt,
    }


def make_dc_motor(
    n_samples=20000,
    *,
    excitation_hz=10.0,
    n_steps=1,
    noise=0.01,
    noise_type="measurement",
    episode_length=1000,
    dt=0.001,
    motor_params=None,
    random_state=None,
):
    """Simulate a DC motor driving a load through a gear with backlash.

    The motor is driven by a PWM voltage whose duty cycle and polarity change at
    random ``excitation_hz`` times a second (the paper: 10 Hz for training and
    interpolation, 100 Hz for extrapolation). The gear's shaft coupling has a dead
    zone, so after every reversal the motor turns freely until the gap closes and
    the load follows with a delay. The load angle and speed are observed with
    Gaussian measurement noise; the voltage is the input. Rows follow the window
    convention of :mod:`skhybrid.preprocessing`: steps ``[load_angle, load_speed,
    voltage]``, target the next ``[load_angle, load_speed]``.

    Parameters
    ----------
    n_samples : int, default=20000
        Number of rows (windows) returned.
    excitation_hz : float, default=10.0
        Rate (Hz) at which a new duty cycle and polarity are drawn. A switch
        falls on a sample instant; ``1 / excitation_hz`` is rounded to a whole
        number of samples (at least one).
    n_steps : int, default=1
        Time steps per window.
    noise : float or array-like of shape (2,), default=0.01
        Standard deviation of the noise on the load angle (rad) and load speed
        (rad/s): one value for both, or one each.
    noise_type : {"measurement", "process"}, default="measurement"
        Where the noise enters. ``"measurement"`` (the paper's setting): added to
        the measured load angle and speed only, so a row's inputs are noisy and
        even the true equations' one-step residual is not white.
        ``"process"``: added to the load angle and speed after every sample step
        of the dynamics (a random disturbance the drive evolves from) and
        measured exactly, so the true equations' one-step residual is white with
        standard deviation ``noise``.
    episode_length : int, default=1000
        Time steps per episode (each starts at rest); each gives
        ``episode_length - n_steps`` rows, the last episode fewer.
    dt : float, default=0.001
        Sample period (s).
    motor_params : dict or None, default=None
        Values overriding some of the physical constants listed in Notes;
        ``None`` keeps the defaults. All constants used are returned as
        ``true_params``.
    random_state : int, RandomState instance or None, default=None
        Seed of the excitation and the noise.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        X : ndarray of shape (n_samples, 3 * n_steps)
            Noisy windows ``[load_angle, load_speed, voltage]`` per step.
        y : ndarray of shape (n_samples, 2)
            Noisy observed state after each window.
        groups : ndarray of shape (n_samples,)
            Episode index of each row.
        X_clean, y_clean : ndarrays
            The same without noise: ``y_clean`` is the true next state. Under
            process noise they equal ``X`` and ``y``.
        oracle : ndarray of shape (n_samples, 2)
            The true equations applied to the noisy window: the full drive started
            from the window's newest noisy load angle and speed, the true (hidden)
            current and motor angle and speed, under the window's newest voltage,
            advanced one sample.
        states, states_clean : list of ndarray of shape (n_times, 2)
            Observed states of each episode, with and without noise.
        inputs : list of ndarray of shape (n_times, 1)
            Voltage of each episode; ``inputs[e][t]`` acts between ``t`` and
            ``t + 1``.
        full_states : list of ndarray of shape (n_times, 5)
            Noise-free ``[current, motor_angle, motor_speed, load_angle,
            load_speed]`` of each episode (``full_state_names``).
        feature_names : list of str
            Name of every column of ``X``, e.g. ``"voltage[t]"``.
        target_names, state_names, input_names : list of str
            ``["load_angle", "load_speed"]`` and ``["voltage"]``.
        true_params : dict
            The physical constants used (the defaults updated with
            ``motor_params``) and ``dt``.
        rigid_params : dict
            ``gain``, ``time_constant`` and ``dt`` of
            :func:`~skhybrid.domain.dc_motor_step` for these constants (the
            backlash-free reduction).
        excitation_hz : float
            Rate of the voltage switches.
        dt : float
            Sample period (s).
        n_steps : int
            Time steps per window.
        noise : ndarray of shape (2,)
            Noise standard deviation of each state.
        noise_type : str
            ``"measurement"`` or ``"process"``.
        DESCR : str
            Description of the data and the equations.

    See Also
    --------
    skhybrid.domain.dc_motor_step : A physically parametrised rigid-drive model to fit.
    skhybrid.domain.LinearStateSpaceModel : The paper's physics model of the motor.
    make_pendulum : The actuated pendulum.

    Notes
    -----
    The constants (SI units) are ``resistance`` R, ``inductance`` L, ``back_emf``
    Ke, ``torque_constant`` Kt, ``motor_inertia`` Jm, ``motor_friction`` bm,
    ``gear_ratio`` n, ``load_inertia`` Jl, ``load_friction`` bl, ``stiffness`` k
    and ``damping`` c of the engaged shaft, ``backlash`` (half-width of the gap,
    rad at the load) and ``max_voltage``; their defaults are R = 2 ohm, L = 1 mH,
    Ke = Kt = 0.02, Jm = 1e-6 kg m^2, bm = 1e-6, n = 10, Jl = 1e-4 kg m^2,
    bl = 5e-4, k = 1 N m/rad, c = 2e-3 N m s/rad, backlash 0.05 rad and 12 V.
    ``DESCR`` gives the equations. The PWM
    carrier is averaged over the sample period (a mean-value model), so the
    voltage is piecewise constant. The drive is integrated with a fixed-step RK4
    scheme (at most 0.1 ms per step), because restarting
    :func:`scipy.integrate.solve_ivp` at every switch and every contact is slow;
    the test suite checks it against ``solve_ivp``.

    Examples
    --------
    >>> from skhybrid.datasets import make_dc_motor
    >>> train = make_dc_motor(n_samples=1000, episode_length=250, random_state=0)
    >>> train.X.shape, train.y.shape
    ((1000, 3), (1000, 2))
    >>> train.feature_names
    ['load_angle[t]', 'load_speed[t]', 'voltage[t]']
    >>> extrapolative = make_dc_motor(
    ...     1000, excitation_hz=100.0, episode_length=250, random_state=1
    ... )
    """
    n_samples = _check_int(n_samples, "n_samples", 1)
    excitation_hz = _check_real(
        excitation_hz, "excitation_hz", low=0.0, low_closed=False
    )
    n_steps = _check_int(n_steps, "n_steps", 1)
    noise = _check_noise(noise, 2, _STATE_NAMES)
    noise_type = _check_noise_type(noise_type)
    episode_length = _check_int(episode_length, "episode_length", 2)
    dt = _check_real(dt, "dt", low=0.0, low_closed=False)
    params = _check_motor_params(motor_params)
    rng = check_random_state(random_state)

    lengths = _episode_lengths(n_samples, episode_length, n_steps)
    n_episodes, n_times = len(lengths), lengths[0]
    hold = max(1, round(1.0 / (excitation_hz * dt)))
    n_switches = math.ceil(n_times / hold)
    duty = rng.uniform(0.0, 1.0, (n_episodes, n_switches))
    polarity = rng.choice([-1.0, 1.0], (n_episodes, n_switches))
    levels = params["max_voltage"] * duty * polarity
    voltage = np.repeat(levels, hold, axis=1)[:, :n_times]

    disturbance = None
    if noise_type == "process":
        disturbance = lambda n: _process_noise(rng, noise, n)  # noqa: E731
    full = _simulate(voltage, dt, params, disturbance=disturbance)
    full_states = [full[e, :n] for e, n in enumerate(lengths)]
    inputs = [voltage[e, :n, None] for e, n in enumerate(lengths)]
    states_clean = [f[:, 3:5] for f in full_states]
    data = _window_bunch(
        states_clean,
        inputs,
        noise=noise,
        noise_type=noise_type,
        n_steps=n_steps,
        rng=rng,
        state_names=_STATE_NAMES,
        input_names=_INPUT_NAMES,
        full_states=full_states,
        full_state_names=list(_FULL_STATE_NAMES),
        true_params={**params, "dt": dt},
        rigid_params=_rigid_motor_params(params, dt),
        excitation_hz=excitation_hz,
        dt=dt,
        DESCR=_DESCR,
    )
    hidden = _newest_rows(full_states, n_steps)
    newest = data.X[:, -3:]
    start = np.column_stack([hidden[:, :3], newest[:, :2]])
    data.oracle = _advance(start, newest[:, 2], dt, params)[:, 3:5]
    return data
