"""WindowLayout: rows from sequences, split and join, shift, names."""

import numpy as np
import pytest
import torch

from skhybrid.preprocessing import WindowLayout, make_windows


@pytest.mark.parametrize("n_steps", [1, 3])
@pytest.mark.parametrize("n_inputs", [0, 2])
def test_rows_split_join_round_trip(n_steps, n_inputs):
    rng = np.random.default_rng(0)
    states, inputs = rng.normal(size=(20, 2)), rng.normal(size=(20, n_inputs))
    layout = WindowLayout(2, n_inputs, n_steps)
    X, y = layout.make_rows(states, inputs if n_inputs else None)
    X_ref, y_ref = make_windows(states, inputs if n_inputs else None, n_steps=n_steps)
    np.testing.assert_array_equal(X, X_ref)
    np.testing.assert_array_equal(y, y_ref)
    s, u = layout.split(X)
    assert s.shape == (len(X), n_steps, 2) and u.shape == (len(X), n_steps, n_inputs)
    np.testing.assert_array_equal(s[:, -1], layout.newest_states(X))
    np.testing.assert_array_equal(layout.join(s, u), X)


@pytest.mark.parametrize("n_inputs", [0, 1])
def test_shift_gives_the_next_row(n_inputs):
    # Shifting row i by the true next state and input gives row i + 1.
    rng = np.random.default_rng(1)
    states, inputs = rng.normal(size=(30, 2)), rng.normal(size=(30, n_inputs))
    layout = WindowLayout(2, n_inputs, 4)
    X, y = layout.make_rows(states, inputs if n_inputs else None)
    next_input = inputs[4 : 4 + len(X)] if n_inputs else None
    shifted = layout.shift(X, y, next_input)
    np.testing.assert_array_equal(shifted[:-1], X[1:])
    tX = torch.tensor(X, requires_grad=True)
    t_input = None if next_input is None else torch.as_tensor(next_input)
    t_shifted = layout.shift(tX, torch.as_tensor(y), t_input)
    np.testing.assert_array_equal(t_shifted.detach().numpy(), shifted)
    t_shifted.sum().backward()  # differentiable


def test_from_shapes_derives_the_missing_count():
    assert WindowLayout.from_shapes(12, 2, n_steps=3) == WindowLayout(2, 2, 3)
    assert WindowLayout.from_shapes(12, 2, n_inputs=2) == WindowLayout(2, 2, 3)
    with pytest.raises(ValueError, match="not a whole number of steps"):
        WindowLayout.from_shapes(10, 2, n_inputs=2)
    with pytest.raises(ValueError, match="fewer than the 3 states"):
        WindowLayout.from_shapes(4, 3, n_steps=2)


def test_feature_names_and_bad_values():
    layout = WindowLayout(1, 1, 2, state_names=["pos"], input_names=["volt"])
    assert layout.feature_names() == ["pos[t-1]", "volt[t-1]", "pos[t]", "volt[t]"]
    with pytest.raises(ValueError, match="n_states must be an integer >= 1"):
        WindowLayout(0)
    with pytest.raises(ValueError, match="state_names must hold 2 names"):
        WindowLayout(2, state_names=["a"])
    with pytest.raises(ValueError, match="must have 4 columns"):
        layout.split(np.zeros((3, 5)))


def test_horizon_starts_stay_inside_episodes():
    rng = np.random.default_rng(2)
    episodes = [rng.normal(size=(12, 2)), rng.normal(size=(9, 2))]
    inputs = [rng.normal(size=(12, 1)), rng.normal(size=(9, 1))]
    layout = WindowLayout(2, 1, 3)
    X, y, groups = layout.make_rows(episodes, inputs, return_groups=True)
    cont = layout.continues(X, y)
    np.testing.assert_array_equal(cont, groups[1:] == groups[:-1])
    starts = layout.horizon_starts(X, y, 4)
    assert len(starts) == (9 - 3) + (6 - 3)
    for i in starts:  # every start's horizon lies in one episode
        assert len(set(groups[i : i + 4])) == 1
    np.testing.assert_array_equal(layout.horizon_starts(X, y, 1), np.arange(len(X)))
    # Shuffled rows hold no sequence longer than one step.
    perm = rng.permutation(len(X))
    assert len(layout.horizon_starts(X[perm], y[perm], 2)) <= 1


