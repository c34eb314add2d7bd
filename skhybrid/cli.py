"""The ``skhybrid`` command: run the paper's experiments and write a report."""

import argparse
import contextlib
import importlib.util
import logging
import os
import shlex
import signal
import sys
import time

__all__ = ["main"]

DESCRIPTION = """\
Hybrid physics / neural / stochastic models of dynamical systems.

`skhybrid run SYSTEM` simulates the system, fits the paper's model zoo (physics
alone, a linear state-space model, dense, recurrent and cyclic networks, and the
physics+network hybrids), scores every model on interpolative and extrapolative
test sets, and writes results.csv, results.json, the figures and a self-contained
report.html to the output folder. `skhybrid run cascaded-tanks` (or emps,
silverbox, coupled-electric-drives, wiener-hammerstein, friction-damper) does
the same for a measured benchmark, scored by its official protocol beside
the published figures: its files come from --data DIR, or are downloaded once
into the data home ($SKHYBRID_DATA, else ~/skhybrid_data) and checked.
`skhybrid run --system module:object` runs your own machine's SystemSpec the
same way. A measured run chooses every model by blocked cross-validation of
the estimation records at the first seed and refits each choice at every seed
(--seeds, default 0 1 2), writes the sealed
selection (selection.json, with its SHA-256) and only then reads the test
records.
"""

