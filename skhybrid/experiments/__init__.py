"""The paper's experiments (section 6) and the measured benchmarks: one pipeline.

Systems, their model zoos, the runner, the run folder and the report. The paper's
simulated systems and the measured benchmarks (``cascaded-tanks``, ``emps``,
``silverbox``, whose files live in a folder the user names) run the same way.
Run them from the shell with ``skhybrid run pendulum --quick`` or ``skhybrid run
emps --data ../shared/data --quick`` (see ``skhybrid --help``), or from Python::

    from skhybrid.experiments import run_experiment, write_report
    result = run_experiment("pendulum", quick=True)
    write_report([result], "results")
"""

import importlib

# Names load on first use (PEP 562), so that ``skhybrid run`` can check its
# output folder (skhybrid.experiments._store) before torch and the zoo import.
_LAZY = {
    "MEASURED_SYSTEMS": "_measured",
    "PUBLISHED": "_measured",
    "SYSTEMS": "_systems",
    "ExperimentResult": "_runner",
    "ExperimentSettings": "_settings",
    "System": "_systems",
    "check_claims": "_claims",
    "model_zoo": "_zoo",
    "run_experiment": "_runner",
    "run_measured": "_measured",
    "write_report": "_report",
}

__all__ = [
    "MEASURED_SYSTEMS",
    "PUBLISHED",
    "SYSTEMS",
    "ExperimentResult",
    "ExperimentSettings",
    "System",
    "check_claims",
    "model_zoo",
    "run_experiment",
    "run_measured",
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
