"""TransformedInputSimulator: a fitted model simulated on transformed inputs.

The system ``y[t+1] = 0.5 y[t] + 0.1 u[t] + 0.2 u[t+1]`` reads the next input: a
linear ARX fitted on ``[u(t), u(t+1)]`` is exact for it.
"""

import pickle

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from sklearn.base import clone
from sklearn.linear_model import Ridge

import skhybrid.hybrid
import skhybrid.hybrid._correction
from skhybrid.hybrid import NARXSimulator, TransformedInputSimulator


def lead(u):
    """``[u(t), u(t+1)]``, the last sample repeated (module level: it pickles)."""
    u = np.asarray(u, dtype=float)
    return np.hstack([u, np.vstack([u[1:], u[-1:]])])


def _record(n=400, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 1))
    y = np.zeros((n, 1))
    for t in range(n - 1):
        y[t + 1] = 0.5 * y[t] + 0.1 * u[t] + 0.2 * u[t + 1]
    return u, y


@pytest.fixture(scope="module")
def narx():
    u, y = _record()
    return NARXSimulator(Ridge(alpha=1e-8)).fit(lead(u), y)


@pytest.fixture(scope="module")
def model(narx):
    return TransformedInputSimulator(narx, input_transform=lead)


def test_simulate_is_the_wrapped_simulate_on_transformed_inputs(narx, model):
    u, y = _record(seed=1)
    assert_array_equal(model.simulate(u, y[:2]), narx.simulate(lead(u), y[:2]))
    assert float(np.max(np.abs(model.simulate(u, y[:1]) - y))) < 1e-4
    # No transform: the record's inputs as they are.
    plain = TransformedInputSimulator(narx)
    assert_array_equal(plain.simulate(lead(u), y[:1]), narx.simulate(lead(u), y[:1]))


def test_fitted_attributes_read_through(narx, model):
    assert model.n_outputs_ == narx.n_outputs_
    assert model.model_ is narx.model_
    assert not hasattr(model, "n_features_in_")  # the wrapper's own, set by fit


def test_fit_validates_the_record_and_keeps_the_model(narx):
    u, y = _record(seed=2)
    coef = narx.model_[-1].coef_.copy()
    wrapper = TransformedInputSimulator(narx, input_transform=lead)
    assert wrapper.fit(u, y) is wrapper
    assert wrapper.n_features_in_ == 1
    assert wrapper.estimator is narx
    assert_array_equal(narx.model_[-1].coef_, coef)
    with pytest.raises(ValueError, match=r"inputs has 2 column\(s\)"):
        wrapper.simulate(np.hstack([u, u]), y[:1])
    with pytest.raises(ValueError, match="Input X contains NaN"):
        TransformedInputSimulator(narx, lead).fit(np.where(u > 1, np.nan, u), y)


def test_clone_keeps_the_fitted_model(narx, model):
    cloned = clone(model)
    assert cloned is not model
    assert cloned.estimator is narx
    u, y = _record(seed=3)
    assert_array_equal(cloned.simulate(u, y[:1]), model.simulate(u, y[:1]))


def test_pickle_round_trip_simulates_identically(model):
    restored = pickle.loads(pickle.dumps(model))
    assert type(restored) is TransformedInputSimulator
    u, y = _record(seed=4)
    assert_array_equal(restored.simulate(u, y[:1]), model.simulate(u, y[:1]))


def test_the_private_name_is_the_public_class():
    for module in (skhybrid.hybrid, skhybrid.hybrid._correction):
        assert module._TransformedInputs is TransformedInputSimulator
    assert "TransformedInputSimulator" in skhybrid.hybrid.__all__
    assert "_TransformedInputs" not in skhybrid.hybrid.__all__


def test_a_pickle_made_under_the_private_name_loads(narx, model):
    # A run folder pickled the private class: its name as text (protocol 0),
    # its state the parameters only (no versions, no n_features_in_).
    old = skhybrid.hybrid._correction._TransformedInputs(narx, lead)
    old.__dict__ = {"estimator": narx, "transform": lead}  # the old parameter name
    blob = pickle.dumps(old, protocol=0)
    blob = blob.replace(
        b"skhybrid.hybrid._transformed_inputs\nTransformedInputSimulator\n",
        b"skhybrid.hybrid._correction\n_TransformedInputs\n",
    )
    assert b"_correction\n_TransformedInputs\n" in blob
    restored = pickle.loads(blob)
    assert type(restored) is TransformedInputSimulator
    u, y = _record(seed=5)
    assert_array_equal(restored.simulate(u, y[:1]), model.simulate(u, y[:1]))
    assert restored.n_outputs_ == narx.n_outputs_
    assert restored.input_transform is lead
    assert restored.get_params()["input_transform"] is lead


@pytest.mark.parametrize("transform", ["lead", 3])
def test_a_transform_that_is_not_callable_raises_naming_it(narx, transform):
    u, y = _record(50)
    wrapper = TransformedInputSimulator(narx, input_transform=transform)
    name = "TransformedInputSimulator"
    match = rf"The 'input_transform' parameter of {name} .* Got {transform!r}"
    with pytest.raises(TypeError, match=match):
        wrapper.simulate(u, y[:1])
    with pytest.raises(TypeError, match=match):
        wrapper.fit(u, y)
