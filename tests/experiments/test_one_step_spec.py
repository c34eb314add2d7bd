"""A system of the paper's one-step protocol is a SystemSpec like any other.

The built-in pendulum, double pendulum and DC motor are specs with
``protocol=OneStepWindows(...)``; a user's simulator is written the same way and
runs through the same zoo, report and command line.
"""

import json
import subprocess
import sys
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from skhybrid.benchmarks import SIMULATED
from skhybrid.cli import main
from skhybrid.datasets import make_dc_motor
from skhybrid.domain import ParametricModel, dc_motor_step
from skhybrid.experiments import (
    OneStepSizes,
    OneStepWindows,
    RunSettings,
    SystemSpec,
    check_claims,
    run_experiment,
    run_system,
)
from skhybrid.experiments._registry import SYSTEMS, get_system

#: Small enough for the default suite: every model of the zoo, a few epochs
#: (the guide's spec's quick sizes).
TINY = OneStepSizes(n_train=300, n_test=200, max_epochs=2)


def _motor(**kwargs):
    """The guide's spec (docs/experiments.md): a DC motor of one's own."""
    fields = {
        "records": partial(make_dc_motor, excitation_hz=10.0),
        "tests": {"fast": partial(make_dc_motor, excitation_hz=100.0)},
        "physics": ParametricModel(
            partial(dc_motor_step, dt=0.001), {"gain": 1.0, "time_constant": 0.05}
        ),
        "n_init": 4,
        # Its --quick run at tiny sizes.
        "protocol": OneStepWindows(
            descriptions={"train": "10 Hz", "fast": "100 Hz"}, quick_sizes=TINY
        ),
    }
    fields.update(kwargs)
    return SystemSpec("my-motor", **fields)


def test_the_papers_systems_are_specs_of_the_one_step_protocol():
    for name, module in SIMULATED.items():
        spec = module.SPEC
        assert isinstance(spec, SystemSpec) and spec.name == name
        assert isinstance(spec.protocol, OneStepWindows)
        assert SYSTEMS[name].spec is spec
    pendulum = SYSTEMS["pendulum"]
    assert pendulum.hybrid_physics == "physics (frozen)"
    assert pendulum.ensemble_physics == "physics (refit)"
    settings = RunSettings(quick=True, seed=3)
    splits = pendulum.make_splits(settings)
    assert list(splits) == ["train", "interpolation", "extrapolation"]
    # The test sets are simulated 1000 and 2000 seeds away from the run's: the
    # extrapolative one with larger torques.
    torque = splits["extrapolation"].feature_names.index("torque[t]")
    assert np.abs(splits["extrapolation"].X[:, torque]).max() > 1.0
    assert np.abs(splits["train"].X[:, torque]).max() <= 1.0
    assert SYSTEMS["double-pendulum"].noise_type(settings) == "process"


def test_a_users_simulator_runs_the_zoo_and_is_scored_on_its_test_sets():
    spec = _motor()
    result = run_experiment(spec, quick=True)
    assert result.system.name == "my-motor"
    assert result.sizes == TINY and len(result.splits["train"].X) == 300
    assert result.test_splits == ["fast"]
    models = set(result.predictions["fast"]) - {"oracle"}
    assert {"physics", "linear", "dense", "physics+dense", "ensemble"} <= models
    # Scored against the oracle on its own test set; the physics' parameters
    # fitted, with standard errors.
    assert all(np.isfinite(row["rmse"]) for row in result.model_rows("fast", "dense"))
    assert set(result.params["physics"]) == {"gain", "time_constant"}
    assert check_claims(result) == []  # the spec states no claim


def test_a_one_step_specs_claims_reach_the_report(tmp_path):
    def claims(result):
        return [{"claim": "the physics is fitted", "passed": True, "detail": "ok"}]

    spec = _motor(protocol=OneStepWindows(claims=claims, quick_sizes=TINY))
    result = run_experiment(spec, quick=True)
    # A quick run's claim is not judged.
    (claim,) = check_claims(result)
    assert claim["passed"] is None and claim["detail"].endswith("ok")
    # A full run's is, at the spec's own full sizes.
    spec = _motor(protocol=OneStepWindows(claims=claims, sizes=TINY))
    result = run_experiment(spec, settings=RunSettings(seed=1))
    assert result.sizes == TINY
    (claim,) = check_claims(result)
    assert claim["passed"] is True and claim["detail"] == "ok"


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"records": [(np.zeros(50), np.zeros(50))]}, TypeError, "records must be a"),
        ({"tests": None}, TypeError, "tests must be a non-empty dict"),
        ({"tests": {"train": make_dc_motor}}, ValueError, "'train'"),
        ({"physics": object()}, TypeError, "physics must be a regressor"),
        ({"segments": (100,)}, ValueError, "segments belong to the free-run"),
        ({"dt": 0.1}, ValueError, "dt belong to the free-run"),
        ({"protocol": "one-step"}, TypeError, "protocol must be 'free-run' or"),
        (
            {
                "physics": {
                    "a": ParametricModel(dc_motor_step, {"gain": 1.0}),
                    "b": ParametricModel(dc_motor_step, {"gain": 2.0}),
                }
            },
            ValueError,
            "protocol.hybrid_physics must name one of",
        ),
    ],
)
def test_a_one_step_spec_is_checked_when_built(kwargs, error, match):
    with pytest.raises(error, match=match):
        _motor(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"noise": -1.0}, "noise must be a finite number"),
        ({"noise_type": "both"}, "noise_type must be one of"),
        ({"claims": "yes"}, "claims must be a callable"),
        ({"descriptions": ["train"]}, "descriptions must be a dict"),
        ({"hybrid_physics": 3}, "hybrid_physics must be a label"),
        ({"sizes": {"n_train": 300}}, "sizes must be a OneStepSizes"),
        ({"quick_sizes": None}, "quick_sizes must be a OneStepSizes"),
    ],
)
def test_the_protocol_names_the_parameter_it_refuses(kwargs, match):
    with pytest.raises((TypeError, ValueError), match=match):
        OneStepWindows(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_train": 0}, "n_train must be an int >= 1; got n_train=0"),
        ({"max_epochs": 2.5}, "max_epochs must be an int"),
        ({"lags": True}, "lags must be an int"),
        ({"dense_layers": [32, 32]}, "dense_layers must be a non-empty tuple"),
        (
            {"dense_layers": (32, -1)},
            "dense_layers\\[1\\] must be an int >= 1; got dense_layers\\[1\\]=-1",
        ),
    ],
)
def test_the_sizes_name_the_parameter_they_refuse(kwargs, match):
    with pytest.raises((TypeError, ValueError), match=match):
        OneStepSizes(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"quick": 1}, TypeError, "quick must be a bool; got quick=1"),
        ({"seed": -1}, ValueError, "seed must be an int in \\[0, 2\\*\\*32 - 1\\]"),
        ({"seed": 2**32}, ValueError, "seed must be an int"),
        ({"seed": 1.0}, TypeError, "seed must be an int"),
        ({"noise_type": "both"}, ValueError, "noise_type must be one of"),
    ],
)
def test_the_run_settings_name_the_parameter_they_refuse(kwargs, error, match):
    with pytest.raises(error, match=match):
        RunSettings(**kwargs)


