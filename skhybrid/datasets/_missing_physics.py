"""Machines with known missing physics: a true system and the physics a user writes.

Each machine is a mass on a spring driven by a force, whose position alone is
measured (the velocity is latent). The true system has one term the user's
physics, a linear mass-spring-damper, does not: a hardening spring, Coulomb and
Stribeck friction, a saturating actuator, an actuator's dead zone, or a second
mode. Both are :class:`~skhybrid.domain.StateSpaceModel` instances, so the
true structure can be fitted from the same records (the reference a hybrid
should approach) and the physics is what a hybrid starts from.
"""

import numpy as np
from sklearn.base import clone
from sklearn.utils import Bunch, check_random_state

from skhybrid.datasets._base import _check_int, _check_real
from skhybrid.domain import StateSpaceModel, stribeck_friction

__all__ = ["MISSING_PHYSICS_MACHINES", "make_missing_physics"]

#: Sample period of every machine (s).
DT = 0.05
#: Samples of every machine's initialisation window (1 s).
N_INIT = 20
#: Samples simulated and dropped before each record starts, so that records
#: start in motion rather than at rest.
_BURN_IN = 100
#: Runge-Kutta steps per sample of the simulation that makes the data; the
#: models integrate with ``_MODEL_SUBSTEPS``, as a user's model would.
_DATA_SUBSTEPS = 10
_MODEL_SUBSTEPS = 2
#: Each force level is held for this many samples (drawn uniformly, inclusive).
_HOLD = (4, 40)
#: The amplitude of the test record beyond the training amplitude, as a factor.
BEYOND = 1.5


def mass_spring_damper(x, u, *, xp, mass, k, c):
    """The physics a user writes: a linear mass-spring-damper, force ``u``."""
    position, velocity = x[:, 0], x[:, 1]
    accel = (u[:, 0] - k * position - c * velocity) / mass
    return xp.stack([velocity, accel], axis=1)


def hardening_spring(x, u, *, xp, mass, k, k3, c):
    """A spring that stiffens: the restoring force ``k x + k3 x**3``."""
    position, velocity = x[:, 0], x[:, 1]
    accel = (u[:, 0] - k * position - k3 * position**3 - c * velocity) / mass
    return xp.stack([velocity, accel], axis=1)


def stribeck_slider(x, u, *, xp, mass, k, c, Fc, Fs, vs, eps):
    """Viscous, Coulomb and Stribeck friction (breakaway ``Fs`` falling to ``Fc``)."""
    position, velocity = x[:, 0], x[:, 1]
    friction = stribeck_friction(velocity, xp=xp, Fc=Fc, Fs=Fs, vs=vs, Fv=c, eps=eps)
    accel = (u[:, 0] - k * position - friction) / mass
    return xp.stack([velocity, accel], axis=1)


def saturating_actuator(x, u, *, xp, mass, k, c, u_max):
    """An actuator whose force saturates smoothly at ``u_max``."""
    position, velocity = x[:, 0], x[:, 1]
    force = u_max * xp.tanh(u[:, 0] / u_max)
    accel = (force - k * position - c * velocity) / mass
    return xp.stack([velocity, accel], axis=1)


def _relu(z):
    # Written with abs so that it runs on NumPy and torch alike, also where
    # the dead zone's width is a tensor.
    return 0.5 * (z + abs(z))


def dead_zone_actuator(x, u, *, xp, mass, k, c, width):
    """An actuator that gives no force for commands within ``+-width``."""
    position, velocity = x[:, 0], x[:, 1]
    force = _relu(u[:, 0] - width) - _relu(-u[:, 0] - width)
    accel = (force - k * position - c * velocity) / mass
    return xp.stack([velocity, accel], axis=1)


def two_masses(x, u, *, xp, mass, k, c, mass2, k2, c2):
    """A second mass on a spring behind the first: an unmodelled second mode."""
    p1, v1, p2, v2 = x[:, 0], x[:, 1], x[:, 2], x[:, 3]
    coupling = k2 * (p2 - p1) + c2 * (v2 - v1)
    a1 = (u[:, 0] - k * p1 - c * v1 + coupling) / mass
    a2 = -coupling / mass2
    return xp.stack([v1, a1, v2, a2], axis=1)


_LINEAR = {"mass": 1.0, "k": 4.0, "c": 0.5}

