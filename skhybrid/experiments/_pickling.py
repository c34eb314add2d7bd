"""How a fit is cached in the run folder, its user's functions by name.

A run keeps its deterministic fits in the run folder's cache, written in
whichever process made the fit (the run's own, or a worker of a search) and
read in any of them. A function or class written in the user's script
(``__main__``) is stored there by its name, as pickle stores it, but without
pickle's check that the name gives back the very object: a worker holds the
copies each task received by value, and names in its ``__main__`` only those
of its first task (:func:`main_objects`, see
:func:`~skhybrid.experiments.free_run._family.expose_main_functions`). Read in
the run's process, the names give back the script's own.
"""

import functools
import pickle
import sys
import types

__all__ = ["dump_fit", "load_fit", "main_objects"]


def _main_name(obj):
    """The name of a function or class defined at the top of ``__main__``, or None."""
    if not isinstance(obj, (types.FunctionType, type)):
        return None
    if getattr(obj, "__module__", None) != "__main__":
        return None
    name = getattr(obj, "__qualname__", "")
    return name if name.isidentifier() else None


def _names_in(code):
    """The global names a code object and the code nested in it read."""
    yield from code.co_names
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            yield from _names_in(const)


def _reachable(value, seen):
    """Functions and classes reachable from ``value``.

    Through an estimator's parameters (and its class), dicts, lists, tuples,
    partials, a class's methods, and what a function of ``__main__`` reads from
    its globals or its closure.
    """
    if id(value) in seen:
        return
    seen.add(id(value))
    if isinstance(value, type):
        yield value
        if value.__module__ == "__main__":
            for attr in vars(value).values():  # its methods
                yield from _reachable(getattr(attr, "__func__", attr), seen)
    elif hasattr(value, "get_params"):
        yield from _reachable(type(value), seen)
        for v in value.get_params(deep=False).values():
            yield from _reachable(v, seen)
    elif isinstance(value, dict):
        for v in value.values():
            yield from _reachable(v, seen)
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _reachable(v, seen)
    elif isinstance(value, functools.partial):
        yield from _reachable(value.func, seen)
        yield from _reachable(value.args, seen)
        yield from _reachable(value.keywords, seen)
    elif isinstance(value, types.FunctionType):
        yield value
        if value.__module__ != "__main__":
            return
        for name in _names_in(value.__code__):
            found = value.__globals__.get(name)
            if isinstance(found, (types.FunctionType, type, functools.partial)) or (
                hasattr(found, "get_params") and not isinstance(found, type)
            ):
                yield from _reachable(found, seen)
        for cell in value.__closure__ or ():
            try:
                yield from _reachable(cell.cell_contents, seen)
            except ValueError:  # an empty cell
                pass
    elif callable(value):
        yield value


def main_objects(*values):
    """The functions and classes of ``__main__`` reachable from ``values``, by name.

    Parameters
    ----------
    *values : object
        What a run's fits are made of (a spec's physics and its inputs map).

    Returns
    -------
    objects : dict of str to object
        Each function or class defined at the top of ``__main__`` (a script, a
        notebook) that ``values`` use, under its name.
    """
    seen, objects = set(), {}
    for value in values:
        for obj in _reachable(value, seen):
            name = _main_name(obj)
            if name is not None:
                objects.setdefault(name, obj)
    return objects


class _FitPickler(pickle.Pickler):
    """Pickle that stores the functions and classes of ``__main__`` by name."""

    def persistent_id(self, obj):
        name = _main_name(obj)
        return None if name is None else ("__main__", name)


class _FitUnpickler(pickle.Unpickler):
    """Unpickle, finding the functions and classes of ``__main__`` by name."""

    def persistent_load(self, pid):
        kind, name = pid
        if kind != "__main__":
            raise pickle.UnpicklingError(f"unknown persistent id {pid!r}")
        try:
            return getattr(sys.modules["__main__"], name)
        except AttributeError:
            raise pickle.UnpicklingError(
                f"{name!r}, stored by name from __main__, is not found here"
            ) from None


def dump_fit(model, path):
    """Write a fit to ``path``, its functions and classes of ``__main__`` by name.

    Parameters
    ----------
    model : object
        The fit.
    path : str or Path
        The file.
    """
    with open(path, "wb") as f:
        _FitPickler(f, protocol=pickle.HIGHEST_PROTOCOL).dump(model)


def load_fit(path):
    """Read a fit written by :func:`dump_fit`.

    Its functions and classes of ``__main__`` are this process's ``__main__``'s
    of the same name: in a worker, those :func:`main_objects` named there.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    model : object
        The fit.
    """
    with open(path, "rb") as f:
        return _FitUnpickler(f).load()