def test_a_run_takes_run_settings_only():
    assert RunSettings(seed=np.int64(3)).to_dict() == {
        "quick": False,
        "seed": 3,
        "noise_type": None,
    }
    with pytest.raises(TypeError, match=r"settings must be a skhybrid\.experiments"):
        run_experiment(_motor(), settings=TINY)


def test_a_one_step_spec_has_no_records_to_read(tmp_path):
    with pytest.raises(ValueError, match="protocol=OneStepWindows"):
        _motor().estimation_records()


def test_run_system_runs_a_one_step_spec_at_one_seed(tmp_path, monkeypatch):
    spec = _motor()
    with pytest.raises(ValueError, match="one seed"):
        run_system(spec, tmp_path / "two", seeds=[0, 1], quick=True)
    assert not (tmp_path / "two").exists()
    out = tmp_path / "run"
    summary = run_system(spec, out, seeds=0, quick=True, n_jobs=1, progress=False)
    assert json.loads((out / "run.json").read_text())["status"] == "complete"
    assert (out / "report.html").is_file()
    on_disk = json.loads((out / "results.json").read_text())["systems"]["my-motor"]
    assert summary == on_disk
    # The same run again carries the folder's finished models on (resume).
    again = run_system(
        spec, out, seeds=0, quick=True, n_jobs=1, progress=False, resume=True
    )
    again.pop("wall_time_s"), summary.pop("wall_time_s")
    assert again == summary
    # Process noise, as --noise-type gives it.
    summary = run_system(
        spec,
        tmp_path / "process",
        seeds=0,
        quick=True,
        noise_type="process",
        n_jobs=1,
        progress=False,
    )
    assert summary["noise_type"] == "process"
    assert summary["settings"]["noise_type"] == "process"
    assert on_disk["noise_type"] == "measurement"


def test_get_system_takes_a_spec_of_either_protocol():
    assert get_system(_motor()).name == "my-motor"
    assert get_system(SIMULATED["pendulum"].SPEC).measured is False


def test_a_one_step_specs_digest_is_the_same_in_a_fresh_process():
    code = (
        "from skhybrid.experiments._registry import SYSTEMS;"
        "print(SYSTEMS['pendulum'].digest())"
    )
    digests = {
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.strip()
        for _ in range(2)
    }
    assert digests == {SYSTEMS["pendulum"].digest()}
    changed = replace(SIMULATED["pendulum"].SPEC, n_init=5)
    assert get_system(changed).digest() != SYSTEMS["pendulum"].digest()


def test_the_command_line_runs_a_users_one_step_spec(tmp_path, monkeypatch, capsys):
    module = tmp_path / "my_motor.py"
    module.write_text(
        "from functools import partial\n"
        "from skhybrid.datasets import make_dc_motor\n"
        "from skhybrid.domain import ParametricModel, dc_motor_step\n"
        "from skhybrid.experiments import OneStepSizes, OneStepWindows, SystemSpec\n"
        "spec = SystemSpec(\n"
        "    'my-motor',\n"
        "    records=partial(make_dc_motor, excitation_hz=10.0),\n"
        "    tests={'fast': partial(make_dc_motor, excitation_hz=100.0)},\n"
        "    physics=ParametricModel(\n"
        "        partial(dc_motor_step, dt=0.001),\n"
        "        {'gain': 1.0, 'time_constant': 0.05},\n"
        "    ),\n"
        "    n_init=4,\n"
        "    # Its --quick run at tiny sizes: the zoo's every model, in seconds.\n"
        "    protocol=OneStepWindows(\n"
        "        quick_sizes=OneStepSizes(n_train=300, n_test=200, max_epochs=2),\n"
        "    ),\n"
        ")\n"
    )
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    argv = ["run", "--system", "my_motor:spec", "--quick", "--no-progress"]
    assert main([*argv, "--seeds", "0", "1", "--out", "x"]) == 2
    assert "runs one seed" in capsys.readouterr().err
    assert main([*argv, "--noise-type", "process", "--out", "out"]) == 0
    results = json.loads(Path("out/results.json").read_text())
    assert list(results["systems"]) == ["my-motor"]
    assert (Path("out") / "report.html").is_file()
