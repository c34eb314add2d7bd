"""The measured zoo's static corrections (skhybrid.hybrid._correction) and its one
choose-refit-score rule (skhybrid.experiments.free_run._search.choose_and_refit)."""

import inspect

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import Ridge

from skhybrid.benchmarks.emps import physics as emps_physics
from skhybrid.benchmarks.silverbox import with_next_input
from skhybrid.experiments._registry import MEASURED_SYSTEMS
from skhybrid.experiments.free_run._family import N_SPLITS, MeasuredContext, ZooModel
from skhybrid.experiments.free_run._search import choose_and_refit, fit_model
from skhybrid.hybrid._correction import (
    TransformedInputSimulator,
    _NARXSimulator,
    _PhysicsCorrection,
)
from skhybrid.model_selection import RecordBlockSplit

EMPS = MEASURED_SYSTEMS["emps"]

CONTRACT = (
    "(inputs, initial, *, init='measured', n_samples=None, random_state=None, "
    "return_std=False)"
)


def _record(n=600, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 1))
    y = np.zeros((n, 1))
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.3 * u[t - 1] + 0.05 * np.tanh(3 * y[t - 1])
    return u, y


def _physics(u, y):
    model = emps_physics(1e-3, max_nfev=3)
    # Three evaluations: a physics to build corrections on, not a converged fit.
    with pytest.warns(ConvergenceWarning, match="max_nfev=3"):
        return model.fit_simulation(u, y)


def _fitted():
    u, y = _record()
    physics = TransformedInputSimulator(_physics(*_axis()))
    return {
        "narx": _NARXSimulator(Ridge(alpha=1e-6), 2).fit(u, y),
        "correction": _PhysicsCorrection(physics, Ridge(alpha=1e-3), 3, n_init=20).fit(
            *_axis()
        ),
        "transformed": physics,
    }


def _axis(n=400):
    t = np.arange(n) * 1e-3
    u = np.sin(2 * np.pi * 3 * t)[:, None]
    model = emps_physics(1e-3)
    model.set_params(fixed=tuple(model.params))
    y = model.fit_simulation(u, np.zeros((n, 1))).simulate_from_state(u, [0, 0])
    return u, y


@pytest.fixture(scope="module")
def fitted():
    return _fitted()


def test_simulate_has_the_librarys_signature(fitted):
    for model in fitted.values():
        assert str(inspect.signature(model.simulate)) == CONTRACT


@pytest.mark.parametrize("name", ["narx", "correction", "transformed"])
def test_no_noise_model_means_clear_errors(fitted, name):
    model = fitted[name]
    u, y = _axis() if name != "narx" else _record()
    with pytest.raises(ValueError, match=r"need a noise model; .* has none"):
        model.simulate(u, y[:20], return_std=True)
    with pytest.raises(ValueError, match="need a noise model"):
        model.simulate(u, y[:20], n_samples=3)
    with pytest.raises(ValueError, match="init must be one of"):
        model.simulate(u, y[:20], init="zeros")


def test_least_squares_init_is_refused_where_unsupported(fitted):
    u, y = _axis()
    for name in ("correction", "transformed"):
        with pytest.raises(ValueError, match="supports init in \\('measured',\\)"):
            fitted[name].simulate(u, y[:20], init="least_squares")
    # The NARX passes it to skhybrid.simulation.simulate.
    u, y = _record()
    sim = fitted["narx"].simulate(u, y[:10], init="least_squares")
    assert sim.shape == y.shape


def test_estimator_conventions(fitted):
    narx = _NARXSimulator(Ridge(), 3)
    assert narx.get_params()["n_steps"] == 3
    assert not hasattr(narx, "model_")  # __init__ stores parameters only
    copy = clone(fitted["correction"])
    assert copy.n_steps == 3 and not hasattr(copy, "model_")
    assert copy.physics is fitted["correction"].physics  # the physics is kept as is
    with pytest.raises(ValueError, match="'n_steps' parameter of NARXSimulator"):
        _NARXSimulator(Ridge(), 0).fit(*_record())
    with pytest.raises(ValueError, match="outputs must hold one output"):
        _PhysicsCorrection(fitted["transformed"], Ridge()).fit(
            np.zeros((50, 1)), np.zeros((50, 2))
        )


