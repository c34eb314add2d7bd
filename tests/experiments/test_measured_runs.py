"""A measured benchmark runs through the paper systems' pipeline.

`skhybrid run emps|cascaded-tanks|silverbox --data DIR` uses the same runner, run
folder (checks, lock, resume, overwrite protection), Dask option, progress and
report as the simulated systems. Most tests here replace the EMPS data with a
simulated axis and the zoo with four quick models (a :class:`SyntheticAxis`
registered as ``emps``), so that they run in seconds without the benchmark
files; the tests on the real files skip where ``../shared/data`` is absent.
"""

import csv
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from sklearn.utils import Bunch

from skhybrid import cli
from skhybrid.benchmarks.emps import PUBLISHED as EMPS_PUBLISHED
from skhybrid.benchmarks.emps import physics as emps_physics
from skhybrid.cli import main
from skhybrid.experiments import SystemSpec
from skhybrid.experiments._registry import MEASURED_SYSTEMS
from skhybrid.experiments.free_run import _family as _measured_zoo
from skhybrid.experiments.free_run import _search as _measured_search
from skhybrid.experiments.free_run import _system as _measured_system
from skhybrid.experiments.free_run._system import MeasuredSystem
from skhybrid.experiments.run import _runner

REPO = Path(__file__).resolve().parents[2]
TINY = ["dense NARX", "linear ARX", "physics", "physics + linear"]
NO_DASK = "dask[distributed] is not installed: pip install 'skhybrid[dask]'"


def _axis_records(n=1600, seed=0):
    """An EMPS-like axis simulated from known parameters, and a test record."""
    rng = np.random.default_rng(seed)
    t = np.arange(2 * n) * 1e-3
    u = np.sin(2 * np.pi * 1.5 * t) + 0.5 * np.sin(2 * np.pi * 15.1 * t + 1.0)
    u = u[:, None] + 0.1 * rng.standard_normal((2 * n, 1))
    model = emps_physics(1e-3)
    truth = {
        "M": 90.0,
        "Fv_pos": 160.0,
        "Fv_neg": 210.0,
        "Fc_pos": 22.0,
        "Fc_neg": 23.0,
    }
    model.set_params(params={**model.params, **truth}, fixed=tuple(model.params))
    y = model.fit_simulation(u, np.zeros((2 * n, 1))).simulate_from_state(u, [0.0, 0.0])
    y = y + 1e-5 * rng.standard_normal(y.shape)
    return (u[:n], y[:n]), {"test": (u[n:], y[n:])}


class SyntheticAxis(MeasuredSystem):
    """The EMPS benchmark on a simulated axis, with a four-model zoo."""

    name = "emps"
    title = "EMPS electro-mechanical positioning axis (measured, closed loop)"
    unit = "mm"
    scale = 1e3
    hybrids = False

    def make_spec(self, data=None, quick=False):
        if data is not None and not Path(data).is_dir():
            raise FileNotFoundError(f"no EMPS files in {data}")
        train, tests = _axis_records()
        return SystemSpec(
            "emps",
            records=[train],
            physics=emps_physics(1e-3, max_nfev=8),
            n_init=20,
            dt=1e-3,
            tests=lambda: tests,
            unit="mm",
            scale=1e3,
            published=EMPS_PUBLISHED,
            segments=(None,),
            hybrids=None,
        )

    def model_zoo(self, settings):
        full = super().model_zoo(settings)
        return {
            name: full[name]
            for name in ("physics", "linear ARX", "dense NARX", "physics + linear")
        }


def _small_dense(ctrl_c=None):
    from skhybrid.neural import DenseRegressor

    def make(quick, seed):
        return DenseRegressor(
            (8,),
            max_epochs=4,
            batch_size=256,
            random_state=seed,
            callbacks=None if ctrl_c is None else [ctrl_c(2)],
        )

    return make


#: The zoo's dense network, before any test replaces it.
_REAL_DENSE = _measured_zoo._dense