#: Each machine: its true equations and constants, what they add to the
#: physics, its state names and the training amplitude of the force.
_MACHINES = {
    "hardening-spring": {
        "rhs": hardening_spring,
        "params": {**_LINEAR, "k3": 8.0},
        "amplitude": 4.0,
        "missing": "a cubic spring k3 x**3 (hardening)",
    },
    "stribeck-friction": {
        "rhs": stribeck_slider,
        "params": {**_LINEAR, "c": 0.3, "Fc": 0.6, "Fs": 1.0, "vs": 0.1, "eps": 0.02},
        "fixed": ("eps",),
        "amplitude": 3.0,
        "missing": "Coulomb and Stribeck friction (Fc, Fs, vs)",
    },
    "saturating-actuator": {
        "rhs": saturating_actuator,
        "params": {**_LINEAR, "u_max": 2.0},
        "amplitude": 3.0,
        "missing": "a saturation of the force, u_max tanh(u / u_max)",
    },
    "dead-zone": {
        "rhs": dead_zone_actuator,
        "params": {**_LINEAR, "width": 0.6},
        "amplitude": 3.0,
        "missing": "a dead zone of the force, +-width",
    },
    "second-mode": {
        "rhs": two_masses,
        "params": {**_LINEAR, "mass2": 1.0, "k2": 8.0, "c2": 0.2},
        "states": ["position", "velocity", "position2", "velocity2"],
        "amplitude": 3.0,
        "missing": "a second mass behind a spring (a second mode, two states)",
    },
}

#: The machines' names, for :func:`make_missing_physics`.
MISSING_PHYSICS_MACHINES = tuple(_MACHINES)

#: The physics' start: what a user might guess, not the truth.
_PHYSICS_START = {"mass": 1.5, "k": 2.0, "c": 1.0}

_DESCR = """\
{name}: a machine with known missing physics
--------------------------------------------

A mass on a spring, driven by a force held at random levels (uniform in
+-{amplitude:g} N, each held 0.2-2 s), position measured every {dt:g} s with
Gaussian noise of {noise:g} times the position's standard deviation; the
velocity is latent. The true system adds {missing} to the physics a user
writes, a linear mass-spring-damper m x'' = u - k x - c x'.

Estimation records: {n_records} of {n_samples} samples. Test records: "inside"
(the training amplitude, other draws) and "beyond" ({beyond:g} times it), each
of {n_samples} samples. Every record starts in motion ({burn_in} samples
simulated before it). The data are simulated with {data_substeps} Runge-Kutta
steps per sample; the models integrate with {model_substeps}.
"""


def _check_name(name):
    if not isinstance(name, str) or name not in _MACHINES:
        raise ValueError(
            f"name must be one of {list(MISSING_PHYSICS_MACHINES)}; got name={name!r}."
        )
    return name


def _model(rhs, params, states, fixed=(), n_substeps=_MODEL_SUBSTEPS):
    return StateSpaceModel(
        rhs,
        dict(params),
        state_names=list(states),
        observed=["position"],
        dt=DT,
        n_substeps=n_substeps,
        n_init=N_INIT,
        fixed=tuple(fixed),
        bounds={p: (1e-6, np.inf) for p in params if p not in fixed},
        vectorized=True,
    )


def _forces(rng, n_times, amplitude):
    n_holds = n_times // _HOLD[0] + 1
    durations = rng.randint(_HOLD[0], _HOLD[1] + 1, n_holds)
    levels = rng.uniform(-amplitude, amplitude, n_holds)
    return np.repeat(levels, durations)[:n_times, None]


