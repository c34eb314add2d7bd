"""Tests of ConvexHullSplitDisplay, checking the artists it draws."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from skhybrid.model_selection import (
    ConvexHullSplit,
    ConvexHullSplitDisplay,
    interpolation_extrapolation_split,
)


@pytest.fixture
def split(rng):
    X = rng.uniform(-1, 1, size=(150, 3))
    parts = interpolation_extrapolation_split(X, np.arange(150), random_state=0)
    return X, parts[3:]


def test_from_split_draws_three_sets_and_hull(pyplot, split):
    X, (train, interp, extrap) = split
    disp = ConvexHullSplitDisplay.from_split(X, train, interp, extrap, features=(0, 2))
    assert_allclose(disp.train_.get_offsets(), X[train][:, [0, 2]])
    assert_allclose(disp.interp_.get_offsets(), X[interp][:, [0, 2]])
    assert_allclose(disp.extrap_.get_offsets(), X[extrap][:, [0, 2]])
    # The outline is closed and encloses every projected training point.
    outline = disp.hull_.get_xydata()
    assert_allclose(outline[0], outline[-1])
    from matplotlib.path import Path

    path = Path(outline)
    assert path.contains_points(X[train][:, [0, 2]], radius=1e-9).sum() >= len(
        train
    ) - len(outline)
    assert disp.ax_.get_xlabel() == "feature 0"
    assert disp.ax_.get_ylabel() == "feature 2"
    labels = [t.get_text() for t in disp.ax_.get_legend().get_texts()]
    assert labels == ["train", "interpolative", "extrapolative", "training hull"]
    assert disp.figure_ is disp.ax_.figure


def test_plot_on_given_axes_with_masks_and_kwargs(pyplot, split):
    X, (train, _, extrap) = split
    _, ax = pyplot.subplots()
    mask = np.zeros(len(X), dtype=bool)
    mask[train] = True
    disp = ConvexHullSplitDisplay.from_split(
        X, mask, None, extrap, ax=ax, feature_names=("angle", "torque")
    )
    assert disp.ax_ is ax and disp.interp_ is None
    assert len(disp.train_.get_offsets()) == len(train)
    disp.plot(ax=ax, extrap_kwargs=dict(c="k"), hull_kwargs=dict(ls="--"))
    assert disp.hull_.get_linestyle() == "--"
    assert ax.get_xlabel() == "angle"


def test_from_cv_and_errors(pyplot, rng):
    X = rng.uniform(-1, 1, size=(80, 2))
    cv = ConvexHullSplit(n_splits=2, random_state=0)
    disp = ConvexHullSplitDisplay.from_cv(cv, X, split=1)
    train, test = list(cv.split(X))[1]
    assert_allclose(disp.extrap_.get_offsets(), X[test])
    disp = ConvexHullSplitDisplay.from_cv(ConvexHullSplit(1, kind="interpolation"), X)
    assert disp.extrap_ is None and disp.interp_ is not None
    with pytest.raises(ValueError, match="split=5 is out of range"):
        ConvexHullSplitDisplay.from_cv(cv, X, split=5)
    with pytest.raises(ValueError, match="features must be two column indices"):
        ConvexHullSplitDisplay.from_split(X, train, features=(0, 7))
    with pytest.raises(ValueError, match="boolean mask of shape"):
        ConvexHullSplitDisplay.from_split(X, np.ones(3, dtype=bool))
