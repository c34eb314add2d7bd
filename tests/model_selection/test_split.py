"""Tests of the interpolative / extrapolative splits."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal
from scipy.spatial import Delaunay
from sklearn.linear_model import Ridge
from sklearn.model_selection import GridSearchCV, cross_val_score, cross_validate
from sklearn.tree import DecisionTreeRegressor

from skhybrid.model_selection import (
    ConvexHullSplit,
    ExtrapolationSplit,
    interpolation_extrapolation_split,
)


def _inside(points, reference):
    return Delaunay(reference).find_simplex(points) >= 0


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_samples=st.integers(60, 150),
    dim=st.integers(2, 3),
    strategy=st.sampled_from(["shell", "direction"]),
    sizes=st.tuples(st.floats(0.05, 0.3), st.floats(0.05, 0.3)),
)
def test_property_split_guarantees(seed, n_samples, dim, strategy, sizes):
    X = np.random.default_rng(seed).uniform(-1, 1, size=(n_samples, dim))
    idx = np.arange(n_samples)
    kwargs = dict(
        interpolation_size=sizes[0],
        extrapolation_size=sizes[1],
        strategy=strategy,
        random_state=seed,
    )
    try:
        Xtr, Xin, Xex, tr, it, ex = interpolation_extrapolation_split(X, idx, **kwargs)
    except ValueError as exc:  # impossible sizes must say what is possible
        assert "only" in str(exc)
        return
    # Disjoint and covering, with the asked sizes.
    assert_array_equal(np.sort(np.r_[tr, it, ex]), idx)
    assert len(it) == int(np.ceil(sizes[0] * n_samples))
    assert len(ex) == int(np.ceil(sizes[1] * n_samples))
    assert_array_equal(X[tr], Xtr)
    assert_array_equal(X[it], Xin)
    assert_array_equal(X[ex], Xex)
    # Checked against Delaunay, independently of in_convex_hull.
    assert _inside(Xin, Xtr).all()
    assert not _inside(Xex, Xtr).any()
    # Same random_state, same split.
    again = interpolation_extrapolation_split(X, idx, **kwargs)
    for a, b in zip((tr, it, ex), again[3:], strict=True):
        assert_array_equal(a, b)


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    kind=st.sampled_from(["extrapolation", "interpolation"]),
    n_splits=st.integers(1, 4),
    use_groups=st.booleans(),
)
def test_property_convex_hull_split(seed, kind, n_splits, use_groups):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(120, 2))
    groups = rng.integers(0, 30, size=120) if use_groups else None
    cv = ConvexHullSplit(n_splits, kind=kind, test_size=0.2, random_state=seed)
    try:
        splits = list(cv.split(X, groups=groups))
    except ValueError as exc:
        assert "empty test fold" in str(exc)
        return
    assert len(splits) == n_splits == cv.get_n_splits()
    for train, test in splits:
        assert_array_equal(np.sort(np.r_[train, test]), np.arange(120))
        assert len(test) > 0
        inside = _inside(X[test], X[train])
        assert inside.all() if kind == "interpolation" else not inside.any()
        if groups is not None:
            assert not set(groups[train]) & set(groups[test])
    again = list(cv.split(X, groups=groups))
    for (a, b), (c, d) in zip(splits, again, strict=True):
        assert_array_equal(a, c)
        assert_array_equal(b, d)


def test_splits_cut_from_different_directions(rng):
    X = rng.uniform(-1, 1, size=(400, 2))
    cv = ConvexHullSplit(n_splits=4, test_size=0.1, random_state=0)
    centres = [X[test].mean(axis=0) for _, test in cv.split(X)]
    # Test folds sit in different places around the data.
    dists = [
        np.linalg.norm(a - b) for i, a in enumerate(centres) for b in centres[i + 1 :]
    ]
    assert min(dists) > 0.3
    unit = [c / np.linalg.norm(c) for c in centres]
    assert np.ptp(np.degrees(np.arctan2(*np.array(unit).T))) > 60


def test_grid_search_with_convex_hull_split(rng):
    X = rng.uniform(-1, 1, size=(150, 2))
    y = X[:, 0] + 2 * X[:, 1]
    cv = ConvexHullSplit(n_splits=3, random_state=0)
    search = GridSearchCV(
        DecisionTreeRegressor(random_state=0),
        {"max_depth": [1, 3, 6]},
        cv=cv,
    ).fit(X, y)
    assert search.best_params_["max_depth"] in (1, 3, 6)
    assert search.cv_results_["split2_test_score"].shape == (3,)
    # A linear model extrapolates a linear function; a tree does not.
    linear = cross_val_score(Ridge(alpha=1e-6), X, y, cv=cv)
    assert linear.min() > search.best_score_
    scores = cross_validate(Ridge(), X, y, cv=ConvexHullSplit(2, kind="interpolation"))
    assert len(scores["test_score"]) == 2


def test_groups_keep_trajectories_whole(rng):
    # Twenty short trajectories, each a small cloud around its own centre.
    groups = np.repeat(np.arange(20), 10)
    X = rng.uniform(-1, 1, size=(20, 2))[groups] + 0.05 * rng.standard_normal((200, 2))
    X_tr, X_in, X_ex, g_tr, g_in, g_ex = interpolation_extrapolation_split(
        X,
        groups,
        groups=groups,
        interpolation_size=0.1,
        extrapolation_size=0.1,
        random_state=0,
    )
    assert not (set(g_tr) & set(g_in) or set(g_tr) & set(g_ex) or set(g_in) & set(g_ex))
    assert _inside(X_in, X_tr).all()
    assert not _inside(X_ex, X_tr).any()
    for g in set(g_in) | set(g_ex):
        assert (groups == g).sum() == np.sum(np.r_[g_in, g_ex] == g)


def test_impossible_sizes_raise(rng):
    X = rng.uniform(-1, 1, size=(50, 2))
    with pytest.raises(ValueError, match=r"ask for 30 \+ 30 of 50 samples"):
        interpolation_extrapolation_split(
            X, interpolation_size=30, extrapolation_size=30
        )
    # In 12 dimensions few of 40 points lie inside the hull of the others.
    X = rng.standard_normal((40, 12))
    with pytest.raises(ValueError, match=r"interpolation_size=0.5 asks for 20 points"):
        interpolation_extrapolation_split(
            X, interpolation_size=0.5, extrapolation_size=0.1, random_state=0
        )
    with pytest.raises(ValueError, match=r"extrapolation_size=1\.5"):
        interpolation_extrapolation_split(X, extrapolation_size=1.5)
    with pytest.raises(TypeError, match="interpolation_size"):
        interpolation_extrapolation_split(X, interpolation_size="half")
    with pytest.raises(ValueError, match="strategy"):
        interpolation_extrapolation_split(X, strategy="ring")


def test_convex_hull_split_validates_in_split():
    cv = ConvexHullSplit(n_splits=0, kind="sideways")  # no error yet
    X = np.zeros((10, 2))
    with pytest.raises(ValueError, match="n_splits must be an int >= 1; got 0"):
        cv.split(X)
    with pytest.raises(ValueError, match="kind must be"):
        ConvexHullSplit(kind="sideways").split(X)
    with pytest.raises(ValueError, match=r"test_size=2\.0"):
        next(ConvexHullSplit(test_size=2.0).split(X))
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        next(ConvexHullSplit().split(np.ones((10, 2)), groups=np.zeros(3)))


def test_extrapolation_split_by_torque_range(rng):
    torque = rng.uniform(-2, 2, size=300)
    X = np.column_stack([rng.standard_normal(300), torque])
    cv = ExtrapolationSplit(features=1, bounds=(-1, 1))
    ((train, test),) = list(cv.split(X))
    assert np.all(np.abs(X[train, 1]) <= 1)
    assert np.all(np.abs(X[test, 1]) > 1)
    assert_array_equal(np.sort(np.r_[train, test]), np.arange(300))
    assert not _inside(X[test], X[train]).any()
    assert cv.get_n_splits() == 1
    # Windows: the torque at any step leaving the range sends the row to test.
    windows = np.column_stack([torque, np.roll(torque, 1)])
    ((train, test),) = list(ExtrapolationSplit([0, 1], bounds=(-1, 1)).split(windows))
    assert np.all(np.abs(windows[train]) <= 1)
    assert np.all(np.any(np.abs(windows[test]) > 1, axis=1))
    # Groups: a trajectory leaving the range goes whole to test.
    groups = np.repeat(np.arange(30), 10)
    amplitude = rng.uniform(0, 2, size=30)[groups]
    Xg = np.column_stack([X[:, 0], amplitude * np.sin(np.arange(300))])
    ((train, test),) = list(cv.split(Xg, groups=groups))
    assert not set(groups[train]) & set(groups[test])
    assert np.all(np.abs(Xg[train, 1]) <= 1) and len(test) % 10 == 0
    # One-sided and per-feature bounds.
    ((train, _),) = list(ExtrapolationSplit(1, bounds=(None, 1.0)).split(X))
    assert X[train, 1].max() <= 1.0
    cv2 = ExtrapolationSplit([0, 1], bounds=[(-5, 5), (-1, 1)])
    assert_array_equal(next(cv2.split(X))[1], np.flatnonzero(np.abs(torque) > 1))


def test_extrapolation_split_errors(rng):
    X = rng.uniform(-1, 1, size=(20, 2))
    with pytest.raises(ValueError, match="leave no test rows"):
        ExtrapolationSplit(1, bounds=(-5, 5)).split(X)
    with pytest.raises(ValueError, match="low < high"):
        ExtrapolationSplit(1, bounds=(1, -1)).split(X)
    with pytest.raises(TypeError, match="bounds must be"):
        ExtrapolationSplit(1, bounds="wide").split(X)
    with pytest.raises(ValueError, match="features=5"):
        ExtrapolationSplit(5).split(X)
