"""The built-in systems by name, as the pipeline runs them.

The systems themselves are the modules of the catalogue,
:mod:`skhybrid.benchmarks`; this maps their names to what
:func:`~skhybrid.experiments.run_experiment` runs.
"""

from skhybrid.benchmarks import MEASURED, SIMULATED
from skhybrid.experiments._measured_system import MeasuredSystem

__all__ = ["MEASURED_SYSTEMS", "SYSTEMS", "get_system"]

#: The paper's simulated systems by name.
SYSTEMS = {name: module.SYSTEM for name, module in SIMULATED.items()}

#: The measured benchmarks by name.
MEASURED_SYSTEMS = {
    name: MeasuredSystem(module=module) for name, module in MEASURED.items()
}


def get_system(system):
    """The system named ``system`` (a paper system or a measured benchmark).

    Parameters
    ----------
    system : str or System or MeasuredSystem
        A name from ``skhybrid list``, or the system.

    Returns
    -------
    system : System or MeasuredSystem
        The system.
    """
    if not isinstance(system, str):
        return system
    known = {**SYSTEMS, **MEASURED_SYSTEMS}
    if system not in known:
        raise ValueError(
            f"system must be one of {sorted(known)}; got system={system!r}."
        )
    return known[system]