EPILOG = """\
examples:
  skhybrid list                          the systems you can run
  skhybrid run pendulum --quick          a small run, about a minute on 2 cores
  skhybrid run pendulum --out results    the full pendulum run (under 10 minutes)
  skhybrid run all --n-jobs 2 --seeds 1  every system, two models at a time
  skhybrid run pendulum --resume         finish an interrupted run, same report
  skhybrid run all --dask HOST:8786      fit the models on a Dask cluster
  skhybrid run emps --data ../shared/data --quick
                                         a measured benchmark (files in --data;
                                         without it, downloaded once)
  skhybrid run --system my_machine:spec --out runs/mine
                                         your own machine (a SystemSpec)

Every model's scores and fitted model are written to --out as soon as it
finishes; after a Ctrl-C, the same command (or with --resume) carries on.
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


#: Largest seed: numpy's and scikit-learn's seeds are 32-bit unsigned integers.
MAX_SEED = 2**32 - 1


def _seed(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(
            f"expected a seed between 0 and {MAX_SEED} (2**32 - 1), got {text!r}"
        )
    return value


def _folder(text):
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder, got an empty path")
    return text


#: The systems ``skhybrid run`` knows: the paper's simulated ones, then the
#: measured benchmarks (the keys of ``SYSTEMS`` and ``MEASURED_SYSTEMS``; a test
#: checks). Named here so that arguments and the output folder are checked
#: before the experiments (torch, the zoos) are imported.
SIMULATED_SYSTEMS = ("pendulum", "double-pendulum", "dc-motor")
MEASURED_SYSTEMS = (
    "cascaded-tanks",
    "emps",
    "silverbox",
    "coupled-electric-drives",
    "wiener-hammerstein",
    "friction-damper",
)


def _build_parser():
    parser = _Parser(
        prog="skhybrid",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from skhybrid import __version__

    parser.add_argument(
        "--version", action="version", version=f"skhybrid {__version__}"
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
        nargs="?",
        choices=[*SIMULATED_SYSTEMS, "all", *MEASURED_SYSTEMS],
        metavar="SYSTEM",
        help="one of: "
        + ", ".join([*SIMULATED_SYSTEMS, "all", *MEASURED_SYSTEMS])
        + f" (the last {len(MEASURED_SYSTEMS)} are measured benchmarks: --data, or "
        "downloaded)",
    )
    run.add_argument(
        "--system",
        dest="spec",
        metavar="MODULE:OBJECT",
        help="your own measured system: a skhybrid.experiments.SystemSpec (or a "
        "function of no argument returning one) importable as MODULE:OBJECT "
        "(the current folder is searched first)",
    )
    run.add_argument(
        "--data",
        type=_folder,
        metavar="DIR",
        help="folder holding the measured benchmark files (for example a clone's "
        "../shared/data); without it a measured system downloads its files once "
        "into the data home ($SKHYBRID_DATA, else ~/skhybrid_data)",
    )
    run.add_argument(
        "--quick",
        action="store_true",
        help="small data and few epochs: about a minute on 2 cores",
    )
    run.add_argument(
        "--out",
        type=_folder,
        default="skhybrid-results",
        metavar="DIR",
        help="output folder (default: skhybrid-results)",
    )
    run.add_argument(
        "--n-jobs",
        type=_positive_int,
        default=2,
        metavar="N",
        help="joblib workers: a simulated system's models, or a measured "
        "system's (candidate, fold) fits, run in parallel; -1 uses every core "
        "(default: 2)",
    )
    run.add_argument(
        "--seeds",
        type=_seed,
        nargs="+",
        default=None,
        metavar="S",
        help="seeds, 0 to 2**32 - 1: a measured run searches at the first and "
        "refits each choice at every seed, and reports the mean and spread over "
        "them (default: 0 1 2); a "
        "simulated system runs one, the seed of its data and models (default: 0)",
    )
    # The former one-seed option, kept working: --seed S is --seeds S.
    run.add_argument("--seed", type=_seed, default=None, help=argparse.SUPPRESS)
    run.add_argument(
        "--noise-type",
        choices=["measurement", "process"],
        default=None,
        help="where the simulators' noise enters: on the measured states (the "
        "paper's setting) or into the dynamics, which makes the true model's "
        "one-step residual white (default: process for double-pendulum, "
        "measurement for the others)",
    )
    run.add_argument(
        "--device",
        choices=["cpu", "cuda"],
        default="cpu",
        help="where every network of the run trains (the physics stays on the "
        "CPU); cuda needs a CUDA device (default: cpu)",
    )
    run.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    again = run.add_mutually_exclusive_group()
    again.add_argument(
        "--resume",
        action="store_true",
        help="carry on a run in --out: skip its finished models (the same command "
        "without --resume also carries on an unfinished run)",
    )
    again.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a finished run (or other results) already in --out",
    )
    run.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="fit the models on the Dask cluster whose scheduler is at ADDRESS "
        "(e.g. tcp://host:8786), or on a local cluster of --n-jobs workers with "
        "'local'; needs dask[distributed]",
    )
    listing = sub.add_parser(
        "list", help="list the systems, their kind and what they show"
    )
    listing.add_argument(
        "--data",
        metavar="DIR",
        help="also say whether each measured benchmark's files are in DIR "
        "(default: the data home, $SKHYBRID_DATA or ~/skhybrid_data)",
    )
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


#: How long ``skhybrid run --dask ADDRESS`` tries to reach the scheduler.
DASK_CONNECT_TIMEOUT = "10s"

#: What ``skhybrid run --dask`` imports in addition.
DASK_REQUIREMENTS = {
    "distributed": 'pip install "dask[distributed]" (the skhybrid[dask] extra)',
}


def _list(out, data=None):
    from skhybrid.experiments import list_systems

    for name, kind, title, shows, where in list_systems(data):
        extra = "" if where is None else f"; {where}"
        out.write(f"{name:<24} {kind:<9} {title} ({shows}{extra})\n")


def _error(message):
    sys.stderr.write(f"skhybrid: error: {message}\n")


class _SpecError(Exception):
    pass


def _load_spec(text):
    """The SystemSpec named ``module:object`` (the current folder searched first)."""
    from skhybrid.experiments import SystemSpec

    module_name, sep, attr = text.partition(":")
    if not sep or not module_name or not attr:
        raise _SpecError(
            f"--system expects MODULE:OBJECT (a SystemSpec importable as "
            f"module.object); got --system {text!r}"
        )
    if os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise _SpecError(
            f"--system {text}: cannot import {module_name}: {exc}"
        ) from None
    except (TypeError, ValueError) as exc:
        # A SystemSpec built at import is checked then: its one-line message.
        raise _SpecError(f"--system {text}: {exc}") from None
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise _SpecError(f"--system {text}: {module_name} has no {attr}")
        obj = getattr(obj, part)
    if callable(obj) and not isinstance(obj, SystemSpec):
        try:
            obj = obj()
        except (TypeError, ValueError) as exc:
            raise _SpecError(f"--system {text}: {exc}") from None
    if not isinstance(obj, SystemSpec):
        raise _SpecError(
            f"--system {text} is a {type(obj).__name__}, not a "
            "skhybrid.experiments.SystemSpec (or a function returning one)"
        )
    return obj


def _resume_command(argv):
    """The command line that carries on this run."""
    words = [w for w in argv if w != "--overwrite"]
    if "--resume" not in words:
        words.append("--resume")
    return "skhybrid " + shlex.join(words)


@contextlib.contextmanager
def _dask_backend(address, n_workers):
    """joblib's Dask backend on the cluster at ``address`` (or a local one)."""
    import joblib
    from dask.distributed import Client, LocalCluster

    cluster = None
    try:
        if address == "local":
            # Worker processes started while SIGINT is ignored keep ignoring it: a
            # Ctrl-C reaches this process alone, which stops and closes them.
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                # One thread per worker process: each fits one model at a time.
                cluster = LocalCluster(
                    n_workers=n_workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0",  # any free port: 8787 may be taken
                    silence_logs=logging.ERROR,
                )
            finally:
                signal.signal(signal.SIGINT, previous)
            client = Client(cluster)
        else:
            client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as exc:
        if cluster is not None:
            cluster.close()
        raise _DaskError(
            f"cannot reach the Dask scheduler at {address}: {exc}"
        ) from None
    try:
        with joblib.parallel_config(backend="dask"):
            yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class _DaskError(Exception):
    pass


