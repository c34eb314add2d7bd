"""The paper's experiments (section 6): systems, the model zoo, the runner, the report.

Run them from the shell with ``skhybrid run pendulum --quick`` (see
``skhybrid --help``), or from Python::

    from skhybrid.benchmarks import run_experiment, write_report
    result = run_experiment("pendulum", quick=True)
    write_report([result], "results")
"""

from skhybrid.benchmarks._claims import check_claims
from skhybrid.benchmarks._report import write_report
from skhybrid.benchmarks._runner import ExperimentResult, run_experiment
from skhybrid.benchmarks._settings import ExperimentSettings
from skhybrid.benchmarks._systems import SYSTEMS, System
from skhybrid.benchmarks._zoo import model_zoo

__all__ = [
    "SYSTEMS",
    "ExperimentResult",
    "ExperimentSettings",
    "System",
    "check_claims",
    "model_zoo",
    "run_experiment",
    "write_report",
]
