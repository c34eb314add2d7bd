"""Networks with batch normalisation trained in lockstep get what each gets alone.

A search on a GPU trains a candidate's folds in threads of one process, their
forward and backward passes computed as one batched call
(:mod:`skhybrid.neural._lockstep`). The dense networks start with batch
normalisation, whose running statistics the batched call updates on the
members' stacked buffers and copies back into each member's module.

The dense networks train in float32, where a batched matrix product rounds
otherwise than one member's (a few units in the last place, which training
carries on): the members are compared with their fits alone at 1e-8 with the
networks made float64 (a test-only patch of their tensors' type), and, as
shipped in float32, at 1e-5. The ensemble hybrid trains physics and network
in float64, compared at 1e-8.
"""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from sklearn.linear_model import Ridge

from skhybrid.domain import LinearStateSpaceModel, ParametricModel, StateSpaceModel
from skhybrid.experiments.free_run._family import zoo
from skhybrid.hybrid import HybridBoostingRegressor, HybridEnsembleRegressor
from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor, _lockstep
from skhybrid.neural._base import BaseNeuralRegressor
from skhybrid.preprocessing import WindowLayout
from skhybrid.utils._lockstep import run_in_lockstep

#: (rtol of the losses, atol of the weights and running statistics).
TOLERANCES = {"float64": (1e-8, 1e-8), "float32": (1e-5, 1e-5)}


def _rows(n, rng):
    X = rng.normal(size=(n, 3))
    return X, np.sin(2 * X[:, 0]) + X[:, 1] * X[:, 2]


def _pieces(lengths):
    rng = np.random.default_rng(0)
    return [_rows(n, rng) for n in lengths]


def _network(kind):
    settings = {
        "max_epochs": 12,
        "batch_size": 64,
        "patience": 4,  # early stopping and the schedule act within 12 epochs
        "lr_patience": 1,
        "random_state": 0,
    }
    if kind is CyclicRegressor:
        return kind(hidden_layer_sizes=(8,), **settings)
    if kind is RNNRegressor:
        return kind(n_steps=3, hidden_size=4, **settings)
    return kind(hidden_layer_sizes=(16, 16), **settings)


def _in_float64(monkeypatch, kind):
    """Train ``kind``'s networks on float64 tensors (a test-only patch)."""
    make = kind._make_module

    def to_tensor(self, array):
        return torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64))

    monkeypatch.setattr(BaseNeuralRegressor, "_to_tensor", to_tensor)
    monkeypatch.setattr(kind, "_make_module", lambda self, *a: make(self, *a).double())


@pytest.fixture
def groups(monkeypatch):
    """The requests of every batched call: ``[(training, rows of each), ...]``."""
    calls = []
    group = _lockstep._forward_group

    def counted(key, requests):
        calls.append((requests[0].module.training, [len(r.x) for r in requests]))
        return group(key, requests)

    monkeypatch.setattr(_lockstep, "_forward_group", counted)
    return calls


def _fit(member):
    model, (X, y) = member
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a 12-epoch network rarely converges
        return model.fit(X, y)


def _solo_and_together(kind, pieces, groups):
    alone = [_fit((_network(kind), p)) for p in pieces]
    assert not groups  # outside lockstep nothing is routed
    together = [_network(kind) for _ in pieces]
    outcomes = run_in_lockstep(list(zip(together, pieces, strict=True)), _fit)
    for outcome in outcomes:
        assert not isinstance(outcome, BaseException), outcome
    return alone, together


def _assert_same(alone, together, precision):
    rtol, atol = TOLERANCES[precision]
    for solo, member in zip(alone, together, strict=True):
        assert member.n_epochs_ == solo.n_epochs_
        assert member.best_epoch_ == solo.best_epoch_
        for column in ("train_loss", "valid_loss"):
            np.testing.assert_allclose(
                member.history_[:, column], solo.history_[:, column], rtol=rtol
            )
        state = solo.net_.module_.state_dict()
        assert any("running_var" in name for name in state)
        for name, value in member.net_.module_.state_dict().items():
            np.testing.assert_allclose(
                value.double(), state[name].double(), atol=atol, err_msg=name
            )


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("kind", [DenseRegressor, CyclicRegressor])
def test_members_in_lockstep_match_their_fits_alone(
    kind, precision, groups, monkeypatch
):
    if precision == "float64":
        _in_float64(monkeypatch, kind)
    alone, together = _solo_and_together(kind, _pieces((300, 300, 300)), groups)
    # The members' passes were computed together, not one by one.
    assert max(len(rows) for _, rows in groups) == 3
    _assert_same(alone, together, precision)


def test_a_member_with_other_rows_is_not_padded_into_a_batch(groups, monkeypatch):
    _in_float64(monkeypatch, DenseRegressor)
    # 240 and 200 training rows: batches of 60 and of 50 rows.
    pieces = _pieces((300, 250, 300))
    alone, together = _solo_and_together(DenseRegressor, pieces, groups)
    # Batch norm in training normalises by the batch: such batches are computed
    # together only with batches of as many rows; validation (running
    # statistics, row by row) pads the shorter.
    assert any(len(rows) >= 2 for training, rows in groups if training)
    assert all(len(set(rows)) == 1 for training, rows in groups if training)
    assert any(len(set(rows)) > 1 for training, rows in groups if not training)
    _assert_same(alone, together, "float64")