@pytest.fixture
def axis(monkeypatch, ctrl_c_at_epoch):
    """Register :class:`SyntheticAxis` as ``emps``; ``axis(True)`` presses Ctrl-C
    in the dense NARX's second epoch (as the paper systems' tests do)."""
    monkeypatch.setitem(MEASURED_SYSTEMS, "emps", SyntheticAxis())

    def use(interrupt=False):
        dense = _small_dense(ctrl_c_at_epoch if interrupt else None)
        monkeypatch.setattr(_measured_zoo, "_dense", dense)

    use()
    return use


@pytest.fixture
def no_training(monkeypatch):
    def fail(*args, **kwargs):  # pragma: no cover - must not be reached
        raise AssertionError("training started")

    monkeypatch.setattr(_measured_search, "fit_model", fail)
    monkeypatch.setattr(_measured_search, "choose_and_refit", fail)
    monkeypatch.setattr(MeasuredSystem, "new_result", fail)


def _run(out, *extra, data=None):
    data = data or out.parent
    argv = ["run", "emps", "--quick", "--data", str(data), "--out", str(out)]
    if "--seed" not in extra and "--seeds" not in extra:
        extra = (*extra, "--seeds", "0")  # one selection: seconds, not minutes
    return main([*argv, "--no-progress", "--n-jobs", "1", *extra])


def _table(out):
    """results.csv without the fit times (the one column that is a measurement)."""
    with (Path(out) / "results.csv").open() as f:
        return [
            {k: v for k, v in row.items() if k != "fit_time_s"}
            for row in csv.DictReader(f)
        ]


def _finished(out, system="emps-seed-0"):
    folder = Path(out) / "models" / system
    return sorted(json.loads(p.read_text())["model"] for p in folder.glob("*.json"))


def _one_error_line(capsys, *words):
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith("skhybrid: error: ")
    for word in words:
        assert word in err, err
    return err


def _snapshot(folder):
    return {
        p.relative_to(folder): p.read_bytes()
        for p in sorted(Path(folder).rglob("*"))
        if p.is_file()
    }


# -- the output folder is checked before any training --------------------------------


def test_out_that_is_a_file_exits_2_within_15_s(tmp_path):
    # The whole command, interpreter start and imports included.
    target = tmp_path / "results.csv"
    target.write_text("precious")
    (tmp_path / "data").mkdir()
    argv = [sys.executable, "-m", "skhybrid.cli", "run", "emps", "--quick"]
    argv += ["--data", str(tmp_path / "data"), "--out", str(target)]
    start = time.monotonic()
    done = subprocess.run(
        argv,
        env=dict(os.environ, PYTHONPATH=str(REPO)),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert time.monotonic() - start < 15
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1, done.stderr
    assert f"--out {target} is a file, not a folder" in done.stderr
    assert target.read_text() == "precious"


def test_out_that_is_a_file_is_refused_before_training(tmp_path, capsys, no_training):
    target = tmp_path / "results.json"
    target.write_text("precious")
    assert _run(target) == 2
    _one_error_line(capsys, f"--out {target} is a file, not a folder")
    assert target.read_text() == "precious"


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0,
    reason="root writes into read-only folders",
)
def test_read_only_out_is_refused_before_training(tmp_path, capsys, no_training):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        assert _run(locked) == 2
    finally:
        locked.chmod(0o700)
    _one_error_line(capsys, f"--out {locked} is not writable")


def test_unwritable_out_is_refused_before_training_whoever_runs_it(
    tmp_path, capsys, no_training, monkeypatch
):
    # Root writes into read-only folders: refuse the lock's creation instead, as
    # the file system does for a read-only folder.
    import errno

    real_open = os.open

    def read_only(path, *args, **kwargs):
        if str(path).startswith(str(tmp_path / "ro")):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", read_only)
    (tmp_path / "ro").mkdir()
    assert _run(tmp_path / "ro") == 2
    _one_error_line(capsys, f"--out {tmp_path / 'ro'} is not writable")
    assert list((tmp_path / "ro").iterdir()) == []


def test_busy_out_is_refused_before_training(tmp_path, capsys, no_training):
    # Another run holds the folder: a live process's pid in its lock.
    out = tmp_path / "run"
    out.mkdir()
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        (out / ".lock").write_text(
            json.dumps({"pid": other.pid, "host": os.uname().nodename, "started": "x"})
        )
        assert _run(out) == 2
    finally:
        other.kill()
        other.wait()
    _one_error_line(capsys, "in use by another skhybrid run", f"pid {other.pid}")
    assert (out / ".lock").exists()  # still the other run's


