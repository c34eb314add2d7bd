"""A model fitted by simulation error is a candidate of the search as it is."""

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import FitFailedWarning
from sklearn.frozen import FrozenEstimator
from sklearn.utils import check_array, estimator_checks

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments.run._fitting import fit_segments
from skhybrid.model_selection import SimulationFit, SimulationSearchCV

N_INIT = 4


def mass_spring_damper(x, u, *, xp, k, c):
    """The guide's known physics, linear: a mass on a spring with a damper."""
    position, velocity = x[:, 0], x[:, 1]
    return xp.stack([velocity, u[:, 0] - k * position - c * velocity], axis=1)


def _physics(params, **kwargs):
    return StateSpaceModel(
        mass_spring_damper,
        params,
        state_names=["position", "velocity"],
        observed=["position"],
        time="continuous",
        dt=0.05,
        n_init=N_INIT,
        vectorized=True,
        **kwargs,
    )


@pytest.fixture(scope="module")
def records():
    rng = np.random.default_rng(0)
    truth = _physics({"k": 4.0, "c": 0.5}, fixed=("k", "c"))
    U, Y = [], []
    for n in (200, 160):
        u = np.repeat(rng.uniform(-1, 1, n // 20 + 1), 20)[:n, None]
        y = truth.fit_simulation(u, np.zeros((n, 1))).simulate_from_state(u, [0, 0])
        U.append(u)
        Y.append(y + 0.002 * rng.standard_normal(y.shape))
    return U, Y


class OneStep(BaseEstimator):
    """A model whose fit takes 2-D windows only, as a domain model's fit does."""

    def fit(self, X, y):
        check_array(X)
        return self

    def simulate(self, inputs, initial):
        return np.zeros((len(inputs), 1))


def physics_alone(physics):
    return FrozenEstimator(physics)


class Zero(OneStep):
    def fit(self, U, Y):
        return self


def test_the_guides_state_space_model_is_a_candidate_as_it_is(records):
    U, Y = records
    physics = _physics({"k": 2.0, "c": 1.0})
    search = SimulationSearchCV(
        [("physics", physics), ("zero", Zero())], n_init=N_INIT
    ).fit(U, Y)
    assert all(e is None for e in search.cv_results_["split0_error"])
    assert search.best_candidate_ == "physics"
    assert search.best_score_ < 0.02  # the output's spread is about 0.2
    # The refit is the run's physics fit (fit_segments) and fit_simulation, on
    # the same records, to the last digit.
    by_run = fit_segments(physics, U, Y, None)
    by_hand = clone(physics).fit_simulation(U, Y)
    for other in (by_run, by_hand):
        assert search.best_estimator_.params_ == other.params_
    assert "params_" not in vars(physics)  # the candidate given is not fitted


def test_simulation_fit_cuts_segments_as_the_run_does(records):
    U, Y = records
    physics = _physics({"k": 2.0, "c": 1.0})
    fit = SimulationFit(physics, segment=50).fit(U, Y)
    assert fit.n_segments_ == 4 + 3  # 200 -> 4 x 50; 160 -> 50, 50, 60
    assert fit.estimator_.params_ == fit_segments(physics, U, Y, 50).params_
    assert_allclose(fit.estimator_.params_["k"], 4.0, rtol=0.02)
    run = fit.simulate(U[0], Y[0][:N_INIT])
    assert run.shape == Y[0].shape
    # In a search, its segment is a setting like any other.
    search = SimulationSearchCV(
        [("physics", SimulationFit(physics), {"segment": [None, 50]})],
        n_init=N_INIT,
    ).fit(U, Y)
    assert np.isfinite(search.cv_results_["mean_test_score"]).all()
    with pytest.raises(ValueError, match=r"segment=4 must exceed the model's n_init"):
        SimulationFit(physics, segment=4).fit(U, Y)
    with pytest.raises(ValueError, match="'segment' parameter of SimulationFit"):
        SimulationFit(physics, segment=0).fit(U, Y)


def test_a_state_space_physics_is_shared_by_factories(records):
    U, Y = records
    search = SimulationSearchCV(
        [("physics", physics_alone)],
        physics=_physics({"k": 2.0, "c": 1.0}),
        n_init=N_INIT,
    ).fit(U, Y)
    assert np.isfinite(search.best_score_)
    assert_allclose(search.physics_.params_["k"], 4.0, rtol=0.02)


def test_a_candidate_failing_alike_on_every_fold_raises_naming_it(records):
    U, Y = records
    search = SimulationSearchCV([("zero", Zero()), ("one-step", OneStep())], n_init=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitFailedWarning)
        with pytest.raises(
            ValueError, match="candidate 'one-step' failed on all 4"
        ) as e:
            search.fit(U, Y)
    assert "fit(U, Y) raised ValueError on every fold" in str(e.value)
    assert "fit_simulation" in str(e.value)
    # The same with a shared physics that never fits.
    search = SimulationSearchCV(
        [("zero", Zero()), ("physics", physics_alone)],
        physics=OneStep(),
        n_init=2,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitFailedWarning)
        with pytest.raises(ValueError, match="its shared physics' fit raised"):
            search.fit(U, Y)


def test_record_meta_estimators_api_checks():
    est = SimulationFit(_physics({"k": 2.0, "c": 1.0}), segment=50)
    name = type(est).__name__
    estimator_checks.check_no_attributes_set_in_init(name, est)
    estimator_checks.check_get_params_invariance(name, est)
    estimator_checks.check_set_params(name, est)
    estimator_checks.check_estimator_cloneable(name, est)
    estimator_checks.check_do_not_raise_errors_in_init_or_set_params(name, est)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_a_candidates_folds_run_in_lockstep_as_one_batch(records, n_jobs, monkeypatch):
    # A StateSpaceModel's folds are fitted side by side, each step's free runs
    # of every fold simulated together (rows of several folds in one run); the
    # scores are those of the folds fitted one by one.
    U, Y = records
    grid = {"segment": [None, 60]}

    def search():
        return SimulationSearchCV(
            [("physics", SimulationFit(_physics({"k": 2.0, "c": 1.0})), grid)],
            n_init=N_INIT,
            n_jobs=n_jobs,
        ).fit(U, Y)

    rows = []
    simulate = StateSpaceModel._simulate_records

    def counted(self, U_rows, *args, **kwargs):
        rows.append(len(U_rows))
        return simulate(self, U_rows, *args, **kwargs)

    if n_jobs == 1:
        monkeypatch.setattr(StateSpaceModel, "_simulate_records", counted)
    together = search()
    assert SimulationFit(_physics({"k": 1.0, "c": 1.0})).fits_in_lockstep
    monkeypatch.setattr(StateSpaceModel, "fits_in_lockstep", False)
    n_together, rows_together = len(rows), list(rows)
    rows.clear()
    apart = search()
    if n_jobs == 1:
        # Fewer, wider simulations: several folds' sets in one run.
        assert n_together < len(rows)
        assert max(rows_together) > max(rows)
    for k in range(together.n_splits_):
        assert_allclose(
            together.cv_results_[f"split{k}_test_score"],
            apart.cv_results_[f"split{k}_test_score"],
            rtol=1e-6,
        )
    assert together.best_params_ == apart.best_params_
