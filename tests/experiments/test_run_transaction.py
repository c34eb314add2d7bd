"""The run folder as a transaction, models that load anywhere, a reproducible seal.

- A physics written in the script that ran (``__main__``) is stored by value:
  every stored model loads and simulates in a new session.
- Every refusal comes before anything in the folder changes; ``overwrite`` moves
  the old run aside and deletes it once the new run has started; ``run.json``
  ends complete, interrupted or failed from Python as from the command line.
- Every stored file has its SHA-256 in the folder, checked on load and on
  resume; a damaged file is named with the fix.
- The seal (``selection.json``) names callables, never their memory address: the
  same run has the same SHA-256 in two fresh processes.
- ``run_system``'s arguments are checked as the command line checks its own.
"""

import json
import os
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import skhybrid.domain
import skhybrid.hybrid
import skhybrid.model_selection
from skhybrid.domain import StateSpaceModel
from skhybrid.exceptions import RefusedTestRecordsError
from skhybrid.experiments import SystemSpec, load_fitted, run_system
from skhybrid.experiments.run._store import RunFolderError


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


def make_spec(**kwargs):
    options = dict(
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
    options.update(kwargs)
    return SystemSpec(**options)


def _files(folder):
    """Every file of a folder with its bytes (what a refusal must not change)."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != ".lock"
    }


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished tiny run (one seed); tests copy it before changing it."""
    out = tmp_path_factory.mktemp("finished") / "run"
    run_system(make_spec(), out, quick=True, seeds=[0], n_jobs=1)
    return out


@pytest.fixture
def run(finished, tmp_path):
    out = tmp_path / "run"
    shutil.copytree(finished, out)
    return out


# -- a physics written in the script that ran -------------------------------------
SCRIPT = textwrap.dedent(
    """
    import sys

    import numpy as np

    from skhybrid.domain import StateSpaceModel
    from skhybrid.experiments import SystemSpec, run_system


    def linear_msd(x, u, *, xp, a, b):
        return a * x + b * u


    def half_inputs(u):
        return 0.5 * u


    def record(n, seed):
        rng = np.random.default_rng(seed)
        u = np.repeat(rng.uniform(-1, 1, n // 10 + 1), 10)[:n]
        y, x = np.empty(n), 0.0
        for t in range(n):
            y[t] = x
            x = 0.8 * x + 0.5 * u[t] - 0.05 * x**3
        return u[:, None], (y + 0.001 * rng.standard_normal(n))[:, None]


    if __name__ == "__main__":
        spec = SystemSpec(
            "main-machine",
            records=[record(300, 0), record(240, 1)],
            physics=StateSpaceModel(
                linear_msd, {"a": 0.5, "b": 2.0}, state_names=["y"],
                observed=["y"], time="discrete",
            ),
            physics_inputs=half_inputs,
            n_init=5,
            dt=0.1,
            tests={"test": record(200, 2)},
            hybrids=None,
        )
        summary = run_system(spec, sys.argv[1], quick=True, seeds=0)  # two jobs
        print(summary["selection_sha256"])
    """
)

LOAD = textwrap.dedent(
    """
    import json
    import sys

    import numpy as np

    from skhybrid.experiments import load_fitted
    from skhybrid.experiments.run._store import RunFolder

    out, u, y = sys.argv[1], *np.load(sys.argv[2]).values()
    folder = RunFolder(out)
    rmse, types = {}, {}
    for name in folder.finished("main-machine-seed-0"):
        model = load_fitted(out, seed=0, model=name)
        types[name] = type(model).__name__
        pred = np.ravel(model.simulate(u, y[:5]))
        rmse[name] = float(np.sqrt(np.mean((pred[5:] - y[5:, 0]) ** 2)))
    chosen = load_fitted(out, seed=0)
    print(json.dumps({"rmse": rmse, "types": types, "chosen": type(chosen).__name__}))
    """
)


def _python(*args, cwd):
    # One thread per process: torch's threads fight over the test machine's cores.
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, *map(str, args)],
        check=False,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.strip().splitlines()[-1]


