"""The measured benchmarks' physics: grey-box :class:`StateSpaceModel` s and their fit.

Each benchmark's physics is a :class:`~skhybrid.domain.StateSpaceModel` whose
unmeasured states are latent: the upper tank's level, the EMPS velocity, the
Silverbox's derivative. Their initial values are estimated from the
initialisation window by least squares through the physics, and the parameters
are fitted by the free-run (output) error with
:meth:`StateSpaceModel.fit_simulation`, the one output-error fit of the library.
The state equations are written with the array namespace ``xp``, so that the
state-space hybrid (:class:`~skhybrid.hybrid.StateSpaceHybridRegressor`) trains
through them in torch.

The Silverbox's input is band-limited, not held between samples: its Duffing
equation is integrated with the input interpolated as a band-limited signal,
at the start, midpoint and end of each step
(:func:`skhybrid.domain.band_limited_inputs`); until issue 24 it was
interpolated linearly between ``u(t)`` and ``u(t + 1)`` (first-order hold,
:func:`with_next_input`), which left the physics 0.935 mV from the validation
tail, against 0.281 now. Its fit starts from a one-step (equation-error)
regression on finite differences and refines by the simulation error over
segments of the record (multiple shooting: every segment's initial state is
estimated from its own first samples), which keeps a lightly damped
oscillator's least-squares landscape free of the local minima of one long free
run.
"""

import itertools

import numpy as np

# _LinearOutputError (the best linear approximation) lives in skhybrid.domain;
# run folders pickled before it moved there load it from here.
from skhybrid.domain import (
    StateSpaceModel,
    _LinearOutputError,  # noqa: F401
    asymmetric_friction,
    band_limited_inputs,
)

__all__ = [
    "duffing",
    "duffing_foh",
    "emps_axis",
    "emps_physics",
    "fit_segments",
    "silverbox_physics",
    "tanks",
    "tanks_output",
    "tanks_physics",
    "with_next_input",
]


# -- cascaded tanks ----------------------------------------------------------------
def tanks(
    x, u, *, xp, k1, k2, k3, k4, k5, k6, u0, x1max, kof, y_offset, zmax, dt, n_sub
):
    """Two tanks with Torricelli outflow, both overflowing (discrete).

    ``x1' = -k1 sqrt(x1) - k5 x1 + k4 (u - u0)`` (upper tank, latent; it
    overflows at ``x1max`` and a share ``kof`` of the overflow reaches the lower
    tank) and ``z' = k2 sqrt(x1) + k5 x1 - k3 sqrt(z - y_offset) - k6 (z -
    y_offset)``, ``z`` the lower tank's level in sensor volts (its level plus
    the sensor's offset ``y_offset``), which overflows at ``zmax``: the level
    saturates there and the water above it is lost (a saturating state, not
    only a clipped output). The pump's net inflow is affine in its voltage,
    zero at ``u0`` and negative below it. Explicit Euler with ``n_sub``
    sub-steps per sample of ``dt`` seconds.
    """
    x1, z = x[:, 0], x[:, 1]
    h = dt / n_sub
    inflow = k4 * (u[:, 0] - u0)
    for _ in range(int(n_sub)):
        s1 = _sqrt_positive(x1, xp)
        x2 = z - y_offset
        s2 = _sqrt_positive(x2, xp)
        x1_next = x1 + h * (-k1 * s1 - k5 * x1 + inflow)
        overflow = xp.maximum(x1_next - x1max, 0.0 * x1)
        z = z + h * (k2 * s1 + k5 * x1 - k3 * s2 - k6 * x2) + kof * overflow
        z = xp.minimum(z, zmax + 0.0 * z)
        x1 = x1_next - overflow
    return xp.stack([x1, z], axis=1)


def _sqrt_positive(v, xp):
    """``sqrt(max(v, 0))`` whose gradient is finite (zero) where ``v <= 0``.

    The square root's derivative is infinite at zero, and the chain rule
    through ``maximum`` multiplies it by zero, which autograd evaluates as NaN:
    a level at or below its outlet made a state-space hybrid's training
    diverge. The 1e-12 moves the value by at most 1e-6 V.
    """
    return xp.sqrt(xp.maximum(v, 0.0 * v) + 1e-12)


def tanks_output(x, *, xp, **params):
    """The lower tank's sensor, which saturates at 10 V."""
    return xp.minimum(x[:, 1:2], 10.0 + 0.0 * x[:, 1:2])