def _check_run_args(args):
    """One line for arguments that do not fit together, or None."""
    measured = args.system in MEASURED_SYSTEMS
    if (args.system is None) == (args.spec is None):
        return "give one system: SYSTEM, or --system MODULE:OBJECT for your own"
    # Seeds and --noise-type are checked by the run's plan, for a spec as for a
    # built-in system: they depend on its protocol.
    if args.spec is None and not measured and args.data is not None:
        return (
            f"--data names a measured benchmark's files; {args.system} is "
            "simulated: drop --data, or run one of " + ", ".join(MEASURED_SYSTEMS)
        )
    if args.spec is not None and args.data is not None:
        return (
            "--data names a built-in benchmark's files; a --system spec holds its own"
        )
    if args.seed is not None and args.seeds is not None:
        return "give --seeds S [S ...] once (--seed S is the same option)"
    if args.device == "cuda":
        from skhybrid.neural.engine import check_device  # imports torch

        try:
            check_device(args.device)
        except ValueError as exc:
            return f"--device cuda: {exc}"
    if args.seed is not None:
        args.seeds = [args.seed]
    return None


def main(argv=None):
    """Entry point of the ``skhybrid`` command; returns the exit status."""
    parser = _build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    if args.command == "list":
        try:
            _list(sys.stdout, args.data)
            sys.stdout.flush()
        except BrokenPipeError:
            # The reader stopped early (``skhybrid list | head``): not an error.
            # Python's own flush at exit would fail again on the closed pipe.
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0

    problem = _check_run_args(args)
    if problem is not None:
        _error(problem)
        return 2
    needed = dict(RUN_REQUIREMENTS)
    if args.dask is not None:
        needed.update(DASK_REQUIREMENTS)
    missing = missing_requirements(needed)
    if missing:
        for line in missing:
            verb = "`skhybrid run --dask`" if "dask" in line else "`skhybrid run`"
            _error(f"{verb} needs {line}")
        return 2

    from skhybrid.exceptions import RefusedTestRecordsError
    from skhybrid.experiments import RunFolderError, RunTransaction

    command = "skhybrid " + shlex.join(argv)
    try:
        # The output folder is checked and locked before training.
        with RunTransaction(args.out) as run:
            return _run(args, argv, command, run)
    except (RunFolderError, _SpecError, RefusedTestRecordsError) as exc:
        _error(str(exc))
        return 2
    except KeyboardInterrupt:
        # Ctrl-C while the folder was locked or the models counted, before the
        # run's own handler: nothing was trained, nothing to resume.
        sys.stderr.write("\nskhybrid: interrupted before training\n")
        return 130


