"""Machines with known missing physics, as system specs.

The machines of :func:`skhybrid.datasets.make_missing_physics` (a mass on a
spring whose true equations add a hardening spring, Stribeck friction, a
saturating actuator, a dead zone or a second mode to the linear physics a user
writes), each as a :class:`~skhybrid.experiments.SystemSpec` of its estimation
records, its incomplete physics and two test records: ``inside`` the training
amplitude and ``beyond`` it. Run one with::

    skhybrid run --system skhybrid.benchmarks.missing_physics:hardening_spring

or ``run_system(make_spec("hardening-spring"), "runs/spring")``.
``benchmarks/bench_missing_physics.py`` compares, on each machine, the physics,
the state-space hybrid and the true structure fitted from the same records.
"""

from skhybrid.datasets import MISSING_PHYSICS_MACHINES, make_missing_physics
from skhybrid.experiments import SystemSpec

__all__ = ["MACHINES", "make_spec"]

#: The machines' names.
MACHINES = MISSING_PHYSICS_MACHINES

NOTES = (
    "A simulated machine with a known missing term: the physics is a linear "
    "mass-spring-damper; the test records are at the training amplitude "
    "('inside') and 1.5 times it ('beyond')."
)


def make_spec(name, *, n_records=3, n_samples=2000, noise=0.01, random_state=0):
    """The :class:`~skhybrid.experiments.SystemSpec` of a machine of the suite.

    Parameters
    ----------
    name : str
        The machine, one of :data:`MACHINES`.
    n_records : int, default=3
        Estimation records.
    n_samples : int, default=2000
        Samples of every record.
    noise : float, default=0.01
        Measurement noise on the position, as a fraction of its standard
        deviation.
    random_state : int, RandomState instance or None, default=0
        Seed of the forces and the noise.

    Returns
    -------
    spec : SystemSpec
        The estimation records, the incomplete physics (unfitted),
        ``n_init=20`` and the test records ``inside`` and ``beyond``.

    Examples
    --------
    >>> from skhybrid.benchmarks.missing_physics import make_spec
    >>> spec = make_spec("dead-zone", n_records=2, n_samples=400)
    >>> spec.n_init, spec.dt, [len(u) for u in spec.estimation_records()[0]]
    (20, 0.05, [400, 400])
    """
    data = make_missing_physics(
        name,
        n_records=n_records,
        n_samples=n_samples,
        noise=noise,
        random_state=random_state,
    )
    return SystemSpec(
        f"missing-physics-{name}",
        records=list(zip(data.inputs, data.outputs, strict=True)),
        physics=data.physics,
        n_init=data.n_init,
        dt=data.dt,
        tests=dict(data.tests),
        inputs=list(data.input_names),
        outputs=list(data.output_names),
        title=f"Missing physics: {name} ({data.missing})",
        unit="m",
        notes=NOTES,
    )


# One spec per machine at the default size, for ``skhybrid run --system
# skhybrid.benchmarks.missing_physics:<machine>`` (functions, so that importing
# the module simulates nothing).
def hardening_spring():
    """The hardening spring's spec (:func:`make_spec` at its defaults)."""
    return make_spec("hardening-spring")


def stribeck_friction():
    """The Stribeck friction's spec (:func:`make_spec` at its defaults)."""
    return make_spec("stribeck-friction")


def saturating_actuator():
    """The saturating actuator's spec (:func:`make_spec` at its defaults)."""
    return make_spec("saturating-actuator")


def dead_zone():
    """The dead zone's spec (:func:`make_spec` at its defaults)."""
    return make_spec("dead-zone")


def second_mode():
    """The second mode's spec (:func:`make_spec` at its defaults)."""
    return make_spec("second-mode")
