"""The test records' free runs of every seed's models, each simulated once.

A sealed run simulates each seed's fitted models over the test records. The
seeds' deterministic models are the same fit (read from the run's cache), so
their free runs are the same numbers: each is simulated once and shared. The
free runs are independent of each other, so they run side by side on the run's
workers, each with this process's threads (torch's, the BLAS's and OpenMP's),
so that a free run gives the same numbers side by side as alone. A stack's run
is its members' runs averaged
(:func:`~skhybrid.experiments.free_run._stack.averaged_run`), so it is not
simulated here.
"""

import contextlib
import hashlib
import pickle
import warnings

import cloudpickle
import joblib
from joblib import Parallel, delayed
from threadpoolctl import threadpool_info, threadpool_limits

from skhybrid.experiments.free_run._family import simulate_records
from skhybrid.experiments.run._workers import worker_restarts_explained
from skhybrid.model_selection import StackedSimulation

__all__ = ["simulate_tests"]


def _identity(result, model):
    """What names a seed's fit of ``model``: equal only for the same fitted model.

    A deterministic model's fit is the same at every seed; its key is then a
    hash of its fitted state (:func:`_fingerprint`), so two seeds share its
    runs only where the fits are equal to the bit (a model that cannot be
    pickled is not shared). Any other model is its seed's own.
    """
    selection = result.fits[model].get("selection") or {}
    if selection.get("deterministic"):
        fingerprint = _fingerprint(result.estimators[model])
        if fingerprint is not None:
            return ("deterministic", model, fingerprint)
    return ("seed", result.store_key, model)


def _fingerprint(estimator):
    """A hash of ``estimator``'s fitted state, or None where it cannot be pickled.

    joblib's hash, which two equal fits share whatever objects they share
    inside; for a physics written in the user's script (``__main__``), which
    pickle refuses, the SHA-256 of its cloudpickle (as the run folder stores
    it), which goes by value.
    """
    try:
        with warnings.catch_warnings():
            # pickle's lookup of a function in ``__main__`` warns on the way
            # to refusing it (importlib's module_repr, on Python 3.11).
            warnings.simplefilter("ignore", DeprecationWarning)
            return joblib.hash(estimator)
    except (pickle.PicklingError, TypeError, AttributeError):
        pass
    try:
        return hashlib.sha256(cloudpickle.dumps(estimator)).hexdigest()
    except (pickle.PicklingError, TypeError, AttributeError):
        return None


def _threads_here():
    """This process's threads: ``({user_api: threads}, torch's threads)``."""
    import torch

    limits = {}
    for info in threadpool_info():
        api = info["user_api"]
        limits[api] = max(limits.get(api, 0), int(info["num_threads"]))
    return limits, torch.get_num_threads()


@contextlib.contextmanager
def _threads_as(threads):
    """Run with the threads :func:`_threads_here` gave (more or fewer than now).

    A worker started by joblib has one thread per library; a matrix product
    split over another count of threads can differ in its last bits.
    """
    import torch

    limits, n_torch = threads
    before = torch.get_num_threads()
    with threadpool_limits(limits=limits):
        torch.set_num_threads(n_torch)
        try:
            yield
        finally:
            torch.set_num_threads(before)


def _free_run(estimator, u, y, n_init, threads):
    """One free run of a test record and why it failed (None where it did not)."""
    with _threads_as(threads):
        (pred,), (error,) = simulate_records(estimator, [u], [y], n_init)
    return pred, error


def simulate_tests(results, tests, *, n_jobs=1):
    """Every seed's models simulated over the test records, each fit once.

    Parameters
    ----------
    results : list of MeasuredResult
        The sealed seeds' results (``estimators`` fitted).
    tests : dict of str to tuple of ndarray
        ``{split: (u, y)}``, read after sealing.
    n_jobs : int, default=1
        Free runs simulated side by side with joblib, on its active backend,
        each with this process's threads.

    Returns
    -------
    runs : list of dict
        For each result, ``{split: {model: (free run, error or None)}}`` for
        every fitted model but a stack.
    """
    calls, places = {}, []
    for index, result in enumerate(results):
        for model in result.fits:
            estimator = result.estimators.get(model)
            if estimator is None or isinstance(estimator, StackedSimulation):
                continue
            key = _identity(result, model)
            for split in tests:
                places.append((index, split, model, (key, split)))
                calls.setdefault((key, split), (estimator, split))
    n_init = results[0].n_init if results else 0
    threads = _threads_here()
    with worker_restarts_explained():
        outputs = Parallel(n_jobs=n_jobs)(
            delayed(_free_run)(estimator, *tests[split], n_init, threads)
            for estimator, split in calls.values()
        )
    done = dict(zip(calls, outputs, strict=True))
    runs = [{split: {} for split in tests} for _ in results]
    for index, split, model, key in places:
        runs[index][split][model] = done[key]
    return runs