def test_resume_into_another_systems_results_is_refused_and_changes_nothing(
    tmp_path, capsys, no_training
):
    out = tmp_path / "run"
    (out / "models" / "pendulum").mkdir(parents=True)
    (out / "models" / "pendulum" / "linear.json").write_text('{"model": "linear"}')
    (out / "results.csv").write_text("the pendulum's table")
    (out / "report.html").write_text("the pendulum's report")
    manifest = {
        "format": 1,
        "status": "complete",
        "command": "skhybrid run pendulum --quick",
        "identity": {"systems": ["pendulum"], "quick": True, "seed": 0},
    }
    (out / "run.json").write_text(json.dumps(manifest))
    before = _snapshot(out)
    assert _run(out, "--resume") == 2
    _one_error_line(capsys, "already holds a finished run", "skhybrid run pendulum")
    assert _snapshot(out) == before
    # An unfinished run of another system is refused the same way.
    (out / "run.json").write_text(json.dumps({**manifest, "status": "running"}))
    before = _snapshot(out)
    assert _run(out, "--resume") == 2
    _one_error_line(capsys, "holds an unfinished run of other settings")
    assert _snapshot(out) == before


def test_missing_data_is_one_line(tmp_path, capsys):
    assert _run(tmp_path / "run", data=tmp_path / "nowhere") == 2
    err = _one_error_line(capsys)
    assert "nowhere" in err
    assert not (tmp_path / "run" / ".lock").exists()


def test_data_or_noise_type_where_they_mean_nothing_is_refused(tmp_path, capsys):
    argv = ["run", "pendulum", "--data", str(tmp_path), "--out", str(tmp_path / "r")]
    assert main(argv) == 2
    _one_error_line(capsys, "--data", "pendulum is simulated")
    assert _run(tmp_path / "r", "--noise-type", "process") == 2
    _one_error_line(capsys, "--noise-type", "measured system")
    assert not (tmp_path / "r").exists()


# -- the run: results as models finish, Ctrl-C, resume, report ---------------


# About 45 s; a paper system's Ctrl-C and resume run by default
# (test_run_folder.py), this measured one with `pytest -m slow`.
@pytest.mark.slow
def test_ctrl_c_keeps_finished_models_and_resume_skips_them(
    tmp_path, capsys, axis, monkeypatch
):
    import matplotlib
    import matplotlib.pyplot as plt

    out = tmp_path / "run"
    axis(interrupt=True)
    assert _run(out) == 130
    err = capsys.readouterr().err
    assert "interrupted: 2 of 4 models are finished and kept" in err
    assert f"--out {out} --no-progress --n-jobs 1 --seeds 0 --resume" in err
    assert "Traceback" not in err
    assert _finished(out) == ["linear ARX", "physics"]  # not the dense NARX
    # The physics' fits of every fold are kept in the run's cache: the resume
    # and the models built on the physics read them instead of fitting again.
    assert any((out / "cache").glob("*.pickle"))
    assert not (out / "results.csv").exists()
    assert not (out / ".lock").exists()

    # The resumed run fits only the two others: the physics that the correction
    # starts from is read back from the folder.
    axis(interrupt=False)
    fitted = []
    fit_model = _measured_search.fit_model

    def counting(name, *args, **kwargs):
        fitted.append(name)
        return fit_model(name, *args, **kwargs)

    monkeypatch.setattr(_measured_system, "fit_model", counting)
    backend = matplotlib.get_backend()
    users_figure = plt.figure()  # a user's own plotting session
    assert _run(out, "--resume") == 0
    assert matplotlib.get_backend() == backend
    assert plt.get_fignums() == [users_figure.number]
    plt.close(users_figure)
    assert "resuming: 2 of 4 models already finished" in capsys.readouterr().out
    assert sorted(fitted) == ["dense NARX", "physics + linear"]
    assert _finished(out) == TINY

    assert _run(tmp_path / "uninterrupted") == 0
    assert _table(out) == _table(tmp_path / "uninterrupted")
    # The validation runs come back from the folder: the stochastic part of a
    # resumed run is the uninterrupted run's.
    resumed, whole = (
        json.loads((folder / "results.json").read_text())["systems"]["emps"]
        for folder in (out, tmp_path / "uninterrupted")
    )
    assert resumed["stochastic"] == whole["stochastic"]
    assert resumed["stochastic"]["0"]["noise"]["fitted"]
    assert {row["model"] for row in _table(out)} == set(TINY)

    summary = json.loads((out / "results.json").read_text())["systems"]["emps"]
    validation = summary["validation_rmse"]["0"]
    assert summary["chosen_model"]["0"] == min(validation, key=validation.get)
    selection = {k: f["selection"] for k, f in summary["fits"]["0"].items()}
    assert selection["physics"]["segment"] is None
    assert selection["dense NARX"]["n"] == selection["linear ARX"]["n"]
    assert summary["published"]["test"]["state of the art (CT-SUBNET)"]["rmse"] == 4.61
    assert set(summary["physics_params"]["0"]) >= {"M", "Fv_pos", "Fc_neg"}
    assert (out / "emps.png").stat().st_size > 10_000
    page = (out / "report.html").read_text()
    assert "Champneys" in page and "src='data:image/png;base64," in page


