"""What a run says when joblib's loky replaces one of its worker processes.

loky (joblib's default backend) shuts a worker down after a job where its memory
has grown by more than 300 MB since its first job (a worker's first job is often
a physics fit; a later one loads torch and trains networks, which grows it that
much), or once it has sat idle past its timeout (300 s; the run's workers wait
while this process refits a model). It starts a new worker in its place and, if
jobs were waiting, warns "A worker stopped while some jobs were given to the
executor. This can be caused by a too short worker timeout or by a memory
leak.", which reads as if work were lost. None was: the worker stops only
between jobs, after sending its last result back, and the jobs waiting in the
shared queue run on the other workers and the new one. During a run that
warning is replaced by one line that says so.
"""

import contextlib
import warnings

__all__ = ["WORKER_RESTARTED", "worker_restarts_explained"]

#: The start of loky's warning.
LOKY_RESTART = "A worker stopped while some jobs were given to the executor"

#: The line shown instead, once per run.
WORKER_RESTARTED = (
    "joblib replaced a worker process that had stopped between jobs (loky "
    "stops one whose memory grew 300 MB past its first job's, as loading torch "
    "does, or one idle past its timeout); nothing was lost: every result it "
    "finished was returned and the jobs waiting run on the other workers."
)


@contextlib.contextmanager
def worker_restarts_explained():
    """Within the block, show loky's worker-restart warning as one calm line.

    The warning is raised in this process by loky's manager thread, so it is
    caught where it is shown (``warnings.showwarning``), for the block only;
    every other warning is shown as it would be. The line is shown once.
    """
    told = []
    with warnings.catch_warnings():
        show = warnings.showwarning

        def explained(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, UserWarning) and str(message).startswith(
                LOKY_RESTART
            ):
                if not told:
                    told.append(True)
                    show(WORKER_RESTARTED, UserWarning, filename, lineno, file)
                return
            show(message, category, filename, lineno, file, line)

        warnings.showwarning = explained
        yield
