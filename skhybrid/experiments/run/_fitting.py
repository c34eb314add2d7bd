"""What every fit of the pipeline shares: interrupts, reading parameters, segments."""

import contextlib
import signal

import numpy as np

from skhybrid.model_selection import SimulationFit

__all__ = ["fit_segments", "interrupts_raise", "n_epochs", "physical_params"]


def physical_params(estimator):
    """``{name: (value, std)}`` of the physics inside ``estimator``, if any."""
    candidates = [estimator]
    stages = getattr(estimator, "stages_", None)
    if stages:
        candidates.append(stages[0][1])
    for est in candidates:
        params = getattr(est, "params_", None)
        if isinstance(params, dict):
            std = getattr(est, "params_std_", None) or {}
            # A fixed parameter was not fitted: it has no standard error.
            fixed = set(getattr(est, "fixed", None) or ())
            free = getattr(est, "free_params_", None)
            if free is not None:
                fixed |= set(params) - set(free)
            return {
                name: {
                    "value": np.asarray(value).tolist(),
                    "std": None
                    if name not in std or name in fixed
                    else np.asarray(std[name]).tolist(),
                    "fixed": name in fixed,
                }
                for name, value in params.items()
            }
    return {}


def n_epochs(estimator):
    for est in [estimator, *(s for _, s in getattr(estimator, "stages_", []))]:
        if hasattr(est, "n_epochs_"):
            return int(est.n_epochs_)
    return None


@contextlib.contextmanager
def interrupts_raise():
    """Make a Ctrl-C during the body raise KeyboardInterrupt after it.

    skorch catches KeyboardInterrupt in ``fit`` and returns the network trained so
    far, as if training had finished: a model cut short would be recorded as
    complete. Here a SIGINT is remembered and raised again once the body returns.
    Only the main thread of a process receives signals: elsewhere (a Dask worker's
    thread) this does nothing. A process that ignores SIGINT (started as a
    background job of a script, whose Ctrl-C is not meant for it) keeps ignoring
    it here too, as Python does everywhere else in it: a Ctrl-C is never
    ignored before the fits and obeyed during them.
    """
    hit = []

    def handler(signum, frame):
        hit.append(signum)
        raise KeyboardInterrupt

    installed = False
    if signal.getsignal(signal.SIGINT) != signal.SIG_IGN:
        try:
            previous = signal.signal(signal.SIGINT, handler)
            installed = True
        except ValueError:  # not the main thread
            pass
    if not installed:
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if hit:
        raise KeyboardInterrupt


def fit_segments(model, u, y, segment):
    """Fit a clone of ``model`` by the simulation error over segments of records.

    The public path, :class:`~skhybrid.model_selection.SimulationFit`, which
    :class:`~skhybrid.model_selection.SimulationSearchCV` takes for every
    candidate with a ``fit_simulation``: each segment of ``segment`` samples is
    a record whose initial state is estimated from its own first
    ``model.n_init`` samples (multiple shooting); the remainder of a record
    (fewer than ``segment`` samples) joins its last segment. A model without
    ``fit_simulation`` (any estimator that simulates) is fitted with
    ``fit(U, Y)`` on the records as they are.

    Parameters
    ----------
    model : StateSpaceModel or estimator
        The model to fit; it is cloned, not changed.
    u, y : ndarray of shape (n_times, n_inputs) and (n_times, n_outputs), or \
lists of them
        One record, or several.
    segment : int or None
        Samples per segment; ``None`` fits whole records.

    Returns
    -------
    model : StateSpaceModel or estimator
        The fitted clone.
    """
    several = isinstance(u, (list, tuple))
    U, Y = (list(u), list(y)) if several else ([u], [y])
    return SimulationFit(model, segment=segment).fit(U, Y).estimator_
