"""Progress of least-squares fits: who waits sees the evaluations go by."""

import contextlib
import contextvars

__all__ = ["fit_progress"]

#: The hook of the innermost :func:`fit_progress` context, or None.
_HOOK = contextvars.ContextVar("skhybrid_fit_progress", default=None)


@contextlib.contextmanager
def fit_progress(hook):
    """Report every residual evaluation of the domain fits run inside the context.

    A domain model's fit (:meth:`DomainModel.fit`,
    :meth:`StateSpaceModel.fit_simulation`, their several starts) calls
    ``hook(nfev, max_nfev, n_records)`` after each evaluation of its residuals:
    ``nfev`` counts the evaluations of the current least-squares fit from 1,
    those of a finite-difference Jacobian included; ``max_nfev`` is the most
    it can make (None where scipy's default limit applies): the model's
    ``max_nfev``, times one plus the number of free parameters where the
    Jacobian is taken by finite differences (scipy's ``max_nfev`` counts none
    of those), and
    ``n_records`` how many records (or multiple-shooting segments) the fit
    simulates. A long physics fit can so show how far it has gone against its
    budget. The hook runs in the fitting thread: keep it quick, and let it raise
    nothing (an exception it raises ends the fit).

    Parameters
    ----------
    hook : callable or None
        ``hook(nfev, max_nfev, n_records)``; None turns reporting off inside the
        context.

    Yields
    ------
    None

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import ParametricModel, fit_progress
    >>> def line(X, *, a, b, xp=np):
    ...     return a * X[:, :1] + b
    >>> X = np.linspace(0, 1, 20)[:, None]
    >>> seen = []
    >>> with fit_progress(lambda n, limit, records: seen.append(n)):
    ...     model = ParametricModel(line, {"a": 0.0, "b": 0.0}).fit(X, 2 * X[:, 0] + 1)
    >>> seen[0], len(seen) > 1
    (1, True)
    """
    if hook is not None and not callable(hook):
        raise TypeError(
            f"hook must be a callable hook(nfev, max_nfev, n_records) or None; got "
            f"hook={hook!r}."
        )
    token = _HOOK.set(hook)
    try:
        yield
    finally:
        _HOOK.reset(token)


def counting(fun, max_nfev, n_records):
    """``fun`` reporting each call to the active :func:`fit_progress` hook.

    Parameters
    ----------
    fun : callable
        The residual function of one least-squares fit.
    max_nfev : int or None
        Its evaluation limit.
    n_records : int
        Records or segments it simulates.

    Returns
    -------
    fun : callable
        ``fun`` itself when no hook is active, else a wrapper that counts.
    """
    hook = _HOOK.get()
    if hook is None:
        return fun
    count = 0

    def counted(z):
        nonlocal count
        out = fun(z)
        count += 1
        hook(count, max_nfev, n_records)
        return out

    return counted