def _tanks_guess(outputs, inputs):
    """Upper tank mid-range, lower tank at its first measured value."""
    y0 = np.asarray(outputs)[:, 0, 0]
    return np.column_stack([np.full_like(y0, 5.0), y0])


def tanks_physics(dt, *, max_nfev=400):
    """The cascaded tanks' grey-box :class:`StateSpaceModel` (level units: volts).

    Parameters
    ----------
    dt : float
        Sample period (s), ``data.dt``.
    max_nfev : int, default=400
        Most residual evaluations of the fit (it converges in 107-120 on the
        estimation record's first 75 %, depending on the BLAS kernel, to the
        same minimum; stopped short, a fit ends where the kernel's rounding
        leads it).

    Returns
    -------
    model : StateSpaceModel
        Unfitted; ``fixed`` holds ``dt`` and the sub-steps.
    """
    return StateSpaceModel(
        tanks,
        {
            "k1": 0.05,
            "k2": 0.05,
            "k3": 0.05,
            "k4": 0.03,
            "k5": 0.001,
            "k6": 0.001,
            "u0": 0.0,
            "x1max": 6.0,
            "kof": 0.3,
            "y_offset": 0.5,
            "zmax": 10.0,
            "dt": float(dt),
            "n_sub": 4.0,
        },
        state_names=["upper level (latent)", "lower level"],
        output=tanks_output,
        time="discrete",
        initial_state=_tanks_guess,
        n_init=50,
        fixed=("dt", "n_sub"),
        bounds={
            "k1": (1e-4, 1),
            "k2": (1e-4, 1),
            "k3": (1e-4, 1),
            "k4": (1e-4, 1),
            "k5": (0.0, 1.0),
            "k6": (0.0, 1.0),
            "u0": (-5.0, 5.0),
            "x1max": (1.0, 100.0),
            "kof": (0.0, 1.0),
            "y_offset": (-3.0, 6.0),
            "zmax": (8.0, 12.0),
        },
        max_nfev=max_nfev,
        vectorized=True,
    )


# -- EMPS ----------------------------------------------------------------------------
#: The EMPS friction's sign is smoothed over eps = 0.1 mm/s, which makes the
#: simulation error rough in the parameters: a direct fit stopped at 60 (or, run
#: to convergence, 64 or 139) evaluations in one of several nearby minima,
#: which one depending on the BLAS kernel (validation tail 0.836 / 0.864 mm).
#: Fitted first at 1 mm/s, every kernel tried reaches the same, lower minimum
#: (0.796 mm; issue 24).
EMPS_CONTINUATION = {"eps": (1e-3,)}


def emps_axis(x, u, *, xp, M, Fv_pos, Fv_neg, Fc_pos, Fc_neg, gtau, dt, eps):
    """Rigid axis ``M q'' = gtau u - F(q')`` with direction-dependent friction.

    ``F`` is :func:`~skhybrid.domain.asymmetric_friction`: Coulomb and viscous
    friction with other coefficients in each direction of motion (the
    description's asymmetric model). Semi-implicit Euler over one sample of
    ``dt`` seconds: the velocity first, then the position with the new
    velocity; the sign is smoothed as ``tanh(q' / eps)``.
    """
    q, v = x[:, 0], x[:, 1]
    friction = asymmetric_friction(
        v, xp=xp, Fc_pos=Fc_pos, Fc_neg=Fc_neg, Fv_pos=Fv_pos, Fv_neg=Fv_neg, eps=eps
    )
    acc = (gtau * u[:, 0] - friction) / M
    v_next = v + dt * acc
    return xp.stack([q + dt * v_next, v_next], axis=1)


