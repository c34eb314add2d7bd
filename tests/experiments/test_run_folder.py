"""`skhybrid run` never loses work: checks before training, results as models
finish, Ctrl-C, --resume, --overwrite and a lock against concurrent runs.

Most tests run a small zoo (physics, a linear model and two small networks) on the
quick pendulum data so that they stay fast; one slow test interrupts and resumes
the real quick run.
"""

import contextlib
import csv
import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from skhybrid import experiments
from skhybrid.cli import main
from skhybrid.experiments.one_step import _report as _simulated_report
from skhybrid.experiments.one_step import _system as _one_step
from skhybrid.experiments.run import _console
from skhybrid.experiments.run._fitting import interrupts_raise
from skhybrid.experiments.run._store import FolderLock, RunFolder, RunFolderError
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor

TINY = ["physics (refit)", "linear", "dense", "physics+dense"]


def _tiny_zoo(interrupt_dense=False, ctrl_c=None):
    real = experiments.model_zoo

    def zoo(system, settings):
        full = real(system, settings)
        dense = DenseRegressor(
            (8,),
            max_epochs=6,
            random_state=settings.seed,
            callbacks=[ctrl_c(2)] if interrupt_dense else None,
        )
        out = {name: full[name] for name in ("physics (refit)", "linear")}
        out["dense"] = dense
        out["physics+dense"] = HybridBoostingRegressor(
            [
                ("physics", full["physics (refit)"]),
                ("dense", DenseRegressor((8,), max_epochs=6, random_state=1)),
            ],
            n_steps=system.n_steps,
        )
        return out

    return zoo


@pytest.fixture
def tiny_zoo(monkeypatch, ctrl_c_at_epoch):
    """Replace the zoo with four quick models; ``tiny_zoo(True)`` interrupts."""

    def use(interrupt_dense=False):
        zoo = _tiny_zoo(interrupt_dense, ctrl_c_at_epoch)
        monkeypatch.setattr(experiments, "model_zoo", zoo)
        monkeypatch.setattr(_one_step, "model_zoo", zoo)

    # The paper's claims compare models that the small zoo does not have.
    monkeypatch.setattr(_console, "check_claims", lambda result: [])
    monkeypatch.setattr(_simulated_report, "check_claims", lambda result: [])

    use()
    return use


@pytest.fixture
def no_training(monkeypatch):
    def fail(*args, **kwargs):  # pragma: no cover - must not be reached
        raise AssertionError("training started")

    monkeypatch.setattr(experiments, "run_experiment", fail)
    monkeypatch.setattr(_one_step, "fit_one", fail)


def _run(out, *extra):
    argv = ["run", "pendulum", "--quick", "--out", str(out), "--no-progress"]
    return main([*argv, "--n-jobs", "1", *extra])


def _table(out):
    """results.csv without the fit times (the one column that is a measurement)."""
    with (Path(out) / "results.csv").open() as f:
        return [
            {k: v for k, v in row.items() if k != "fit_time_s"}
            for row in csv.DictReader(f)
        ]


def _finished(out):
    folder = Path(out) / "models" / "pendulum"
    return sorted(json.loads(p.read_text())["model"] for p in folder.glob("*.json"))


@contextlib.contextmanager
def _started_as_from_a_terminal():
    """Start children with SIGINT at its default, as a terminal starts a run.

    A child inherits an ignored SIGINT (a suite run as a background job of a
    script ignores it), and Python then never turns a SIGINT into
    KeyboardInterrupt; a Python handler is reset to the default at ``exec``.
    """
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _ended_by_ctrl_c(proc, err):
    """The run handled the Ctrl-C (its message printed) and ended as interrupted.

    ``python -m`` on CPython up to 3.13 may end a process whose Ctrl-C was
    handled by SIGINT instead of the exit code 130 it returned: a
    KeyboardInterrupt that once passed out of code run by ``exec`` of a string
    (dataclasses and namedtuples build their methods so) leaves a flag that only
    the ``-m`` path checks at exit (cpython gh-128130). A shell reports both as
    130; the console script ``skhybrid`` always returns 130.
    """
    assert proc.returncode in (130, -signal.SIGINT), err
    assert "skhybrid: interrupted" in err, err


