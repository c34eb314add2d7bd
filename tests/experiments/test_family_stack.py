"""The measured family's stack: weights from the other folds, chosen like a model."""

from types import SimpleNamespace

import numpy as np
import pytest
from sklearn.base import BaseEstimator

from skhybrid.experiments.free_run._family import N_SPLITS, MeasuredContext, zoo
from skhybrid.experiments.free_run._stack import STACK, averaged_run, choose_stack
from skhybrid.model_selection import RecordBlockSplit, StackedSimulation, take_pieces
from skhybrid.model_selection._stacking import _simplex_weights

N_INIT = 5


class Offset(BaseEstimator):
    """Simulates the measured record plus a constant (a fitted model stand-in)."""

    def __init__(self, offset=0.0, y=None):
        self.offset = offset
        self.y = y

    def simulate(self, inputs, initial):
        return self.y[: len(inputs)] + self.offset


def _records():
    rng = np.random.default_rng(0)
    U = [rng.normal(size=(240, 1)), rng.normal(size=(200, 1))]
    Y = [np.cumsum(u, axis=0) * 0.1 for u in U]
    return U, Y


def _targets(U, Y):
    out = []
    for _, test in RecordBlockSplit(N_SPLITS, n_init=N_INIT).split(U, Y):
        _, Y_test = take_pieces(U, Y, test)
        out.append(np.concatenate([y[N_INIT:].ravel() for y in Y_test]))
    return out


def _context(U, Y, searched=None, scale=1.0):
    system = SimpleNamespace(scale=scale)
    return MeasuredContext(
        system, U, Y, N_INIT, 1.0, quick=True, seed=0, searched=searched
    )


def _dep(runs, deterministic=True, offset=0.0):
    return {
        "model": Offset(offset),
        "fit": {"selection": {"deterministic": deterministic}},
        "runs": runs,
    }


def _members(targets, seed=1):
    """Three models' out-of-fold runs: noisy copies of the targets."""
    rng = np.random.default_rng(seed)
    return {
        name: [t + scale * rng.normal(size=t.shape) for t in targets]
        for name, scale in (("a", 0.05), ("b", 0.1), ("c", 0.3))
    }


def _model():
    return SimpleNamespace(requires=("a", "b", "c"))


def test_each_fold_is_scored_with_weights_fitted_on_the_other_folds():
    U, Y = _records()
    targets = _targets(U, Y)
    runs = _members(targets)
    deps = {name: _dep(r) for name, r in runs.items()}
    fitted, selection, stack_runs = choose_stack(
        _model(), _context(U, Y, scale=1000.0), deps, n_splits=N_SPLITS
    )
    names = ["a", "b", "c"]
    assert selection["members"] == names
    assert selection["cv_folds"] == len(targets) == N_SPLITS
    for k, target in enumerate(targets):
        others = [j for j in range(len(targets)) if j != k]
        P = np.column_stack(
            [np.concatenate([runs[m][j] for j in others]) for m in names]
        )
        t = np.concatenate([targets[j] for j in others])
        w = _simplex_weights(P, t)
        assert [selection["fold_weights"][k][m] for m in names] == pytest.approx(w)
        run = np.column_stack([runs[m][k] for m in names]) @ w
        np.testing.assert_allclose(stack_runs[k], run)
        # The CV figure is in official units (the system's scale).
        rmse = 1000.0 * np.sqrt(np.mean((run - target) ** 2))
        assert selection["cv_rmse_chosen_by_fold"][k] == pytest.approx(rmse)
    assert selection["validation_rmse"] == pytest.approx(
        np.mean(selection["cv_rmse_chosen_by_fold"])
    )
    weights = np.array([selection["weights"][m] for m in names])
    assert np.all(weights >= 0) and weights.sum() == pytest.approx(1.0)
    # The refitted stack averages the fitted models with the weights of every fold.
    assert isinstance(fitted, StackedSimulation)
    kept = [m for m in names if selection["weights"][m] > 0]
    assert list(fitted.named_estimators_) == kept
    assert fitted.weights_.sum() == pytest.approx(1.0)
    assert selection["deterministic"] is True


def test_a_fold_s_own_runs_never_reach_its_weights():
    U, Y = _records()
    targets = _targets(U, Y)
    runs = _members(targets)
    first = choose_stack(
        _model(),
        _context(U, Y),
        {name: _dep(r) for name, r in runs.items()},
        n_splits=N_SPLITS,
    )[1]
    # Make model "c" perfect on fold 0 only: fold 0's weights cannot see it,
    # every other fold's weights do.
    runs["c"][0] = targets[0].copy()
    second = choose_stack(
        _model(),
        _context(U, Y),
        {name: _dep(r) for name, r in runs.items()},
        n_splits=N_SPLITS,
    )[1]
    assert second["fold_weights"][0] == pytest.approx(first["fold_weights"][0])
    for k in range(1, N_SPLITS):
        assert second["fold_weights"][k]["c"] > first["fold_weights"][k]["c"]


