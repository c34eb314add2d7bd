"""Run a system into a run folder: run_system, run_measured and load_fitted.

:func:`run_system` takes a spec of either protocol and runs its
:class:`~skhybrid.experiments.run._plan.RunPlan` in the folder's transaction,
as ``skhybrid run`` does; the rest of this note is the free-run protocol's.

A measured system, a user's or a built-in benchmark, is a
:class:`~skhybrid.experiments.SystemSpec` run through the same pipeline as the
paper's simulated systems (:func:`~skhybrid.experiments.run_experiment`, the run
folder with its lock and resume, joblib or Dask, progress, :func:`write_report`):

- its estimation records are loaded (a built-in benchmark's from the folder the
  user names with ``--data``, or fetched), with the official split and
  initialisation window of the ``nonlinear-benchmarks`` loader (v1.0.1);
- its zoo (:mod:`skhybrid.experiments.free_run._family`) fits every model on the
  estimation records only, choosing every candidate (window and segment
  lengths, the state-space hybrid's horizon, the model quoted) on validation
  blocked folds of the records (:class:`~skhybrid.model_selection.SimulationSearchCV`),
  never on a test record;
- the search runs at the first seed and each choice is refitted at every seed;
  every seed's selection is sealed (:mod:`skhybrid.experiments.free_run._seal`), then
  each model is simulated in free run on each test record from the first
  ``n_init`` measured outputs and scored by ``RMSE(y[n_init:],
  y_model[n_init:])`` in the official units, beside the published figures.
"""

import json
import shlex

import numpy as np

from skhybrid.experiments._registry import MEASURED_SYSTEMS, system_of
from skhybrid.experiments._spec import SystemSpec
from skhybrid.experiments.free_run._identity import measured_identity
from skhybrid.experiments.run._plan import DEFAULT_SEEDS, RunPlan, check_seeds
from skhybrid.experiments.run._store import RunFolder
from skhybrid.experiments.run._transaction import RunTransaction
from skhybrid.hybrid import TransformedInputSimulator
from skhybrid.neural.engine import check_device

__all__ = [
    "DEFAULT_SEEDS",
    "check_seeds",
    "load_fitted",
    "measured_identity",
    "run_measured",
    "run_system",
]


def _run_arguments(seeds, n_jobs, overwrite, resume, device="cpu"):
    """The Python API's arguments, checked as the command line checks its own.

    ``seeds``: an int is one seed (``--seed S``), None the default seeds.
    """
    if seeds is None:
        seeds = DEFAULT_SEEDS
    elif isinstance(seeds, (int, np.integer)) and not isinstance(seeds, bool):
        seeds = [seeds]
    seeds = check_seeds(seeds)
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)):
        raise TypeError(
            f"n_jobs must be an int >= 1, or -1 for all cores; got n_jobs={n_jobs!r}."
        )
    if n_jobs == 0 or n_jobs < -1:
        raise ValueError(
            f"n_jobs must be an int >= 1, or -1 for all cores; got n_jobs={n_jobs!r}."
        )
    if overwrite and resume:
        raise ValueError(
            "overwrite=True replaces the run in the folder and resume=True carries "
            "it on: pass one of them, not both."
        )
    check_device(device)  # its value is checked by the run's settings
    return seeds, int(n_jobs)


def _run_folder(plan, command, out, *, n_jobs, overwrite, resume, progress):
    """Run ``plan`` in the folder ``out`` as a transaction; its system's summary."""
    with RunTransaction(out) as run:
        run.start(plan, command, overwrite=overwrite, resume=resume)
        results = plan.fit(run.folder, n_jobs=n_jobs, progress=progress)
        paths = run.finish(results, command)
    (result,) = results
    if plan.measured:
        return result.summary()
    return json.loads(paths["json"].read_text())["systems"][result.system.name]


