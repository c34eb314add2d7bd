"""A run's further seeds and its test free runs, side by side on the workers.

- The seeds after the first only refit the choices of the first seed's search:
  their fits run together in one pool, each with a search worker's threads, so
  a seed's refits give the same numbers whatever seeds run beside them.
- The test records' free runs run side by side too, each with the threads of
  the run's own process; a deterministic model's fit, the same at every seed,
  is simulated once and its runs shared.
"""

import threading

import numpy as np
import pytest
import torch
from joblib import parallel_config
from threadpoolctl import threadpool_info

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments import SystemSpec, run_system
from skhybrid.experiments.free_run import _system as _measured_system
from skhybrid.experiments.free_run._test_runs import simulate_tests
from skhybrid.model_selection import StackedSimulation


def first_order(x, u, *, xp, a, b):
    return a * x + b * u


def record(n, seed):
    """A first-order system with a small cubic term the physics lacks."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10 + 1), 10)[:n]
    y, x = np.empty(n), 0.0
    for t in range(n):
        y[t] = x
        x = 0.8 * x + 0.5 * u[t] - 0.05 * x**3
    return u[:, None], (y + 0.001 * rng.standard_normal(n))[:, None]


def make_spec():
    return SystemSpec(
        name="tiny",
        records=[record(300, 0), record(240, 1)],
        physics=StateSpaceModel(
            first_order,
            {"a": 0.5, "b": 1.0},
            state_names=["y"],
            observed=["y"],
            time="discrete",
        ),
        n_init=5,
        dt=0.1,
        tests={"test": record(200, 2)},
        hybrids=None,
    )


def _arrays(out, seed):
    """Every array stored for one seed of a run folder."""
    folder = out / "models" / f"tiny-seed-{seed}"
    arrays = {}
    for path in sorted(folder.glob("*.npz")):
        with np.load(path) as data:
            arrays.update({f"{path.stem}/{k}": data[k] for k in data.files})
    return arrays


def test_a_seeds_refits_and_test_runs_do_not_depend_on_the_seeds_beside_it(
    tmp_path,
):
    three = run_system(
        make_spec(), tmp_path / "three", quick=True, seeds=[0, 1, 2], n_jobs=2
    )
    two = run_system(make_spec(), tmp_path / "two", quick=True, seeds=[0, 2], n_jobs=2)
    alone, beside = _arrays(tmp_path / "two", 2), _arrays(tmp_path / "three", 2)
    assert set(alone) == set(beside) and any("test-predictions" in k for k in alone)
    for key, array in alone.items():
        np.testing.assert_array_equal(beside[key], array, err_msg=key)
    # A network refitted at each seed differs; a deterministic model does not.
    tests = [
        _arrays(tmp_path / "three", s)["test-predictions/test/physics"]
        for s in (0, 1, 2)
    ]
    assert all(np.array_equal(tests[0], t) for t in tests)
    dense = [
        _arrays(tmp_path / "three", s)["test-predictions/test/physics + dense"]
        for s in (0, 1, 2)
    ]
    assert not np.array_equal(dense[1], dense[2])
    for name in ("test_rmse", "chosen_model"):
        assert three[name] is not None and two[name] is not None


def test_the_further_seeds_refit_side_by_side(tmp_path, monkeypatch):
    """Seeds 1 and 2 refit the physics at once: each waits for the other's."""
    both = threading.Barrier(2, timeout=60)
    order, lock = [], threading.Lock()
    fit_model = _measured_system.fit_model

    def meeting(name, model, ctx, deps, sink=None):
        with lock:
            order.append((ctx.seed, name))
        if name == "physics" and ctx.seed in (1, 2):
            # Broken (an error) where one seed's refit waits for the other's end.
            both.wait()
        return fit_model(name, model, ctx, deps, sink)

    monkeypatch.setattr(_measured_system, "fit_model", meeting)
    with parallel_config(backend="threading"):
        run_system(make_spec(), tmp_path / "run", quick=True, seeds=[0, 1, 2], n_jobs=2)
    seeds = [seed for seed, _ in order]
    # The first seed's search, every model of it, before any refit.
    assert seeds[: seeds.count(0)] == [0] * seeds.count(0)
    assert seeds.count(1) == seeds.count(2) == seeds.count(0)