def test_a_physics_defined_in_main_loads_in_a_new_session_and_the_seal_repeats(
    tmp_path,
):
    (tmp_path / "machine.py").write_text(SCRIPT)
    (tmp_path / "load.py").write_text(LOAD)
    # The same run in two fresh processes: the same seal.
    first = _python("machine.py", "run1", cwd=tmp_path)
    second = _python("machine.py", "run2", cwd=tmp_path)
    assert first == second
    selection = (tmp_path / "run1" / "selection.json").read_text()
    assert "0x" not in selection
    assert "__main__.linear_msd" in selection and "__main__.half_inputs" in selection
    # Each seed's settings in the seal: what its choices depend on, and no
    # more (a measured run has no noise type), so the hash of the choices of
    # a sealed benchmark repeats from one release of the settings to the next.
    for seed in json.loads(selection)["selection"]["seeds"]:
        assert seed["settings"] == {
            "quick": seed["settings"]["quick"],
            "seed": seed["seed"],
        }
    # A new session, which has no linear_msd: every stored model loads and runs.
    sys.path.insert(0, str(tmp_path))
    try:
        u, y = record(200, 2)
    finally:
        sys.path.pop(0)
    np.savez(tmp_path / "test.npz", u=u, y=y)
    loaded = json.loads(_python("load.py", "run1", "test.npz", cwd=tmp_path))
    summary = json.loads((tmp_path / "run1" / "results.json").read_text())
    by_model = summary["systems"]["main-machine"]["test_rmse"]["test"]
    assert set(loaded["rmse"]) == set(by_model)
    for name, rmse in loaded["rmse"].items():
        expected = by_model[name]["mean"]
        if expected is not None:
            assert rmse == pytest.approx(expected, rel=1e-6), name
    # A spec with physics_inputs: every model loads as a public estimator (the
    # physics and its corrections' physics in a TransformedInputSimulator, the
    # stack a StackedSimulation of them).
    public = (
        set(skhybrid.domain.__all__)
        | set(skhybrid.hybrid.__all__)
        | set(skhybrid.model_selection.__all__)
    )
    assert set(loaded["types"].values()) <= public, loaded["types"]
    assert loaded["types"]["physics"] == "TransformedInputSimulator"


def test_the_seal_names_callables_by_module_and_qualname():
    from skhybrid.experiments._describe import canonical as _canonical
    from skhybrid.experiments.free_run._seal import describe_spec

    spec = make_spec(physics_inputs=np.negative)
    U, Y = spec.estimation_records()
    text = _canonical(describe_spec(spec, U, Y))
    assert "0x" not in text
    assert f"{__name__}.first_order" in text and "numpy.negative" in text


# -- refusals change nothing ------------------------------------------------------
def test_overwrite_refused_by_bad_records_keeps_the_finished_run(run, tmp_path):
    before = _files(run)
    u, y = record(300, 0)
    y = y.copy()
    y[10] = np.nan
    bad = make_spec(records=lambda: [(u, y)])
    with pytest.raises(ValueError, match=r"records\[0\] holds NaN"):
        run_system(bad, run, quick=True, seeds=[0], overwrite=True, n_jobs=1)
    assert _files(run) == before


