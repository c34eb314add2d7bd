"""Pickles that record the versions of the packages that made them.

A fitted model holds arrays laid out by skhybrid, scikit-learn's estimators and,
for networks, torch tensors inside a skorch net: any of the four may change what
an old pickle means. :class:`VersionedPickleMixin` records their versions when an
estimator is pickled and warns with
:class:`~skhybrid.exceptions.InconsistentVersionWarning` when it is loaded under
other versions, as scikit-learn does for its own version.
"""

import functools
import inspect
import warnings
from importlib.metadata import PackageNotFoundError, version

__all__ = ["PICKLED_PACKAGES", "VersionedPickleMixin", "package_versions"]

#: Distributions whose versions every pickle records.
PICKLED_PACKAGES = ("skhybrid", "scikit-learn", "torch", "skorch")

#: Key of the record in a pickled estimator's state.
VERSIONS_KEY = "_skhybrid_versions"


@functools.cache
def _versions():
    import skhybrid

    out = {}
    for name in PICKLED_PACKAGES:
        if name == "skhybrid":
            out[name] = skhybrid.__version__
            continue
        try:
            out[name] = version(name)
        except PackageNotFoundError:  # pragma: no cover - all are dependencies
            out[name] = None
    return out


def package_versions():
    """Installed versions of :data:`PICKLED_PACKAGES`.

    Returns
    -------
    versions : dict of str to str or None
        Distribution name to its version (``None`` where it is not installed).
    """
    return dict(_versions())


class VersionedPickleMixin:
    """Record package versions in pickles; warn on loading under others.

    Put it first among an estimator's bases. ``__getstate__`` adds the versions of
    skhybrid, scikit-learn, torch and skorch to the pickled state;
    ``__setstate__`` compares them with the installed ones and warns with one
    :class:`~skhybrid.exceptions.InconsistentVersionWarning` naming every package
    that differs. Pickles made before versions were recorded load silently.
    A pickle made before a parameter was added loads with that parameter at its
    default (new parameters default to the behaviour before them).
    """

    def __getstate__(self):
        try:
            state = super().__getstate__()
        except AttributeError:  # Python < 3.11: object has no __getstate__
            state = None
        state = dict(self.__dict__ if state is None else state)
        state[VERSIONS_KEY] = package_versions()
        return state

    def __setstate__(self, state):
        state = dict(state)
        pickled = state.pop(VERSIONS_KEY, None)
        if pickled is not None:
            current = package_versions()
            differ = {
                name: (pickled.get(name), current.get(name))
                for name in PICKLED_PACKAGES
                if pickled.get(name) != current.get(name)
            }
            if differ:
                from skhybrid.exceptions import InconsistentVersionWarning

                warnings.warn(
                    InconsistentVersionWarning(
                        estimator_name=type(self).__name__,
                        original_versions=pickled,
                        current_versions=current,
                    ),
                    stacklevel=2,
                )
        try:
            super().__setstate__(state)
        except AttributeError:  # plain objects have no __setstate__
            self.__dict__.update(state)
        for name, param in inspect.signature(type(self).__init__).parameters.items():
            if param.default is not param.empty and name not in self.__dict__:
                setattr(self, name, param.default)