# --------------------------------------------------------------------------------------
# arguments are validated as an estimator validates its data (issue 25)
# --------------------------------------------------------------------------------------
def _rows(n_inputs=1, n_steps=2, n=6):
    rng = np.random.default_rng(3)
    layout = WindowLayout(2, n_inputs, n_steps)
    states = rng.normal(size=(n + n_steps, 2))
    inputs = rng.normal(size=(n + n_steps, n_inputs)) if n_inputs else None
    return layout, *layout.make_rows(states, inputs)


@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_shift_rejects_wrong_widths(backend):
    layout, X, y = _rows()
    wrap = torch.as_tensor if backend == "torch" else np.asarray
    X, u = wrap(X), wrap(np.zeros((len(X), 1)))
    with pytest.raises(
        ValueError, match=r"next_state must have shape \(6, 2\).*\(6, 3\)"
    ):
        layout.shift(X, wrap(np.zeros((len(X), 3))), u)
    with pytest.raises(
        ValueError, match=r"next_state must have shape .*got shape \(5, 2\)"
    ):
        layout.shift(X, wrap(np.zeros((len(X) - 1, 2))), u)
    with pytest.raises(
        ValueError, match=r"next_input must have shape \(6, 1\).*\(6, 2\)"
    ):
        layout.shift(X, wrap(y), wrap(np.zeros((len(X), 2))))
    autonomous, X0, y0 = _rows(n_inputs=0)
    with pytest.raises(ValueError, match=r"next_input must have shape \(6, 0\)"):
        autonomous.shift(wrap(X0), wrap(y0), wrap(np.zeros((len(X0), 1))))
    # A width-0 input of an autonomous system is accepted.
    assert autonomous.shift(X0, y0, np.zeros((len(X0), 0))).shape == X0.shape


def test_continues_rejects_wrong_y_and_atol():
    layout, X, y = _rows()
    with pytest.raises(
        ValueError, match=r"y must have shape \(6, 2\).*got shape \(6, 1\)"
    ):
        layout.continues(X, y[:, :1])
    with pytest.raises(ValueError, match=r"y must have shape .*got shape \(6,\)"):
        layout.continues(X, y[:, 0])  # 1-D only for one state
    with pytest.raises(ValueError, match=r"y must have shape .*got shape \(5, 2\)"):
        layout.continues(X, y[:-1])
    for atol in (-1e-9, np.nan, np.inf, "0"):
        with pytest.raises(ValueError, match="atol must be a finite number >= 0"):
            layout.continues(X, y, atol=atol)
    one = WindowLayout(1)
    X1, y1 = one.make_rows(np.arange(5.0))
    np.testing.assert_array_equal(one.continues(X1, y1.ravel()), [True] * 3)


def test_horizon_starts_on_small_inputs():
    layout = WindowLayout(1)
    X, y = np.zeros((1, 1)), np.zeros((1, 1))
    for horizon in (1, 2, 3):
        starts = layout.horizon_starts(X, y, horizon)
        assert starts.tolist() == ([0] if horizon == 1 else [])
    for horizon in (1, 3):
        starts = layout.horizon_starts(np.zeros((0, 1)), np.zeros((0, 1)), horizon)
        assert starts.tolist() == [] and starts.dtype.kind == "i"
    X, y = layout.make_rows(np.arange(4.0))  # 3 rows, one sequence
    assert layout.horizon_starts(X, y, 3).tolist() == [0]
    assert layout.horizon_starts(X, y, 4).tolist() == []
    with pytest.raises(ValueError, match="horizon must be an integer >= 1"):
        layout.horizon_starts(X, y, 0)


