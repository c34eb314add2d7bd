"""The paper's experiments (section 6) and the measured benchmarks: one pipeline.

Systems, their model zoos, the runner, the run folder and the report. The paper's
simulated systems and the measured benchmarks (``cascaded-tanks``, ``emps``,
``silverbox``, ``coupled-electric-drives``, ``wiener-hammerstein``,
``friction-damper``, whose files live in a folder the user names or are fetched
once) run the same way.
Run them from the shell with ``skhybrid run pendulum --quick`` or ``skhybrid run
emps --data ../shared/data --quick`` (see ``skhybrid --help``), or from Python::

    from skhybrid.experiments import run_experiment, write_report
    result = run_experiment("pendulum", quick=True)
    write_report([result], "results")

Every system is a :class:`SystemSpec`. The paper's three are specs of its
one-step protocol (``protocol=OneStepWindows(...)``: simulators as records and
tests, the paper's zoo scored one step ahead), run by :func:`run_experiment`.
A user's own machine is a :class:`SystemSpec` (records, sample period,
initialisation window, physics, test records) run by :func:`run_system`, or by
``skhybrid run --system module:object``: the same candidate family, chosen by
blocked cross-validation of the estimation records (searched at the first seed,
refitted at each), with the
selection sealed before the test records are read. Both run a :class:`RunPlan`
(one identity, however the run was started) inside a :class:`RunTransaction`, the
run folder's life cycle, as ``skhybrid run`` does. The built-in systems are the
catalogue :mod:`skhybrid.benchmarks`, one module each;
:func:`skhybrid.benchmarks.benchmark_spec` returns a measured benchmark's spec.
"""

import importlib

# Names load on first use (PEP 562), so that ``skhybrid run`` can check its
# output folder (skhybrid.experiments._store) before torch and the zoo import.
_LAZY = {
    "MEASURED_SYSTEMS": "_registry",
    "RunFolderError": "_store",
    "RunPlan": "_run_plan",
    "RunTransaction": "_transaction",
    "get_system": "_registry",
    "list_systems": "_catalog",
    "summary_lines": "_console",
    "SystemSpec": "_spec",
    "load_fitted": "_run_system",
    "run_system": "_run_system",
    "SYSTEMS": "_registry",
    "ExperimentResult": "_simulated",
    "OneStepSizes": "_protocol",
    "OneStepWindows": "_protocol",
    "RunSettings": "_settings",
    "check_claims": "_claims",
    "hybrid_settings": "_spec",
    "model_zoo": "_one_step",
    "run_experiment": "_runner",
    "run_measured": "_run_system",
    "write_report": "_report",
}

__all__ = [
    "MEASURED_SYSTEMS",
    "SYSTEMS",
    "ExperimentResult",
    "OneStepSizes",
    "OneStepWindows",
    "RunFolderError",
    "RunPlan",
    "RunSettings",
    "RunTransaction",
    "SystemSpec",
    "check_claims",
    "get_system",
    "hybrid_settings",
    "list_systems",
    "load_fitted",
    "model_zoo",
    "run_experiment",
    "run_measured",
    "run_system",
    "summary_lines",
    "write_report",
]


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted({*globals(), *_LAZY})
