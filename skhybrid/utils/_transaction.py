"""All-or-nothing fits: a fit that fails leaves the previous model untouched."""

import functools

__all__ = ["TransactionalFitMixin", "transactional"]


def transactional(fit):
    """Wrap ``fit`` so that an exception or interrupt restores the estimator.

    The instance's attributes are snapshotted (a shallow copy of ``__dict__``)
    before ``fit`` runs; if it raises anything, ``KeyboardInterrupt`` included,
    the snapshot is put back before the exception propagates. A refit that
    fails therefore leaves the previous fitted model exactly as it was, and a
    first fit that fails leaves an unfitted estimator. This relies on ``fit``
    never mutating an existing fitted attribute in place (it builds new objects
    and assigns them), which every skhybrid estimator respects.

    Parameters
    ----------
    fit : callable
        The method ``fit(self, *args, **kwargs)``.

    Returns
    -------
    wrapped : callable
        The transactional ``fit``.
    """
    if getattr(fit, "__skhybrid_transactional__", False):
        return fit

    @functools.wraps(fit)
    def wrapped(self, *args, **kwargs):
        snapshot = dict(self.__dict__)
        try:
            return fit(self, *args, **kwargs)
        except BaseException:
            self.__dict__.clear()
            self.__dict__.update(snapshot)
            raise

    wrapped.__skhybrid_transactional__ = True
    return wrapped


class TransactionalFitMixin:
    """Make the ``fit`` of every subclass all-or-nothing (see :func:`transactional`).

    A subclass that defines ``fit`` gets it wrapped when the class is created,
    so a new estimator cannot forget the guarantee.
    """

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "fit" in cls.__dict__:
            cls.fit = transactional(cls.__dict__["fit"])
