"""Runs on a Dask cluster through joblib's Dask backend.

The tests that need ``dask[distributed]`` skip with a reason where it is missing
(it is in the ``tests`` extra, so CI runs them).
"""

import csv
import time
from pathlib import Path

import numpy as np
import pytest
from joblib import Parallel, delayed, parallel_config

from skhybrid import cli
from skhybrid.cli import main

NO_DASK = "dask[distributed] is not installed: pip install 'skhybrid[dask]'"


@pytest.fixture(scope="module")
def client():
    """A client of a 2-worker local cluster (one thread per worker process)."""
    distributed = pytest.importorskip("distributed", reason=NO_DASK)
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    )
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def _hybrid():
    from skhybrid.domain import LinearStateSpaceModel
    from skhybrid.hybrid import HybridBoostingRegressor
    from skhybrid.neural import DenseRegressor

    return HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel()),
            ("dense", DenseRegressor((8,), max_epochs=6, random_state=0)),
        ],
        stage_input="window",
    )


def test_grid_search_on_dask_gives_the_default_backends_best_params(client, rng):
    from sklearn.model_selection import GridSearchCV, KFold

    X = rng.standard_normal((240, 3))
    y = 0.8 * X[:, 0] - 0.3 * X[:, 2] + np.sin(2 * X[:, 1])
    grid = {"dense__hidden_layer_sizes": [(4,), (16,)], "dense__lr": [0.003, 0.03]}

    def search():
        model = _hybrid().set_params(dense__max_epochs=3)
        return GridSearchCV(model, grid, cv=KFold(2), n_jobs=2).fit(X, y)

    local = search()
    with parallel_config(backend="dask"):
        on_dask = search()
    assert on_dask.best_params_ == local.best_params_
    np.testing.assert_allclose(
        on_dask.cv_results_["mean_test_score"],
        local.cv_results_["mean_test_score"],
        rtol=1e-6,
    )
    # The fits ran on the cluster's workers.
    assert sum(client.run(lambda dask_worker: len(dask_worker.data)).values()) >= 0
    assert (
        client.run_on_scheduler(
            lambda dask_scheduler: len(dask_scheduler.task_prefixes)
        )
        > 0
    )


def test_epochs_are_counted_from_dask_events(client, rng):
    from skhybrid.experiments.run._progress import DaskEventSink, attach_epoch_logger
    from skhybrid.hybrid import HybridBoostingRegressor

    X = rng.standard_normal((120, 3))
    y = X[:, 0] - np.sin(X[:, 1])
    sink = DaskEventSink("skhybrid-test-epochs").subscribe(client)
    models = [_hybrid().set_params(dense__max_epochs=e) for e in (2, 3)]
    for i, model in enumerate(models):
        attach_epoch_logger(model, sink, f"model{i}")
    with parallel_config(backend="dask"):
        fitted = Parallel(n_jobs=-1)(
            delayed(HybridBoostingRegressor.fit)(m, X, y) for m in models
        )
    assert [f.stages_[1][1].n_epochs_ for f in fitted] == [2, 3]
    deadline = time.monotonic() + 10
    while sink.count() < 5 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.2)
    assert sink.count() == 5
    sink.unsubscribe()


def _table(out):
    with (Path(out) / "results.csv").open() as f:
        return [
            {k: v for k, v in row.items() if k != "fit_time_s"}
            for row in csv.DictReader(f)
        ]


@pytest.mark.slow  # about 15 s: two clusters' worth of process starts
def test_dask_local_run_gives_the_local_table(tmp_path, monkeypatch):
    pytest.importorskip("distributed", reason=NO_DASK)
    from skhybrid.experiments.one_step import _report as _simulated_report
    from skhybrid.experiments.one_step import _system as _one_step
    from skhybrid.experiments.run import _console

    full_zoo = _one_step.model_zoo

    def zoo(system, settings):
        full = full_zoo(system, settings)
        return {k: full[k] for k in ("physics (refit)", "linear", "dense")}

    monkeypatch.setattr(_one_step, "model_zoo", zoo)
    monkeypatch.setattr(_console, "check_claims", lambda result: [])
    monkeypatch.setattr(_simulated_report, "check_claims", lambda result: [])
    argv = ["run", "pendulum", "--quick", "--no-progress", "--n-jobs", "2"]
    assert main([*argv, "--out", str(tmp_path / "local")]) == 0
    assert main([*argv, "--out", str(tmp_path / "dask"), "--dask", "local"]) == 0
    assert _table(tmp_path / "dask") == _table(tmp_path / "local")
    assert len(_table(tmp_path / "dask")) == 4 * 2 * 3  # + oracle, 2 splits, 3 outputs


@pytest.mark.slow
def test_quick_pendulum_on_dask_local_gives_the_local_table(tmp_path):
    pytest.importorskip("distributed", reason=NO_DASK)
    # Two local workers of one thread each, as joblib gives two local processes on
    # two cores: the same arithmetic, so the same numbers.
    argv = ["run", "pendulum", "--quick", "--no-progress", "--n-jobs", "2"]
    assert main([*argv, "--out", str(tmp_path / "local")]) == 0
    assert main([*argv, "--out", str(tmp_path / "dask"), "--dask", "local"]) == 0
    assert _table(tmp_path / "dask") == _table(tmp_path / "local")


def test_unreachable_scheduler_is_reported_before_training(
    tmp_path, capsys, monkeypatch
):
    pytest.importorskip("distributed", reason=NO_DASK)
    from skhybrid import experiments

    def no_training(*args, **kwargs):  # pragma: no cover - must not be reached
        raise AssertionError("training started")

    monkeypatch.setattr(experiments, "run_experiment", no_training)
    monkeypatch.setattr(cli, "DASK_CONNECT_TIMEOUT", "1s")
    out = tmp_path / "r"
    assert (
        main(["run", "pendulum", "--out", str(out), "--dask", "tcp://127.0.0.1:9"]) == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err


def test_dask_without_distributed_says_how_to_install(tmp_path, capsys, monkeypatch):
    import importlib.util

    real_find_spec = importlib.util.find_spec

    def find_spec(name, *args, **kwargs):
        if name == "distributed":
            return None
        return real_find_spec(name, *args, **kwargs)

    monkeypatch.setattr(importlib.util, "find_spec", find_spec)
    out = tmp_path / "r"
    assert main(["run", "pendulum", "--out", str(out), "--dask", "local"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    expected = (
        "skhybrid: error: `skhybrid run --dask` needs distributed, which is not "
        'installed; install it with `pip install "dask[distributed]" (the '
        "skhybrid[dask] extra)`"
    )
    assert err == [expected]
    assert not out.exists()
