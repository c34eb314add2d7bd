"""The run's cache of deterministic fits, written and read in any process.

A search's workers receive the functions of the user's script (``__main__``) by
value, a new copy with each task, and name in their own ``__main__`` only the
first task's (``expose_main_functions``); pickle refuses to store a function by a
name that gives back another object, so a fit a worker made was never kept and
the models built on the physics fitted it again (issue 54). The cache stores
them by name; these tests make a worker's situation in this process.
"""

import pickle
import sys
import types

import numpy as np
import pytest

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments._pickling import dump_fit, load_fit, main_objects


def _in_main(source, name):
    """A function defined by ``source`` as a script defines it (in ``__main__``)."""
    namespace = {"__name__": "__main__"}
    exec(source, namespace)  # noqa: S102 - the test's own source
    return namespace[name]


DECAY = """
def decay(x, u, *, xp, a):
    return a * x + u
"""


@pytest.fixture
def script(monkeypatch):
    """``__main__`` holding ``decay``, and a worker's copy of it (another object)."""
    main = sys.modules["__main__"]
    original, copy = _in_main(DECAY, "decay"), _in_main(DECAY, "decay")
    monkeypatch.setattr(main, "decay", original, raising=False)
    return types.SimpleNamespace(original=original, copy=copy)


def _fitted(func):
    model = StateSpaceModel(
        func, {"a": 0.5}, state_names=["x"], observed=["x"], time="discrete"
    )
    u = np.linspace(-1, 1, 60)[:, None]
    y = model.set_params(fixed=("a",)).fit_simulation(u, np.zeros((60, 1)))
    return y.simulate_from_state(u, [0.0]), model


def test_a_fit_holding_a_copy_of_a_script_function_is_kept_and_read(script, tmp_path):
    run, model = _fitted(script.copy)
    with pytest.raises(pickle.PicklingError, match="not the same object"):
        pickle.dumps(model)  # what the cache wrote before: the fit was lost
    path = tmp_path / "fit.pickle"
    dump_fit(model, path)
    loaded = load_fit(path)
    # Read back, the function is the script's own (by its name).
    assert loaded.rhs is script.original
    u = np.linspace(-1, 1, 60)[:, None]
    np.testing.assert_array_equal(loaded.simulate_from_state(u, [0.0]), run)


def test_a_name_not_in_main_is_an_unpickling_error(script, tmp_path, monkeypatch):
    path = tmp_path / "fit.pickle"
    dump_fit(_fitted(script.copy)[1], path)
    monkeypatch.delattr(sys.modules["__main__"], "decay")
    with pytest.raises(pickle.UnpicklingError, match=r"'decay'.*not found"):
        load_fit(path)


def test_the_script_functions_a_callable_physics_reads_are_found():
    make = _in_main(
        DECAY
        + """
from skhybrid.domain import StateSpaceModel

def physics(U, Y, dt):
    return StateSpaceModel(decay, {"a": 0.5}, state_names=["x"], observed=["x"])
""",
        "physics",
    )
    found = main_objects(make, None)
    assert set(found) == {"physics", "decay"}
    assert found["decay"] is make.__globals__["decay"]
    # An importable function is not the script's: pickle stores it as it is.
    assert main_objects(np.tanh, StateSpaceModel) == {}
