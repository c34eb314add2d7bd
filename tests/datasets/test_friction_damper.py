"""The friction damper with backlash: the loader's splits and its checks.

The real files are read where ``../shared/data`` is present; the checks run on
small stand-in files written into ``tmp_path`` (the same layout and columns), so
they run in every checkout.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from skhybrid.datasets import load_friction_damper

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
needs_data = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"the benchmark data folder {DATA} is absent"
)

TRAIN = [
    "0.5Hz30lbtension0.5amplitude",
    "0.5Hz30lbtension1.5amplitude",
    "0.5Hz30lbtension1amplitude",
    "1Hz30lbtension0.5amplitude",
    "1Hz30lbtension1.5amplitude",
    "1Hz30lbtension1amplitude",
    "2Hz30lbtension0.5amplitude",
]
TEST = ["ImperialValleyDBE", "KocaeliDBE"]
FILES = [
    *(f"characterization_datasets/{stem}.json" for stem in TRAIN),
    *(f"earthquake_profiles/{stem}.json" for stem in TEST),
]
SPLITS = [*(f"train_{s}" for s in TRAIN), *(f"test_{s}" for s in TEST)]


@needs_data
@pytest.mark.parametrize("where", ["parent", "folder"])
def test_the_real_files_load_into_one_split_per_file(where):
    folder = DATA / "friction_damper_backlash"
    data = load_friction_damper(DATA if where == "parent" else folder)
    assert list(data.splits) == SPLITS
    assert data.dt == 1 / 1024 and data.n_init == 50
    assert data.input_names == ["displacement [in]", "velocity [in/s]"]
    assert data.output_names == ["friction force [kip]"]
    assert data.license == "CC BY-SA 4.0"
    assert "Coble" in data.citation and "Downey" in data.citation
    assert "CC BY-SA 4.0" in data.DESCR
    lengths = {}
    for name, file in zip(SPLITS, FILES, strict=True):
        raw = np.asarray(json.loads((folder / file).read_text())["data"])
        split = data.splits[name]
        assert split.u.shape == (raw.shape[0], 2) and split.y.shape == (raw.shape[0], 1)
        assert split.u.dtype == np.float64 and split.y.dtype == np.float64
        np.testing.assert_array_equal(split.u, raw[:, [1, 3]])  # x, v
        np.testing.assert_array_equal(split.y, raw[:, [2]])  # F
        lengths[name] = raw.shape[0]
    assert lengths["test_KocaeliDBE"] == 27342
    assert lengths["test_ImperialValleyDBE"] == 28698
    assert lengths["train_2Hz30lbtension0.5amplitude"] == 3585


def _matrix(n=200, seed=0):
    """An N x 6 record: t at 1/1024 s, then columns with distinct scales."""
    rng = np.random.default_rng(seed)
    out = np.empty((n, 6))
    out[:, 0] = np.arange(n) / 1024
    for col in range(1, 6):
        out[:, col] = col * 10 + rng.normal(size=n)
    return out


def _write(root, matrices=None, skip=()):
    """The nine files under ``root``, each from ``matrices[name]`` or a stand-in."""
    matrices = matrices or {}
    for i, name in enumerate(FILES):
        if name in skip:
            continue
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        data = matrices.get(name, _matrix(seed=i))
        if isinstance(data, np.ndarray):
            data = data.tolist()
        path.write_text(json.dumps({"data": data, "dt": 1 / 1024}))
    return root


def test_stand_in_files_give_columns_x_v_as_inputs_and_f_as_output(tmp_path):
    kocaeli = _matrix(300, seed=5)
    _write(tmp_path / "friction_damper_backlash", {FILES[-1]: kocaeli})
    data = load_friction_damper(tmp_path)
    assert list(data.splits) == SPLITS  # train sorted by name, then tests
    split = data.splits["test_KocaeliDBE"]
    np.testing.assert_array_equal(split.u[:, 0], kocaeli[:, 1])
    np.testing.assert_array_equal(split.u[:, 1], kocaeli[:, 3])
    np.testing.assert_array_equal(split.y[:, 0], kocaeli[:, 2])
    assert data.splits["train_1Hz30lbtension1amplitude"].u.shape == (200, 2)


def test_a_missing_file_is_named_with_the_folder(tmp_path):
    missing = "earthquake_profiles/ImperialValleyDBE.json"
    _write(tmp_path, skip={missing})
    with pytest.raises(FileNotFoundError) as info:
        load_friction_damper(tmp_path)
    message = str(info.value)
    assert missing in message and str(tmp_path) in message
    assert "friction_damper_backlash/" in message


def test_a_path_that_is_not_a_path_is_refused():
    with pytest.raises(TypeError, match=r"path must be a str or pathlib\.Path"):
        load_friction_damper(3)


def _with(matrix, row, col, value):
    data = matrix.tolist()
    data[row][col] = value
    return data


BASE = _matrix()
UNEVEN = BASE.copy()
UNEVEN[120:, 0] += 0.5 / 1024  # a half-sample jump at 120


@pytest.mark.parametrize(
    "content, match",
    [
        ("{not json", r"is not a readable JSON file"),
        (json.dumps({"values": BASE.tolist()}), r'must hold an object with a "data"'),
        (json.dumps([1, 2]), r'must hold an object with a "data" matrix; got list'),
        ({"data": BASE[:, :5]}, r"N x 6 numeric matrix .*got shape \(200, 5\)"),
        ({"data": BASE[:, 0]}, r"N x 6 numeric matrix .*got shape \(200,\)"),
        ({"data": _with(BASE, 3, 2, "1.5")}, r"numeric matrix; got entries of type"),
        ({"data": _with(BASE, 3, 2, None)}, r"numeric matrix; got entries of type"),
        ({"data": [*BASE.tolist()[:-1], [0.0] * 5]}, r"got ragged rows"),
        ({"data": _with(BASE, 7, 2, float("nan"))}, r"data\[7\]\[2\]=nan"),
        ({"data": _with(BASE, 9, 3, float("inf"))}, r"data\[9\]\[3\]=inf"),
        ({"data": UNEVEN}, r"advance by dt = 1/1024 s .*t\[120\] - t\[119\]"),
        (
            {"data": _matrix() * [1024 / 1000, 1, 1, 1, 1, 1]},
            r"t\[1\] - t\[0\] = 0\.001 s",
        ),
        ({"data": _matrix(50)}, r"has 50 samples; a record needs at least .* 51"),
    ],
    ids=[
        "not-json",
        "no-data",
        "not-an-object",
        "five-columns",
        "a-vector",
        "a-string",
        "a-null",
        "ragged",
        "nan",
        "inf",
        "uneven-time",
        "another-dt",
        "too-short",
    ],
)
def test_a_corrupt_file_is_refused_and_named(content, match, tmp_path):
    name = "earthquake_profiles/KocaeliDBE.json"
    _write(tmp_path)
    if isinstance(content, dict):
        data = content["data"]
        content = json.dumps(
            {"data": data.tolist() if isinstance(data, np.ndarray) else data}
        )
    (tmp_path / name).write_text(content)
    with pytest.raises(ValueError, match=match) as info:
        load_friction_damper(tmp_path)
    assert str(info.value).startswith("load_friction_damper: ")
    assert "KocaeliDBE.json" in str(info.value)


def test_a_time_column_within_the_tolerance_is_accepted(tmp_path):
    jitter = BASE.copy()
    jitter[:, 0] *= 1 + 1e-8  # every step off by 1e-8 relative
    _write(tmp_path, {FILES[0]: jitter})
    data = load_friction_damper(tmp_path)
    assert data.splits[SPLITS[0]].y.shape == (200, 1)
