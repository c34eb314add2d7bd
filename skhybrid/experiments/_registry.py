"""The built-in systems by name, as the pipeline runs them.

The systems themselves are the modules of the catalogue,
:mod:`skhybrid.benchmarks`, each a :class:`~skhybrid.experiments.SystemSpec`;
this maps their names, and any spec, to what
:func:`~skhybrid.experiments.run_experiment` runs: a spec of the one-step
protocol as a :class:`~skhybrid.experiments.one_step._system.OneStepSystem`, a
free-run one as a :class:`~skhybrid.experiments.free_run._system.MeasuredSystem`.
"""

from skhybrid.benchmarks import MEASURED, SIMULATED
from skhybrid.experiments._protocol import OneStepWindows
from skhybrid.experiments._spec import SystemSpec
from skhybrid.experiments.free_run._system import MeasuredSystem
from skhybrid.experiments.one_step._system import OneStepSystem

__all__ = ["MEASURED_SYSTEMS", "SYSTEMS", "get_system", "system_of"]

#: The paper's simulated systems by name.
SYSTEMS = {name: OneStepSystem(module.SPEC) for name, module in SIMULATED.items()}

#: The measured benchmarks by name.
MEASURED_SYSTEMS = {
    name: MeasuredSystem(module=module) for name, module in MEASURED.items()
}


def system_of(spec):
    """The pipeline's system for ``spec``, by its protocol.

    Parameters
    ----------
    spec : SystemSpec
        A system of the one-step protocol or of the free-run one.

    Returns
    -------
    system : OneStepSystem or MeasuredSystem
        What :func:`~skhybrid.experiments.run_experiment` runs.
    """
    if isinstance(spec.protocol, OneStepWindows):
        return OneStepSystem(spec)
    return MeasuredSystem.from_spec(spec)


def get_system(system):
    """The system named ``system`` (a paper system or a measured benchmark).

    Parameters
    ----------
    system : str, SystemSpec, OneStepSystem or MeasuredSystem
        A name from ``skhybrid list``, a spec, or the system.

    Returns
    -------
    system : OneStepSystem or MeasuredSystem
        The system.
    """
    if isinstance(system, SystemSpec):
        return system_of(system)
    if not isinstance(system, str):
        return system
    known = {**SYSTEMS, **MEASURED_SYSTEMS}
    if system not in known:
        raise ValueError(
            f"system must be one of {sorted(known)}; got system={system!r}."
        )
    return known[system]
