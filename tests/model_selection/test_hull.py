"""Tests of in_convex_hull: every method agrees with Delaunay and with the LP."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal
from scipy.spatial import Delaunay

from skhybrid.model_selection import in_convex_hull

METHODS = ["auto", "facets", "delaunay", "nearest_point", "lp"]


def _delaunay_truth(points, reference):
    return Delaunay(reference).find_simplex(points) >= 0


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("dim", [2, 3, 4])
def test_methods_agree_with_delaunay(method, dim, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    reference = rng.standard_normal((60, dim))
    points = 1.3 * rng.standard_normal((40, dim))
    expected = _delaunay_truth(points, reference)
    assert 0 < expected.sum() < len(points)  # both answers occur
    assert_array_equal(in_convex_hull(points, reference, method=method), expected)


@pytest.mark.parametrize("dim", [8, 16, 32])
def test_nearest_point_agrees_with_lp_in_high_dimension(dim, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    reference = rng.standard_normal((300, dim))
    # Shrunken points are mostly inside, the rest mostly outside.
    points = (
        rng.standard_normal((30, dim)) * np.r_[np.full(15, 0.15), np.ones(15)][:, None]
    )
    fast = in_convex_hull(points, reference, method="nearest_point")
    exact = in_convex_hull(points, reference, method="lp")
    assert_array_equal(fast, exact)
    assert fast.any() and not fast.all()


def test_reference_points_and_their_mixtures_are_inside(rng):
    reference = rng.standard_normal((50, 6))
    weights = rng.dirichlet(np.ones(50), size=20)
    points = np.vstack([reference, weights @ reference])
    assert in_convex_hull(points, reference).all()


def test_points_beyond_tolerance_are_outside(rng):
    square = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    for method in METHODS:
        assert not in_convex_hull([[1 + 1e-6, 0.5]], square, method=method)[0]
        assert in_convex_hull([[1.0, 0.5]], square, method=method)[0]


def test_flat_reference_sets():
    # Points on a plane in 3-D, and a constant feature: work in the affine hull.
    rng = np.random.default_rng(0)
    plane = np.column_stack([rng.uniform(size=(30, 2)), np.zeros(30)])
    inside = np.array([[0.5, 0.5, 0.0]])
    above = np.array([[0.5, 0.5, 1e-3]])
    for method in METHODS:
        assert in_convex_hull(inside, plane, method=method)[0]
        assert not in_convex_hull(above, plane, method=method)[0]
    segment = np.array([[0.0, 0.0], [1.0, 1.0]])
    assert_array_equal(
        in_convex_hull([[0.5, 0.5], [0.5, 0.6], [2.0, 2.0]], segment),
        [True, False, False],
    )
    single = np.ones((3, 4))
    assert_array_equal(in_convex_hull([[1, 1, 1, 1], [1, 1, 1, 2]], single), [1, 0])


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dim=st.integers(2, 4),
    n_reference=st.integers(12, 40),
    spread=st.floats(0.5, 2.0),
)
def test_property_agrees_with_delaunay(seed, dim, n_reference, spread):
    rng = np.random.default_rng(seed)
    reference = rng.standard_normal((n_reference, dim)) * rng.uniform(0.1, 10, dim)
    points = spread * rng.standard_normal((20, dim)) * reference.std(axis=0)
    expected = _delaunay_truth(points, reference)
    for method in ("auto", "nearest_point"):
        assert_array_equal(in_convex_hull(points, reference, method=method), expected)


def test_input_validation():
    ref = np.zeros((3, 2))
    with pytest.raises(ValueError, match="points has 3 features but reference has 2"):
        in_convex_hull(np.zeros((1, 3)), ref)
    with pytest.raises(ValueError, match="method"):
        in_convex_hull(ref, ref, method="qhull")
    with pytest.raises(ValueError, match="tol"):
        in_convex_hull(ref, ref, tol=-1.0)
    with pytest.raises(ValueError, match="NaN"):
        in_convex_hull([[np.nan, 0.0]], ref)