def emps_physics(dt, *, n_init=20, max_nfev=300, continuation=EMPS_CONTINUATION):
    """The EMPS model as a :class:`StateSpaceModel` (velocity latent).

    Parameters
    ----------
    dt : float
        Sample period (s), ``data.dt``.
    n_init : int, default=20
        Samples from which a record's initial velocity is estimated.
    max_nfev : int, default=300
        Most residual evaluations of each fit (the continuation's stage and the
        final fit).
    continuation : dict or None, default=EMPS_CONTINUATION
        The friction sign's width fitted first at 1 mm/s, then at the model's
        0.1 mm/s (:class:`StateSpaceModel`'s ``continuation``); None fits at
        0.1 mm/s directly.

    Returns
    -------
    model : StateSpaceModel
        Unfitted; the motor constant ``gtau = 35.15 N/V`` (the description's),
        ``dt`` and the smoothing ``eps`` are fixed.
    """
    return StateSpaceModel(
        emps_axis,
        {
            "M": 95.0,
            "Fv_pos": 200.0,
            "Fv_neg": 200.0,
            "Fc_pos": 20.0,
            "Fc_neg": 20.0,
            "gtau": 35.15,
            "dt": float(dt),
            "eps": 1e-4,
        },
        state_names=["position", "velocity (latent)"],
        observed=["position"],
        time="discrete",
        n_init=n_init,
        fixed=("gtau", "dt", "eps"),
        bounds={
            "M": (1.0, 1e3),
            "Fv_pos": (0.0, 1e4),
            "Fv_neg": (0.0, 1e4),
            "Fc_pos": (0.0, 1e3),
            "Fc_neg": (0.0, 1e3),
        },
        max_nfev=max_nfev,
        vectorized=True,
        continuation=continuation,
    )


# -- Silverbox -------------------------------------------------------------------------
def with_next_input(u):
    """Columns ``[u(t), u(t + 1)]`` (the last sample repeats) of a 1-input record."""
    u = np.asarray(u, dtype=float).reshape(len(u), -1)[:, 0]
    return np.column_stack([u, np.r_[u[1:], u[-1:]]])


def _duffing_rhs(y, v, u, g, d, k1, k2, k3, c):
    return v, g * u + c - d * v - k1 * y - k2 * y**2 - k3 * y**3


def duffing(x, u, *, xp, g, d, k1, k2, k3, c):
    """Duffing ``y'' = g u + c - d y' - k1 y - k2 y^2 - k3 y^3``, continuous time.

    The quadratic term ``k2`` and the constant ``c`` absorb the circuit's
    asymmetry and offsets. :func:`silverbox_physics` integrates it with the
    input read between samples (``StateSpaceModel(input_points=...)``).
    """
    dy, dv = _duffing_rhs(x[:, 0], x[:, 1], u[:, 0], g, d, k1, k2, k3, c)
    return xp.stack([dy, dv], axis=1)


def duffing_foh(x, u, *, xp, g, d, k1, k2, k3, c, dt):
    """Duffing ``y'' = g u + c - d y' - k1 y - k2 y^2 - k3 y^3`` over one sample.

    Classical Runge-Kutta over ``dt`` with the input interpolated linearly from
    ``u[:, 0]`` (at the sample) to ``u[:, 1]`` (at the next): a first-order
    hold. The Silverbox's physics until issue 24, kept for the run folders that
    pickled it: :func:`duffing` with ``input_points=2`` is the same step, to
    the last bit.
    """
    y, v = x[:, 0], x[:, 1]
    u0, u1 = u[:, 0], u[:, 1]
    um = 0.5 * (u0 + u1)
    p = (g, d, k1, k2, k3, c)
    a1, b1 = _duffing_rhs(y, v, u0, *p)
    a2, b2 = _duffing_rhs(y + 0.5 * dt * a1, v + 0.5 * dt * b1, um, *p)
    a3, b3 = _duffing_rhs(y + 0.5 * dt * a2, v + 0.5 * dt * b2, um, *p)
    a4, b4 = _duffing_rhs(y + dt * a3, v + dt * b3, u1, *p)
    return xp.stack(
        [
            y + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
            v + dt / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
        ],
        axis=1,
    )


def _duffing_equation_error(u, y, dt):
    """One-step start: regress central second differences of ``y`` on the terms."""
    u, y = np.ravel(u), np.ravel(y)
    if len(y) < 8:
        raise ValueError(
            f"the Duffing start needs at least 8 samples; got {len(y)} samples."
        )
    ydd = (y[2:] - 2.0 * y[1:-1] + y[:-2]) / dt**2
    yd = (y[2:] - y[:-2]) / (2.0 * dt)
    yc = y[1:-1]
    A = np.column_stack([u[1:-1], np.ones_like(yc), -yd, -yc, -(yc**2), -(yc**3)])
    theta = np.linalg.lstsq(A, ydd, rcond=None)[0]
    return dict(zip(("g", "c", "d", "k1", "k2", "k3"), theta.tolist(), strict=True))


