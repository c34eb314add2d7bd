"""The suite of machines with known missing physics (make_missing_physics)."""

import numpy as np
import pytest
from sklearn.base import clone

from skhybrid.datasets import MISSING_PHYSICS_MACHINES, make_missing_physics


def _free_run_rmse(model, u, y, n_init=20):
    sim = model.simulate(u, y[:n_init])
    return float(np.sqrt(np.mean((sim[n_init:] - y[n_init:]) ** 2)))


def test_the_suite_holds_the_machines_the_issue_names():
    assert {
        "hardening-spring",
        "stribeck-friction",
        "saturating-actuator",
        "second-mode",
    } <= set(MISSING_PHYSICS_MACHINES)


@pytest.mark.parametrize("name", MISSING_PHYSICS_MACHINES)
def test_each_machine_misses_what_its_true_structure_holds(name):
    data = make_missing_physics(name, n_records=2, n_samples=300, random_state=1)
    assert len(data.inputs) == len(data.outputs) == 2
    assert all(y.shape == (300, 1) for y in data.outputs)
    # The noise is the stated fraction of the clean position's spread.
    clean = np.concatenate(data.outputs_clean)
    noise = np.concatenate(data.outputs) - clean
    assert np.std(noise) == pytest.approx(0.01 * np.std(clean), rel=0.15)
    # The test record beyond the training amplitude is driven harder.
    u_in, u_out = data.tests["inside"][0], data.tests["beyond"][0]
    assert np.abs(u_in).max() <= data.amplitude < np.abs(u_out).max()

    # The true structure at the true constants reproduces the clean records
    # (from their own first samples; the models integrate more coarsely than
    # the simulation that made the data), the physics at its linear part's
    # true constants does not.
    everything = tuple(data.true_params)
    truth = clone(data.true_model).set_params(fixed=everything).initialize()
    linear = {"mass": 1.0, "k": data.true_params["k"], "c": data.true_params["c"]}
    physics = clone(data.physics).set_params(params=linear, fixed=tuple(linear))
    physics.initialize()
    u, y = data.tests["inside"][0], data.tests_clean["inside"]
    true_error = _free_run_rmse(truth, u, y)
    assert true_error < 0.02 * np.std(y)
    assert _free_run_rmse(physics, u, y) > 10 * true_error


def test_a_seed_gives_the_same_records():
    a = make_missing_physics("dead-zone", n_records=1, n_samples=100, random_state=3)
    b = make_missing_physics("dead-zone", n_records=1, n_samples=100, random_state=3)
    np.testing.assert_array_equal(a.outputs[0], b.outputs[0])
    np.testing.assert_array_equal(a.tests["beyond"][1], b.tests["beyond"][1])


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"name": "spring"}, "name must be one of"),
        ({"name": "dead-zone", "n_samples": 50}, "n_samples must be an integer >= 80"),
        ({"name": "dead-zone", "n_records": 0}, "n_records must be an integer >= 1"),
        ({"name": "dead-zone", "noise": -0.1}, "noise must be >= 0.0"),
    ],
)
def test_bad_arguments_name_the_parameter(kwargs, words):
    name = kwargs.pop("name")
    with pytest.raises(ValueError, match=words):
        make_missing_physics(name, **kwargs)
