"""Blocked cross-validation of whole records, for models judged in free run.

A record is one measured experiment: inputs ``u`` of shape (n_times, n_inputs)
and outputs ``y`` of shape (n_times, n_outputs), in time order. A model of a
dynamical system is judged by simulating a record from its first ``n_init``
measured outputs, so its validation data must be contiguous stretches of
records, never shuffled samples.
"""

from numbers import Integral

import numpy as np

__all__ = ["RecordBlockSplit", "take_pieces"]

#: A held-out block holds at least this many times ``n_init`` samples, so that
#: most of it is scored (its first ``n_init`` samples only start the free run).
MIN_BLOCK_FACTOR = 8


def _as_record_list(records, name):
    """A list of records (3-D array, list or tuple) or one record, as a list."""
    if isinstance(records, (list, tuple)):
        out = [np.asarray(r) for r in records]
    else:
        arr = np.asarray(records)
        out = list(arr) if arr.ndim == 3 else [arr]
    if not out:
        raise ValueError(f"{name} holds no record; give a list of records.")
    for i, r in enumerate(out):
        if r.ndim not in (1, 2) or len(r) == 0:
            raise ValueError(
                f"{name}[{i}] has shape {r.shape}; each record must be an array "
                "of shape (n_times,) or (n_times, n_columns) with n_times >= 1."
            )
    return out


def _check_records(U, Y=None):
    """Both lists of records, checked to be aligned record by record.

    Parameters
    ----------
    U : list of array-like of shape (n_times_i, n_inputs)
        Inputs of each record (or one record, or a 3-D array of records).
    Y : list of array-like of shape (n_times_i, n_outputs), default=None
        Outputs of each record.

    Returns
    -------
    U, Y : list of ndarray
        The records, not copied (``Y`` is None where it was).
    """
    U = _as_record_list(U, "U")
    if Y is None:
        return U, None
    Y = _as_record_list(Y, "Y")
    if len(U) != len(Y):
        raise ValueError(
            f"U holds {len(U)} records and Y {len(Y)}; give one output record per "
            "input record."
        )
    for i, (u, y) in enumerate(zip(U, Y, strict=True)):
        if len(u) != len(y):
            raise ValueError(
                f"record {i} holds {len(u)} input and {len(y)} output time steps; "
                "each record's inputs and outputs must be aligned."
            )
    return U, Y


def take_pieces(U, Y, pieces):
    """The pieces ``(record, start, stop)`` of records, each a separate record.

    Parameters
    ----------
    U : list of array-like of shape (n_times_i, n_inputs)
        Inputs of each record.
    Y : list of array-like of shape (n_times_i, n_outputs) or None
        Outputs of each record.
    pieces : list of tuple of (int, int, int)
        ``(record_index, start, stop)`` slices, as :meth:`RecordBlockSplit.split`
        yields them.

    Returns
    -------
    U_pieces, Y_pieces : list of ndarray
        ``U[record][start:stop]`` and ``Y[record][start:stop]`` for each piece,
        in order (views, not copies); ``Y_pieces`` is None where ``Y`` is.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.model_selection import take_pieces
    >>> U, Y = [np.arange(6.0)[:, None]], [np.arange(6.0)[:, None]]
    >>> u, y = take_pieces(U, Y, [(0, 0, 2), (0, 4, 6)])
    >>> [p.ravel().tolist() for p in u]
    [[0.0, 1.0], [4.0, 5.0]]
    """
    U, Y = _check_records(U, Y)
    U_pieces = [U[r][a:b] for r, a, b in pieces]
    Y_pieces = None if Y is None else [Y[r][a:b] for r, a, b in pieces]
    return U_pieces, Y_pieces


