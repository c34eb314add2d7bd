"""band_limited_inputs: the input between samples for a physics' integrator."""

import functools
import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from skhybrid.domain import band_limited_inputs


def _sine(t, f=0.13):
    return np.sin(2 * np.pi * f * t)


def test_samples_are_kept_and_the_midpoint_is_interpolated():
    t = np.arange(400.0)
    u = _sine(t)
    points = band_limited_inputs(u)
    assert points.shape == (400, 3)
    assert_array_equal(points[:, 0], u)
    assert_array_equal(points[:-1, 2], u[1:])
    inner = slice(30, -30)
    error = np.abs(points[inner, 1] - _sine(t + 0.5)[inner]).max()
    linear = np.abs(0.5 * (u[:-1] + u[1:]) - _sine(t[:-1] + 0.5))[inner].max()
    # A sine of 0.13 cycles a sample bends between samples: holding it
    # linearly misses the midpoint by 8 % of its amplitude.
    assert linear > 0.08 and error < 0.01


def test_more_points_and_several_inputs():
    t = np.arange(300.0)
    u = np.column_stack([_sine(t, 0.05), 3.0 * _sine(t, 0.08)])
    points = band_limited_inputs(u, n_points=5)
    assert points.shape == (300, 10)
    inner = slice(30, -30)
    for j, (f, a) in enumerate([(0.05, 1.0), (0.08, 3.0)]):
        for i in range(5):
            exact = a * _sine(t + i / 4, f)
            assert np.abs(points[inner, 5 * j + i] - exact[inner]).max() < 0.01 * a


def test_the_last_sample_continues_along_a_line():
    u = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    points = band_limited_inputs(u, n_points=2)
    assert_array_equal(points[:, 0], u)
    assert_array_equal(points[:, 1], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    # A line is interpolated as a line, within the polyphase filter's ripple
    # (a gain 5e-4 from one between the samples).
    assert_allclose(band_limited_inputs(u)[:, 1], u + 0.5, rtol=1e-3, atol=1e-3)
    assert_allclose(band_limited_inputs(np.ones(50))[:, 1], 1.0, rtol=1e-3)


def test_it_can_be_a_specs_physics_inputs():
    """A spec's physics_inputs must pickle, with another n_points too."""
    for transform in (
        band_limited_inputs,
        functools.partial(band_limited_inputs, n_points=4),
    ):
        again = pickle.loads(pickle.dumps(transform))
        assert again(np.arange(10.0)).shape[1] == transform(np.arange(10.0)).shape[1]


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (
            dict(inputs=np.zeros(10), n_points=1),
            ValueError,
            "n_points must be at least 2; got 1",
        ),
        (
            dict(inputs=np.zeros(10), n_points=2.5),
            TypeError,
            "n_points must be an integer; got 2.5",
        ),
        (
            dict(inputs=np.zeros(10), n_points=True),
            TypeError,
            "n_points must be an integer",
        ),
        (
            dict(inputs=np.zeros((4, 2, 2))),
            ValueError,
            r"inputs must have shape .* got shape \(4, 2, 2\)",
        ),
        (
            dict(inputs=np.zeros(1)),
            ValueError,
            "at least 2 samples to interpolate; got 1",
        ),
        (dict(inputs=[0.0, 1.0, np.nan]), ValueError, "input 0 at time step 2 is nan"),
    ],
)
def test_bad_input_is_named(kwargs, error, match):
    with pytest.raises(error, match=match):
        band_limited_inputs(**kwargs)