def test_correction_adds_its_static_map_to_the_physics_free_run(fitted):
    corr = fitted["correction"]
    u, y = _axis()
    y_phys = np.ravel(corr.physics.simulate(u, y[:20]))
    sim = corr.simulate(u, y[:20])
    assert sim.shape == (len(u), 1)
    # The measured window, then the corrected free run (simulate's contract).
    assert_allclose(sim[:20], y[:20])
    assert_allclose(sim[20:, 0], corr.correct(u, y_phys)[20:])


def test_transformed_inputs_feed_the_transform_and_read_through():
    u, y = _axis()
    physics = _physics(u, y)
    wrapped = TransformedInputSimulator(physics, lambda v: 2.0 * np.asarray(v))
    assert wrapped.params_ is physics.params_  # fitted attributes read through
    assert_allclose(wrapped.simulate(u, y[:20]), physics.simulate(2.0 * u, y[:20]))
    assert_allclose(with_next_input(u)[:-1, 1], u[1:, 0])
    assert wrapped.fit(u, y) is wrapped  # validates; the physics is kept
    assert wrapped.estimator is physics


# -- choose, refit, score -------------------------------------------------------------


class _Constant:
    """A 'model' whose free run is a constant: its candidate."""

    def __init__(self, level, fitted_on):
        self.level = level
        self.fitted_on = fitted_on

    def simulate(self, inputs, initial):
        return np.full((len(inputs), 1), float(self.level))


def _constant_fit(calls):
    def fit(candidate, U, Y, ctx, deps, start):
        n = sum(len(u) for u in U)
        calls.append((candidate, n, start))
        if candidate == "bad":
            raise FloatingPointError("diverged")
        return _Constant(candidate, n)

    return fit


def test_a_failed_candidate_is_named_in_the_models_warnings():
    u = np.zeros((400, 1))
    y = np.full((400, 1), 2.0)
    ctx = MeasuredContext(EMPS, [u], [y], 10, 1e-3, True, 0, label="constant")
    model = ZooModel(_constant_fit([]), lambda ctx, records: {1.9: 1.9, "bad": "bad"})
    _, out = fit_model("constant", model, ctx, {})
    assert out["selection"]["chosen"] == 1.9
    # The report lists a model's warnings: the failure is there too.
    assert out["warnings"] == [
        "candidate bad failed: fit: FloatingPointError: diverged"
    ]


def test_choose_and_refit_chooses_by_the_folds_and_refits_the_choice():
    u = np.zeros((400, 1))
    y = np.full((400, 1), 2.0)
    # Two records of different lengths, each cut into the same number of blocks.
    U, Y = [u, u[:240]], [y, y[:240]]
    ctx = MeasuredContext(EMPS, U, Y, 10, 1e-3, True, 0, label="constant")
    calls = []
    model = ZooModel(
        _constant_fit(calls),
        lambda ctx, records: {0.0: 0.0, 1.9: 1.9, 3.0: 3.0, "bad": "bad"},
        choice="level",
    )
    chosen, selection, runs = choose_and_refit(model, ctx, {})
    folds = list(RecordBlockSplit(N_SPLITS, n_init=10).split(U, Y))
    # The 240-sample record holds 3 blocks of at least 8 n_init: 3 folds.
    assert selection["cv_folds"] == len(folds) == 3
    assert selection["level"] == 1.9
    assert selection["validation_rmse_by_candidate"]["bad"] == float("inf")
    assert selection["cv_rmse_by_fold"]["1.9"] == pytest.approx([EMPS.scale * 0.1] * 3)
    # Why the failed candidate failed is kept in the run folder's record.
    assert selection["errors"] == {"bad": "fit: FloatingPointError: diverged"}
    # The chosen candidate's out-of-fold runs: each fold's held-out samples
    # after their first n_init.
    for run, (_, test) in zip(runs, folds, strict=True):
        assert len(run) == sum(stop - start - 10 for _, start, stop in test)
    assert_allclose(selection["validation_rmse"], EMPS.scale * 0.1)
    # Each candidate fitted on each fold's pieces, then the choice on the whole.
    assert len(calls) == 4 * 3 + 1
    assert chosen.fitted_on == 640 and calls[-1] == (1.9, 640, None)
    assert selection["fitted_on"] == "the whole estimation records"
