"""NARXSimulator and PhysicsCorrection: free-run models of whole records.

The first-order system ``y[t+1] = 0.9 y[t] + 0.1 u[t]`` throughout: a linear ARX
of one step is exact for it, and a physics whose pole is 0.8 is deliberately
wrong, for a correction to improve.
"""

import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

import skhybrid.hybrid
import skhybrid.hybrid._correction
from skhybrid.domain import StateSpaceModel
from skhybrid.hybrid import NARXSimulator, PhysicsCorrection
from skhybrid.preprocessing import WindowLayout


def first_order(x, u, *, xp, a, b):
    """``x(t+1) = a x + b u``, at module level so that the physics pickles."""
    return a * x + b * u


def _record(n=800, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 1))
    y = np.zeros((n, 1))
    for t in range(n - 1):
        y[t + 1] = 0.9 * y[t] + 0.1 * u[t]
    return u, y


def _rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def _wrong_physics(u, y):
    """The system's structure with its pole at 0.8 instead of 0.9, fitted as is."""
    return StateSpaceModel(
        first_order,
        {"a": 0.8, "b": 0.1},
        state_names=["y"],
        observed=["y"],
        time="discrete",
        fixed=("a", "b"),
    ).fit_simulation(u, y)


@pytest.fixture(scope="module")
def physics():
    return _wrong_physics(*_record())


@pytest.fixture(scope="module")
def narx():
    return NARXSimulator(Ridge(alpha=1e-8)).fit(*_record())


@pytest.fixture(scope="module")
def corrected(physics):
    return PhysicsCorrection(physics, Ridge(alpha=1e-6), n_steps=20).fit(*_record())


# -- NARXSimulator ------------------------------------------------------------------
def test_narx_recovers_a_first_order_system_on_a_new_record(narx):
    u, y = _record(seed=1)
    y_sim = narx.simulate(u, y[:1])
    assert y_sim.shape == y.shape
    assert _rmse(y_sim, y) < 1e-4 * np.std(y)
    assert narx.n_features_in_ == 1 and narx.n_outputs_ == 1


def test_narx_windows_never_span_two_records():
    (u1, y1), (u2, y2) = _record(300, seed=2), _record(200, seed=3)
    model = NARXSimulator(Ridge(), n_steps=3).fit([u1, u2], [y1, y2])
    X, target = WindowLayout(1, 1, 3).make_rows([y1, y2], [u1, u2])
    expected = make_pipeline(StandardScaler(), Ridge()).fit(X, target)
    assert len(X) == 300 + 200 - 2 * 3
    assert_allclose(model.model_[-1].coef_, expected[-1].coef_)


def test_narx_simulates_several_outputs_and_batches(narx):
    u, y = _record(seed=4)
    y2 = np.hstack([y, -2.0 * y])
    model = NARXSimulator(Ridge(alpha=1e-8), n_steps=2).fit(u, y2)
    U, Y = np.stack([u, u[::-1]]), np.stack([y2, y2[::-1]])
    batch = model.simulate(U, Y[:, :5])
    assert batch.shape == Y.shape
    for i in range(2):
        assert_allclose(batch[i], model.simulate(U[i], Y[i, :5]), rtol=1e-12)
    assert_array_equal(batch[:, :5], Y[:, :5])  # the measured window, as is
    assert _rmse(batch[0], Y[0]) < 1e-3 * np.std(y2)


# -- PhysicsCorrection --------------------------------------------------------------
def test_correction_improves_a_wrong_physics_on_a_new_record(physics, corrected):
    u, y = _record(seed=5)
    y_phys = physics.simulate(u, y[:1])
    y_sim = corrected.simulate(u, y[:1])
    assert y_sim.shape == (len(u), 1)
    assert _rmse(y_sim, y) < 0.2 * _rmse(y_phys, y)


def test_correction_returns_the_measured_window_then_the_corrected_run(corrected):
    u, y = _record(seed=6)
    y_sim = corrected.simulate(u, y[:10])
    assert_array_equal(y_sim[:10], y[:10])
    y_phys = corrected.physics.simulate(u, y[:10])
    assert_allclose(y_sim[10:, 0], corrected.correct(u, y_phys)[10:])
    # Records of different lengths, as a list: each as a separate call.
    runs = corrected.simulate([u, u[:300]], [y[:10], y[:20]])
    assert_allclose(runs[0], y_sim)
    assert_allclose(runs[1], corrected.simulate(u[:300], y[:20]))


def test_fit_on_physics_equals_fit_given_the_same_run(physics, corrected):
    u, y = _record()
    run = physics.simulate(u, y[:1])
    model = clone(corrected).fit_on_physics(u, y, run)
    assert_allclose(model.model_[-1].coef_, corrected.model_[-1].coef_)


# -- clone keeps the fitted physics -------------------------------------------------
def test_clone_keeps_the_fitted_physics_and_resets_the_rest(physics, corrected):
    copy = clone(corrected)
    assert copy.physics is physics  # the same fitted object, not reset
    assert copy.regressor is not corrected.regressor  # cloned as usual
    assert copy.get_params()["n_steps"] == 20
    assert not hasattr(copy, "model_")
    u, y = _record()
    refit = copy.fit(u, y)  # fits: the physics is still fitted
    assert_allclose(refit.simulate(u, y[:1]), corrected.simulate(u, y[:1]))