def run_system(
    spec,
    out,
    *,
    seeds=DEFAULT_SEEDS,
    quick=False,
    noise_type=None,
    n_jobs=2,
    overwrite=False,
    resume=False,
    progress=True,
    device="cpu",
):
    """Fit, choose, seal and score the system described by ``spec``, into ``out``.

    The public workflow of a user's machine (and of the built-in benchmarks).
    A spec of the one-step protocol (``protocol=OneStepWindows(...)``, the
    paper's simulated systems) runs at one seed: its splits are simulated, the
    paper's zoo fitted and scored on every test set, and the report written
    into ``out`` with the same lock, resume and ``run.json`` as below. A spec
    of the free-run protocol (measured records):
    the default candidate family is fitted on the estimation records and every
    choice made by blocked cross-validation of them at the first seed, and each
    choice is refitted on the whole records at every seed; the selections of
    all seeds are written to ``OUT/selection.json`` with their SHA-256 before
    any test record is read; then every model is simulated on the test records
    and ``results.csv``, ``results.json`` (the hash, each seed's choice and the
    chosen model's test RMSE over seeds), ``report.html`` and a figure are
    written. The same as ``skhybrid run --system module:object --out OUT``.

    Parameters
    ----------
    spec : SystemSpec
        The system.
    out : str or Path
        The run folder, checked and locked before any fit; finished models are
        kept as they land and an unfinished run of the same settings is carried
        on.
    seeds : int, sequence of int or None, default=(0, 1, 2)
        Seeds of the networks, each between 0 and ``2**32 - 1``; each is a full
        selection. An int is one seed (``--seed S``); None the default seeds.
        A spec of the one-step protocol takes one seed (of its data too).
    quick : bool, default=False
        Shorter fits and fewer candidates (a smoke test, not a figure).
    noise_type : {"measurement", "process"} or None, default=None
        Where a one-step spec's simulators put their noise, as the command
        line's ``--noise-type``; None takes the spec's own. A free-run spec's
        records hold their own noise: it takes None only.
    n_jobs : int, default=2
        Workers of joblib (-1: all cores), as the command line's ``--n-jobs``:
        the models are fitted one after another, each model's (candidate,
        fold) fits in parallel.
    overwrite : bool, default=False
        Replace a previous run in ``out``: it is moved aside and deleted once
        the new run has started (its records read and checked).
    resume : bool, default=False
        Also accept a finished run of the same settings (its report is written
        again). Not with ``overwrite``.
    progress : bool, default=True
        Progress on standard error, as the command line shows it: bars of the
        models and epochs in a terminal, a line per finished model elsewhere (a
        notebook's log, a file); False is silent.
    device : {"cpu", "cuda"}, default="cpu"
        Where every network of the run trains and simulates, as ``--device``
        (the physics' fits stay on the CPU); ``"cuda"`` needs a CUDA device.
        A run on another device is another run (its floating point differs).

    Returns
    -------
    results : dict
        The system's entry of ``results.json``.

    Raises
    ------
    RunFolderError
        The folder cannot take this run (another run, other records, a damaged
        stored file); nothing in it was changed. ``run.json`` records how a run
        that started ended: ``"complete"``, ``"interrupted"`` (Ctrl-C) or
        ``"failed"`` (an error), as the command line records it.

    Examples
    --------
    >>> from skhybrid.experiments import SystemSpec, run_system  # doctest: +SKIP
    >>> spec = SystemSpec("my-machine", records=[(u1, y1), (u2, y2)],
    ...                   physics=physics, n_init=10, dt=0.01,
    ...                   tests={"test": (u3, y3)})  # doctest: +SKIP
    >>> results = run_system(spec, "runs/my-machine")  # doctest: +SKIP
    >>> results["chosen_test_rmse"]["test"]["mean"]  # doctest: +SKIP
    """
    seeds, n_jobs = _run_arguments(seeds, n_jobs, overwrite, resume, device)
    if not isinstance(spec, SystemSpec):
        raise TypeError(f"spec must be a SystemSpec; got {type(spec).__name__}.")
    plan = RunPlan(
        [system_of(spec)],
        seeds=seeds,
        quick=quick,
        noise_type=noise_type,
        device=device,
    )
    noise = "" if noise_type is None else f", noise_type={noise_type!r}"
    noise += "" if device == "cpu" else f", device={device!r}"
    command = (
        f"skhybrid.experiments.run_system(<SystemSpec {spec.name!r}>, "
        f"{str(out)!r}, seeds={seeds}, quick={bool(quick)}{noise})"
    )
    return _run_folder(
        plan,
        command,
        out,
        n_jobs=n_jobs,
        overwrite=overwrite,
        resume=resume,
        progress=progress,
    )