def test_a_model_without_runs_on_every_fold_is_left_out():
    U, Y = _records()
    targets = _targets(U, Y)
    runs = _members(targets)
    runs["b"][2] = np.full_like(targets[2], np.nan)  # a diverged fold
    deps = {name: _dep(r) for name, r in runs.items()}
    deps["c"]["model"] = None  # a model whose every fit failed
    _, selection, _ = choose_stack(_model(), _context(U, Y), deps, n_splits=N_SPLITS)
    assert "failed" in selection and "a stack needs two" in selection["failed"]
    assert selection["validation_rmse"] == float("inf")
    deps["c"]["model"] = Offset()
    fitted, selection, _ = choose_stack(
        _model(), _context(U, Y), deps, n_splits=N_SPLITS
    )
    assert selection["members"] == ["a", "c"]
    assert list(fitted.named_estimators_) == [
        m for m in ("a", "c") if selection["weights"][m] > 0
    ]
    assert set(selection["weights"]) == {"a", "c"}


def test_a_later_seed_averages_its_own_models_with_the_first_seed_s_weights():
    U, Y = _records()
    targets = _targets(U, Y)
    runs = _members(targets)
    deps = {name: _dep(r, deterministic=name != "b") for name, r in runs.items()}
    _, selection, stack_runs = choose_stack(
        _model(), _context(U, Y), deps, n_splits=N_SPLITS
    )
    assert selection["weights"]["b"] > 0
    assert selection["deterministic"] is False  # "b" trains a network
    y = np.ravel(Y[0])
    later = {
        name: _dep(None, offset=offset)
        for name, offset in (("a", 1.0), ("b", 2.0), ("c", 3.0))
    }
    for dep in later.values():
        dep["model"].y = y
    searched = {"selection": selection, "runs": stack_runs, "seed": 0}
    fitted, again, again_runs = choose_stack(
        _model(), _context(U, Y, searched=searched), later, n_splits=N_SPLITS
    )
    assert again["searched_at_seed"] == 0
    assert again["weights"] == selection["weights"]
    assert again_runs is stack_runs
    w = selection["weights"]
    expected = y + sum(w[m] * off for m, off in (("a", 1.0), ("b", 2.0), ("c", 3.0)))
    np.testing.assert_allclose(np.ravel(fitted.simulate(U[0], Y[0][:N_INIT])), expected)


def test_the_stack_is_the_family_s_last_model_and_requires_every_other():
    system = SimpleNamespace(has_hybrids=lambda quick: True)
    models = zoo(system, quick=True)
    assert list(models)[-1] == STACK
    assert models[STACK].requires == tuple(list(models)[:-1])
    assert models[STACK].choose is not None


def test_a_later_seed_whose_member_failed_has_no_stack_and_says_why():
    U, Y = _records()
    targets = _targets(U, Y)
    deps = {name: _dep(r) for name, r in _members(targets).items()}
    _, selection, runs = choose_stack(_model(), _context(U, Y), deps, n_splits=N_SPLITS)
    weighted = next(m for m, w in selection["weights"].items() if w > 0)
    deps[weighted]["model"] = None
    searched = {"selection": selection, "runs": runs, "seed": 0}
    fitted, again, _ = choose_stack(
        _model(), _context(U, Y, searched=searched), deps, n_splits=N_SPLITS
    )
    assert fitted is None
    assert again["failed"] == f"{weighted}, averaged with a weight, failed at this seed"


class Wavy(BaseEstimator):
    """A fitted stand-in whose free run is a fixed function of the inputs."""

    def __init__(self, scale=1.0):
        self.scale = scale

    def simulate(self, inputs, initial):
        return np.sin(self.scale * np.cumsum(inputs, axis=0))


def test_the_averaged_run_is_the_stack_s_own_simulation_to_the_bit():
    u = np.random.default_rng(3).normal(size=(300, 1))
    members = [("a", Wavy(0.1)), ("b", Wavy(0.37)), ("c", Wavy(1.3))]
    stack = StackedSimulation._from_fitted(members, [0.2, 0.0, 0.8])
    runs = {name: np.ravel(m.simulate(u, None)) for name, m in members}
    run, error = averaged_run(stack, runs, {})
    np.testing.assert_array_equal(run, np.ravel(stack.simulate(u, None)))
    assert error is None
    # A member with no weight need not have run; one with a weight must.
    del runs["b"]
    assert averaged_run(stack, runs, {})[0] is not None
    del runs["c"]
    assert averaged_run(stack, runs, {}) == (None, None)
    # A member whose free run failed fails the stack, with its reason.
    runs = {"a": np.full(300, np.nan), "c": np.zeros(300)}
    run, error = averaged_run(stack, runs, {"a": "diverged at step 7"})
    assert np.all(np.isnan(run))
    assert error == "a's free run failed: diverged at step 7"