def test_an_unfitted_physics_is_named(physics):
    unfitted = clone(physics)
    assert not hasattr(unfitted, "params_")
    with pytest.raises(NotFittedError, match="physics must be a fitted model"):
        PhysicsCorrection(unfitted, Ridge()).fit(*_record())


# -- pickles ------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["narx", "corrected"])
def test_pickle_round_trip_simulates_identically(name, request):
    model = request.getfixturevalue(name)
    restored = pickle.loads(pickle.dumps(model))
    assert type(restored) is type(model)
    u, y = _record(seed=7)
    assert_array_equal(restored.simulate(u, y[:3]), model.simulate(u, y[:3]))


def test_the_private_names_are_the_public_classes():
    for module in (skhybrid.hybrid, skhybrid.hybrid._correction):
        assert module._NARXSimulator is NARXSimulator
        assert module._PhysicsCorrection is PhysicsCorrection
    assert {"NARXSimulator", "PhysicsCorrection"} <= set(skhybrid.hybrid.__all__)
    assert "_NARXSimulator" not in skhybrid.hybrid.__all__


@pytest.mark.parametrize("name", ["narx", "corrected"])
def test_a_pickle_made_under_the_private_name_loads(name, request):
    model = request.getfixturevalue(name)
    public = type(model).__name__
    # Protocol 0 names the class as text; a run folder pickled it privately,
    # before the widths it was fitted on were recorded.
    old = pickle.loads(pickle.dumps(model))
    del old.n_features_in_, old.n_outputs_
    blob = pickle.dumps(old, protocol=0)
    module = type(model).__module__.encode()
    blob = blob.replace(
        module + b"\n" + public.encode() + b"\n",
        b"skhybrid.hybrid._correction\n_" + public.encode() + b"\n",
    )
    assert b"_correction\n_" + public.encode() in blob
    restored = pickle.loads(blob)
    assert type(restored) is type(model)
    u, y = _record(seed=8)
    assert_array_equal(restored.simulate(u, y[:3]), model.simulate(u, y[:3]))


# -- bad parameters and data --------------------------------------------------------
@pytest.mark.parametrize(
    "make, param, value",
    [
        (lambda p: NARXSimulator(Ridge(), n_steps=0), "n_steps", "0"),
        (lambda p: NARXSimulator(Ridge(), n_steps=1.5), "n_steps", "1.5"),
        (lambda p: NARXSimulator("ridge"), "regressor", "'ridge'"),
        (lambda p: PhysicsCorrection(p, Ridge(), n_steps=0), "n_steps", "0"),
        (lambda p: PhysicsCorrection(p, Ridge(), n_steps=1.5), "n_steps", "1.5"),
        (lambda p: PhysicsCorrection(p, Ridge(), n_init=0), "n_init", "0"),
        (lambda p: PhysicsCorrection(None, Ridge()), "physics", "None"),
    ],
)
def test_bad_parameters_raise_naming_parameter_and_value(physics, make, param, value):
    model = make(physics)
    with pytest.raises(
        ValueError,
        match=rf"The '{param}' parameter of {type(model).__name__} must be .* "
        rf"Got {value} instead",
    ):
        model.fit(*_record(100))


def test_bad_data_raise_naming_what_is_wrong(physics, narx, corrected):
    u, y = _record(100)
    with pytest.raises(ValueError, match=r"X must be 2-D .* shape \(100,\)"):
        NARXSimulator(Ridge()).fit(u[:, 0], y)
    with pytest.raises(ValueError, match="Input X contains NaN"):
        NARXSimulator(Ridge()).fit(np.where(u > 1, np.nan, u), y)
    with pytest.raises(ValueError, match=r"n_steps=3 .* record 1 has 3 sample"):
        NARXSimulator(Ridge(), n_steps=3).fit([u, u[:3]], [y, y[:3]])
    with pytest.raises(ValueError, match="same number of outputs; got"):
        NARXSimulator(Ridge()).fit([u, u], [y, np.hstack([y, y])])
    with pytest.raises(ValueError, match=r"must hold one output .* got 2 columns"):
        PhysicsCorrection(physics, Ridge()).fit(u, np.hstack([y, y]))
    with pytest.raises(ValueError, match=r"n_init=100 .* record 0 has 100 sample"):
        PhysicsCorrection(physics, Ridge(), n_init=100).fit(u, y)
    with pytest.raises(ValueError, match=r"inputs has 2 column\(s\); .* on 1 input"):
        narx.simulate(np.hstack([u, u]), y[:1])
    with pytest.raises(ValueError, match=r"initial has 2 column\(s\)"):
        corrected.simulate(u, np.hstack([y, y])[:1])
    with pytest.raises(ValueError, match=r"supports init in \('measured',\)"):
        corrected.simulate(u, y[:1], init="least_squares")
    with pytest.raises(ValueError, match="need a noise model"):
        narx.simulate(u, y[:1], return_std=True)
    with pytest.raises(NotFittedError):
        NARXSimulator(Ridge()).simulate(u, y[:1])