def run_measured(
    name,
    data,
    out,
    *,
    quick=False,
    seeds=DEFAULT_SEEDS,
    n_jobs=2,
    overwrite=False,
    progress=True,
    device="cpu",
):
    """Run a built-in measured benchmark into the run folder ``out``.

    The same pipeline as ``skhybrid run NAME --data DATA --out OUT``: the folder
    is checked and locked before any fit, finished models are kept as they land,
    an unfinished run of the same settings in ``out`` is carried on, and the
    selection of every seed is sealed before the test records are read.

    Parameters
    ----------
    name : str
        A built-in measured benchmark (``skhybrid list``).
    data : str or pathlib.Path or None
        Folder holding the benchmark files (for example ``../shared/data``);
        None fetches them.
    out : str or pathlib.Path
        The run folder: ``selection.json``, ``results.csv``, ``results.json``,
        ``report.html``, ``<name>.png`` and ``models/``.
    quick : bool, default=False
        Shorter fits (and a shorter Silverbox estimation record).
    seeds : int, sequence of int or None, default=(0, 1, 2)
        Seeds of the networks: the search runs at the first (fold ``k`` at
        seed + ``k``) and every seed refits its choices (an int is one seed,
        None the default seeds).
    n_jobs : int, default=2
        Workers of joblib (-1: all cores), as ``--n-jobs``: each model's
        (candidate, fold) fits run in parallel.
    overwrite : bool, default=False
        Replace a previous run in ``out``.
    progress : bool, default=True
        Progress on standard error (bars in a terminal, a line per finished
        model elsewhere); False is silent.
    device : {"cpu", "cuda"}, default="cpu"
        Where every network of the run trains and simulates, as ``--device``
        (the physics' fits stay on the CPU); ``"cuda"`` needs a CUDA device.
        A run on another device is another run (its floating point differs).

    Returns
    -------
    results : dict
        The system's entry of ``results.json``.
    """
    if name not in MEASURED_SYSTEMS:
        raise ValueError(
            f"name must be one of {sorted(MEASURED_SYSTEMS)}; got name={name!r}."
        )

    seeds, n_jobs = _run_arguments(seeds, n_jobs, overwrite, False, device)
    words = ["run", name] + (["--data", str(data)] if data is not None else [])
    words += ["--out", str(out)] + ["--quick"] * bool(quick)
    words += ["--seeds", *map(str, seeds)]
    words += [] if device == "cpu" else ["--device", device]
    plan = RunPlan(
        [MEASURED_SYSTEMS[name]], seeds=seeds, quick=quick, data=data, device=device
    )
    return _run_folder(
        plan,
        "skhybrid " + shlex.join(words),
        out,
        n_jobs=n_jobs,
        overwrite=overwrite,
        resume=False,
        progress=progress,
    )


def load_fitted(out, *, seed=0, model=None, system=None):
    """A fitted model of a finished measured run: the chosen one by default.

    Parameters
    ----------
    out : str or Path
        The run folder (of :func:`run_system`, :func:`run_measured` or ``skhybrid
        run``).
    seed : int, default=0
        Which seed's fit.
    model : str or None, default=None
        The model's name in the report (``"physics"``, ``"physics + dense"``...);
        None loads the model chosen on validation at ``seed``.
    system : str or None, default=None
        The system's name; None where the folder holds one system.

    Returns
    -------
    estimator : object
        The fitted model; its ``simulate(inputs, initial)`` runs free from a
        record's first ``n_init`` measured outputs, as the run scored it.

    Raises
    ------
    RunFolderError
        The model's file is missing, damaged (its SHA-256 differs from the one
        recorded when it was written) or cannot be loaded; the message names
        it and the fix.

    Examples
    --------
    >>> from skhybrid.experiments import load_fitted  # doctest: +SKIP
    >>> chosen = load_fitted("runs/my-machine", seed=0)  # doctest: +SKIP
    >>> y_sim = chosen.simulate(u_test, y_test[:10])  # doctest: +SKIP
    """
    folder = RunFolder(out)
    try:
        systems = json.loads((folder.path / "results.json").read_text())["systems"]
    except FileNotFoundError:
        raise FileNotFoundError(
            f"{folder.path} holds no finished run (no results.json)"
        ) from None
    if system is None:
        if len(systems) != 1:
            raise ValueError(
                f"{folder.path} holds the systems {sorted(systems)}: name one with "
                "system=..."
            )
        system = next(iter(systems))
    if system not in systems or "chosen_model" not in systems[system]:
        raise ValueError(
            f"system must be a measured system of {folder.path}; got "
            f"system={system!r} (it holds {sorted(systems)})."
        )
    summary = systems[system]
    if str(seed) not in summary["chosen_model"]:
        raise ValueError(
            f"seed must be one of the run's seeds {summary['seeds']}; got "
            f"seed={seed!r}."
        )
    if model is None:
        model = summary["chosen_model"][str(seed)]
    key = f"{system}-seed-{seed}"
    finished = folder.finished(key)
    if model not in finished:
        raise ValueError(
            f"model must be one of {sorted(finished)}; got model={model!r}."
        )
    estimator = folder.load_estimator(key, finished[model])
    if (
        isinstance(estimator, TransformedInputSimulator)
        and estimator.input_transform is None
    ):
        # A physics or state-space hybrid fed the records' own inputs: the
        # public estimator itself, not the run's wrapper around it.
        return estimator.estimator
    return estimator