@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_join_names_the_argument(backend):
    layout, X, _ = _rows()
    wrap = torch.as_tensor if backend == "torch" else np.asarray
    s, u = layout.split(X)
    s, u = wrap(np.ascontiguousarray(s)), wrap(np.ascontiguousarray(u))
    with pytest.raises(ValueError, match=r"states must have shape \(n_samples, 2, 2\)"):
        layout.join(s[:, :, :1], u)
    with pytest.raises(
        ValueError, match=r"states must have shape .*got shape \(6, 4\)"
    ):
        layout.join(s.reshape(6, 4), u)
    with pytest.raises(
        ValueError, match=r"inputs must have shape \(6, 2, 1\).*\(6, 1, 1\)"
    ):
        layout.join(s, u[:, :1])
    with pytest.raises(ValueError, match=r"inputs must have shape .*\(5, 2, 1\)"):
        layout.join(s, u[:5])
    with pytest.raises(ValueError, match="inputs is needed"):
        layout.join(s, None)
    np.testing.assert_array_equal(np.asarray(layout.join(s, u)), X)


def test_names_must_be_a_sequence_of_unique_names():
    with pytest.raises(ValueError, match=r"state_names must be a sequence .*'ab'"):
        WindowLayout(2, state_names="ab")
    with pytest.raises(ValueError, match="input_names must be a sequence"):
        WindowLayout(1, 1, input_names="u")
    with pytest.raises(ValueError, match="state_names repeats the name 'a'"):
        WindowLayout(2, state_names=["a", "a"])
    with pytest.raises(
        ValueError, match=r"input_names repeats the name 'x'.*state_names"
    ):
        WindowLayout(1, 1, state_names=["x"], input_names=["x"])
    assert WindowLayout(2, state_names=("a", "b")).state_names == ("a", "b")


@pytest.mark.parametrize("n_steps", [1, 2, 3, 4])
@pytest.mark.parametrize("n_inputs", [0, 1, 2])
def test_infer_n_steps_reads_the_window_length_from_ordered_rows(n_steps, n_inputs):
    from skhybrid.preprocessing import infer_n_steps

    rng = np.random.default_rng(n_steps + 10 * n_inputs)
    episodes = [rng.normal(size=(40, 2)), rng.normal(size=(30, 2))]
    inputs = [rng.normal(size=(40, n_inputs)), rng.normal(size=(30, n_inputs))]
    X, y = make_windows(episodes, inputs if n_inputs else None, n_steps=n_steps)
    assert infer_n_steps(X, y) == n_steps
    # Shuffled rows, too few rows and a constant state do not tell.
    perm = rng.permutation(len(X))
    assert infer_n_steps(X[perm], y[perm]) is None
    assert infer_n_steps(X[:2], y[:2]) is None
    # A state that does not change continues under every length that fits.
    flat, flat_y = make_windows(np.zeros((20, 2)), n_steps=max(n_steps, 2))
    assert infer_n_steps(flat, flat_y) is None


def test_layout_methods_name_rows_that_are_not_an_array():
    # split([[0.0] * 9]) was an AttributeError ('list' has no attribute 'ndim').
    layout = WindowLayout(n_states=1, n_inputs=2, n_steps=3)
    for method in (layout.split, layout.newest_states, layout.check):
        with pytest.raises(TypeError, match=r"X must be a NumPy array or a torch"):
            method([[0.0] * 9])
    with pytest.raises(TypeError, match="states must be a NumPy array"):
        layout.join([[[0.0]] * 3])


def test_shift_refuses_a_state_and_inputs_in_another_namespace():
    torch = pytest.importorskip("torch")
    layout = WindowLayout(n_states=1, n_inputs=1, n_steps=2)
    X = torch.zeros((2, 4))
    # A torch state with NumPy inputs returned NumPy silently, cutting the
    # gradient of a differentiable step.
    with pytest.raises(
        TypeError, match="next_input is a NumPy array but X a torch tensor"
    ):
        layout.shift(X, torch.ones((2, 1)), np.ones((2, 1)))
    with pytest.raises(TypeError, match="next_state is a list but X a torch tensor"):
        layout.shift(X, [[1.0], [1.0]], torch.ones((2, 1)))
    with pytest.raises(TypeError, match="next_state is a torch tensor but X a NumPy"):
        layout.shift(np.zeros((2, 4)), torch.ones((2, 1)), np.ones((2, 1)))
    out = layout.shift(X, torch.ones((2, 1)), torch.full((2, 1), 2.0))
    assert torch.equal(out[0], torch.tensor([0.0, 0.0, 1.0, 2.0]))