def test_finished_measured_run_is_kept_and_its_report_rewritten(tmp_path, capsys, axis):
    out = tmp_path / "run"
    assert _run(out) == 0
    table = _table(out)
    capsys.readouterr()
    assert _run(out) == 2
    _one_error_line(capsys, "already holds a finished run", "--overwrite")
    assert _run(out, "--seed", "1") == 2
    _one_error_line(capsys, "already holds a finished run")
    # --resume writes the report again from the stored models, training nothing.
    assert _run(out, "--resume") == 0
    assert "resuming: 4 of 4" in capsys.readouterr().out
    assert _table(out) == table


def test_progress_counts_the_zoos_models(tmp_path, capsys, axis):
    argv = ["run", "emps", "--quick", "--data", str(tmp_path), "--n-jobs", "1"]
    assert main([*argv, "--seeds", "0", "1", "--out", str(tmp_path / "run")]) == 0
    err = capsys.readouterr().err
    # Standard error is not a terminal here: one line per finished model, and
    # one bar per seed (the first searches, each refits).
    lines = [line for line in err.splitlines() if line.startswith("emps seed ")]
    # A physics fit that runs past the log interval (15 s) says how far it is.
    physics = [line for line in lines if ": physics fit, " in line]
    assert all(
        re.search(r"\d+ residual evaluations? of at most \d+", line) for line in physics
    )
    # Each fit of a search (its fold, or the refit) has its line too.
    assert any(re.search(r"fold 1 of \d \(\d+ fit pieces?\), seed 0", x) for x in lines)
    lines = [
        line for line in lines if re.search(r": \d+ models to fit|/4 models: ", line)
    ]
    assert [line.split(" models: ")[0] for line in lines] == [
        text
        for s in (0, 1)
        for text in [
            f"emps seed {s}: 4 models to fit",  # at once: the run has started
            *(f"emps seed {s}: {i}/4" for i in range(1, 5)),
        ]
    ]
    assert "\r" not in err


def test_dask_option_is_used_for_measured_systems(tmp_path, capsys, axis, monkeypatch):
    # A stand-in for the cluster: joblib's threading backend behind the same
    # context manager; the measured run must go through it.
    import contextlib

    import joblib

    entered = []

    @contextlib.contextmanager
    def fake_dask(address, n_workers):
        entered.append((address, n_workers))
        client = Bunch(scheduler=Bunch(address="tcp://fake:8786"))
        with joblib.parallel_config(backend="threading"):
            yield client

    monkeypatch.setattr(cli, "_dask_backend", fake_dask)
    monkeypatch.setattr(cli, "DASK_REQUIREMENTS", {})
    assert _run(tmp_path / "run", "--dask", "local") == 0
    assert entered == [("local", 1)]
    assert "fitting on the Dask cluster at tcp://fake:8786" in capsys.readouterr().out
    assert _finished(tmp_path / "run") == TINY