def test_a_rollout_trained_in_lockstep_matches_its_fits_alone(groups, monkeypatch):
    # horizon > 1: the network rolled 4 steps, its batch norm updated each step.
    _in_float64(monkeypatch, DenseRegressor)
    rng, layout = np.random.default_rng(0), WindowLayout(1, n_inputs=1, n_steps=2)
    pieces = []
    for _ in range(3):
        u, x = rng.uniform(-1, 1, 300), np.zeros(300)
        for t in range(299):
            x[t + 1] = 0.8 * x[t] + 0.3 * np.sin(x[t]) + u[t]
        pieces.append(layout.make_rows(x[:, None], u[:, None]))
    alone = [_fit((_network(DenseRegressor).set_params(horizon=4), p)) for p in pieces]
    together = [_network(DenseRegressor).set_params(horizon=4) for _ in pieces]
    outcomes = run_in_lockstep(list(zip(together, pieces, strict=True)), _fit)
    assert all(o is m for o, m in zip(outcomes, together, strict=True))
    assert max(len(rows) for _, rows in groups) == 3
    _assert_same(alone, together, "float64")


def test_a_recurrent_network_trains_alone_in_lockstep(groups):
    # vmap has no batching rule for torch's recurrent layers: no signature.
    alone, together = _solo_and_together(RNNRegressor, _pieces((120, 120)), groups)
    assert all(len(rows) == 1 for _, rows in groups)
    _assert_same(alone, together, "float32")


def _pendulum(X, *, k, c, xp=np):
    """One Euler step of a damped pendulum: rows ``[theta, omega, u]``."""
    th, om, u = X[:, 0], X[:, 1], X[:, 2]
    return xp.stack([th + 0.05 * om, om + 0.05 * (-k * xp.sin(th) - c * om + u)], 1)


def _ensemble():
    return HybridEnsembleRegressor(
        ParametricModel(_pendulum, {"k": 15.0, "c": 0.25}, bounds={"k": (0, 100)}),
        DenseRegressor(hidden_layer_sizes=(8,)),
        max_epochs=8,
        batch_size=64,
        random_state=0,
    )


def test_ensemble_members_in_lockstep_match_their_fits_alone(groups):
    rng = np.random.default_rng(1)
    pieces = []
    for _ in range(3):
        X = rng.uniform(-2, 2, size=(300, 3))
        pieces.append(
            (X, _pendulum(X, k=9.81, c=0.5) + 0.01 * rng.normal(size=(300, 2)))
        )
    alone = [_fit((_ensemble(), p)) for p in pieces]
    together = [_ensemble() for _ in pieces]
    outcomes = run_in_lockstep(list(zip(together, pieces, strict=True)), _fit)
    for outcome in outcomes:
        assert not isinstance(outcome, BaseException), outcome
    assert max(len(rows) for _, rows in groups) == 3
    # Physics and network train in float64: 1e-8.
    _assert_same(alone, together, "float64")
    for solo, member in zip(alone, together, strict=True):
        for name, value in solo.params_.items():
            np.testing.assert_allclose(member.params_[name], value, rtol=1e-8)


def test_the_dense_networks_and_their_hybrids_fit_in_lockstep_on_a_gpu_only():
    # On a CPU the batched call is slower than the folds in turn: the search
    # spreads them over its workers instead.
    for kind in (DenseRegressor, CyclicRegressor):
        assert not _network(kind).fits_in_lockstep
        assert _network(kind).set_params(device="cuda").fits_in_lockstep
    assert not _network(RNNRegressor).set_params(device="cuda").fits_in_lockstep
    hybrid = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel()), ("dense", _network(DenseRegressor))]
    )
    assert not hybrid.fits_in_lockstep
    assert hybrid.set_params(dense__device="cuda").fits_in_lockstep
    rnn = ("rnn", _network(RNNRegressor).set_params(device="cuda"))
    assert not hybrid.set_params(stages=[*hybrid.stages, rnn]).fits_in_lockstep
    assert not HybridBoostingRegressor([hybrid.stages[0]]).fits_in_lockstep
    # A physics whose own fits batch and a linear stage: no network on a GPU.
    physics = StateSpaceModel(
        lambda x, u, *, xp, a: a * x + u,
        {"a": 0.5},
        state_names=["x"],
        observed=["x"],
        time="discrete",
    )
    physics_and_ridge = [("physics", physics), ("ridge", Ridge())]
    assert physics.fits_in_lockstep
    assert not HybridBoostingRegressor(physics_and_ridge).fits_in_lockstep
    ensemble = _ensemble()
    assert not ensemble.fits_in_lockstep
    assert ensemble.set_params(device="cuda").fits_in_lockstep
    rnn = ensemble.set_params(neural=_network(RNNRegressor).set_params(device="cuda"))
    assert not rnn.fits_in_lockstep


def test_the_runs_network_models_train_their_folds_in_lockstep_on_a_gpu():
    models = zoo(SimpleNamespace(has_hybrids=lambda quick: True))
    for name in ("dense NARX", "physics + dense", "physics + dense ensemble"):
        assert models[name].lockstep(SimpleNamespace(device="cuda")), name
        assert not models[name].lockstep(SimpleNamespace(device="cpu")), name
