"""Corrupt measured data is refused at the loader with one clear ValueError.

Each case writes a corrupted copy of a benchmark file into ``tmp_path`` and asserts
that the loader raises one ValueError naming the file, the variable and the value
(issue 25). The copies start from the real files where the shared data is present,
and otherwise from small stand-ins with the same variables, so the checks run in
every checkout.
"""

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat, savemat

from skhybrid.datasets import load_cascaded_tanks, load_emps, load_silverbox

DATA_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data"


def _stand_in(subfolder, filename):
    """Variables shaped as in the real file (small, except Silverbox's length)."""
    rng = np.random.default_rng(0)
    if subfolder == "cascaded_tanks":
        n = 200
        out = {k: rng.uniform(1, 9, size=(n, 1)) for k in ("uEst", "yEst", "uVal")}
        out["yVal"] = rng.uniform(1, 9, size=(n, 1))
        out["Ts"] = np.array([[4]], dtype=np.uint8)
        return out
    if subfolder == "emps":
        n = 300
        out = {k: rng.normal(size=(n, 1)) for k in ("vir", "qm", "qg")}
        out["t"] = (np.arange(n) * 1e-3)[:, None]
        out.update(gtau=np.array([[35.15]]), kp=np.array([[160.18]]))
        out["kv"] = np.array([[243.45]])
        return out
    n = 131072
    return {"V1": rng.normal(size=(1, n)), "V2": rng.normal(size=(1, n))}


def _variables(subfolder, filename):
    real = DATA_DIR / subfolder / filename
    if real.is_file():
        return {k: v for k, v in loadmat(real).items() if not k.startswith("__")}
    return _stand_in(subfolder, filename)


# loader, subfolder, file corrupted, files needed, output, input, sample period
LOADERS = {
    "tanks": (
        load_cascaded_tanks,
        "cascaded_tanks",
        "dataBenchmark.mat",
        ["dataBenchmark.mat"],
        "yVal",
        "uVal",
    ),
    "emps": (
        load_emps,
        "emps",
        "DATA_EMPS_PULSES.mat",
        ["DATA_EMPS.mat", "DATA_EMPS_PULSES.mat"],
        "qm",
        "vir",
    ),
    "silverbox": (
        load_silverbox,
        "silverbox",
        "SNLS80mV.mat",
        ["SNLS80mV.mat"],
        "V2",
        "V1",
    ),
}


def _set(variables, name, index, value):
    array = np.array(variables[name], dtype=float)
    array.reshape(-1)[index] = value
    variables[name] = array


def _shorten(variables, names, n):
    for name in names:
        array = np.asarray(variables[name])
        variables[name] = array.reshape(-1)[:n].reshape(
            (1, -1) if array.shape[0] == 1 else (-1, 1)
        )


def _sample_period(kind, value):
    """Corrupt the sample period: Ts itself, or EMPS's time stamps' step."""

    def corrupt(variables, system):
        if system == "tanks":
            variables["Ts"] = np.array([[value]], dtype=float)
        else:  # EMPS stores the time stamps; one step of `value` seconds
            t = np.array(variables["t"], dtype=float)
            t[11] = t[10] + value
            variables["t"] = t

    return corrupt


def _corruptions(system):
    _, _, _, _, output, inputs = LOADERS[system]
    if system == "tanks":
        record, n_init = ["uVal", "yVal"], 50
    elif system == "emps":
        record, n_init = ["vir", "qm", "t", "qg"], 20
    else:
        record, n_init = ["V1", "V2"], 50
    cases = {
        "truncated": ("bytes", 0.5, "not a readable MATLAB .mat file"),
        "empty": ("bytes", 0.0, "not a readable MATLAB .mat file"),
        "random bytes": ("random", None, "not a readable MATLAB .mat file"),
        "missing variable": (
            lambda v, s: v.pop(output),
            None,
            f"variable '{output}' is missing",
        ),
        "NaN": (
            lambda v, s: _set(v, output, 7, np.nan),
            None,
            rf"variable '{output}' must hold finite values; got {output}\[7\]=nan",
        ),
        "inf in the input": (
            lambda v, s: _set(v, inputs, 3, np.inf),
            None,
            rf"variable '{inputs}' must hold finite values; got {inputs}\[3\]=inf",
        ),
        "unequal lengths": (
            lambda v, s: _shorten(v, [output], 40 + n_init),
            None,
            f"variable '{output}' must have as many samples as the input",
        ),
        "too short": (
            lambda v, s: _shorten(v, record, n_init - 5),
            None,
            f"has {n_init - 5} samples; .*at least",
        ),
    }
    if system == "tanks":
        cases["zero sample period"] = (
            _sample_period("tanks", 0.0),
            None,
            "variable 'Ts' must be a positive finite sample period.*got Ts=0.0",
        )
        cases["negative sample period"] = (
            _sample_period("tanks", -4.0),
            None,
            "variable 'Ts' must be a positive finite sample period.*got Ts=-4.0",
        )
    if system == "emps":
        cases["zero sample period"] = (
            _sample_period("emps", 0.0),
            None,
            r"variable 't' must increase.*got t\[11\] - t\[10\] = 0 s",
        )
        cases["negative sample period"] = (
            _sample_period("emps", -1e-3),
            None,
            r"variable 't' must increase.*got t\[11\] - t\[10\] = -0.001 s",
        )
    return cases


CASES = [
    pytest.param(system, case, id=f"{system}-{case}")
    for system in LOADERS
    for case in _corruptions(system)
]


@pytest.mark.parametrize("system, case", CASES)
def test_corrupt_file_raises_one_error_naming_it(system, case, tmp_path):
    loader, subfolder, target, needed, _, _ = LOADERS[system]
    corrupt, fraction, message = _corruptions(system)[case]
    folder = tmp_path / subfolder
    folder.mkdir()
    for filename in needed:
        savemat(folder / filename, _variables(subfolder, filename))
    path = folder / target
    if corrupt == "bytes":
        data = path.read_bytes()
        path.write_bytes(data[: int(len(data) * fraction)])
    elif corrupt == "random":
        path.write_bytes(np.random.default_rng(0).bytes(5000))
    else:
        variables = _variables(subfolder, target)
        corrupt(variables, system)
        savemat(path, variables)
    with pytest.raises(ValueError) as info:
        loader(tmp_path)
    text = str(info.value)
    assert "\n" not in text, "the error is one line"
    assert str(path) in text, "the error names the file"
    assert loader.__name__ in text
    assert re.search(message, text), text


@pytest.mark.parametrize("system", list(LOADERS))
def test_clean_copies_load(system, tmp_path):
    """The copies the corruptions start from load (so each failure is the fault's)."""
    loader, subfolder, _, needed, _, _ = LOADERS[system]
    folder = tmp_path / subfolder
    folder.mkdir()
    for filename in needed:
        savemat(folder / filename, _variables(subfolder, filename))
    data = loader(tmp_path)
    assert data.dt > 0
    for split in data.splits.values():
        assert split.u.shape == split.y.shape
        assert split.u.shape[0] > data.n_init
