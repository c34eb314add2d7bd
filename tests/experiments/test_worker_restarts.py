"""loky's worker-restart warning is said, during a run, as one line: nothing lost."""

import threading
import warnings

from skhybrid.experiments.free_run import _test_runs
from skhybrid.experiments.run._workers import (
    WORKER_RESTARTED,
    worker_restarts_explained,
)

LOKY = (
    "A worker stopped while some jobs were given to the executor. This can be "
    "caused by a too short worker timeout or by a memory leak."
)


def _from_a_thread(message):
    # loky warns from its manager thread, not from the caller's.
    thread = threading.Thread(target=warnings.warn, args=(message, UserWarning))
    thread.start()
    thread.join()


def _shown(func):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        func()
    return [str(w.message) for w in record]


def test_the_restart_warning_becomes_one_line_saying_nothing_was_lost():
    def run():
        with worker_restarts_explained():
            _from_a_thread(LOKY)
            _from_a_thread(LOKY)  # said once
            warnings.warn("another warning", UserWarning, stacklevel=1)
        _from_a_thread(LOKY)  # outside the block: loky's own

    assert _shown(run) == [WORKER_RESTARTED, "another warning", LOKY]
    assert "nothing was lost" in WORKER_RESTARTED and "\n" not in WORKER_RESTARTED


class RestartingParallel:
    """A joblib.Parallel whose pool replaces a worker while jobs wait."""

    def __init__(self, n_jobs=None):
        self.n_jobs = n_jobs

    def __call__(self, jobs):
        jobs = list(jobs)
        _from_a_thread(LOKY)
        return [func(*args, **kwargs) for func, args, kwargs in jobs]


def test_the_test_records_pool_explains_a_restart(monkeypatch):
    monkeypatch.setattr(_test_runs, "Parallel", RestartingParallel)
    shown = _shown(lambda: _test_runs.simulate_tests([], {}, n_jobs=2))
    assert shown == [WORKER_RESTARTED]
