"""A machine of the missing-physics suite runs through run_system, tiny."""

import dataclasses

import numpy as np
import pytest

from skhybrid.benchmarks.missing_physics import MACHINES, make_spec
from skhybrid.experiments import run_system


def test_a_machine_of_the_suite_runs_through_run_system(tmp_path):
    spec = make_spec("hardening-spring", n_records=2, n_samples=320)
    # The smallest family that still trains a state-space hybrid.
    spec = dataclasses.replace(
        spec,
        hybrids={
            "T=20": {
                "horizon": 20,
                "hidden_layer_sizes": (8,),
                "max_epochs": 2,
                "batch_size": 16,
                "stride": 10,
            }
        },
    )
    summary = run_system(spec, tmp_path / "run", quick=True, seeds=[0], n_jobs=1)
    scores = summary["test_rmse"]
    assert set(scores) == {"inside", "beyond"}
    for test in ("inside", "beyond"):
        assert np.isfinite(scores[test]["physics"]["mean"])
        assert np.isfinite(scores[test]["state-space hybrid"]["mean"])
    # The linear physics misses the hardening spring: its free run is far
    # above the measurement noise (1 % of the position's spread).
    assert scores["inside"]["physics"]["mean"] > 0.05


@pytest.mark.parametrize("name", MACHINES)
def test_every_machine_has_a_spec_for_the_command_line(name, monkeypatch):
    from skhybrid.benchmarks import missing_physics

    calls = []
    monkeypatch.setattr(missing_physics, "make_spec", calls.append)
    getattr(missing_physics, name.replace("-", "_"))()
    assert calls == [name]
