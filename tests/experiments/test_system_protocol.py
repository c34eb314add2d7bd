"""The runner's written contract: both protocols' systems and results answer it.

:class:`ZooSystem` and :class:`ZooResult` list what the runner asks; a system of
the one-step protocol and one of the free-run protocol (a user's spec and a
built-in benchmark not yet bound) must answer every hook with the signature the
contract writes, and the runner must inspect nothing else.
"""

import ast
import inspect
from pathlib import Path

import numpy as np
import pytest

import skhybrid.experiments.run._runner as runner
from skhybrid.benchmarks import MEASURED, SIMULATED
from skhybrid.domain import StateSpaceModel
from skhybrid.experiments import RunSettings, SystemSpec
from skhybrid.experiments.free_run._system import MeasuredResult, MeasuredSystem
from skhybrid.experiments.one_step._result import ExperimentResult
from skhybrid.experiments.one_step._system import OneStepSystem
from skhybrid.experiments.run._contract import ZooResult, ZooSystem


def first_order(x, u, *, xp, a, b):
    return a * x + b * u


def _record(n, seed):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n, 1))
    return u, np.cumsum(u, axis=0) * 0.1


def _measured_spec():
    return SystemSpec(
        "tiny",
        records=[_record(200, 0)],
        physics=StateSpaceModel(
            first_order,
            {"a": 0.5, "b": 1.0},
            state_names=["y"],
            observed=["y"],
            time="discrete",
        ),
        n_init=5,
        dt=0.1,
        tests={"test": _record(100, 1)},
        hybrids=None,
    )


def _hooks(protocol):
    """The protocol's methods: every public callable it defines."""
    return {
        name: value
        for name, value in vars(protocol).items()
        if not name.startswith("_") and inspect.isfunction(value)
    }


def _parameters(function):
    return [
        (p.name, p.kind, p.default)
        for p in inspect.signature(function).parameters.values()
    ]


SYSTEMS = {
    "one-step": lambda: OneStepSystem(SIMULATED["pendulum"].SPEC),
    "free-run spec": lambda: MeasuredSystem.from_spec(_measured_spec()),
    "free-run benchmark": lambda: MeasuredSystem(module=MEASURED["emps"]),
}


@pytest.mark.parametrize("kind", list(SYSTEMS))
def test_every_system_answers_the_runners_contract(kind):
    system = SYSTEMS[kind]()
    assert isinstance(system, ZooSystem)
    hooks = _hooks(ZooSystem)
    assert {"new_result", "model_zoo", "job", "requirements", "bind"} <= set(hooks)
    for name, hook in hooks.items():
        assert _parameters(getattr(type(system), name)) == _parameters(hook), name
        assert getattr(type(system), name).__doc__, f"{kind}: {name} undocumented"


def test_every_result_answers_the_runners_contract():
    one_step = OneStepSystem(SIMULATED["pendulum"].SPEC)
    experiment = ExperimentResult(
        one_step, RunSettings(quick=True), {"train": None, "test": None}
    )
    measured = MeasuredSystem.from_spec(_measured_spec())
    spec = measured.spec
    U, Y = spec.estimation_records()
    fitted = MeasuredResult(measured, RunSettings(), (U, Y), 5, 0.1)
    for result in (experiment, fitted):
        assert isinstance(result, ZooResult)
        for name, hook in _hooks(ZooResult).items():
            assert _parameters(getattr(type(result), name)) == _parameters(hook), name
    assert experiment.searched == {} and experiment.validation_runs == {}
    experiment.keep_estimator("physics", object())  # the folder keeps it
    kept = object()
    fitted.keep_estimator("physics", kept)
    assert fitted.estimators["physics"] is kept


def test_requirements_name_every_model_of_the_zoo():
    settings = RunSettings(quick=True)
    for system in (
        OneStepSystem(SIMULATED["pendulum"].SPEC),
        MeasuredSystem.from_spec(_measured_spec()),
    ):
        zoo = system.model_zoo(settings)
        requires = system.requirements(zoo)
        assert set(requires) == set(zoo)
        assert all(set(deps) <= set(zoo) for deps in requires.values())
    assert requires["physics + linear"] == ("physics",)


def test_the_runner_inspects_nothing():
    # The runner calls the contract's hooks: no getattr or hasattr on a result,
    # a system or a model.
    tree = ast.parse(Path(runner.__file__).read_text())
    called = {
        node.func.id
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    }
    assert not called & {"getattr", "hasattr"}