def _one_error_line(capsys, *words):
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith("skhybrid: error: ")
    for word in words:
        assert word in err, err
    return err


# -- the output location and the seed, checked before any training ---------------


def test_out_that_is_a_file_is_refused_before_training(tmp_path, capsys, no_training):
    target = tmp_path / "results.csv"
    target.write_text("precious")
    assert _run(target) == 2
    _one_error_line(capsys, f"--out {target} is a file, not a folder")
    assert target.read_text() == "precious"


def test_out_under_a_file_is_refused_before_training(tmp_path, capsys, no_training):
    (tmp_path / "file").write_text("x")
    assert _run(tmp_path / "file" / "sub") == 2
    _one_error_line(capsys, "cannot be created")


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0,
    reason="root writes into read-only folders",
)
def test_unwritable_out_is_refused_before_training(tmp_path, capsys, no_training):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        assert _run(locked) == 2
    finally:
        locked.chmod(0o700)
    _one_error_line(capsys, f"--out {locked} is not writable")


def test_huge_seed_is_refused_before_training(capsys, no_training):
    with pytest.raises(SystemExit) as exc:
        main(["run", "pendulum", "--seed", str(2**32)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "2**32 - 1" in err


# -- results land as each model finishes; Ctrl-C keeps them; resume --------------


def test_ctrl_c_in_a_network_stops_keeps_finished_and_resumes_to_same_table(
    tmp_path, capsys, tiny_zoo
):
    # skorch catches the KeyboardInterrupt of a Ctrl-C inside fit and returns the
    # network as if trained: the run must still stop and not record that model.
    out = tmp_path / "run"
    tiny_zoo(interrupt_dense=True)
    assert _run(out) == 130
    err = capsys.readouterr().err
    assert "interrupted: 2 of 4 models are finished and kept" in err
    assert f"--out {out} --no-progress --n-jobs 1 --resume" in err
    assert _finished(out) == ["linear", "physics (refit)"]  # not dense, nor later
    assert not (out / "results.csv").exists()
    assert not (out / ".lock").exists()
    manifest = json.loads((out / "run.json").read_text())
    assert manifest["status"] == "interrupted"
    assert manifest["reason"] == "Ctrl-C after 2 of 4 models"
    record = json.loads((out / "models" / "pendulum" / "linear.json").read_text())
    assert {r["split"] for r in record["scores"]} == {"interpolation", "extrapolation"}
    assert (out / "models" / "pendulum" / "linear.joblib").is_file()

    tiny_zoo(interrupt_dense=False)
    assert _run(out, "--resume") == 0
    assert "resuming: 2 of 4 models already finished" in capsys.readouterr().out
    assert _finished(out) == sorted(TINY)

    assert _run(tmp_path / "uninterrupted") == 0
    assert _table(out) == _table(tmp_path / "uninterrupted")
    # One wall time: the console prints the number the report records.
    console = re.search(r"\(([0-9.]+) s\)", capsys.readouterr().out).group(1)
    results = json.loads((tmp_path / "uninterrupted" / "results.json").read_text())
    assert f"{results['environment']['wall_time_s']:.1f}" == console
    assert json.loads((out / "run.json").read_text())["status"] == "complete"


def test_same_command_again_carries_on_an_unfinished_run(tmp_path, capsys, tiny_zoo):
    out = tmp_path / "run"
    tiny_zoo(interrupt_dense=True)
    assert _run(out) == 130
    tiny_zoo()
    assert _run(out) == 0
    assert "resuming: 2 of 4" in capsys.readouterr().out


def test_stored_model_is_the_fitted_model(tmp_path, tiny_zoo):
    import joblib
    import numpy as np

    out = tmp_path / "run"
    assert _run(out) == 0
    folder = out / "models" / "pendulum"
    model = joblib.load(folder / "physics-refit.joblib")
    with np.load(folder / "physics-refit.npz") as data:
        stored = data["interpolation"]
    X = (
        experiments.SYSTEMS["pendulum"]
        .make_splits(experiments.RunSettings(quick=True))["interpolation"]
        .X
    )
    np.testing.assert_array_equal(model.predict(X), stored)


# -- a finished run is kept; other runs are refused --------------------------------


def test_finished_run_is_not_overwritten_without_overwrite(
    tmp_path, capsys, tiny_zoo, monkeypatch
):
    out = tmp_path / "run"
    assert _run(out) == 0
    before = (out / "results.csv").read_bytes()
    table = _table(out)
    capsys.readouterr()
    for extra in ([], ["--seed", "1"]):
        assert _run(out, *extra) == 2
        _one_error_line(capsys, "already holds a finished run", "--overwrite")
    assert (out / "results.csv").read_bytes() == before
    # --resume writes the report again from the stored models, training nothing.
    fit_one = _one_step.fit_one
    monkeypatch.setattr(_one_step, "fit_one", None)  # calling it would fail
    assert _run(out, "--resume") == 0
    monkeypatch.setattr(_one_step, "fit_one", fit_one)
    assert "resuming: 4 of 4" in capsys.readouterr().out
    assert _table(out) == table
    assert _run(out, "--overwrite", "--seed", "1") == 0
    assert {row["seed"] for row in _table(out)} == {"1"}


def test_results_of_an_older_run_are_not_overwritten(tmp_path, capsys, no_training):
    out = tmp_path / "old"
    out.mkdir()
    (out / "report.html").write_text("an old report")
    assert _run(out) == 2
    _one_error_line(capsys, "already holds results", "--overwrite")
    assert (out / "report.html").read_text() == "an old report"


def test_unfinished_run_of_other_settings_is_refused(tmp_path, capsys, tiny_zoo):
    out = tmp_path / "run"
    tiny_zoo(interrupt_dense=True)
    assert _run(out) == 130
    capsys.readouterr()
    tiny_zoo()
    assert _run(out, "--seed", "5") == 2
    _one_error_line(capsys, "holds an unfinished run of other settings")
    assert _finished(out) == ["linear", "physics (refit)"]


def test_concurrent_run_is_refused(tmp_path, capsys, no_training):
    # Another run holds the folder: a live process's pid in the lock.
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


def test_stale_lock_is_taken_over(tmp_path, tiny_zoo):
    out = tmp_path / "run"
    out.mkdir()
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    (out / ".lock").write_text(
        json.dumps({"pid": gone.pid, "host": os.uname().nodename, "started": "x"})
    )
    assert _run(out) == 0
    assert not (out / ".lock").exists()


def test_lock_is_exclusive(tmp_path):
    first = FolderLock(tmp_path).acquire()
    with pytest.raises(RunFolderError, match="in use by another skhybrid run"):
        FolderLock(tmp_path).acquire()
    first.release()
    FolderLock(tmp_path).acquire().release()
    assert not (tmp_path / ".lock").exists()


def test_run_folder_refuses_a_file(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(RunFolderError, match="is a file, not a folder"):
        RunFolder(tmp_path / "f").prepare()


# -- the real quick run, interrupted from outside and resumed ----------------------


@pytest.mark.slow
@pytest.mark.parametrize("n_jobs", ["1", "2"])
def test_ctrl_c_on_quick_run_then_resume_gives_the_uninterrupted_table(
    tmp_path, n_jobs
):
    import time

    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    argv = [sys.executable, "-m", "skhybrid.cli", "run", "pendulum", "--quick"]
    argv += ["--n-jobs", n_jobs, "--no-progress", "--out"]
    out = tmp_path / "run"
    with _started_as_from_a_terminal():
        proc = subprocess.Popen(
            [*argv, str(out)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
    models = out / "models" / "pendulum"
    deadline = time.monotonic() + 300
    while not (models.is_dir() and len(list(models.glob("*.json"))) >= 2):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    # A Ctrl-C in a terminal reaches the whole process group (joblib's workers too).
    os.killpg(proc.pid, signal.SIGINT)
    start = time.monotonic()
    _, err = proc.communicate(timeout=60)
    assert time.monotonic() - start < 10  # promptly
    _ended_by_ctrl_c(proc, err)
    assert "--resume" in err
    kept = len(list(models.glob("*.json")))
    assert 2 <= kept < 12
    resumed = subprocess.run(
        [*argv, str(out), "--resume"],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming: {kept} of 12" in resumed.stdout
    whole = subprocess.run(
        [*argv, str(tmp_path / "whole")],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert whole.returncode == 0, whole.stderr
    assert _table(out) == _table(tmp_path / "whole")


def test_damaged_run_record_is_refused_not_cleared(tmp_path, capsys, tiny_zoo):
    out = tmp_path / "run"
    tiny_zoo(interrupt_dense=True)
    assert _run(out) == 130
    capsys.readouterr()
    (out / "run.json").write_text("{ not json")
    assert _run(out) == 2
    _one_error_line(capsys, "run.json cannot be read", "--overwrite")
    (out / "run.json").unlink()
    assert _run(out) == 2
    _one_error_line(capsys, "that no run.json describes")
    assert _finished(out) == ["linear", "physics (refit)"]


def test_second_run_into_a_busy_folder_is_refused(tmp_path, capsys, no_training):
    import time

    out = tmp_path / "run"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    # The full run, not --quick: the quick one (about 20 s) once finished and
    # exited 0 when a Ctrl-C was lost.
    argv = ["run", "pendulum", "--no-progress", "--n-jobs", "1"]
    with _started_as_from_a_terminal():
        first = subprocess.Popen(
            [sys.executable, "-m", "skhybrid.cli", *argv, "--out", str(out)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
    try:
        deadline = time.monotonic() + 120
        while not (out / ".lock").exists():
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        assert _run(out, "--seed", "1") == 2
        _one_error_line(capsys, "in use by another skhybrid run", f"pid {first.pid}")
        # Ctrl-C once the run has started (run.json written): the folder then
        # records the run as interrupted.
        while not (out / "run.json").exists():
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        first.send_signal(signal.SIGINT)
        try:
            _, err = first.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            # A run that did not stop must not go on beside the rest of the
            # suite (a lost full run held a core for the suite's remainder).
            first.kill()
            first.communicate()
            raise
    _ended_by_ctrl_c(first, err)
    assert not (out / ".lock").exists()
    assert json.loads((out / "run.json").read_text())["status"] == "interrupted"


def test_ctrl_c_while_the_models_are_counted_exits_130_and_unlocks(
    tmp_path, capsys, monkeypatch
):
    # Between locking the folder and the run's own Ctrl-C handler the models of
    # the zoo are counted; an interrupt there must not end in a traceback.
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(_one_step.OneStepSystem, "model_zoo", interrupted)
    out = tmp_path / "run"
    argv = ["run", "pendulum", "--quick", "--no-progress", "--out", str(out)]
    assert main(argv) == 130
    assert "interrupted before training" in capsys.readouterr().err
    assert not (out / ".lock").exists()


# -- a Ctrl-C during a fit, and a process that ignores Ctrl-C -----------------------


@pytest.fixture
def sigint_handler():
    """Set this process's SIGINT handler for one test, then put it back."""
    previous = signal.getsignal(signal.SIGINT)
    yield lambda handler: signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_during_a_fit_that_swallows_it_is_raised_after_the_fit(
    sigint_handler,
):
    sigint_handler(signal.default_int_handler)
    swallowed = []
    with pytest.raises(KeyboardInterrupt), interrupts_raise():
        try:  # as skorch's fit does
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            swallowed.append(True)
    assert swallowed == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_process_that_ignores_ctrl_c_ignores_it_during_fits_too(sigint_handler):
    # A background job of a script ignores SIGINT from its start; a fit must
    # not start obeying it (before the fits it is ignored all the same).
    sigint_handler(signal.SIG_IGN)
    with interrupts_raise():
        signal.raise_signal(signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN


def test_an_error_in_the_fit_passes_through_interrupts_raise(sigint_handler):
    sigint_handler(signal.default_int_handler)
    with pytest.raises(ValueError, match="bad fit"), interrupts_raise():
        raise ValueError("bad fit")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