#: The Silverbox physics' input points a sample for each way of reading the
#: input between samples, with the function that makes them from a record's.
INTERSAMPLE = {
    "band-limited": (3, band_limited_inputs),
    "first-order hold": (2, with_next_input),
}


def silverbox_physics(dt, u, y, *, n_init=50, max_nfev=30, intersample="band-limited"):
    """The Silverbox's Duffing :class:`StateSpaceModel`, started one step ahead.

    Parameters
    ----------
    dt : float
        Sample period (s), ``data.dt``.
    u, y : array-like of shape (n_times, 1)
        Estimation record: its equation-error regression gives the start.
    n_init : int, default=50
        Samples from which a record's initial derivative is estimated.
    max_nfev : int, default=30
        Most residual evaluations of the simulation-error refinement.
    intersample : {"band-limited", "first-order hold"}, default="band-limited"
        The input between samples, read by one RK4 step of :func:`duffing` a
        sample at its start, midpoint and end: interpolated as a band-limited
        signal (``input_points=3``; the model's inputs are
        :func:`~skhybrid.domain.band_limited_inputs` columns) or linearly
        (``input_points=2``, inputs :func:`with_next_input`). Chosen on the
        validation tail (issue 24): 0.281 mV against 0.935.

    Returns
    -------
    model : StateSpaceModel
        Unfitted, its ``params`` the one-step regression's; its inputs are
        the columns ``INTERSAMPLE[intersample][1]`` makes of a record's.
    """
    if intersample not in INTERSAMPLE:
        raise ValueError(
            f"intersample must be one of {sorted(INTERSAMPLE)}; got {intersample!r}."
        )
    return StateSpaceModel(
        duffing,
        _duffing_equation_error(u, y, dt),
        state_names=["output", "derivative (latent)"],
        observed=["output"],
        dt=float(dt),
        input_points=INTERSAMPLE[intersample][0],
        n_init=n_init,
        max_nfev=max_nfev,
        vectorized=True,
    )