@pytest.mark.slow  # two clusters' worth of process starts
def test_dask_local_measured_run_gives_the_local_table(tmp_path, axis, monkeypatch):
    pytest.importorskip("distributed", reason=NO_DASK)
    # The zoo's own networks: the fixture's small one is patched into this
    # process only, which the local run's refits use and no worker sees.
    monkeypatch.setattr(_measured_zoo, "_dense", _REAL_DENSE)
    argv = ["run", "emps", "--quick", "--data", str(tmp_path), "--no-progress"]
    argv += ["--n-jobs", "2"]
    assert main([*argv, "--out", str(tmp_path / "local")]) == 0
    assert main([*argv, "--out", str(tmp_path / "dask"), "--dask", "local"]) == 0
    assert _table(tmp_path / "dask") == _table(tmp_path / "local")


def test_no_library_module_switches_the_matplotlib_backend():
    offenders = [
        str(path.relative_to(REPO))
        for path in (REPO / "skhybrid").rglob("*.py")
        if "matplotlib.use(" in path.read_text()
    ]
    assert offenders == []


def test_run_experiment_runs_a_measured_system_from_python(tmp_path, axis):
    # run_experiment selects; it reads no test record (run_system scores them
    # once every seed's selection is sealed).
    result = _runner.run_experiment("emps", quick=True, data=tmp_path)
    assert list(result.fits) == [
        "physics",
        "linear ARX",
        "dense NARX",
        "physics + linear",
    ]
    assert result.tests == {} and result.rows == []
    assert set(result.estimators) == set(TINY)
    assert result.selected_model() in TINY


def test_a_measured_run_without_data_fetches_and_says_where_files_go(
    tmp_path, monkeypatch
):
    import socket

    with socket.socket() as s:  # a port nothing listens on: no network
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    monkeypatch.setenv("SKHYBRID_DATA", str(tmp_path / "home"))
    monkeypatch.setenv("SKHYBRID_DATA_MIRROR", f"http://127.0.0.1:{port}")
    with pytest.raises(OSError, match=r"CascadedTanksFiles\.zip") as info:
        _runner.run_experiment("cascaded-tanks", quick=True)
    assert str(tmp_path / "home" / "cascaded_tanks") in str(info.value)


# -- the real benchmark files ---------------------------------------------------


@pytest.mark.slow
def test_cascaded_tanks_quick_run_on_the_real_files(shared_data_dir, tmp_path):
    out = tmp_path / "tanks"
    argv = ["run", "cascaded-tanks", "--quick", "--data", str(shared_data_dir)]
    argv += ["--seeds", "0"]
    assert main([*argv, "--out", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "results.json").read_text())["systems"][
        "cascaded-tanks"
    ]
    assert summary["n_init"] == 50 and summary["unit"] == "V"
    models = {
        "physics",
        "linear ARX",
        "dense NARX",
        "physics + linear",
        "physics + dense",
        "physics + dense ensemble",
        "state-space hybrid",
        "stacked",
    }
    assert set(summary["test_rmse"]["test"]) == models
    # The original protocol: defined for the physics, its corrections and the
    # state-space hybrid (from the physics' state), not for the black boxes.
    original = summary["test_rmse"]["test_original_protocol"]
    assert original["physics"]["mean"] is not None
    assert original["state-space hybrid"]["mean"] is not None
    assert original["linear ARX"]["mean"] is None
    assert (out / "cascaded-tanks.png").stat().st_size > 10_000
    assert main([*argv, "--out", str(out)]) == 2  # finished: kept


def test_cli_knows_every_system_by_name():
    from skhybrid.experiments import SYSTEMS

    assert cli.SIMULATED_SYSTEMS == tuple(SYSTEMS)
    assert cli.MEASURED_SYSTEMS == tuple(MEASURED_SYSTEMS)


def test_run_measured_writes_a_folder_the_command_carries_on(tmp_path, axis, capsys):
    from skhybrid.experiments import run_measured

    out = tmp_path / "run"
    summary = run_measured("emps", tmp_path, out, quick=True, seeds=[0], n_jobs=1)
    assert summary["chosen_model"]["0"] in TINY
    assert _finished(out) == TINY
    # The command sees the same run: --resume rewrites its report.
    assert _run(out, "--resume") == 0
    assert "resuming: 4 of 4" in capsys.readouterr().out
