"""What every measured benchmark of the catalogue shares: reading its files."""

__all__ = ["pair", "read_files", "test_records"]


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