class _Counted:
    """A free-run model that counts its runs and reports the threads it ran with."""

    def __init__(self, offset):
        self.offset = offset

    def simulate(self, inputs, initial):
        blas = max(
            (i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"),
            default=0,
        )
        out = np.full(len(inputs), self.offset, dtype=float)
        out[:2] = [torch.get_num_threads(), blas]
        return out


class _Result:
    """What simulate_tests reads of a seed's result."""

    def __init__(self, seed, estimators, deterministic):
        self.store_key = f"toy-seed-{seed}"
        self.n_init = 2
        self.estimators = estimators
        self.fits = {
            name: {"selection": {"deterministic": name in deterministic}}
            for name in estimators
        }


def test_a_deterministic_fit_is_simulated_once_and_every_run_has_the_threads_here():
    physics = _Counted(1.0)
    results = [
        _Result(
            seed,
            {
                "physics": physics,
                "network": _Counted(10.0 + seed),
                "stacked": StackedSimulation([("physics", physics)]),
            },
            deterministic={"physics"},
        )
        for seed in range(3)
    ]
    tests = {
        "a": (np.zeros((20, 1)), np.zeros((20, 1))),
        "b": (np.ones((30, 1)), np.ones((30, 1))),
    }
    runs = simulate_tests(results, tests, n_jobs=2)
    assert len(runs) == 3
    here = (
        torch.get_num_threads(),
        max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"),
    )
    for seed, seed_runs in enumerate(runs):
        assert set(seed_runs) == {"a", "b"}
        for split, (u, _) in tests.items():
            # A stack is not simulated: its members' runs are averaged later.
            assert set(seed_runs[split]) == {"physics", "network"}
            for name, (run, error) in seed_runs[split].items():
                assert error is None and len(run) == len(u)
                assert tuple(run[:2]) == here, f"{name} ran with other threads"
            network = seed_runs[split]["network"][0]
            assert np.all(network[2:] == 10.0 + seed)
            # The same fit of the physics at every seed: one run, shared.
            assert seed_runs[split]["physics"][0] is runs[0][split]["physics"][0]


def test_deterministic_fits_that_differ_are_simulated_each():
    results = [
        _Result(s, {"physics": _Counted(1.0 + s)}, deterministic={"physics"})
        for s in (0, 1)
    ]
    runs = simulate_tests(results, {"t": (np.zeros((9, 1)), np.zeros((9, 1)))})
    first, second = (r["t"]["physics"][0] for r in runs)
    assert np.all(first[2:] == 1.0) and np.all(second[2:] == 2.0)


class _WithFunction(_Counted):
    """A model that holds a function, as a physics holds its equations."""

    def __init__(self, offset, rhs):
        super().__init__(offset)
        self.rhs = rhs


def test_a_deterministic_fit_with_a_function_from_the_users_script_is_shared():
    # A function of the script that ran (``__main__``), where pickle looks it up
    # by name and finds another object (or none): pickle refuses it.
    def rhs(x):
        return x

    rhs.__module__, rhs.__qualname__ = "__main__", "rhs_not_in_main"
    physics = _WithFunction(1.0, rhs)
    results = [
        _Result(s, {"physics": physics}, deterministic={"physics"}) for s in (0, 1)
    ]
    runs = simulate_tests(results, {"t": (np.zeros((9, 1)), np.zeros((9, 1)))})
    first, second = (r["t"]["physics"][0] for r in runs)
    assert first is second and np.all(first[2:] == 1.0)


def test_a_failed_free_run_is_named_and_nan():
    class Diverges:
        def simulate(self, inputs, initial):
            raise FloatingPointError("overflow in the free run")

    results = [_Result(0, {"bad": Diverges()}, deterministic=set())]
    (runs,) = simulate_tests(results, {"t": (np.zeros((8, 1)), np.zeros((8, 1)))})
    run, error = runs["t"]["bad"]
    assert np.all(np.isnan(run)) and "overflow" in error


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_simulate_tests_gives_what_each_model_simulates(n_jobs):
    results = [
        _Result(s, {"m": _Counted(2.0 + s)}, deterministic=set()) for s in (0, 1)
    ]
    tests = {"t": (np.zeros((12, 1)), np.zeros((12, 1)))}
    runs = simulate_tests(results, tests, n_jobs=n_jobs)
    for seed, seed_runs in enumerate(runs):
        run, _ = seed_runs["t"]["m"]
        assert np.all(run[2:] == 2.0 + seed)
