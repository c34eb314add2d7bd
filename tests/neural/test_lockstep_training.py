"""Fits trained side by side in lockstep get what each gets alone.

A search trains a candidate's folds in threads of one process, their forward
and backward passes computed as one batched call
(:mod:`skhybrid.neural._lockstep`); every member keeps its own data, weights,
optimiser, early stopping and schedule.
"""

import warnings

import numpy as np
import pytest
import torch
from sklearn.base import clone

from skhybrid.domain import StateSpaceModel
from skhybrid.hybrid import StateSpaceHybridRegressor
from skhybrid.neural import _lockstep
from skhybrid.utils._lockstep import run_in_lockstep


def spring(x, u, *, xp, k, c):
    position, velocity = x[:, 0], x[:, 1]
    return xp.stack([velocity, u[:, 0] - k * position - c * velocity], axis=1)


def _model(rhs):
    return StateSpaceModel(
        rhs,
        {"k": 2.0, "c": 0.5},
        state_names=["position", "velocity"],
        observed=["position"],
        time="continuous",
        dt=0.1,
        n_init=4,
    )


def _measure(force, dt=0.1, substeps=10):
    """Positions of a mass on a stiffening spring under ``force``, plus noise."""
    x, v, h, y = 0.0, 0.0, dt / substeps, np.empty(len(force))
    for t, f in enumerate(force):
        y[t] = x
        for _ in range(substeps):
            x, v = x + h * v, v + h * (f - 2 * x - 0.5 * v - 5 * x**3)
    return y[:, None]


@pytest.fixture(scope="module")
def pieces():
    """Three members' records (other lengths, so their batches differ)."""
    rng = np.random.default_rng(0)
    U = [np.repeat(rng.uniform(-2, 2, 40), 10)[:n, None] for n in (240, 180, 210)]
    Y = [_measure(u[:, 0]) + 0.002 * rng.standard_normal((len(u), 1)) for u in U]
    return [
        ([U[0], U[1]], [Y[0], Y[1]]),
        ([U[1], U[2]], [Y[1], Y[2]]),
        ([U[2]], [Y[2]]),
    ]


def _hybrid():
    return StateSpaceHybridRegressor(
        _model(spring),
        horizon=8,
        hidden_layer_sizes=(8,),
        encoder_hidden_layer_sizes=(8,),
        max_epochs=3,
        batch_size=16,
        random_state=0,
        # The case the tolerances below were set on (the hybrid's default is
        # larger; it schedules the encoder's pre-training too).
        lr_patience=10,
    )


def _fit(member):
    model, (U, Y) = member
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a 3-epoch correction rarely helps
        return model.fit_simulation(U, Y)


def _weights(model):
    return torch.cat([p.detach().flatten() for p in model.module_.parameters()])


def test_members_in_lockstep_match_their_fits_alone(pieces, monkeypatch):
    calls = []
    group = _lockstep._forward_group

    def counted(key, requests):
        calls.append(len(requests))
        return group(key, requests)

    monkeypatch.setattr(_lockstep, "_forward_group", counted)
    alone = [_fit((_hybrid(), p)) for p in pieces]
    assert not calls  # outside lockstep nothing is routed
    together = [_hybrid() for _ in pieces]
    outcomes = run_in_lockstep(list(zip(together, pieces, strict=True)), _fit)
    for outcome in outcomes:
        assert not isinstance(outcome, BaseException), outcome
    # The members' passes were computed together, not one by one.
    assert max(calls) >= 2
    for solo, member in zip(alone, together, strict=True):
        assert member.n_epochs_ == solo.n_epochs_
        np.testing.assert_allclose(
            member.loss_curve_, solo.loss_curve_, rtol=1e-8, atol=1e-12
        )
        np.testing.assert_allclose(
            member.validation_scores_, solo.validation_scores_, rtol=1e-8
        )
        np.testing.assert_allclose(_weights(member), _weights(solo), atol=1e-8)


def test_a_member_that_fails_leaves_the_others_training(pieces):
    bad = clone(_hybrid()).set_params(horizon=500)  # no record is long enough
    members = [(_hybrid(), pieces[0]), (bad, pieces[1]), (_hybrid(), pieces[2])]
    outcomes = run_in_lockstep(members, _fit)
    assert isinstance(outcomes[1], ValueError)
    assert "n_init + horizon" in str(outcomes[1])
    for i in (0, 2):
        assert outcomes[i] is members[i][0]
        assert np.isfinite(outcomes[i].loss_curve_).all()


def test_a_search_batches_a_hybrids_folds_on_a_gpu_only():
    # On a CPU the batched call costs what the folds cost in turn
    # (docs/results.md): the search spreads them over its workers instead.
    assert not _hybrid().fits_in_lockstep
    assert _hybrid().set_params(device="cuda").fits_in_lockstep


@pytest.mark.gpu
def test_members_in_lockstep_on_a_gpu_match_their_fits_alone(pieces):
    # Where the search batches a hybrid's folds: on the GPU.
    if not torch.cuda.is_available():
        pytest.skip("needs CUDA")
    alone = [_fit((_hybrid().set_params(device="cuda"), p)) for p in pieces]
    together = [_hybrid().set_params(device="cuda") for _ in pieces]
    assert together[0].fits_in_lockstep
    outcomes = run_in_lockstep(list(zip(together, pieces, strict=True)), _fit)
    for outcome in outcomes:
        assert not isinstance(outcome, BaseException), outcome
    for solo, member in zip(alone, together, strict=True):
        assert member.n_epochs_ == solo.n_epochs_
        # float64 on the device; a batched call's reductions add in another
        # order than a member's own.
        np.testing.assert_allclose(member.loss_curve_, solo.loss_curve_, rtol=1e-6)
        np.testing.assert_allclose(
            _weights(member).cpu(), _weights(solo).cpu(), rtol=1e-5, atol=1e-7
        )