def _plan(args):
    """What the run fits (a RunPlan), from the command line's arguments."""
    from skhybrid.experiments import RunPlan, get_system

    if args.spec is not None:
        try:
            systems = [get_system(_load_spec(args.spec))]
        except (TypeError, ValueError) as exc:
            raise _SpecError(f"--system {args.spec}: {exc}") from None
    elif args.system == "all":
        systems = [get_system(name) for name in SIMULATED_SYSTEMS]
    else:
        systems = [get_system(args.system)]
    try:
        return RunPlan(
            systems,
            seeds=args.seeds,
            quick=args.quick,
            data=args.data,
            noise_type=args.noise_type,
            device=args.device,
        )
    except ValueError as exc:
        raise _SpecError(str(exc)) from None


def _run(args, argv, command, run):
    """Run the plan in the started transaction ``run``; the exit status."""
    from skhybrid.experiments import summary_lines

    plan = _plan(args)
    n_models = plan.n_models
    start = time.perf_counter()
    try:
        try:
            # The folder's run first, then a measured system's files, at the
            # boundary before the folder changes: a corrupt or missing file is
            # one line and exit 2; every refusal of the folder comes here too.
            n_finished = run.start(
                plan, command, overwrite=args.overwrite, resume=args.resume
            )
        except (ValueError, OSError) as exc:
            _error(str(exc))
            return 2
        if n_finished:
            sys.stdout.write(
                f"resuming: {n_finished} of {n_models} models already finished in "
                f"{run.folder.path}\n"
            )
        with contextlib.ExitStack() as stack:
            n_jobs = args.n_jobs
            if args.dask is not None:
                n_workers = args.n_jobs if args.n_jobs > 0 else (os.cpu_count() or 1)
                n_workers = min(n_workers, n_models)  # no idle worker processes
                try:
                    client = stack.enter_context(_dask_backend(args.dask, n_workers))
                except _DaskError as exc:
                    _error(str(exc))
                    run.failed(str(exc))
                    return 2
                address = client.scheduler.address
                sys.stdout.write(f"fitting on the Dask cluster at {address}\n")
                n_jobs = -1  # every worker of the cluster
            try:
                results = plan.fit(
                    run.folder, n_jobs=n_jobs, progress=not args.no_progress
                )
            except FileNotFoundError as exc:  # a measured benchmark's files
                _error(str(exc))
                run.failed(str(exc))
                return 2
        # One wall time: the report's and the console's are the same number.
        wall = time.perf_counter() - start
        paths = run.finish(results, command, wall_time=wall)
    except KeyboardInterrupt:
        done = run.interrupted()
        sys.stderr.write(
            f"\nskhybrid: interrupted: {done} of {n_models} models are finished and "
            f"kept in {run.folder.path}; resume with: {_resume_command(argv)}\n"
        )
        return 130
    sys.stdout.write(f"wrote {paths['html']} ({wall:.1f} s)\n")
    if args.quick and not plan.measured:
        sys.stdout.write(
            "  --quick trains on small data for a few epochs: the paper's claims "
            "are not evaluated on it (they are judged on the full run)\n"
        )
    for result in results:
        for line in summary_lines(result):
            sys.stdout.write(line + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
