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
