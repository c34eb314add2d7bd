"""target_scaling: per-output or shared standardisation of the targets."""

import numpy as np
import pytest

from skhybrid.neural import DenseRegressor


def _data(rng, n=600):
    X = rng.uniform(-1, 1, (n, 2))
    # Output 0 is pure noise (what a good physics stage leaves); output 1 is a
    # large smooth residual the network should learn.
    y = np.column_stack([0.01 * rng.standard_normal(n), 2.0 * np.sin(2 * X[:, 0])])
    return X, y


def test_shared_scaling_uses_one_scale_and_returns_original_units(rng):
    X, y = _data(rng)
    model = DenseRegressor(
        (32, 32), max_epochs=40, target_scaling="shared", random_state=0
    ).fit(X, y)
    assert model.y_scale_[0] == model.y_scale_[1]
    np.testing.assert_allclose(
        model.y_scale_[0], np.sqrt(np.mean(y.std(axis=0) ** 2)), rtol=1e-6
    )
    per_output = DenseRegressor((32, 32), max_epochs=1, random_state=0).fit(X, y)
    np.testing.assert_allclose(per_output.y_scale_, y.std(axis=0), rtol=1e-6)
    pred = model.predict(X)
    assert pred.shape == y.shape and pred.dtype == np.float64
    assert np.sqrt(np.mean((pred[:, 1] - y[:, 1]) ** 2)) < 0.2


def test_bad_target_scaling_names_the_value(rng):
    X, y = _data(rng, 50)
    with pytest.raises(ValueError, match=r"target_scaling.*Got 'global'"):
        DenseRegressor((4,), target_scaling="global").fit(X, y)
