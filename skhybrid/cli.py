"""The ``skhybrid`` command: run the paper's experiments and write a report."""

import argparse
import importlib.util
import shlex
import sys
import time

__all__ = ["main"]

DESCRIPTION = """\
Hybrid physics / neural / stochastic models of dynamical systems.

`skhybrid run SYSTEM` simulates the system, fits the paper's model zoo (physics
alone, a linear state-space model, dense, recurrent and cyclic networks, and the
physics+network hybrids), scores every model on interpolative and extrapolative
test sets, and writes results.csv, results.json, the figures and a self-contained
report.html to the output folder.
"""

EPILOG = """\
examples:
  skhybrid list                          the systems you can run
  skhybrid run pendulum --quick          a small run, about a minute on 2 cores
  skhybrid run pendulum --out results    the full pendulum run (under 10 minutes)
  skhybrid run all --n-jobs 2 --seed 1   every system, two models at a time
"""


class _Parser(argparse.ArgumentParser):
    """Report bad arguments on one line and exit with status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value == 0 or value < -1:
        raise argparse.ArgumentTypeError(
            f"expected a positive integer or -1 (all cores), got {text!r}"
        )
    return value


def _seed(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a seed >= 0, got {text!r}")
    return value


def _build_parser():
    from skhybrid.experiments import SYSTEMS

    parser = _Parser(
        prog="skhybrid",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", metavar="{run,list}")
    sub.required = True
    run = sub.add_parser(
        "run",
        help="run the paper's experiment on a system and write the report",
        description="Fit the model zoo on SYSTEM and write the report to --out.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.error = parser.error  # one-line errors for the subcommand too
    run.add_argument(
        "system",
        choices=[*SYSTEMS, "all"],
        metavar="SYSTEM",
        help="one of: " + ", ".join([*SYSTEMS, "all"]),
    )
    run.add_argument(
        "--quick",
        action="store_true",
        help="small data and few epochs: about a minute on 2 cores",
    )
    run.add_argument(
        "--out",
        default="skhybrid-results",
        metavar="DIR",
        help="output folder (default: skhybrid-results)",
    )
    run.add_argument(
        "--n-jobs",
        type=_positive_int,
        default=2,
        metavar="N",
        help="models fitted in parallel; -1 uses every core (default: 2)",
    )
    run.add_argument(
        "--seed", type=_seed, default=0, metavar="S", help="seed of data and models"
    )
    run.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    sub.add_parser("list", help="list the systems and what they show")
    return parser


#: What ``skhybrid run`` imports, and how to install each: checked before any
#: training starts, so a missing piece never costs a finished run.
RUN_REQUIREMENTS = {
    "torch": "pip install -c constraints.txt torch",
    "skorch": "pip install skorch",
    "statsmodels": "pip install statsmodels",
    "matplotlib": "pip install matplotlib",
}


def missing_requirements(modules=RUN_REQUIREMENTS):
    """One line per module in ``modules`` that cannot be imported.

    Parameters
    ----------
    modules : dict of str to str, default=RUN_REQUIREMENTS
        Module names and the command that installs each.

    Returns
    -------
    lines : list of str
        ``"<module>, which is not installed; install it with `<command>`"`` for each
        missing module, in order; empty when everything is there.
    """
    lines = []
    for module, command in modules.items():
        if importlib.util.find_spec(module) is None:
            lines.append(
                f"{module}, which is not installed; install it with `{command}`"
            )
    return lines


def _list(out):
    from skhybrid.experiments import SYSTEMS

    for name, system in SYSTEMS.items():
        splits = ", ".join(system.split_descriptions())
        out.write(f"{name:<16} {system.title} (section {system.section}; {splits})\n")


def main(argv=None):
    """Entry point of the ``skhybrid`` command; returns the exit status."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    if args.command == "list":
        _list(sys.stdout)
        return 0

    missing = missing_requirements()
    if missing:
        for line in missing:
            sys.stderr.write(f"skhybrid: error: `skhybrid run` needs {line}\n")
        return 2

    from skhybrid.experiments import SYSTEMS, run_experiment, write_report

    start = time.perf_counter()
    names = list(SYSTEMS) if args.system == "all" else [args.system]
    results = [
        run_experiment(
            name,
            quick=args.quick,
            seed=args.seed,
            n_jobs=args.n_jobs,
            progress=not args.no_progress,
        )
        for name in names
    ]
    wall = time.perf_counter() - start
    command = "skhybrid " + shlex.join(sys.argv[1:] if argv is None else argv)
    paths = write_report(results, args.out, command=command, wall_time=wall)
    total = time.perf_counter() - start
    sys.stdout.write(f"wrote {paths['html']} ({total:.1f} s)\n")
    if args.quick:
        sys.stdout.write(
            "  --quick trains on small data for a few epochs: the paper's claims "
            "below are judged on the full run\n"
        )
    for result in results:
        from skhybrid.experiments import check_claims

        for claim in check_claims(result):
            word = "holds" if claim["passed"] else "FAILS"
            sys.stdout.write(f"  [{word}] {claim['claim']}: {claim['detail']}\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