def test_overwrite_through_the_cli_refused_by_bad_records_keeps_the_run(
    run, tmp_path, monkeypatch, capsys
):
    from skhybrid.cli import main

    (tmp_path / "nan_machine.py").write_text(
        "import numpy as np\n"
        f"from {__name__} import make_spec, record\n"
        "def records():\n"
        "    u, y = record(300, 0)\n"
        "    return [(u, np.where(np.arange(300)[:, None] == 9, np.nan, y))]\n"
        "spec = make_spec(records=records)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    before = _files(run)
    argv = ["run", "--system", "nan_machine:spec", "--out", str(run), "--quick"]
    assert main([*argv, "--seeds", "0", "--overwrite"]) == 2
    assert "holds NaN" in capsys.readouterr().err
    assert _files(run) == before


def test_a_refused_resume_leaves_run_json_as_it_was(run):
    before = _files(run)
    changed = make_spec(records=[record(300, 5), record(240, 6)])
    with pytest.raises(RunFolderError, match="fitted on other records"):
        run_system(changed, run, quick=True, seeds=[0], resume=True, n_jobs=1)
    assert _files(run) == before
    # The finished run is still guarded.
    with pytest.raises(RunFolderError, match="already holds a finished run"):
        run_system(make_spec(), run, quick=True, seeds=[0], n_jobs=1)


def test_overwrite_moves_the_old_run_aside_until_the_new_one_started(run, monkeypatch):
    from skhybrid.experiments.run import _plan as _run_plan
    from skhybrid.experiments.run._store import RunFolder

    seen = {}
    discard = RunFolder.discard_replaced

    def watch(self):
        aside = self.path / ".replaced"
        seen["aside"] = sorted(p.name for p in aside.iterdir())
        seen["run.json"] = json.loads((self.path / "run.json").read_text())
        discard(self)

    def stop(*args, **kwargs):
        seen["models"] = (run / "models").exists()
        raise KeyboardInterrupt

    monkeypatch.setattr(RunFolder, "discard_replaced", watch)
    monkeypatch.setattr(_run_plan, "run_seeds", stop)
    with pytest.raises(KeyboardInterrupt):
        run_system(make_spec(), run, quick=True, seeds=[0], overwrite=True, n_jobs=1)
    assert {"models", "run.json", "selection.json", "results.json"} <= set(
        seen["aside"]
    )
    assert seen["run.json"]["status"] == "running"
    assert not seen["models"]
    assert not (run / ".replaced").exists()
    manifest = json.loads((run / "run.json").read_text())
    assert manifest["status"] == "interrupted"


def test_run_json_ends_failed_after_an_error_in_python(tmp_path, monkeypatch):
    from skhybrid.experiments.run import _plan as _run_plan

    def fail(*args, **kwargs):
        raise RuntimeError("a fit broke")

    monkeypatch.setattr(_run_plan, "run_seeds", fail)
    with pytest.raises(RuntimeError, match="a fit broke"):
        run_system(make_spec(), tmp_path / "run", quick=True, seeds=[0], n_jobs=1)
    manifest = json.loads((tmp_path / "run" / "run.json").read_text())
    assert manifest["status"] == "failed"
    assert manifest["reason"] == "RuntimeError: a fit broke"
    assert not (tmp_path / "run" / ".lock").exists()


def test_a_bad_callable_test_record_is_named_and_the_run_marked_failed(tmp_path):
    u, y = record(200, 2)
    spec = make_spec(tests=lambda: {"test": (np.hstack([u, u]), y)})
    with pytest.raises(RefusedTestRecordsError, match=r"tests\['test'\] has inputs"):
        run_system(spec, tmp_path / "run", quick=True, seeds=[0], n_jobs=1)
    manifest = json.loads((tmp_path / "run" / "run.json").read_text())
    assert manifest["status"] == "failed"


def test_a_nan_test_record_found_after_sealing_is_one_line_and_resume_scores(
    tmp_path, monkeypatch, capsys
):
    from skhybrid.cli import main

    # The test record is read from a file only once the selection is sealed.
    (tmp_path / "late_machine.py").write_text(
        "import numpy as np\n"
        f"from {__name__} import make_spec\n"
        "def tests():\n"
        "    data = np.load('test-record.npz')\n"
        "    return {'test': (data['u'], data['y'])}\n"
        "spec = make_spec(tests=tests)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    u, y = record(200, 2)
    bad = y.copy()
    bad[7] = np.nan
    np.savez(tmp_path / "test-record.npz", u=u, y=bad)
    out = tmp_path / "run"
    argv = ["run", "--system", "late_machine:spec", "--out", str(out), "--quick"]
    argv += ["--seeds", "0", "--n-jobs", "1", "--no-progress"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "tests['test'] holds NaN" in lines[0]  # the record, not tests['test'][0]
    assert "selection.json" in lines[0] and "--resume" in lines[0]
    manifest = json.loads((out / "run.json").read_text())
    assert manifest["status"] == "failed"
    sealed = (out / "selection.json").read_text()
    # Fixed, the resumed run scores the same sealed selection: nothing refitted.
    np.savez(tmp_path / "test-record.npz", u=u, y=y)
    assert main([*argv, "--resume"]) == 0
    assert (out / "selection.json").read_text() == sealed
    summary = json.loads((out / "results.json").read_text())
    chosen = summary["systems"]["tiny"]["chosen_test_rmse"]["test"]["mean"]
    assert np.isfinite(chosen)


# -- checksums ----------------------------------------------------------------------
def test_every_stored_file_has_its_checksum(finished):
    import hashlib

    records = list((finished / "models" / "tiny-seed-0").glob("*.json"))
    assert records
    for path in records:
        record = json.loads(path.read_text())
        names = {record["predictions"], record.get("estimator")}
        names |= set((record.get("extras") or {}).values())
        assert set(record["sha256"]) == names - {None}
        for name, digest in record["sha256"].items():
            data = (path.parent / name).read_bytes()
            assert hashlib.sha256(data).hexdigest() == digest


def test_a_damaged_model_is_named_on_load_and_on_resume(run):
    path = run / "models" / "tiny-seed-0" / "physics.joblib"
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(RunFolderError) as info:
        load_fitted(run, model="physics")
    message = str(info.value)
    assert str(path) in message and "is damaged" in message
    assert "--overwrite" in message
    before = _files(run)
    with pytest.raises(RunFolderError, match=r"physics\.joblib is damaged"):
        run_system(make_spec(), run, quick=True, seeds=[0], resume=True, n_jobs=1)
    assert _files(run) == before
    path.unlink()
    with pytest.raises(RunFolderError, match=r"physics\.joblib is missing"):
        load_fitted(run, model="physics")


# -- run_system's arguments -------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"seeds": [2**40]}, ValueError, "between 0 and 2**32 - 1"),
        ({"seeds": []}, ValueError, "non-empty sequence"),
        ({"seeds": "0"}, ValueError, "got seeds='0'"),
        ({"seeds": [-1]}, ValueError, "got seeds=[-1]"),
        ({"n_jobs": 0}, ValueError, "n_jobs must be an int >= 1, or -1"),
        ({"n_jobs": -2}, ValueError, "got n_jobs=-2"),
        ({"n_jobs": 1.5}, TypeError, "got n_jobs=1.5"),
        ({"n_jobs": "a"}, TypeError, "got n_jobs='a'"),
        ({"n_jobs": True}, TypeError, "got n_jobs=True"),
        ({"overwrite": True, "resume": True}, ValueError, "not both"),
    ],
)
def test_bad_arguments_are_refused_before_the_folder(tmp_path, kwargs, error, words):
    import re

    with pytest.raises(error, match=re.escape(words)):
        run_system(make_spec(), tmp_path / "run", quick=True, **kwargs)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(("seeds", "expected"), [(0, [0]), (3, [3]), (None, [0, 1, 2])])
def test_an_int_is_one_seed_and_none_the_default_seeds(
    tmp_path, monkeypatch, seeds, expected
):
    from skhybrid.experiments.run import _run_system

    seen = {}

    def capture(plan, command, out, **kwargs):
        seen["seeds"] = plan.seeds

    monkeypatch.setattr(_run_system, "_run_folder", capture)
    run_system(make_spec(), tmp_path / "run", seeds=seeds, n_jobs=1)
    assert seen["seeds"] == expected
