"""What every measured benchmark of the catalogue shares: its facts, its files.

A measured benchmark's facts, known before its files are read, are constants of
its module, each the one owner of its fact: ``NAME``, ``TITLE``, ``UNIT``,
``SCALE`` (from the data's units to the official reporting units),
``PUBLISHED``, ``NOTES`` and, where its family holds no state-space hybrid,
``HYBRIDS = False``. The catalogue and the runner read them there (a run's
title before any record is loaded); :func:`measured_spec` fills the
:class:`~skhybrid.experiments.SystemSpec`'s arguments from them.
"""

import textwrap

from skhybrid.experiments import SystemSpec
from skhybrid.utils._docstrings import fill_docstring

__all__ = [
    "FACTS",
    "fill_make_spec_docstring",
    "measured_spec",
    "pair",
    "read_files",
    "test_records",
]

#: The module constants that hold a measured benchmark's facts, and the
#: :class:`~skhybrid.experiments.SystemSpec` argument each fills.
FACTS = {
    "NAME": "name",
    "TITLE": "title",
    "UNIT": "unit",
    "SCALE": "scale",
    "PUBLISHED": "published",
    "NOTES": "notes",
}


#: The parameters and return of every measured benchmark's ``make_spec``, filled
#: into its docstring's ``%(make_spec_parameters)s`` line (each docstring says
#: what its ``quick`` shortens).
MAKE_SPEC_PARAMETERS = """\
    Parameters
    ----------
    data : str or Path or None, default=None
        Folder holding the benchmark's files; None fetches them once.
    quick : bool, default=False
        The quick form, as the summary above says.

    Returns
    -------
    spec : SystemSpec
        The estimation records loaded; the test records load when called."""


def fill_make_spec_docstring(doc):
    """``doc`` with its ``%(make_spec_parameters)s`` line written out.

    Parameters
    ----------
    doc : str
        A ``make_spec`` docstring.

    Returns
    -------
    doc : str
        The docstring with the shared Parameters and Returns sections.
    """
    return fill_docstring(
        doc, make_spec_parameters=textwrap.dedent(MAKE_SPEC_PARAMETERS)
    )


def measured_spec(module, files, **arguments):
    """A measured benchmark's spec, its facts read from its module's constants.

    Parameters
    ----------
    module : module
        The benchmark's module in :mod:`skhybrid.benchmarks`, holding the
        constants of :data:`FACTS` (and ``HYBRIDS = False`` where its family
        holds no state-space hybrid: the spec's ``hybrids`` is None then).
    files : Bunch
        Its data, :func:`read_files`'s: the spec's ``n_init`` and ``dt``.
    **arguments
        The spec's other arguments (``records``, ``tests``, ``physics``...).

    Returns
    -------
    spec : SystemSpec
        The benchmark's spec.

    Raises
    ------
    TypeError
        If ``arguments`` repeats a fact the module's constants own.
    """
    facts = {argument: getattr(module, name) for name, argument in FACTS.items()}
    if not getattr(module, "HYBRIDS", True):
        facts["hybrids"] = None
    facts.update(n_init=files.n_init, dt=files.dt)
    doubled = sorted(set(facts) & set(arguments))
    if doubled:
        raise TypeError(
            f"{doubled} of {module.__name__} are read from its constants and its "
            "files; set them there, not as arguments of measured_spec."
        )
    return SystemSpec(**facts, **arguments)


def pair(split):
    """``(u, y)`` of a data split."""
    return (split.u, split.y)


def read_files(fetch, load, data):
    """A benchmark's data Bunch: ``load(data)``, or ``fetch()`` where ``data`` is None.

    Parameters
    ----------
    fetch, load : callable
        The benchmark's fetcher and loader in :mod:`skhybrid.datasets`.
    data : str or Path or None
        The folder of its files.

    Returns
    -------
    data : Bunch
        Its splits, ``n_init`` and ``dt``.
    """
    return fetch() if data is None else load(data)


def test_records(fetch, load, data, names):
    """The test records ``{report name: (u, y)}``, read from the files.

    A spec's ``tests`` is this function with its arguments bound
    (:func:`functools.partial`), so the files are read again only once the
    selection is sealed.

    Parameters
    ----------
    fetch, load : callable
        The benchmark's fetcher and loader.
    data : str or Path or None
        The folder of its files.
    names : dict of str to str
        ``{report name: split}``.

    Returns
    -------
    tests : dict of str to tuple
        The test records.
    """
    splits = read_files(fetch, load, data).splits
    return {name: pair(splits[split]) for name, split in names.items()}
