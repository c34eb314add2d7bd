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
# output folder (skhybrid.experiments.run._store) before torch and the zoo import.
_LAZY = {
    "MEASURED_SYSTEMS": "_registry",
    "RunFolderError": "run._store",
    "RunPlan": "run._plan",
    "RunTransaction": "run._transaction",
    "get_system": "_registry",
    "list_systems": "_catalog",
    "summary_lines": "run._console",
    "SystemSpec": "_spec",
    "load_fitted": "run._run_system",
    "run_system": "run._run_system",
    "SYSTEMS": "_registry",
    "ExperimentResult": "one_step._result",
    "OneStepSizes": "_protocol",
    "OneStepWindows": "_protocol",
    "RunSettings": "_settings",
    "check_claims": "one_step._claims",
    "hybrid_settings": "_spec",
    "model_zoo": "one_step._system",
    "run_experiment": "run._runner",
    "run_measured": "run._run_system",
    "write_report": "run._report",
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
