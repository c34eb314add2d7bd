"""A corrupt measured file stops `skhybrid run` at the boundary: one line, exit 2."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat, savemat

from skhybrid.cli import main

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
pytestmark = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"the benchmark data folder {DATA} is absent"
)


def _copy_with(tmp_path, folder, filename, change):
    target = tmp_path / "data" / folder
    shutil.copytree(DATA / folder, target)
    if change == "truncate":
        path = target / filename
        path.write_bytes(path.read_bytes()[:200])
        return tmp_path / "data"
    variables = {
        k: v for k, v in loadmat(target / filename).items() if not k.startswith("__")
    }
    change(variables)
    savemat(target / filename, variables)
    return tmp_path / "data"


def _nan_at(name, index=5):
    def change(variables):
        array = np.array(variables[name], dtype=float)
        array.reshape(-1)[index] = np.nan
        variables[name] = array

    return change


CASES = {
    "tanks Ts=0": (
        "cascaded-tanks",
        "cascaded_tanks",
        "dataBenchmark.mat",
        lambda v: v.update(Ts=np.array([[0.0]])),
        "'Ts' must be a positive finite sample period",
    ),
    "tanks Ts<0": (
        "cascaded-tanks",
        "cascaded_tanks",
        "dataBenchmark.mat",
        lambda v: v.update(Ts=np.array([[-4.0]])),
        "'Ts' must be a positive finite sample period",
    ),
    "tanks NaN": (
        "cascaded-tanks",
        "cascaded_tanks",
        "dataBenchmark.mat",
        _nan_at("yVal"),
        "'yVal' must hold finite values",
    ),
    "emps truncated": (
        "emps",
        "emps",
        "DATA_EMPS_PULSES.mat",
        "truncate",
        "is not a readable MATLAB .mat file",
    ),
    "emps missing": (
        "emps",
        "emps",
        "DATA_EMPS.mat",
        lambda v: v.pop("qm"),
        "'qm' is missing",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_corrupt_file_is_one_line_and_exit_2_before_training(case, tmp_path, capsys):
    system, folder, filename, change, message = CASES[case]
    data = _copy_with(tmp_path, folder, filename, change)
    out = tmp_path / "out"
    argv = ["run", system, "--data", str(data), "--out", str(out), "--quick"]
    assert main([*argv, "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert message in err and filename in err
    # Nothing trained: no model and no report in the run folder.
    assert not list(out.rglob("*.joblib")) and not (out / "report.html").exists()


def test_bad_files_are_refused_before_the_folder_changes(tmp_path, capsys):
    data = _copy_with(
        tmp_path,
        "cascaded_tanks",
        "dataBenchmark.mat",
        lambda v: v.update(Ts=np.array([[0.0]])),
    )
    out = tmp_path / "out"
    argv = ["run", "cascaded-tanks", "--data", str(data), "--out", str(out)]
    assert main([*argv, "--quick", "--no-progress"]) == 2
    # The records are read before the run starts: nothing is written.
    assert "'Ts' must be a positive finite sample period" in capsys.readouterr().err
    assert not (out / "run.json").exists()
