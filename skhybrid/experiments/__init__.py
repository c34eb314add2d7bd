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

from skhybrid.experiments._claims import check_claims
from skhybrid.experiments._measured import MEASURED_SYSTEMS, PUBLISHED, run_measured
from skhybrid.experiments._report import write_report
from skhybrid.experiments._runner import ExperimentResult, run_experiment
from skhybrid.experiments._settings import ExperimentSettings
from skhybrid.experiments._systems import SYSTEMS, System
from skhybrid.experiments._zoo import model_zoo

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