def fit_segments(model, u, y, segment):
    """Fit ``model`` by the simulation error over consecutive segments of records.

    Multiple shooting: each segment of ``segment`` samples is a record whose
    initial state is estimated from its own first ``model.n_init`` samples; the
    remainder of a record (fewer than ``segment`` samples) joins its last
    segment. A model without ``fit_simulation`` (any estimator that simulates)
    is fitted with ``fit(u, y)`` on the records as they are.

    Parameters
    ----------
    model : StateSpaceModel or estimator
        The model to fit (in place).
    u, y : ndarray of shape (n_times, n_inputs) and (n_times, n_outputs), or \
lists of them
        One record, or several.
    segment : int or None
        Samples per segment; ``None`` fits whole records.

    Returns
    -------
    model : StateSpaceModel or estimator
        The fitted model.
    """
    several = isinstance(u, (list, tuple))
    U, Y = (list(u), list(y)) if several else ([u], [y])
    if not hasattr(model, "fit_simulation"):
        return model.fit(U if several else u, Y if several else y)
    if segment is not None and segment <= model.n_init:
        raise ValueError(
            f"segment={segment} must exceed the model's n_init={model.n_init}: a "
            "segment's first n_init samples only estimate its initial state."
        )
    pieces_U, pieces_Y = [], []
    for u_i, y_i in zip(U, Y, strict=True):
        n = len(y_i)
        if segment is None or segment >= n:
            bounds = [0, n]
        else:
            bounds = [i * segment for i in range(n // segment)] + [n]
        for a, b in itertools.pairwise(bounds):
            pieces_U.append(u_i[a:b])
            pieces_Y.append(y_i[a:b])
    if len(pieces_U) == 1:
        return model.fit_simulation(pieces_U[0], pieces_Y[0])
    return model.fit_simulation(pieces_U, pieces_Y)


# -- coupled electric drives --------------------------------------------------
def ced(x, u, *, xp, K, tau, w, zeta, tau_f):
    """Two motors driving a pulley through a belt, seen by an unsigned speed sensor.

    The data sheet's structure (Wigren & Schoukens 2017): the motors' torque
    follows the input with a first-order lag ``tau``, the belt and pulley are a
    resonance ``w`` (rad/s) with damping ``zeta``, and the pulse counter measures
    the pulley's speed without its sign, behind an analogue low-pass filter
    ``tau_f``: ``m' = (K u - m) / tau``, ``p'' = w^2 (m - p) - 2 zeta w p'``,
    ``f' = (|p| - f) / tau_f``, output ``f``.
    """
    m, p, q, f = x[:, 0], x[:, 1], x[:, 2], x[:, 3]
    return xp.stack(
        [
            (K * u[:, 0] - m) / tau,
            q,
            w**2 * (m - p) - 2 * zeta * w * q,
            (xp.abs(p) - f) / tau_f,
        ],
        axis=1,
    )


def _ced_guess(outputs, inputs):
    """The filtered speed at the first measured value, at rest."""
    y0 = np.asarray(outputs)[:, 0, 0]
    return np.column_stack([y0, y0, 0 * y0, y0])


#: Resonance frequencies (rad/s) the coupled drives' physics is started from.
CED_STARTS = (5.0, 15.0, 30.0, 60.0)


def ced_physics(dt, *, w=15.0, max_nfev=60):
    """The coupled electric drives' grey-box :class:`StateSpaceModel`.

    Parameters
    ----------
    dt : float
        Sample period (s), ``data.dt``.
    w : float, default=15.0
        Starting resonance frequency (rad/s).
    max_nfev : int, default=60
        Most residual evaluations of the fit.

    Returns
    -------
    model : StateSpaceModel
        Unfitted; four states, the filtered speed measured.
    """
    return StateSpaceModel(
        ced,
        {"K": 1.0, "tau": 0.1, "w": float(w), "zeta": 0.3, "tau_f": 0.05},
        state_names=[
            "motor (latent)",
            "pulley velocity (latent)",
            "pulley acceleration (latent)",
            "filtered speed",
        ],
        observed=["filtered speed"],
        dt=float(dt),
        method="rk4",
        n_substeps=2,
        n_init=10,
        initial_state=_ced_guess,
        bounds={
            "tau": (1e-3, 5.0),
            "w": (0.5, 200.0),
            "zeta": (0.01, 5.0),
            "tau_f": (1e-3, 1.0),
        },
        max_nfev=max_nfev,
    )


# -- friction damper with backlash --------------------------------------------------
def band_friction(x, u, *, xp, gap, sigma, Fc, **params):
    """A band brake's dry friction (Dahl) behind a backlash (discrete time).

    The data sheet's device (a banded rotary friction damper driven in
    displacement): the band engages the drum after a gap, so the friction's
    own displacement ``s`` follows the actuator's ``d = u[:, 0]`` only beyond
    ``+-gap`` (a backlash); the friction force ``z`` follows Dahl's model in
    ``s``, ``dz/ds = sigma (1 - sign(ds) z / Fc)``, integrated exactly over
    each step (no step-size limit).
    """
    s, z = x[:, 0], x[:, 1]
    d = u[:, 0]
    s_next = xp.minimum(xp.maximum(s, d - gap), d + gap)
    ds = s_next - s
    target = xp.sign(ds) * Fc
    z_next = target + (z - target) * xp.exp(-sigma * xp.abs(ds) / Fc)
    return xp.stack([s_next, z_next], axis=1)


def band_friction_output(x, *, xp, offset, **params):
    """The load cell: the friction force plus an offset."""
    return x[:, 1:2] + offset


def _band_guess(outputs, inputs):
    """The band at the actuator's position, the force at its first measured value."""
    y0 = np.asarray(outputs)[:, 0, 0]
    d0 = np.asarray(inputs)[:, 0, 0]
    return np.column_stack([d0, y0])


def friction_damper_physics(*, max_nfev=40):
    """The friction damper's grey-box :class:`StateSpaceModel` (inches, kip).

    Parameters
    ----------
    max_nfev : int, default=40
        Most residual evaluations of the fit.

    Returns
    -------
    model : StateSpaceModel
        Unfitted; the band's displacement and the friction force are latent
        (the load cell reads the force plus an offset).
    """
    return StateSpaceModel(
        band_friction,
        {"gap": 0.05, "sigma": 50.0, "Fc": 2.0, "offset": 0.0},
        state_names=["band displacement (latent)", "friction force (latent)"],
        output=band_friction_output,
        time="discrete",
        initial_state=_band_guess,
        n_init=50,
        bounds={"gap": (0.0, 0.5), "sigma": (1.0, 1e4), "Fc": (0.01, 20.0)},
        max_nfev=max_nfev,
    )