def make_missing_physics(
    name, *, n_records=3, n_samples=2000, noise=0.01, random_state=0
):
    """Simulate a machine whose physics misses a known term.

    Each machine is a mass on a spring driven by a force ``u``, its position
    measured (the velocity latent). Its true equations add one term to the
    physics a user writes, a linear mass-spring-damper ``m x'' = u - k x - c
    x'``:

    - ``"hardening-spring"``: a cubic spring ``k3 x**3``;
    - ``"stribeck-friction"``: Coulomb and Stribeck friction
      (:func:`~skhybrid.domain.stribeck_friction`) beside the viscous one;
    - ``"saturating-actuator"``: the force saturates, ``u_max tanh(u / u_max)``;
    - ``"dead-zone"``: the actuator gives no force within ``+-width``;
    - ``"second-mode"``: a second mass on a spring behind the first (two
      states the physics lacks).

    Both are returned as :class:`~skhybrid.domain.StateSpaceModel` instances:
    the physics to start a hybrid from, and the true structure, whose fit by
    simulation error from the same records is the reference a hybrid should
    approach. :func:`skhybrid.benchmarks.missing_physics.make_spec` wraps the
    same records in a :class:`~skhybrid.experiments.SystemSpec`.

    Parameters
    ----------
    name : str
        The machine, one of :data:`MISSING_PHYSICS_MACHINES`.
    n_records : int, default=3
        Estimation records.
    n_samples : int, default=2000
        Samples of every record (estimation and test); at least ``4 * n_init``
        (80).
    noise : float, default=0.01
        Standard deviation of the Gaussian noise on the measured position, as
        a fraction of the noise-free position's standard deviation over the
        estimation records (the same absolute level on the test records).
    random_state : int, RandomState instance or None, default=0
        Seed of the forces and the noise.

    Returns
    -------
    data : :class:`~sklearn.utils.Bunch`
        Dictionary-like object with:

        inputs, outputs : list of ndarray of shape (n_samples, 1)
            Force and measured position of each estimation record;
            ``inputs[r][t]`` acts between samples ``t`` and ``t + 1``.
        outputs_clean : list of ndarray of shape (n_samples, 1)
            The positions without noise.
        tests : dict
            ``{"inside": (u, y), "beyond": (u, y)}``: a record at the training
            amplitude (other draws) and one at ``1.5`` times it, measured with
            the same noise.
        tests_clean : dict
            Their positions without noise.
        physics : StateSpaceModel
            The physics a user writes (unfitted): ``mass``, ``k``, ``c`` free,
            from a rough start.
        true_model : StateSpaceModel
            The true structure (unfitted), its parameters starting at the
            true values (the ones listed in its ``fixed`` are held there); its
            ``fit_simulation`` on ``inputs``, ``outputs`` is the reference.
        true_params : dict
            The true constants.
        missing : str
            What the physics misses, in words.
        amplitude : float
            Training amplitude of the force (N); the test record beyond it
            reaches ``1.5`` times it.
        noise_std : float
            The noise's standard deviation (m).
        dt : float
            Sample period (s), 0.05.
        n_init : int
            Initialisation window of every free run (20 samples).
        state_names, input_names, output_names : list of str
            The true model's states, ``["force"]`` and ``["position"]``.
        name : str
            The machine.
        DESCR : str
            Description of the data.

    See Also
    --------
    skhybrid.benchmarks.missing_physics.make_spec : The same as a system spec.
    skhybrid.hybrid.StateSpaceHybridRegressor : The hybrid these test.

    Examples
    --------
    >>> from skhybrid.datasets import make_missing_physics
    >>> data = make_missing_physics("hardening-spring", n_records=2, n_samples=200)
    >>> len(data.inputs), data.outputs[0].shape, sorted(data.tests)
    (2, (200, 1), ['beyond', 'inside'])
    >>> sorted(data.physics.params), data.missing
    (['c', 'k', 'mass'], 'a cubic spring k3 x**3 (hardening)')
    """
    name = _check_name(name)
    n_records = _check_int(n_records, "n_records", 1)
    n_samples = _check_int(n_samples, "n_samples", 4 * N_INIT)
    noise = _check_real(noise, "noise", low=0.0)
    rng = check_random_state(random_state)
    machine = _MACHINES[name]
    states = machine.get("states", ["position", "velocity"])
    fixed = machine.get("fixed", ())
    truth = dict(machine["params"])
    amplitude = machine["amplitude"]

    true_model = _model(machine["rhs"], truth, states, fixed)
    generator = clone(true_model).set_params(
        n_substeps=_DATA_SUBSTEPS, fixed=tuple(truth)
    )
    generator.initialize()
    n_times = n_samples + _BURN_IN
    levels = [amplitude] * (n_records + 1) + [BEYOND * amplitude]
    U = np.stack([_forces(rng, n_times, a) for a in levels])
    clean = generator.simulate_from_state(U, np.zeros((len(U), len(states))))
    U, clean = U[:, _BURN_IN:], np.asarray(clean)[:, _BURN_IN:]
    noise_std = noise * float(np.std(clean[:n_records]))
    measured = clean + noise_std * rng.standard_normal(clean.shape)

    physics = _model(mass_spring_damper, _PHYSICS_START, ["position", "velocity"])
    data = Bunch(
        inputs=list(U[:n_records]),
        outputs=list(measured[:n_records]),
        outputs_clean=list(clean[:n_records]),
        tests={
            "inside": (U[n_records], measured[n_records]),
            "beyond": (U[n_records + 1], measured[n_records + 1]),
        },
        tests_clean={"inside": clean[n_records], "beyond": clean[n_records + 1]},
        physics=physics,
        true_model=true_model,
        true_params=truth,
        missing=machine["missing"],
        amplitude=amplitude,
        noise_std=noise_std,
        dt=DT,
        n_init=N_INIT,
        state_names=list(states),
        input_names=["force"],
        output_names=["position"],
        name=name,
    )
    # The description reads the machine's name, amplitude, missing term and dt
    # from the Bunch it describes.
    data.DESCR = _DESCR.format(
        **data,
        noise=noise,
        n_records=n_records,
        n_samples=n_samples,
        beyond=BEYOND,
        burn_in=_BURN_IN,
        data_substeps=_DATA_SUBSTEPS,
        model_substeps=_MODEL_SUBSTEPS,
    )
    return data
