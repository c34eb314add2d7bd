"""The Coupled Electric Drives and Wiener-Hammerstein loaders: splits and checks."""

from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat, savemat

from skhybrid.datasets import load_coupled_electric_drives, load_wiener_hammerstein

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
needs_data = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"the benchmark data folder {DATA} is absent"
)


@needs_data
def test_coupled_electric_drives_official_split():
    data = load_coupled_electric_drives(DATA)
    raw = loadmat(DATA / "coupled_electric_drives" / "DATAUNIF.MAT")
    assert data.n_init == 10 and data.dt == 0.02
    for i in (1, 2):
        np.testing.assert_array_equal(data.splits[f"train_{i}"].u, raw[f"u1{i}"][:400])
        np.testing.assert_array_equal(data.splits[f"test_{i}"].y, raw[f"z1{i}"][400:])
        assert data.splits[f"test_{i}"].y.shape == (100, 1)


@needs_data
def test_wiener_hammerstein_official_split():
    data = load_wiener_hammerstein(DATA)
    raw = loadmat(DATA / "wiener_hammerstein" / "WienerHammerBenchMark.mat")
    assert data.n_init == 50 and data.dt == pytest.approx(1 / 51200)
    np.testing.assert_array_equal(
        data.splits["train"].u, raw["uBenchMark"][5200:105200]
    )
    np.testing.assert_array_equal(
        data.splits["test"].y, raw["yBenchMark"][105200:184000]
    )


def _write(folder, name, variables):
    folder.mkdir(parents=True, exist_ok=True)
    savemat(folder / name, variables)


@pytest.mark.parametrize(
    "case, match",
    [
        ("missing", r"'z12' is missing"),
        ("nan", r"'u11' must hold finite values; got u11\[7\]=nan"),
        ("lengths", r"'z11' must have as many samples as the input 'u11'"),
        ("short", r"has 300 samples; a record needs at least"),
        ("truncated", r"is not a readable MATLAB \.mat file"),
    ],
)
def test_coupled_electric_drives_refuses_a_corrupt_file(case, match, tmp_path):
    rng = np.random.default_rng(0)
    n = 300 if case == "short" else 500
    v = {k: rng.normal(size=(n, 1)) for k in ("u11", "z11", "u12", "z12")}
    if case == "missing":
        del v["z12"]
    if case == "nan":
        v["u11"][7] = np.nan
    if case == "lengths":
        v["z11"] = v["z11"][:-3]
    _write(tmp_path, "DATAUNIF.MAT", v)
    if case == "truncated":
        path = tmp_path / "DATAUNIF.MAT"
        path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match=match) as info:
        load_coupled_electric_drives(tmp_path)
    assert "DATAUNIF.MAT" in str(info.value)


@pytest.mark.parametrize("fs", [0, -51200])
def test_wiener_hammerstein_refuses_a_sample_rate_that_is_not_positive(fs, tmp_path):
    n = 188000
    v = {"uBenchMark": np.zeros((n, 1)), "yBenchMark": np.zeros((n, 1))}
    v["fs"] = np.array([[fs]], dtype=float)
    _write(tmp_path / "wiener_hammerstein", "WienerHammerBenchMark.mat", v)
    with pytest.raises(ValueError, match=r"'fs' must be a positive finite sample rate"):
        load_wiener_hammerstein(tmp_path)


@pytest.mark.parametrize(
    "case, match",
    [
        ("missing", r"'yBenchMark' is missing"),
        ("nan", r"'uBenchMark' must hold finite values; got uBenchMark\[7\]=nan"),
        ("short", r"has 1000 samples; a record needs at least"),
        ("truncated", r"is not a readable MATLAB \.mat file"),
    ],
)
def test_wiener_hammerstein_refuses_a_corrupt_file(case, match, tmp_path):
    n = 1000 if case == "short" else 188000
    v = {"uBenchMark": np.zeros((n, 1)), "yBenchMark": np.zeros((n, 1))}
    v["fs"] = np.array([[51200.0]])
    if case == "missing":
        del v["yBenchMark"]
    if case == "nan":
        v["uBenchMark"][7] = np.nan
    folder = tmp_path / "wiener_hammerstein"
    _write(folder, "WienerHammerBenchMark.mat", v)
    if case == "truncated":
        path = folder / "WienerHammerBenchMark.mat"
        path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match=match) as info:
        load_wiener_hammerstein(tmp_path)
    assert "WienerHammerBenchMark.mat" in str(info.value)
