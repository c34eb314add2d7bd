"""A measured run's seeds: search at the first, refit at each, seal, then test.

:func:`run_seeds` searches the candidate family at the run's first seed and
refits each choice at every further seed (:func:`first_searches` hands them
the first seed's searches), seals every seed's selection
(:func:`~skhybrid.experiments.free_run._seal.seal`), and only then reads the
test records and scores every fitted model on them
(:func:`~skhybrid.experiments.free_run._scoring.score_tests`).
"""

import time

from skhybrid.exceptions import RefusedTestRecordsError
from skhybrid.experiments._settings import RunSettings
from skhybrid.experiments.free_run._scoring import MeasuredRun, score_tests
from skhybrid.experiments.free_run._seal import seal
from skhybrid.experiments.free_run._test_runs import simulate_tests
from skhybrid.experiments.run._runner import fit_seed, fit_zoos
from skhybrid.experiments.run._store import SELECTION_FILE

__all__ = ["first_searches", "run_seeds"]


def first_searches(result):
    """Each model's search at ``result``'s seed, for the run's further seeds.

    Parameters
    ----------
    result : MeasuredResult
        The first seed's selection.

    Returns
    -------
    searched : dict of str to dict
        ``{model: {"selection", "runs", "seed"}}`` for every model that was
        searched.
    """
    return {
        name: {
            "selection": fit["selection"],
            "runs": result.validation_runs.get(name),
            "seed": int(result.settings.seed),
        }
        for name, fit in result.fits.items()
        if fit.get("selection")
    }


def run_seeds(
    system,
    *,
    seeds,
    quick=False,
    n_jobs=1,
    progress=False,
    folder=None,
    data=None,
    device="cpu",
):
    """Select at every seed, seal, then read and score the test records.

    Parameters
    ----------
    system : MeasuredSystem
        The system, resolved once for the run (bound by its plan).
    seeds : sequence of int
        The first seed searches; each seed refits the choices.
    quick : bool, default=False
        Shorter fits and fewer candidates.
    n_jobs : int, default=1
        Models fitted in parallel.
    progress : bool, default=False
        Progress bars on standard error.
    folder : RunFolder or None, default=None
        The run folder (finished models kept, ``selection.json`` written).
    data : str or Path or None, default=None
        A built-in benchmark's data folder; None fetches its files.
    device : {"cpu", "cuda"}, default="cpu"
        Where the networks train.

    Returns
    -------
    run : MeasuredRun
        Every seed's selection and test scores, and the seal.

    Notes
    -----
    Every model's search (each candidate on every fold) runs at the first seed,
    fold ``k``'s networks at ``seeds[0] + k``; each further seed refits the
    chosen candidate on the whole records at its own seed. The spread over
    seeds is the refits' spread; the CV figures are the one search's. The
    further seeds' refits run side by side on ``n_jobs`` workers (each with
    the threads of a search's worker, so a refit's numbers do not depend on
    what runs beside it); each of their results' ``wall_time`` is the time
    they took together.
    """
    start = time.perf_counter()
    seeds = list(seeds)
    first = fit_seed(
        system,
        RunSettings(quick=bool(quick), seed=seeds[0], device=device),
        n_jobs=n_jobs,
        progress=progress,
        folder=folder,
        data=data,
    )
    results = [first]
    if len(seeds) > 1:
        # The further seeds' refits, side by side in one pool of workers.
        refit_start = time.perf_counter()
        results += fit_zoos(
            first.system,
            [
                RunSettings(quick=bool(quick), seed=seed, device=device)
                for seed in seeds[1:]
            ],
            n_jobs=n_jobs,
            progress=progress,
            folder=folder,
            data=data,
            searched=first_searches(first),
        )
        for result in results[1:]:
            result.wall_time = time.perf_counter() - refit_start
    sealed = seal(results, None if folder is None else folder.path)
    # The first read of the test records: after the selection file is written.
    # Checked against the estimation records before any model is simulated.
    try:
        tests = results[0].system.spec.test_records(*results[0].train)
    except (TypeError, ValueError) as exc:
        where = "" if folder is None else f" in {folder.path / SELECTION_FILE}"
        raise RefusedTestRecordsError(
            f"{exc} The selection is sealed{where}: fix the test records, then "
            "run the same command with --resume (resume=True) to score it."
        ) from exc
    runs = simulate_tests(results, tests, n_jobs=n_jobs)
    for result, seed_runs in zip(results, runs, strict=True):
        score_tests(result, tests, folder, runs=seed_runs)
    run = MeasuredRun(results, sealed)
    run.wall_time = time.perf_counter() - start
    return run
