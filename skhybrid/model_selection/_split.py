"""Train, interpolative and extrapolative test sets (section 5 of the paper).

An interpolative test point lies inside the convex hull of the training points,
an extrapolative one outside it. Both guarantees are checked with
:func:`in_convex_hull` (or proven by a separating hyperplane) before a split is
returned.
"""

from numbers import Integral, Real

import numpy as np
from sklearn.model_selection import BaseCrossValidator
from sklearn.utils import check_array, check_random_state, indexable

from skhybrid.model_selection._hull import in_convex_hull
from skhybrid.utils._sklearn_compat import _safe_indexing

__all__ = [
    "ConvexHullSplit",
    "ExtrapolationSplit",
    "interpolation_extrapolation_split",
]


def _check_size(value, name, n_samples):
    """Turn a fraction or a count into a count, naming the parameter on error."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise TypeError(
            f"{name} must be a float in (0, 1) or an int >= 0; got {value!r}."
        )
    if isinstance(value, Integral):
        if not 0 <= value <= n_samples:
            raise ValueError(
                f"{name}={value} must lie between 0 and n_samples={n_samples}."
            )
        return int(value)
    if not 0.0 < value < 1.0:
        raise ValueError(
            f"{name}={value!r} must be a fraction in (0, 1) or an int count."
        )
    return int(np.ceil(value * n_samples))


def _check_features(features, n_features, name="features"):
    """Column indices from an int, a sequence of ints, a mask or None (all)."""
    if features is None:
        return np.arange(n_features)
    cols = np.atleast_1d(np.asarray(features))
    if cols.dtype == bool:
        if cols.shape != (n_features,):
            raise ValueError(
                f"{name} is a bool mask of shape {cols.shape}; expected "
                f"({n_features},) to match the columns of X."
            )
        cols = np.flatnonzero(cols)
    elif not np.issubdtype(cols.dtype, np.integer) or cols.ndim != 1:
        raise TypeError(
            f"{name} must be an int, a sequence of ints or a bool mask; got "
            f"{features!r}."
        )
    if cols.size == 0 or np.any((cols < -n_features) | (cols >= n_features)):
        raise ValueError(
            f"{name}={features!r} must name at least one column in "
            f"[-{n_features}, {n_features}); X has {n_features} columns."
        )
    return np.unique(cols % n_features)


def _standardize(X):
    std = X.std(axis=0)
    std[std == 0] = 1.0
    return (X - X.mean(axis=0)) / std


def _outlyingness(Z, strategy, direction, rng):
    """Score each row; the highest scores are extrapolation candidates."""
    if strategy == "shell":
        score = np.linalg.norm(Z, axis=1)
    else:
        if direction is None:
            direction = rng.standard_normal(Z.shape[1])
        direction = np.asarray(direction, dtype=float)
        if direction.shape != (Z.shape[1],) or not np.any(direction):
            raise ValueError(
                f"direction must be a non-zero vector of length {Z.shape[1]} "
                f"(one entry per hull feature); got shape {direction.shape}."
            )
        score = Z @ direction
    return score


def _extrapolation_mask(Xh, order, n_extrap, groups=None):
    """Take rows in ``order`` until ``n_extrap`` lie outside the hull of the rest.

    A candidate (or its whole group) found inside the hull of the remaining
    rows is put back with them for good. Returns the mask and its size, which
    falls short of ``n_extrap`` when the candidates run out.
    """
    n = len(Xh)
    if groups is not None:
        # Rank groups by their least outlying row, so whole groups move.
        _, inverse = np.unique(groups, return_inverse=True)
        rank = np.empty(n, dtype=np.intp)
        rank[order] = np.arange(n)
        group_rank = np.full(inverse.max() + 1, -1)
        np.maximum.at(group_rank, inverse, rank)
        units = [np.flatnonzero(inverse == g) for g in np.argsort(group_rank)]
    else:
        units = [order[i : i + 1] for i in range(n)]
    test = np.zeros(n, dtype=bool)
    rejected = np.zeros(n, dtype=bool)
    pos = 0
    while True:
        while test.sum() < n_extrap and pos < len(units):
            if not rejected[units[pos]].any():
                test[units[pos]] = True
            pos += 1
        if not test.any() or test.all():
            return test, 0
        inside = in_convex_hull(Xh[test], Xh[~test])
        if not inside.any():
            return test, int(test.sum())
        bad = np.flatnonzero(test)[inside]
        if groups is not None:
            bad = np.flatnonzero(np.isin(groups, np.asarray(groups)[bad]))
        test[bad] = False
        rejected[bad] = True


def _interpolation_mask(Xh, available, candidates, n_interp, groups=None):
    """Pick up to ``n_interp`` rows inside the hull of the other available rows.

    ``candidates`` is a random order of the available rows. Taking candidates
    out of training can shrink the hull under earlier picks, so all picks are
    checked together; those found outside go back to training, which only
    enlarges the hull, so the rest stay inside it.
    """
    if groups is not None:
        groups = np.asarray(groups)
        _, first = np.unique(groups[candidates], return_index=True)
        labels = groups[candidates][np.sort(first)]
        units = [np.flatnonzero(available & (groups == g)) for g in labels]
    else:
        units = [candidates[i : i + 1] for i in range(len(candidates))]
    test = np.zeros(len(Xh), dtype=bool)
    pos = 0
    while test.sum() < n_interp and pos < len(units):
        while test.sum() < n_interp and pos < len(units):
            test[units[pos]] = True
            pos += 1
        train = available & ~test
        if not train.any():
            test[units[pos - 1]] = False
            break
        inside = in_convex_hull(Xh[test], Xh[train])
        bad = np.flatnonzero(test)[~inside]
        if groups is not None:
            bad = np.flatnonzero(test & np.isin(groups, groups[bad]))
        test[bad] = False
    return test


def interpolation_extrapolation_split(
    X,
    y=None,
    *,
    interpolation_size=0.2,
    extrapolation_size=0.2,
    strategy="shell",
    direction=None,
    features=None,
    groups=None,
    random_state=None,
):
    """Split data into training, interpolative and extrapolative test sets.

    Works like :func:`sklearn.model_selection.train_test_split` with two test
    sets: every extrapolative point lies outside the convex hull of the
    training points and every interpolative point inside it (checked with
    :func:`in_convex_hull`).

    Parameters
    ----------
    X : array-like of shape (n_samples, n_features)
        Inputs; the hull is taken over ``X[:, features]``.
    y : array-like of shape (n_samples,) or (n_samples, n_outputs), default=None
        Targets, split alongside ``X``. Pass ``np.arange(n_samples)`` to get
        the indices of the three parts.
    interpolation_size : float or int, default=0.2
        Fraction of the samples (float in (0, 1)) or number of samples (int)
        in the interpolative test set.
    extrapolation_size : float or int, default=0.2
        Fraction or number of samples in the extrapolative test set.
    strategy : {"shell", "direction"}, default="shell"
        Which points become extrapolative: ``"shell"`` takes the points
        farthest from the mean (features standardised), so the test set
        surrounds the training region, as an amplitude extrapolation does;
        ``"direction"`` takes the points farthest along one direction, so a
        hyperplane cuts the test set off.
    direction : array-like of shape (n_hull_features,), default=None
        Direction for ``strategy="direction"``, in standardised features;
        ``None`` draws one from ``random_state``.
    features : int, sequence of int, bool mask or None, default=None
        Columns of ``X`` spanning the hull (say, the inputs of a window);
        ``None`` uses all columns.
    groups : array-like of shape (n_samples,), default=None
        Trajectory labels; a trajectory is never divided between the sets.
    random_state : int, RandomState instance or None, default=None
        Draws the interpolative points (and the direction).

    Returns
    -------
    splitting : list of length 3 or 6
        ``[X_train, X_interp, X_extrap]``, followed by
        ``[y_train, y_interp, y_extrap]`` when ``y`` is given.

    Raises
    ------
    ValueError
        When the sizes cannot be met: they add up to more than the data, or
        fewer points lie outside (inside) the hull than asked for. The message
        names the sizes and what is possible.

    See Also
    --------
    ConvexHullSplit : Cross-validation with such test folds.
    ExtrapolationSplit : Extrapolation beyond a range of chosen features.
    in_convex_hull : The membership test behind the guarantees.

    Notes
    -----
    Extrapolative points are chosen first, in order of outlyingness; a
    candidate that turns out to lie inside the hull of the other points is
    returned to them. Interpolative points are then drawn at random from the
    rest and kept only where they lie inside the hull of what remains for
    training. In many dimensions few points lie inside the hull of the others
    (most are vertices), so large interpolative sets may be impossible; the
    error says how many were found.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.model_selection import interpolation_extrapolation_split
    >>> X = np.random.default_rng(0).uniform(-1, 1, size=(200, 2))
    >>> y = X.sum(axis=1)
    >>> X_train, X_interp, X_extrap, y_train, y_interp, y_extrap = (
    ...     interpolation_extrapolation_split(
    ...         X, y, interpolation_size=0.2, extrapolation_size=0.2,
    ...         random_state=0))
    >>> len(X_train), len(X_interp), len(X_extrap)
    (120, 40, 40)
    """
    if strategy not in ("shell", "direction"):
        raise ValueError(f"strategy must be 'shell' or 'direction'; got {strategy!r}.")
    arrays = [X] if y is None else [X, y]
    arrays = indexable(*arrays)
    X = check_array(arrays[0], dtype=np.float64, input_name="X")
    n = X.shape[0]
    cols = _check_features(features, X.shape[1])
    n_interp = _check_size(interpolation_size, "interpolation_size", n)
    n_extrap = _check_size(extrapolation_size, "extrapolation_size", n)
    if n_interp + n_extrap >= n:
        raise ValueError(
            f"interpolation_size={interpolation_size!r} and extrapolation_size="
            f"{extrapolation_size!r} ask for {n_interp} + {n_extrap} of "
            f"{n} samples, leaving none for training; together they may take "
            f"at most {n - 1}."
        )
    if groups is not None:
        groups = np.asarray(groups)
        if groups.shape != (n,):
            raise ValueError(
                f"groups has shape {groups.shape}; expected ({n},), one label "
                "per row of X."
            )
    rng = check_random_state(random_state)
    Xh = X[:, cols]
    Z = _standardize(Xh)
    score = _outlyingness(Z, strategy, direction, rng)
    # Random tie-breaks, so equal scores do not follow the row order.
    order = np.lexsort((rng.permutation(n), -score))
    extrap, found = _extrapolation_mask(Xh, order, n_extrap, groups)
    if found < n_extrap or extrap.all():
        raise ValueError(
            f"extrapolation_size={extrapolation_size!r} asks for {n_extrap} "
            f"points outside the convex hull of the other points, but only "
            f"{found if not extrap.all() else 0} of the {n} samples can be "
            "placed there; ask for fewer or use strategy='direction'."
        )
    available = ~extrap
    candidates = rng.permutation(np.flatnonzero(available))
    interp = _interpolation_mask(Xh, available, candidates, n_interp, groups)
    if interp.sum() < n_interp:
        raise ValueError(
            f"interpolation_size={interpolation_size!r} asks for {n_interp} "
            f"points inside the convex hull of the training points, but only "
            f"{int(interp.sum())} were found (with extrapolation_size="
            f"{extrapolation_size!r}, {n} samples, {len(cols)} hull features); "
            "ask for fewer, or span the hull with fewer features."
        )
    train = available & ~interp
    parts = [np.flatnonzero(train), np.flatnonzero(interp), np.flatnonzero(extrap)]
    out = []
    for a in arrays:
        out.extend(_safe_take(a, idx) for idx in parts)
    return out


def _safe_take(a, idx):
    return _safe_indexing(a, idx)


class ConvexHullSplit(BaseCrossValidator):
    """Cross-validation with interpolative or extrapolative test folds.

    Each split cuts the data from a different random direction (in
    standardised features): with ``kind="extrapolation"`` the test fold is
    the ``test_size`` share of points farthest along that direction, which a
    hyperplane separates from the training fold, so every test point lies
    outside the convex hull of the training points. With
    ``kind="interpolation"`` the test fold is a random draw, less the points
    that fall outside the hull of the training points (they are trained on).

    Parameters
    ----------
    n_splits : int, default=5
        Number of splits (directions).
    kind : {"extrapolation", "interpolation"}, default="extrapolation"
        Whether test points lie outside or inside the training hull.
    test_size : float or int, default=0.2
        Fraction of the samples (float in (0, 1)) or number of samples (int)
        drawn into each test fold; interpolative folds may end up smaller.
    random_state : int, RandomState instance or None, default=None
        Draws the directions and the interpolative test points. Pass an int
        for the same splits on every call.

    See Also
    --------
    interpolation_extrapolation_split : One split with both test sets.
    ExtrapolationSplit : Extrapolation beyond a range of chosen features.
    ConvexHullSplitDisplay : Draws a split over two features.

    Notes
    -----
    With ``groups`` a trajectory goes whole into the training or the test
    fold. A test trajectory with a point inside the training hull (for
    ``kind="extrapolation"``) or outside it (``kind="interpolation"``) is
    moved to the training fold, and the check repeated, so the guarantees
    hold for every test point. Validation happens in :meth:`split`, as
    parameters of an estimator are validated in ``fit``.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import Ridge
    >>> from sklearn.model_selection import cross_val_score
    >>> from skhybrid.model_selection import ConvexHullSplit
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(100, 3))
    >>> y = X @ [1.0, 2.0, 3.0]
    >>> cv = ConvexHullSplit(n_splits=3, random_state=0)
    >>> scores = cross_val_score(Ridge(alpha=1e-6), X, y, cv=cv)
    >>> len(scores), bool(scores.min() > 0.99)
    (3, True)
    """

    def __init__(
        self, n_splits=5, *, kind="extrapolation", test_size=0.2, random_state=None
    ):
        self.n_splits = n_splits
        self.kind = kind
        self.test_size = test_size
        self.random_state = random_state

    def get_n_splits(self, X=None, y=None, groups=None):
        """Return the number of splits.

        Parameters
        ----------
        X, y, groups : object
            Ignored; present for API compatibility.

        Returns
        -------
        n_splits : int
            ``n_splits``.
        """
        return self.n_splits

    def split(self, X, y=None, groups=None):
        """Generate indices of the training and test folds.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Data; the hull is taken over all its columns.
        y : array-like of shape (n_samples,), default=None
            Ignored.
        groups : array-like of shape (n_samples,), default=None
            Trajectory labels; a trajectory is never divided between folds.

        Returns
        -------
        splits : generator of tuple of (ndarray, ndarray)
            The training and test indices of each fold. The arguments are
            validated when ``split`` is called, before the first fold.
        """
        self._check_params()
        return super().split(X, y, groups)

    def _check_params(self):
        if (
            isinstance(self.n_splits, bool)
            or not isinstance(self.n_splits, Integral)
            or self.n_splits < 1
        ):
            raise ValueError(f"n_splits must be an int >= 1; got {self.n_splits!r}.")
        if self.kind not in ("extrapolation", "interpolation"):
            raise ValueError(
                f"kind must be 'extrapolation' or 'interpolation'; got {self.kind!r}."
            )

    def _iter_test_masks(self, X, y=None, groups=None):
        X = check_array(X, dtype=np.float64, input_name="X")
        n = X.shape[0]
        n_test = _check_size(self.test_size, "test_size", n)
        if not 0 < n_test < n:
            raise ValueError(
                f"test_size={self.test_size!r} gives {n_test} test samples of "
                f"{n}; each fold needs at least one training and one test sample."
            )
        if groups is not None:
            groups = np.asarray(groups)
            if groups.shape != (n,):
                raise ValueError(
                    f"groups has shape {groups.shape}; expected ({n},), one "
                    "label per row of X."
                )
        rng = check_random_state(self.random_state)
        Z = _standardize(X)
        directions = _directions(X.shape[1], self.n_splits, rng)
        for k in range(self.n_splits):
            if self.kind == "extrapolation":
                score = Z @ directions[k]
                order = np.lexsort((rng.permutation(n), -score))
                test = self._extrapolation_fold(X, score, order, n_test, groups)
            else:
                candidates = rng.permutation(n)
                test = _interpolation_mask(
                    X, np.ones(n, dtype=bool), candidates, n_test, groups
                )
            if not test.any():
                unit = "trajectory" if groups is not None else "point"
                side = "outside" if self.kind == "extrapolation" else "inside"
                raise ValueError(
                    f"split {k} of ConvexHullSplit(kind={self.kind!r}) has an "
                    f"empty test fold: no {unit} lies {side} the convex hull of "
                    f"the rest ({n} samples, {X.shape[1]} features). Use more "
                    "samples, fewer features or the other kind."
                )
            yield test

    @staticmethod
    def _extrapolation_fold(X, score, order, n_test, groups):
        if groups is None:
            test = np.zeros(len(X), dtype=bool)
            test[order[:n_test]] = True
            # Strictly higher scores than every training point: the
            # hyperplane through the cut separates the folds.
            if score[test].min() > score[~test].max():
                return test
        test, _ = _extrapolation_mask(X, order, n_test, groups)
        return test


def _directions(n_features, n_splits, rng):
    """Unit directions for the splits, as different from each other as possible.

    Each block of ``2 * n_features`` splits walks the two ends of the axes of a
    random orthonormal basis (``q0, -q0, q1, -q1, ...``), so consecutive splits
    cut the data from opposite sides and then from perpendicular ones.
    """
    out = []
    while len(out) < n_splits:
        q, r = np.linalg.qr(rng.standard_normal((n_features, n_features)))
        q *= np.where(np.diag(r) < 0, -1.0, 1.0)  # uniform over rotations
        for axis in q.T:
            out.extend([axis, -axis])
    return np.asarray(out[:n_splits])


class ExtrapolationSplit(BaseCrossValidator):
    """One split: train inside a range of chosen features, test outside it.

    The paper's amplitude extrapolation: train on rows where the torque stays
    within ``|u| <= 1`` and test on rows where it leaves that range. A row
    goes to the test fold when any chosen feature leaves its range (for a
    window, say, the input at any step), so a hyperplane separates every test
    row from the training rows: they lie outside the training hull.

    Parameters
    ----------
    features : int, sequence of int or bool mask, default=-1
        Columns of ``X`` whose range is limited in training.
    bounds : tuple (low, high) or sequence of such tuples, default=(-1.0, 1.0)
        Training range: one pair for every chosen feature, or one pair per
        feature. ``None`` leaves a side open.

    See Also
    --------
    ConvexHullSplit : Several extrapolative splits from random directions.
    interpolation_extrapolation_split : Training, interpolative and
        extrapolative sets in one call.

    Notes
    -----
    With ``groups`` a trajectory that leaves the range anywhere goes whole to
    the test fold. Validation happens in :meth:`split`.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.model_selection import ExtrapolationSplit
    >>> torque = np.linspace(-2, 2, 9)
    >>> X = np.column_stack([np.zeros(9), torque])
    >>> train, test = next(ExtrapolationSplit(features=1, bounds=(-1, 1)).split(X))
    >>> X[train, 1]
    array([-1. , -0.5,  0. ,  0.5,  1. ])
    >>> X[test, 1]
    array([-2. , -1.5,  1.5,  2. ])
    """

    def __init__(self, features=-1, *, bounds=(-1.0, 1.0)):
        self.features = features
        self.bounds = bounds

    def get_n_splits(self, X=None, y=None, groups=None):
        """Return the number of splits, 1.

        Parameters
        ----------
        X, y, groups : object
            Ignored; present for API compatibility.

        Returns
        -------
        n_splits : int
            Always 1.
        """
        return 1

    def split(self, X, y=None, groups=None):
        """Generate the indices of the training and the test fold.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Data.
        y : array-like of shape (n_samples,), default=None
            Ignored.
        groups : array-like of shape (n_samples,), default=None
            Trajectory labels; a trajectory is never divided between folds.

        Returns
        -------
        splits : generator of tuple of (ndarray, ndarray)
            The training and test indices of each fold. The arguments are
            validated when ``split`` is called, before the first fold.
        """
        X, y, groups = indexable(X, y, groups)
        X = check_array(X, dtype=np.float64, input_name="X")
        self._test_mask(X, groups)  # validate before yielding
        return super().split(X, y, groups)

    def _bounds(self, n_cols):
        bounds = self.bounds
        is_pair = isinstance(bounds, (tuple, list)) and len(bounds) == 2
        if is_pair and all(v is None or isinstance(v, Real) for v in bounds):
            pairs = [bounds]
        else:
            pairs = list(bounds) if isinstance(bounds, (tuple, list)) else None
        if not pairs or any(
            not isinstance(p, (tuple, list))
            or len(p) != 2
            or not all(v is None or isinstance(v, Real) for v in p)
            for p in pairs
        ):
            raise TypeError(
                "bounds must be a (low, high) pair of numbers or None, or a "
                f"sequence of such pairs; got {bounds!r}."
            )
        if len(pairs) not in (1, n_cols):
            raise ValueError(
                f"bounds has {len(pairs)} pairs; expected 1 or {n_cols}, one "
                "per chosen feature."
            )
        arr = np.array(
            [
                [-np.inf if lo is None else lo, np.inf if hi is None else hi]
                for lo, hi in pairs
            ],
            dtype=float,
        )
        if np.any(arr[:, 0] >= arr[:, 1]):
            raise ValueError(f"bounds={bounds!r} needs low < high in every pair.")
        return np.broadcast_to(arr, (n_cols, 2))

    def _test_mask(self, X, groups):
        cols = _check_features(self.features, X.shape[1])
        b = self._bounds(len(cols))
        V = X[:, cols]
        test = np.any((V < b[:, 0]) | (V > b[:, 1]), axis=1)
        if groups is not None:
            groups = np.asarray(groups)
            if groups.shape != (X.shape[0],):
                raise ValueError(
                    f"groups has shape {groups.shape}; expected ({X.shape[0]},), "
                    "one label per row of X."
                )
            test = np.isin(groups, groups[test])
        if test.all() or not test.any():
            side = "test" if not test.any() else "training"
            raise ValueError(
                f"bounds={self.bounds!r} on features {cols.tolist()} leave no "
                f"{side} rows: those features range over "
                f"{V.min(axis=0).tolist()} to {V.max(axis=0).tolist()}."
            )
        return test

    def _iter_test_masks(self, X, y=None, groups=None):
        yield self._test_mask(check_array(X, dtype=np.float64), groups)
