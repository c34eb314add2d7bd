"""Several fits in lockstep: their simulations gathered into one batch.

A simulation-error fit spends its time in free runs, loops over the time steps
of the records whose cost hardly grows with the rows simulated at once. Fits
of the same records that differ only in where they start (the short fits of a
model's ``starts``) therefore run side by side in threads: each asks for the
residuals of its parameter sets and waits; once every fit still running has
asked, the last to ask simulates all the sets in one batch and hands each fit
its rows. Which fits share a batch does not depend on the threads' timing (a
batch waits for every fit still running), so the results do not either.
"""

import contextvars
import threading
import warnings

__all__ = [
    "FORWARD_MODE",
    "Lockstep",
    "current_member",
    "parts_fit_in_lockstep",
    "physics_signature",
    "run_in_lockstep",
]

#: ``(lockstep, member)`` of the fit running in this thread, or None.
_MEMBER = contextvars.ContextVar("skhybrid_lockstep_member", default=None)

#: Held around a forward-mode Jacobian (``torch.func.jacfwd``). torch's
#: forward-mode levels are the process's, not a thread's: two fits in lockstep
#: threads taking one at once (members finishing on the same step) tear down
#: each other's ("Trying to access a forward AD level with an invalid index").
FORWARD_MODE = threading.Lock()


def current_member():
    """``(lockstep, member)`` of the fit running in this context, or None.

    A :class:`~skhybrid.domain.StateSpaceModel` fitted inside
    :func:`run_in_lockstep` finds its group here and has its parameter sets
    simulated with the others'.
    """
    return _MEMBER.get()


class Lockstep:
    """Gather the parameter sets of ``n_members`` fits into one batched evaluation.

    Parameters
    ----------
    n_members : int
        Fits taking part; each calls :meth:`evaluate` for every batch it needs
        and :meth:`leave` once when it stops (finished or failed).
    """

    def __init__(self, n_members):
        self._cond = threading.Condition()
        self._live = n_members
        self._pending = {}
        self._results = {}

    def evaluate(self, member, request):
        """The result of ``member``'s request, simulated with the others'.

        Parameters
        ----------
        member : hashable
            Which fit asks.
        request : object
            What it asks for: an object whose type has
            ``simulate_many(requests)`` (a
            :class:`~skhybrid.domain.StateSpaceModel` fit's parameter sets as
            rows of a free run).

        Returns
        -------
        residuals : ndarray of shape (n_sets, n_residuals)
        """
        with self._cond:
            self._pending[member] = request
            if len(self._pending) >= self._live:
                self._run_batch()
            while member not in self._results:
                self._cond.wait()
            result = self._results.pop(member)
        if isinstance(result, BaseException):
            raise result
        return result

    def leave(self):
        """Mark one member as stopped; the others no longer wait for it."""
        with self._cond:
            self._live -= 1
            if self._pending and len(self._pending) >= self._live:
                self._run_batch()

    def _run_batch(self):
        """Simulate every pending request in one batch (the lock is held).

        Requests of one type are handed together to that type's
        ``simulate_many(requests)``, which returns one result (or exception)
        per request; where it raises, every one of them gets the exception
        (the other members would otherwise wait for results that never come).
        """
        members = list(self._pending)
        requests = [self._pending.pop(m) for m in members]
        by_type = {}
        for member, request in zip(members, requests, strict=True):
            by_type.setdefault(type(request), []).append((member, request))
        for kind, pairs in by_type.items():
            try:
                results = kind.simulate_many([request for _, request in pairs])
            except Exception as exc:  # noqa: BLE001 - handed to each member
                results = [exc] * len(pairs)
            self._results.update(zip((m for m, _ in pairs), results, strict=True))
        self._cond.notify_all()


def run_in_lockstep(models, fit):
    """Run ``fit(model)`` for every model at once, their simulations batched.

    Each fit runs in a thread of its own, in a copy of the caller's context
    (its progress hook included) in which :func:`current_member` names the
    shared :class:`Lockstep` and the fit's place in it: a
    :class:`~skhybrid.domain.StateSpaceModel` whose parameter sets are
    simulated in batches asks the group for them.

    Parameters
    ----------
    models : sequence of object
        The models, fitting the same records.
    fit : callable
        ``fit(model)``, run once per model.

    Returns
    -------
    outcomes : list
        Per model, what ``fit`` returned or the exception it raised.
    """
    lockstep = Lockstep(len(models))
    outcomes = [None] * len(models)
    # warnings.catch_warnings is not thread-safe: fits that catch warnings in
    # threads can leave the filters and showwarning of the last to exit; they
    # are put back as they were once every fit has ended.
    filters, showwarning = warnings.filters[:], warnings.showwarning

    def work(i, model):
        _MEMBER.set((lockstep, i))
        try:
            outcomes[i] = fit(model)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            outcomes[i] = exc
        finally:
            lockstep.leave()

    threads = [
        threading.Thread(
            target=contextvars.copy_context().run, args=(work, i, model), daemon=True
        )
        for i, model in enumerate(models)
    ]
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        warnings.filters[:] = filters
        warnings.showwarning = showwarning
        warnings._filters_mutated()
    return outcomes


def parts_fit_in_lockstep(parts):
    """Whether a model made of ``parts`` fits in lockstep: its networks on a GPU do.

    A part says whether it fits in lockstep with its ``fits_in_lockstep`` (a
    network of :mod:`skhybrid.neural`: on a GPU; a
    :class:`~skhybrid.domain.StateSpaceModel`: always, for its own batched
    free runs). The model does where one part is on a GPU (``device="cuda"``,
    a network whose steps batch there) and every part that says says yes. A
    part that does not say (a physics fitted by least squares, a linear stage)
    fits in its thread as it would alone; without a part on a GPU nothing
    would gain, and the folds are better spread over a search's workers.

    Parameters
    ----------
    parts : iterable of estimator
        The model's parts (a hybrid's stages).

    Returns
    -------
    in_lockstep : bool
    """
    parts = list(parts)
    said = [bool(p.fits_in_lockstep) for p in parts if hasattr(p, "fits_in_lockstep")]
    on_gpu = any(getattr(p, "device", None) == "cuda" for p in parts)
    return on_gpu and all(said)


def physics_signature(physics):
    """What of a fitted physics a module's forward pass reads besides its tensors.

    Its class, its settings but the starting values (each member starts from
    its own), its parameters' names and its fixed parameters' values: part of
    the :meth:`lockstep_signature` of a module that runs a physics.

    Parameters
    ----------
    physics : skhybrid.domain.DomainModel
        Fitted (``params_`` and ``free_params_`` set).

    Returns
    -------
    signature : tuple
    """
    settings = sorted(
        (name, repr(value))
        for name, value in physics.get_params(deep=False).items()
        if name != "params"
    )
    fixed = sorted(
        (name, repr(value))
        for name, value in physics.params_.items()
        if name not in physics.free_params_
    )
    return (type(physics), settings, sorted(physics.params_), fixed)
