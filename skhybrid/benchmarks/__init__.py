"""The built-in systems, one module each: a catalogue of specs.

Every module holds everything that makes its system special, in the form a user
writes for their own machine: where its records come from, its physics, its
departures from the default candidate family with the reason (``NOTES``), and
the published figures with their protocol and source (``PUBLISHED``). A
measured benchmark's facts known before its files are read (``NAME``,
``TITLE``, ``UNIT``, ``SCALE``, ``PUBLISHED``, ``NOTES``, ``HYBRIDS``) are
constants of its module, their one owner; its spec reads them there.

The paper's simulated systems (section 6):

- :mod:`~skhybrid.benchmarks.pendulum`: the inverted pendulum (6.1);
- :mod:`~skhybrid.benchmarks.double_pendulum`: the double pendulum (6.2);
- :mod:`~skhybrid.benchmarks.dc_motor`: the DC motor with backlash (6.3).

The measured benchmarks, each with ``make_spec(data=None, *, quick=False)``
returning its :class:`~skhybrid.experiments.SystemSpec`:

- :mod:`~skhybrid.benchmarks.cascaded_tanks`;
- :mod:`~skhybrid.benchmarks.emps`;
- :mod:`~skhybrid.benchmarks.silverbox`;
- :mod:`~skhybrid.benchmarks.coupled_electric_drives`;
- :mod:`~skhybrid.benchmarks.wiener_hammerstein`;
- :mod:`~skhybrid.benchmarks.friction_damper`.

Run one with ``skhybrid run NAME`` (``--data DIR`` for a measured one), or::

    from skhybrid.benchmarks import benchmark_spec
    from skhybrid.experiments import run_system
    run_system(benchmark_spec("emps", "data/"), "emps-run")
"""

from skhybrid.benchmarks import (
    cascaded_tanks,
    coupled_electric_drives,
    dc_motor,
    double_pendulum,
    emps,
    friction_damper,
    pendulum,
    silverbox,
    wiener_hammerstein,
)

__all__ = ["MEASURED", "PUBLISHED", "SIMULATED", "benchmark_spec"]

#: The paper's simulated systems by name, each a module with ``SPEC`` (a spec of
#: the one-step protocol).
SIMULATED = {m.NAME: m for m in (pendulum, double_pendulum, dc_motor)}

#: The measured benchmarks by name, each a module with ``make_spec``.
MEASURED = {
    m.NAME: m
    for m in (
        cascaded_tanks,
        emps,
        silverbox,
        coupled_electric_drives,
        wiener_hammerstein,
        friction_damper,
    )
}

#: Published free-run RMSE of each measured benchmark, in its official units:
#: ``{benchmark: {test: {label: (rmse, source)}}}``.
PUBLISHED = {name: m.PUBLISHED for name, m in MEASURED.items() if m.PUBLISHED}


def benchmark_spec(name, data=None, *, quick=False):
    """The :class:`~skhybrid.experiments.SystemSpec` of a built-in measured benchmark.

    The built-in benchmarks are specs of the same public form a user writes for
    their own machine; this returns one to read, change or run with
    :func:`~skhybrid.experiments.run_system`.

    Parameters
    ----------
    name : str
        The benchmark: ``"cascaded-tanks"``, ``"emps"``, ``"silverbox"``,
        ``"coupled-electric-drives"``, ``"wiener-hammerstein"`` or
        ``"friction-damper"`` (``skhybrid list``).
    data : str or Path or None, default=None
        Folder holding its files; None fetches them once into the data home.
    quick : bool, default=False
        The quick form (a shorter Silverbox or Wiener-Hammerstein estimation
        record, the friction damper's 1 Hz tests).

    Returns
    -------
    spec : SystemSpec
        The estimation records loaded; the test records load when called.
    """
    if name not in MEASURED:
        raise ValueError(f"name must be one of {sorted(MEASURED)}; got name={name!r}.")
    return MEASURED[name].make_spec(data, quick=quick)
