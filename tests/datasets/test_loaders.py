"""Tests of the loaders of measured benchmark data (skipped where it is absent)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from skhybrid.datasets import load_cascaded_tanks, load_emps, load_silverbox


def test_silverbox(shared_data_dir):
    data = load_silverbox(shared_data_dir)
    assert data.u.shape == data.y.shape == (131072, 1)
    lengths = {name: split.u.shape[0] for name, split in data.splits.items()}
    assert lengths == {
        "train": 65062,
        "test_multisine": 21688,
        "test_arrow_full": 40475,
        "test_arrow_no_extrapolation": 32000,
    }
    start, stop = data.split_indices["train"]
    assert_array_equal(data.splits["train"].y, data.y[start:stop])
    # Figures quoted in the data README: the arrow exceeds the training amplitude.
    assert_allclose(np.abs(data.splits["train"].y).max(), 0.2163, atol=1e-4)
    assert data.splits["test_arrow_full"].y.min() < -0.30
    assert data.n_init == 50
    assert_allclose(1 / data.dt, 610.35, atol=0.01)
    assert "Wigren" in data.DESCR
    # The subfolder itself works as well as its parent.
    again = load_silverbox(shared_data_dir / "silverbox")
    assert_array_equal(again.y, data.y)


def test_cascaded_tanks(shared_data_dir):
    data = load_cascaded_tanks(str(shared_data_dir))
    assert set(data.splits) == {"train", "test"}
    for split in data.splits.values():
        assert split.u.shape == split.y.shape == (1024, 1)
    assert data.dt == 4.0
    assert data.n_init == 50
    # The output clips at 10 V when the lower tank overflows.
    assert_allclose(max(s.y.max() for s in data.splits.values()), 10.0, atol=1e-6)
    assert "Schoukens" in data.DESCR


def test_emps(shared_data_dir):
    data = load_emps(shared_data_dir)
    for split in data.splits.values():
        assert split.u.shape == split.y.shape == split.t.shape == (24841, 1)
        assert split.reference.shape == (24841, 1)
    assert_allclose(data.controller["gtau"], 35.15, atol=0.01)
    assert data.n_init == 20 and data.dt == 1e-3
    assert "Janot" in data.DESCR


@pytest.mark.parametrize("loader", [load_silverbox, load_cascaded_tanks, load_emps])
def test_missing_folder_names_the_path(loader, tmp_path):
    with pytest.raises(FileNotFoundError, match="path="):
        loader(tmp_path)
    with pytest.raises(TypeError, match="path"):
        loader(42)


def test_splits_match_the_readme_indices(shared_data_dir):
    """Each split is the README's official slice of the raw .mat records."""
    from scipy.io import loadmat

    sb = loadmat(shared_data_dir / "silverbox" / "SNLS80mV.mat")
    u, y = sb["V1"][0], sb["V2"][0]
    data = load_silverbox(shared_data_dir)
    readme = {
        "train": (40650, 105712),
        "test_multisine": (105712, 127400),
        "test_arrow_full": (100, 40575),
        "test_arrow_no_extrapolation": (100, 32100),
    }
    assert data.split_indices == readme
    for name, (start, stop) in readme.items():
        assert_array_equal(data.splits[name].u[:, 0], u[start:stop])
        assert_array_equal(data.splits[name].y[:, 0], y[start:stop])
    # README: 54 arrow samples exceed the training range, the first at index 29049.
    train_max = np.abs(data.splits["train"].y).max()
    outside = np.flatnonzero(np.abs(data.splits["test_arrow_full"].y[:, 0]) > train_max)
    assert outside.size == 54 and outside.min() == 29049

    ct = loadmat(shared_data_dir / "cascaded_tanks" / "dataBenchmark.mat")
    tanks = load_cascaded_tanks(shared_data_dir)
    assert_array_equal(tanks.splits["train"].u, ct["uEst"])
    assert_array_equal(tanks.splits["test"].y, ct["yVal"])
    assert tanks.dt == float(ct["Ts"][0, 0]) == 4.0

    emps = load_emps(shared_data_dir)
    files = (("train", "DATA_EMPS.mat"), ("test", "DATA_EMPS_PULSES.mat"))
    for name, filename in files:
        mat = loadmat(shared_data_dir / "emps" / filename)
        assert_array_equal(emps.splits[name].u, mat["vir"])
        assert_array_equal(emps.splits[name].y, mat["qm"])
    # The stored time stamps are 1 ms apart, the nominal dt.
    assert_allclose(np.diff(emps.splits["train"].t[:, 0]).mean(), emps.dt, rtol=1e-3)
