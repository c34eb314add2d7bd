"""Display of a training / interpolative / extrapolative split (Fig. 2)."""

import numpy as np
from scipy.spatial import ConvexHull, QhullError
from sklearn.utils import check_array

from skhybrid.model_selection._split import _safe_take

__all__ = ["ConvexHullSplitDisplay"]


class ConvexHullSplitDisplay:
    """Training, interpolative and extrapolative points over two features.

    Draws the paper's Fig. 2: the three sets as scatter plots and the outline
    of the convex hull of the training points projected onto the two chosen
    features. Build it with :meth:`from_split` (or :meth:`from_cv`); the
    constructor stores already projected data.

    Parameters
    ----------
    X_train : ndarray of shape (n_train, 2)
        Training points, projected onto the two features.
    X_interp : ndarray of shape (n_interp, 2) or None
        Interpolative test points, projected.
    X_extrap : ndarray of shape (n_extrap, 2) or None
        Extrapolative test points, projected.
    feature_names : tuple of str, default=("feature 0", "feature 1")
        Axis labels.

    Attributes
    ----------
    train_ : matplotlib PathCollection
        Training points.
    interp_ : matplotlib PathCollection or None
        Interpolative points.
    extrap_ : matplotlib PathCollection or None
        Extrapolative points.
    hull_ : matplotlib Line2D or None
        Outline of the projected training hull (``None`` when the projection
        is degenerate).
    ax_ : matplotlib Axes
        Axes with the plot.
    figure_ : matplotlib Figure
        Figure containing the plot.

    See Also
    --------
    interpolation_extrapolation_split : Makes the split drawn here.
    ConvexHullSplit : Cross-validation with such test folds.

    Notes
    -----
    The outline is the hull of the projection, which is the projection of
    the hull. An extrapolative point outside the hull in all features can
    therefore be drawn inside the outline: it leaves the hull along features
    not shown.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.model_selection import (
    ...     ConvexHullSplitDisplay, interpolation_extrapolation_split)
    >>> X = np.random.default_rng(0).normal(size=(300, 2))
    >>> # Pass the row numbers as y to get the indices of the three sets.
    >>> train, interp, extrap = interpolation_extrapolation_split(
    ...     X, np.arange(300), random_state=0)[3:]
    >>> disp = ConvexHullSplitDisplay.from_split(X, train, interp, extrap)
    >>> disp.hull_ is not None
    True
    """

    def __init__(self, *, X_train, X_interp=None, X_extrap=None, feature_names=None):
        self.X_train = X_train
        self.X_interp = X_interp
        self.X_extrap = X_extrap
        self.feature_names = feature_names

    def plot(
        self,
        ax=None,
        *,
        train_kwargs=None,
        interp_kwargs=None,
        extrap_kwargs=None,
        hull_kwargs=None,
    ):
        """Draw the split.

        Parameters
        ----------
        ax : matplotlib Axes, default=None
            Axes to draw on; a new figure is made when ``None``.
        train_kwargs, interp_kwargs, extrap_kwargs : dict, default=None
            Passed to ``ax.scatter`` for each set.
        hull_kwargs : dict, default=None
            Passed to ``ax.plot`` for the hull outline.

        Returns
        -------
        display : ConvexHullSplitDisplay
            The display, with the artists stored.
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        names = self.feature_names or ("feature 0", "feature 1")
        styles = {
            "train": dict(s=8, c="tab:blue", alpha=0.6, label="train"),
            "interp": dict(s=10, c="tab:green", marker="^", label="interpolative"),
            "extrap": dict(s=10, c="tab:red", marker="s", label="extrapolative"),
        }
        for key, extra in (
            ("train", train_kwargs),
            ("interp", interp_kwargs),
            ("extrap", extrap_kwargs),
        ):
            styles[key].update(extra or {})
        self.train_ = ax.scatter(*self.X_train.T, **styles["train"])
        self.interp_ = self.extrap_ = None
        if self.X_interp is not None and len(self.X_interp):
            self.interp_ = ax.scatter(*self.X_interp.T, **styles["interp"])
        if self.X_extrap is not None and len(self.X_extrap):
            self.extrap_ = ax.scatter(*self.X_extrap.T, **styles["extrap"])
        self.hull_ = None
        outline = _outline(self.X_train)
        if outline is not None:
            kw = dict(color="tab:blue", lw=1.2, label="training hull")
            kw.update(hull_kwargs or {})
            (self.hull_,) = ax.plot(*outline.T, **kw)
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1])
        ax.legend(loc="best")
        self.ax_ = ax
        self.figure_ = ax.figure
        return self

    @classmethod
    def from_split(
        cls,
        X,
        train,
        interp=None,
        extrap=None,
        *,
        features=(0, 1),
        feature_names=None,
        ax=None,
    ):
        """Draw a split given by indices (or boolean masks) into ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Data that was split.
        train : array-like of int or bool
            Training rows.
        interp : array-like of int or bool, default=None
            Interpolative test rows.
        extrap : array-like of int or bool, default=None
            Extrapolative test rows.
        features : tuple of two int, default=(0, 1)
            Columns drawn on the x and y axes.
        feature_names : tuple of two str, default=None
            Axis labels; ``None`` names the columns by index.
        ax : matplotlib Axes, default=None
            Axes to draw on.

        Returns
        -------
        display : ConvexHullSplitDisplay
        """
        X = check_array(X, dtype=np.float64, input_name="X")
        features = tuple(features)
        if len(features) != 2 or not all(
            isinstance(f, (int, np.integer)) and -X.shape[1] <= f < X.shape[1]
            for f in features
        ):
            raise ValueError(
                f"features must be two column indices of X (which has "
                f"{X.shape[1]} columns); got {features!r}."
            )
        if feature_names is None:
            feature_names = tuple(f"feature {f}" for f in features)
        P = X[:, list(features)]

        def take(rows, name):
            if rows is None:
                return None
            rows = np.asarray(rows)
            if rows.dtype == bool and rows.shape != (len(X),):
                raise ValueError(
                    f"{name} is a boolean mask of shape {rows.shape}; expected "
                    f"({len(X)},)."
                )
            return _safe_take(P, rows)

        disp = cls(
            X_train=take(train, "train"),
            X_interp=take(interp, "interp"),
            X_extrap=take(extrap, "extrap"),
            feature_names=feature_names,
        )
        return disp.plot(ax=ax)

    @classmethod
    def from_cv(cls, cv, X, y=None, groups=None, *, split=0, features=(0, 1), ax=None):
        """Draw one split of a cross-validator such as :class:`ConvexHullSplit`.

        The test fold is drawn as extrapolative for ``kind="extrapolation"``
        (and for other splitters), as interpolative for
        ``kind="interpolation"``.

        Parameters
        ----------
        cv : cross-validation splitter
            Object with a ``split(X, y, groups)`` method.
        X : array-like of shape (n_samples, n_features)
            Data.
        y, groups : array-like, default=None
            Passed to ``cv.split``.
        split : int, default=0
            Which split to draw.
        features : tuple of two int, default=(0, 1)
            Columns drawn.
        ax : matplotlib Axes, default=None
            Axes to draw on.

        Returns
        -------
        display : ConvexHullSplitDisplay
        """
        folds = list(cv.split(X, y, groups))
        if not 0 <= split < len(folds):
            raise ValueError(
                f"split={split!r} is out of range; cv yields {len(folds)} splits."
            )
        train, test = folds[split]
        if getattr(cv, "kind", "extrapolation") == "interpolation":
            return cls.from_split(X, train, test, None, features=features, ax=ax)
        return cls.from_split(X, train, None, test, features=features, ax=ax)


def _outline(P):
    """Closed outline of the 2-D hull of ``P``, or ``None`` if degenerate."""
    if len(P) < 3:
        return None
    try:
        hull = ConvexHull(P)
    except QhullError:
        return None
    v = P[hull.vertices]  # counter-clockwise in 2-D
    return np.vstack([v, v[:1]])