class RecordBlockSplit:
    """Blocked cross-validation of records simulated in free run.

    Each record is cut into ``n_splits`` contiguous blocks of (nearly) equal
    length. Fold ``k`` holds out block ``k`` of every record and fits on the
    remaining pieces, each a separate record: the piece before the held-out
    block and the piece after it are never joined across the gap. A held-out
    block is simulated from its own first ``n_init`` measured outputs and scored
    after them, exactly as a test record is. With ``n_splits=4`` and two
    records::

        record 0   |--- block 0 ---|--- block 1 ---|--- block 2 ---|--- block 3 ---|
        fold 0     |    TEST       |               fit (one piece)                 |
        fold 1     | fit (piece 1) |    TEST       |       fit (piece 2)           |
        fold 2     |       fit (piece 1)           |    TEST       | fit (piece 2) |
        fold 3     |               fit (one piece)                 |    TEST       |

        record 1   |-- block 0 --|-- block 1 --|-- block 2 --|-- block 3 --|
        fold k     the same: block k is held out, the rest are fit pieces

    A TEST block is simulated from its first ``n_init`` measured outputs (``ii``)
    and scored on the rest (``ss``)::

        TEST       |ii|ssssssssssss|

    Parameters
    ----------
    n_splits : int, default=4
        Folds asked for (at least 2). Fewer are used where a block would hold
        fewer than ``8 * n_init`` samples (see Notes).
    n_init : int, default=1
        Measured samples that start each held-out block's free run.

    See Also
    --------
    SimulationSearchCV : Chooses among candidate models with this splitter.
    take_pieces : The arrays of the pieces a split yields.

    Notes
    -----
    **Folds used.** With ``n`` samples and ``K`` folds a record's blocks hold
    ``n // K`` samples or one more (block ``i`` spans
    ``[i * n // K, (i + 1) * n // K)``). ``K`` is the largest number, at most
    ``n_splits`` and at least 2, for which every record's blocks hold at least
    ``8 * n_init`` samples, so that most of each block is scored.
    :meth:`get_n_splits` returns it and :meth:`get_n_splits_reason` says why,
    in a sentence a run record can store.

    **Records too short to cut.** A record with fewer than ``2 * 8 * n_init``
    samples cannot give two such blocks: it is never held out and goes whole into
    every fold's fit pieces; the other records decide ``K``. If no record is
    long enough, :meth:`split` raises a ``ValueError``.

    **Pieces too short to fit.** A fit piece with fewer than ``n_init + 1``
    samples (it could not start a free run and score one step) is dropped. Fit
    pieces cut from a held-out record hold whole blocks, so only a short record
    kept whole can be dropped.

    Unlike scikit-learn's splitters, which yield index arrays into one ``X``,
    :meth:`split` yields ``(record_index, start, stop)`` slices of a list of
    records, so the class does not subclass
    :class:`~sklearn.model_selection.BaseCrossValidator`: a sample index means
    nothing across records. Parameters are validated in :meth:`split`, as an
    estimator's are in ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.model_selection import RecordBlockSplit, take_pieces
    >>> U = [np.zeros((100, 1)), np.zeros((60, 1))]
    >>> cv = RecordBlockSplit(n_splits=4, n_init=2)
    >>> cv.get_n_splits(U)
    3
    >>> cv.get_n_splits_reason(U)
    '3 folds of the 4 asked: with 4, record 1 (60 samples) would give blocks of 15 \
samples, fewer than 8 * n_init = 16.'
    >>> fit, test = next(cv.split(U))
    >>> fit
    [(0, 33, 100), (1, 20, 60)]
    >>> test
    [(0, 0, 33), (1, 0, 20)]
    >>> u_fit, _ = take_pieces(U, None, fit)
    >>> [len(u) for u in u_fit]
    [67, 40]
    """

    def __init__(self, n_splits=4, *, n_init=1):
        self.n_splits = n_splits
        self.n_init = n_init

    def __repr__(self):
        return (
            f"{type(self).__name__}(n_splits={self.n_splits!r}, n_init={self.n_init!r})"
        )

    def _check_params(self):
        for name, low in (("n_splits", 2), ("n_init", 1)):
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, Integral)
                or value < low
            ):
                raise ValueError(
                    f"The '{name}' parameter of RecordBlockSplit must be an int "
                    f">= {low}. Got {value!r} instead."
                )

    def _plan(self, lengths):
        """Folds used, which records are cut, and the reason, from record lengths."""
        self._check_params()
        min_block = MIN_BLOCK_FACTOR * self.n_init
        cut = [i for i, n in enumerate(lengths) if n // 2 >= min_block]
        if not cut:
            raise ValueError(
                f"no record is long enough to hold out: records of {list(lengths)} "
                f"samples, and two blocks of at least {MIN_BLOCK_FACTOR} * n_init "
                f"= {min_block} samples need {2 * min_block}; lower n_init="
                f"{self.n_init} or give longer records."
            )
        n_folds = self.n_splits
        while any(lengths[i] // n_folds < min_block for i in cut):
            n_folds -= 1
        if n_folds == self.n_splits:
            reason = f"{n_folds} folds as asked."
        else:
            short = min(cut, key=lambda i: lengths[i])
            reason = (
                f"{n_folds} folds of the {self.n_splits} asked: with "
                f"{n_folds + 1}, record {short} ({lengths[short]} samples) would "
                f"give blocks of {lengths[short] // (n_folds + 1)} samples, fewer "
                f"than {MIN_BLOCK_FACTOR} * n_init = {min_block}."
            )
        whole = [i for i in range(len(lengths)) if i not in cut]
        if whole:
            reason += (
                f" Records {whole} are shorter than {2 * min_block} samples: never "
                "held out, fitted on whole in every fold"
                + (
                    f" (those under n_init + 1 = {self.n_init + 1} samples dropped)."
                    if any(lengths[i] < self.n_init + 1 for i in whole)
                    else "."
                )
            )
        return n_folds, cut, whole, reason

    @staticmethod
    def _lengths(U):
        U, _ = _check_records(U)
        return [len(u) for u in U]

    def get_n_splits(self, U=None, Y=None, groups=None):
        """Return the number of folds used on these records.

        Parameters
        ----------
        U : list of array-like of shape (n_times_i, n_inputs), default=None
            Inputs of each record; only their lengths matter. Without them,
            ``n_splits`` (the number asked for) is returned.
        Y : object, default=None
            Ignored; present for API compatibility.
        groups : object, default=None
            Ignored; present for API compatibility.

        Returns
        -------
        n_splits : int
            The folds :meth:`split` yields on ``U``.
        """
        if U is None:
            return self.n_splits
        return self._plan(self._lengths(U))[0]

    def get_n_splits_reason(self, U, Y=None):
        """Say how many folds are used on these records, and why.

        Parameters
        ----------
        U : list of array-like of shape (n_times_i, n_inputs)
            Inputs of each record; only their lengths matter.
        Y : object, default=None
            Ignored; present for API compatibility.

        Returns
        -------
        reason : str
            One or two sentences, for a run record.
        """
        return self._plan(self._lengths(U))[3]

    def split(self, U, Y=None, groups=None):
        """Generate the fit pieces and the held-out blocks of each fold.

        Parameters
        ----------
        U : list of array-like of shape (n_times_i, n_inputs)
            Inputs of each record (or one record, or a 3-D array of records).
        Y : list of array-like of shape (n_times_i, n_outputs), default=None
            Outputs of each record; checked to align with ``U``.
        groups : object, default=None
            Ignored; a record is its own group.

        Returns
        -------
        splits : generator of tuple of (list, list)
            For each fold, ``fit`` and ``test``: the ``(record_index, start,
            stop)`` slices of the fit pieces (each a separate record) and of the
            held-out blocks (one per record that is cut). Use
            :func:`take_pieces` for the arrays. The arguments are validated when
            ``split`` is called, before the first fold.
        """
        U, Y = _check_records(U, Y)
        lengths = [len(u) for u in U]
        n_folds, cut, whole, _ = self._plan(lengths)  # validate before yielding
        return self._iter(lengths, n_folds, cut, whole)

    def _iter(self, lengths, n_folds, cut, whole):
        min_fit = self.n_init + 1
        for k in range(n_folds):
            fit, test = [], []
            for i, n in enumerate(lengths):
                if i in whole:
                    if n >= min_fit:
                        fit.append((i, 0, n))
                    continue
                edges = [j * n // n_folds for j in range(n_folds + 1)]
                test.append((i, edges[k], edges[k + 1]))
                for a, b in ((0, edges[k]), (edges[k + 1], n)):
                    if b - a >= min_fit:
                        fit.append((i, a, b))
            yield fit, test
