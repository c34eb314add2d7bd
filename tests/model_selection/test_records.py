"""Tests of RecordBlockSplit: blocked folds of records simulated in free run."""

import itertools

import numpy as np
import pytest

from skhybrid.model_selection import RecordBlockSplit, take_pieces


def _records(*lengths, n_cols=1):
    """Records whose values are their own (record, time) labels."""
    U = [
        np.column_stack([np.full(n, i), np.arange(n)])[:, : n_cols + 1]
        for i, n in enumerate(lengths)
    ]
    return U, [u[:, 1:].astype(float) for u in U]


def test_blocks_tile_each_record_and_fold_k_holds_out_block_k():
    U, Y = _records(100, 83)
    cv = RecordBlockSplit(n_splits=4, n_init=2)
    folds = list(cv.split(U, Y))
    assert len(folds) == cv.get_n_splits(U, Y) == 4
    for r, n in enumerate((100, 83)):
        blocks = [next(t for t in test if t[0] == r) for _, test in folds]
        # Consecutive, covering [0, n), nearly equal.
        assert blocks[0][1] == 0 and blocks[-1][2] == n
        assert all(a[2] == b[1] for a, b in itertools.pairwise(blocks))
        sizes = [b - a for _, a, b in blocks]
        assert max(sizes) - min(sizes) <= 1
    for fit, test in folds:
        for r in range(2):
            ((_, a, b),) = [t for t in test if t[0] == r]
            covered = sorted([(s, e) for i, s, e in fit if i == r] + [(a, b)])
            # Fit pieces and the held-out block tile the record without overlap.
            assert covered[0][0] == 0 and covered[-1][1] == (100, 83)[r]
            assert all(x[1] == y[0] for x, y in itertools.pairwise(covered))


def test_fit_pieces_never_cross_the_gap():
    U, Y = _records(120)
    for k, (fit, test) in enumerate(RecordBlockSplit(4, n_init=1).split(U, Y)):
        ((_, a, b),) = test
        u_fit, _y_fit = take_pieces(U, Y, fit)
        # Each piece is contiguous in time and lies wholly on one side of the gap.
        for u in u_fit:
            t = u[:, 1]
            assert np.all(np.diff(t) == 1)
            assert t[-1] < a or t[0] >= b
        # Interior folds give two separate pieces, the end folds one.
        assert len(fit) == (1 if k in (0, 3) else 2)


def test_held_out_block_starts_from_its_own_first_outputs():
    U, Y = _records(64, 80)
    cv = RecordBlockSplit(2, n_init=3)
    for _, test in cv.split(U, Y):
        _, y_test = take_pieces(U, Y, test)
        for (_r, a, _), y in zip(test, y_test, strict=True):
            # The initial window a free run gets is the block's own start.
            np.testing.assert_array_equal(y[:3].ravel(), [a, a + 1, a + 2])


def test_fewer_folds_for_short_records_with_the_reason():
    U, _ = _records(300, 70)
    cv = RecordBlockSplit(n_splits=5, n_init=4)  # blocks need 32 samples
    assert cv.get_n_splits() == 5
    assert cv.get_n_splits(U) == 2
    reason = cv.get_n_splits_reason(U)
    assert reason.startswith("2 folds of the 5 asked")
    assert "record 1 (70 samples)" in reason and "8 * n_init = 32" in reason
    assert len(list(cv.split(U))) == 2
    assert RecordBlockSplit(2, n_init=4).get_n_splits_reason(U) == "2 folds as asked."


def test_a_record_too_short_to_cut_is_fitted_whole_and_a_tiny_one_dropped():
    U, Y = _records(200, 20, 1)
    cv = RecordBlockSplit(4, n_init=2)
    assert cv.get_n_splits(U) == 4
    assert "Records [1, 2]" in cv.get_n_splits_reason(U)
    for fit, test in cv.split(U, Y):
        assert {r for r, _, _ in test} == {0}
        assert (1, 0, 20) in fit
        assert all(r != 2 for r, _, _ in fit)  # 1 sample < n_init + 1


def test_no_record_long_enough_raises():
    U, _ = _records(30, 20)
    with pytest.raises(ValueError, match="no record is long enough"):
        RecordBlockSplit(4, n_init=2).split(U)


@pytest.mark.parametrize(
    "params, name",
    [
        ({"n_splits": 1}, "n_splits"),
        ({"n_splits": 2.0}, "n_splits"),
        ({"n_init": 0}, "n_init"),
        ({"n_init": True}, "n_init"),
    ],
)
def test_bad_params_name_parameter_and_value(params, name):
    U, _ = _records(100)
    value = next(iter(params.values()))
    with pytest.raises(ValueError, match=f"'{name}' parameter.*Got {value!r}"):
        RecordBlockSplit(**params).split(U)


def test_misaligned_records_raise():
    with pytest.raises(ValueError, match="record 0 holds 10 input and 9 output"):
        RecordBlockSplit(2).split([np.zeros((10, 1))], [np.zeros((9, 1))])
    with pytest.raises(ValueError, match="U holds 2 records and Y 1"):
        RecordBlockSplit(2).split([np.zeros(10)] * 2, [np.zeros(10)])


def test_one_record_or_a_3d_array_is_accepted():
    cv = RecordBlockSplit(2, n_init=1)
    one = list(cv.split(np.zeros((40, 2))))
    stacked = list(cv.split(np.zeros((3, 40, 2))))
    assert one[0][1] == [(0, 0, 20)]
    assert [r for r, _, _ in stacked[0][1]] == [0, 1, 2]


def test_repr():
    assert (
        repr(RecordBlockSplit(3, n_init=5)) == "RecordBlockSplit(n_splits=3, n_init=5)"
    )
