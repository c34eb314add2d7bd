"""Tests of SimulationSearchCV and StackedSimulation on toy numpy models."""

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import ConvergenceWarning, FitFailedWarning
from sklearn.frozen import FrozenEstimator
from sklearn.utils import estimator_checks

from skhybrid.model_selection import (
    RecordBlockSplit,
    SimulationSearchCV,
    StackedSimulation,
    take_pieces,
)
from skhybrid.utils import all_estimators
from skhybrid.utils.discovery import RECORD_META_ESTIMATORS

N_INIT = 2


# -- toy models ----------------------------------------------------------------------
def _lagged(y, u, n):
    """Rows [y(t-1..t-n), u(t-1..t-n)] and targets y(t), for t >= n."""
    rows = [np.r_[y[t - n : t][::-1], u[t - n : t][::-1]] for t in range(n, len(y))]
    return np.array(rows), y[n:]


class ARX(BaseEstimator):
    """y(t) = sum_i a_i y(t-i) + b_i u(t-i), least squares over every record."""

    def __init__(self, n_lags=1):
        self.n_lags = n_lags

    def fit(self, U, Y):
        parts = [
            _lagged(np.ravel(y), np.ravel(u), self.n_lags)
            for u, y in zip(U, Y, strict=False)
        ]
        X = np.vstack([p[0] for p in parts])
        t = np.concatenate([p[1] for p in parts])
        self.coef_ = np.linalg.lstsq(X, t, rcond=None)[0]
        return self

    def simulate(self, inputs, initial):
        u, n = np.ravel(inputs), self.n_lags
        y = np.zeros(len(u))
        y[: len(initial)] = np.ravel(initial)
        for t in range(len(initial), len(u)):
            y[t] = self.coef_ @ np.r_[y[t - n : t][::-1], u[t - n : t][::-1]]
        return y[:, None]


class Gain(BaseEstimator):
    """y(t) = g u(t): a static model, with a predict of its own."""

    def __init__(self, scale=1.0):
        self.scale = scale

    def fit(self, U, Y):
        u, y = np.concatenate(U).ravel(), np.concatenate(Y).ravel()
        self.gain_ = self.scale * (u @ y) / (u @ u)
        return self

    def simulate(self, inputs, initial):
        return self.gain_ * np.asarray(inputs, dtype=float).reshape(len(inputs), 1)

    def predict(self, X):
        return self.gain_ * np.ravel(X)


class Broken(BaseEstimator):
    """Fails to fit on a fold that holds a piece starting at 0, else diverges."""

    def __init__(self, mode="fit"):
        self.mode = mode

    def fit(self, U, Y):
        if self.mode == "fit":
            raise RuntimeError("no convergence")
        self.fitted_ = True
        return self

    def simulate(self, inputs, initial):
        return np.full((len(inputs), 1), np.nan)


FITS = []


class CountingPhysics(ARX):
    """A first-order ARX 'physics' that records every fit it makes."""

    def fit(self, U, Y):
        FITS.append(tuple(len(u) for u in U))
        return super().fit(U, Y)


class Correction(BaseEstimator):
    """A fitted physics in free run plus c * u(t), c fitted on its residual."""

    def __init__(self, physics, damping=1.0):
        self.physics = physics
        self.damping = damping

    def fit(self, U, Y):
        res, inp = [], []
        for u, y in zip(U, Y, strict=False):
            res.append(np.ravel(y) - np.ravel(self.physics.simulate(u, y[:N_INIT])))
            inp.append(np.ravel(u))
        r, u = np.concatenate(res), np.concatenate(inp)
        self.c_ = self.damping * (u @ r) / (u @ u)
        return self

    def simulate(self, inputs, initial):
        base = np.ravel(self.physics.simulate(inputs, initial))
        return (base + self.c_ * np.ravel(inputs))[:, None]


def physics_alone(physics):
    return FrozenEstimator(physics)


def corrected(physics, damping=1.0):
    return Correction(physics, damping=damping)


@pytest.fixture(scope="module")
def records():
    rng = np.random.default_rng(0)
    U, Y = [], []
    for n in (240, 200):
        u = rng.normal(size=n)
        y = np.zeros(n)
        for t in range(2, n):
            y[t] = (
                0.7 * y[t - 1]
                - 0.1 * y[t - 2]
                + 0.5 * u[t - 1]
                + 0.1 * np.tanh(2 * u[t])
            )
        U.append(u[:, None])
        Y.append((y + 0.01 * rng.normal(size=n))[:, None])
    return U, Y


def _family():
    return [
        ("arx", ARX(), {"n_lags": [1, 2]}),
        ("gain", Gain()),
    ]


def _hand_rmse(model, U, Y, cv):
    scores = []
    for fit, test in cv.split(U, Y):
        m = clone(model).fit(*take_pieces(U, Y, fit))
        errs = []
        for u, y in zip(*take_pieces(U, Y, test), strict=True):
            run = m.simulate(u, y[:N_INIT])
            errs.append((np.ravel(run) - np.ravel(y))[N_INIT:])
        scores.append(np.sqrt(np.mean(np.concatenate(errs) ** 2)))
    return np.array(scores)


# -- cv_results_ by hand -------------------------------------------------------------
def test_cv_results_match_a_hand_computation(records):
    U, Y = records
    search = SimulationSearchCV(_family(), n_init=N_INIT).fit(U, Y)
    cv = RecordBlockSplit(4, n_init=N_INIT)
    res = search.cv_results_
    expected = [
        _hand_rmse(ARX(n_lags=1), U, Y, cv),
        _hand_rmse(ARX(n_lags=2), U, Y, cv),
        _hand_rmse(Gain(), U, Y, cv),
    ]
    assert search.n_splits_ == 4 and list(res["n_splits"]) == [4, 4, 4]
    assert search.n_splits_reason_ == "4 folds as asked."
    for k in range(4):
        assert_allclose(
            res[f"split{k}_test_score"], [e[k] for e in expected], rtol=1e-12
        )
    means = np.array([e.mean() for e in expected])
    assert_allclose(res["mean_test_score"], means, rtol=1e-12)
    assert_allclose(res["std_test_score"], [e.std() for e in expected], rtol=1e-9)
    assert list(res["rank_test_score"]) == list(np.argsort(np.argsort(means)) + 1)
    assert res["params"] == [
        {"candidate": "arx", "n_lags": 1},
        {"candidate": "arx", "n_lags": 2},
        {"candidate": "gain"},
    ]
    assert list(res["param_candidate"]) == ["arx", "arx", "gain"]
    assert list(res["param_n_lags"].mask) == [False, False, True]
    assert all(res[f"split{k}_error"][i] is None for k in range(4) for i in range(3))
    assert np.all(res["mean_fit_time"] >= 0) and np.all(res["std_fit_time"] >= 0)
    # RMSE convention: positive, lower is better, best_score_ is the minimum.
    best = int(np.argmin(means))
    assert search.best_index_ == best
    assert search.best_score_ == res["mean_test_score"][best] == means.min() > 0
    assert res["rank_test_score"][best] == 1
    assert (search.best_candidate_, search.best_params_) == ("arx", {"n_lags": 2})
    # Refitted on the whole records, and simulate is delegated.
    refit = ARX(n_lags=2).fit(U, Y)
    assert_allclose(search.best_estimator_.coef_, refit.coef_)
    assert_allclose(
        search.simulate(U[1], Y[1][:N_INIT]), refit.simulate(U[1], Y[1][:N_INIT])
    )


def test_tie_goes_to_the_first_row(records):
    U, Y = records
    search = SimulationSearchCV(
        [("b", ARX(n_lags=1)), ("a", ARX(n_lags=1))], n_init=N_INIT
    ).fit(U, Y)
    assert search.best_candidate_ == "b"
    assert list(search.cv_results_["rank_test_score"]) == [1, 1]


def test_predict_is_delegated_only_where_the_best_has_it(records):
    U, Y = records
    search = SimulationSearchCV([("gain", Gain())], n_init=N_INIT).fit(U, Y)
    assert_allclose(search.predict(U[0]), search.best_estimator_.predict(U[0]))
    search = SimulationSearchCV([("arx", ARX())], n_init=N_INIT).fit(U, Y)
    assert not hasattr(search, "predict")
    search = SimulationSearchCV([("arx", ARX())], n_init=N_INIT, refit=False)
    search.fit(U, Y)
    assert not hasattr(search, "best_estimator_")
    assert not hasattr(search, "simulate")
    assert search.best_candidate_ == "arx"


def test_fewer_folds_are_recorded(records):
    U, Y = records
    search = SimulationSearchCV([("gain", Gain())], n_init=8).fit(U, Y)
    # 200 // 4 = 50 < 64 = 8 * n_init; 200 // 3 = 66.
    assert search.n_splits_ == 3
    assert search.n_splits_reason_.startswith("3 folds of the 4 asked")
    assert "split3_test_score" not in search.cv_results_
    assert list(search.cv_results_["n_splits"]) == [3]


# -- failures ------------------------------------------------------------------------
def test_failed_fits_and_free_runs_score_inf_with_their_reason(records):
    U, Y = records
    search = SimulationSearchCV(
        [("gain", Gain()), ("broken", Broken(), {"mode": ["fit", "nan"]})],
        n_init=N_INIT,
    )
    with pytest.warns(FitFailedWarning, match="8 of 12 fold fits scored inf"):
        search.fit(U, Y)
    res = search.cv_results_
    assert np.isinf(res["mean_test_score"][1:]).all()
    assert list(res["rank_test_score"]) == [1, 2, 2]
    assert res["split0_error"][1] == "fit: RuntimeError: no convergence"
    assert res["split2_error"][2] == "simulate: the free run is not finite"
    assert search.best_candidate_ == "gain"


def test_every_candidate_failing_raises(records):
    U, Y = records
    search = SimulationSearchCV([("broken", Broken(mode="nan"))], n_init=N_INIT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitFailedWarning)
        with pytest.raises(ValueError, match="broken, fold 0: simulate: the free"):
            search.fit(U, Y)
    # One whose fit fails alike on every fold is named, with its error.
    search = SimulationSearchCV([("broken", Broken())], n_init=N_INIT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitFailedWarning)
        with pytest.raises(ValueError, match="candidate 'broken' failed on all 4"):
            search.fit(U, Y)
    assert search.cv_results_["split0_error"][0] == "fit: RuntimeError: no convergence"


# -- shared physics ------------------------------------------------------------------
def test_the_shared_physics_is_fitted_once_per_fold_and_once_for_the_refit(records):
    U, Y = records
    FITS.clear()
    search = SimulationSearchCV(
        [
            ("physics", physics_alone),
            ("corrected", corrected, {"damping": [0.5, 1.0]}),
            ("arx", ARX(n_lags=2)),
        ],
        physics=CountingPhysics(n_lags=1),
        n_init=N_INIT,
    ).fit(U, Y)
    cv = RecordBlockSplit(4, n_init=N_INIT)
    fold_lengths = [tuple(b - a for _, a, b in fit) for fit, _ in cv.split(U, Y)]
    best_needs_physics = search.best_candidate_ in ("physics", "corrected")
    assert FITS == fold_lengths + ([(240, 200)] if best_needs_physics else [])
    # Each factory candidate was built on that fold's physics: by hand.
    physics_scores = []
    corrected_scores = []
    for fit, test in cv.split(U, Y):
        phys = ARX(n_lags=1).fit(*take_pieces(U, Y, fit))
        corr = Correction(phys, damping=0.5).fit(*take_pieces(U, Y, fit))
        for model, out in ((phys, physics_scores), (corr, corrected_scores)):
            errs = [
                (np.ravel(model.simulate(u, y[:N_INIT])) - np.ravel(y))[N_INIT:]
                for u, y in zip(*take_pieces(U, Y, test), strict=True)
            ]
            out.append(np.sqrt(np.mean(np.concatenate(errs) ** 2)))
    res = search.cv_results_
    for k in range(4):
        assert_allclose(res[f"split{k}_test_score"][0], physics_scores[k], rtol=1e-12)
        assert_allclose(res[f"split{k}_test_score"][1], corrected_scores[k], rtol=1e-12)
    assert search.physics_fit_time_.shape == (4,)


def test_refit_of_a_physics_candidate_uses_one_physics_fit(records):
    U, Y = records
    FITS.clear()
    search = SimulationSearchCV(
        [("corrected", corrected, {"damping": [0.0, 1.0]})],
        physics=CountingPhysics(n_lags=2),
        n_init=N_INIT,
    ).fit(U, Y)
    assert len(FITS) == 5 and FITS[-1] == (240, 200)
    assert isinstance(search.best_estimator_, Correction)
    assert search.best_estimator_.physics is not search.physics_  # a copy each
    assert_allclose(search.best_estimator_.physics.coef_, search.physics_.coef_)


class FailsOnShortPieces(ARX):
    """A physics whose fit fails where a fold's first piece is short."""

    def fit(self, U, Y):
        if len(U[0]) < 100:
            raise RuntimeError("no convergence")
        return super().fit(U, Y)


def test_a_failing_physics_fails_its_candidates_only(records):
    U, Y = records
    search = SimulationSearchCV(
        [("physics", physics_alone), ("gain", Gain())],
        physics=FailsOnShortPieces(),
        n_init=N_INIT,
    )
    with pytest.warns(FitFailedWarning):
        search.fit(U, Y)
    assert search.cv_results_["split0_error"][0] is None
    assert search.cv_results_["split1_error"][0] == (
        "the shared physics' fit failed: RuntimeError: no convergence"
    )
    assert search.cv_results_["split1_error"][1] is None
    assert search.best_candidate_ == "gain"


# -- stacking ------------------------------------------------------------------------
class Biased(BaseEstimator):
    """Reads the truth from inputs[:, 1]; off by `inside` in block 0, else `outside`."""

    def __init__(self, inside=0.0, outside=0.0):
        self.inside = inside
        self.outside = outside

    def fit(self, U, Y):
        self.fitted_ = True
        return self

    def simulate(self, inputs, initial):
        inputs = np.asarray(inputs)
        bias = np.where(inputs[:, 0] == 0, self.inside, self.outside)
        return (inputs[:, 1] + bias)[:, None]


def _marked_records():
    """One record of 160 samples: column 0 is the block (of 4), column 1 the truth."""
    rng = np.random.default_rng(1)
    y = rng.normal(size=160)
    u = np.column_stack([np.arange(160) // 40, y])
    return [u], [y[:, None]]


def test_stack_weights_of_fold_k_come_from_the_other_folds_only():
    U, Y = _marked_records()
    # A is exact in block 0 and 3 too high elsewhere; B 1 too high in block 0 and
    # 1 too low elsewhere.
    family = [("A", Biased(0.0, 3.0)), ("B", Biased(1.0, -1.0))]
    search = SimulationSearchCV(family, n_init=N_INIT, stack=True).fit(U, Y)
    res = search.cv_results_
    assert res["params"][-1] == {"candidate": "stacked"}
    scored = np.array([40 - N_INIT] * 4)  # scored samples per held-out block
    a = [np.zeros(1), *[np.full(1, 3.0)] * 3]
    b = [np.ones(1), *[np.full(1, -1.0)] * 3]
    for k in range(4):
        others = [j for j in range(4) if j != k]
        # min over w of sum_j n_j (w a_j + (1 - w) b_j)^2, on the other folds only.
        num = -sum(scored[j] * b[j][0] * (a[j][0] - b[j][0]) for j in others)
        den = sum(scored[j] * (a[j][0] - b[j][0]) ** 2 for j in others)
        w = np.clip(num / den, 0, 1)
        assert_allclose(search.stack_fold_weights_[k], [w, 1 - w], atol=1e-6)
        expected = abs(w * a[k][0] + (1 - w) * b[k][0])
        assert_allclose(res[f"split{k}_test_score"][-1], expected, atol=1e-6)
    # Fold 0's weights never saw block 0, where A is exact: A gets 1/4, not more.
    assert_allclose(search.stack_fold_weights_[0], [0.25, 0.75], atol=1e-6)
    assert_allclose(search.stack_weights_.sum(), 1.0)
    assert np.all(search.stack_fold_weights_ >= 0)


def test_the_stack_wins_only_where_it_lowers_the_mean_and_refits():
    U, Y = _marked_records()
    family = [("A", Biased(0.5, 0.5)), ("B", Biased(-0.5, -0.5))]
    search = SimulationSearchCV(family, n_init=N_INIT, stack=True).fit(U, Y)
    assert search.best_candidate_ == "stacked" and search.best_params_ == {}
    assert search.best_score_ < 1e-6
    stack = search.best_estimator_
    assert isinstance(stack, StackedSimulation)
    assert [name for name, _ in stack.estimators] == ["A", "B"]
    assert_allclose(stack.weights_, [0.5, 0.5], atol=1e-6)
    assert_allclose(search.simulate(U[0], Y[0][:N_INIT]), Y[0], atol=1e-6)
    # A perfect candidate ties with the stack; the tie goes to the candidate.
    family = [("exact", Biased()), ("A", Biased(0.5, 0.5))]
    search = SimulationSearchCV(family, n_init=N_INIT, stack=True).fit(U, Y)
    assert search.best_candidate_ == "exact"


def test_stack_needs_two_candidates_run_on_every_fold(records):
    U, Y = records
    search = SimulationSearchCV(
        [("gain", Gain()), ("broken", Broken(mode="nan"))], n_init=N_INIT, stack=True
    )
    with pytest.warns(FitFailedWarning):
        search.fit(U, Y)
    assert np.isinf(search.cv_results_["mean_test_score"][-1])
    assert "a stack needs two" in search.cv_results_["split0_error"][-1]


def test_stacked_simulation_checks_its_weights():
    family = [("a", Gain()), ("b", Gain())]
    U, Y = [np.ones((5, 1))], [np.ones((5, 1))]
    with pytest.raises(ValueError, match=r"sum to one; got weights=\[0.5, 0.6\]"):
        StackedSimulation(family, weights=[0.5, 0.6]).fit(U, Y)
    with pytest.raises(ValueError, match=r"expected \(2,\)"):
        StackedSimulation(family, weights=[1.0]).fit(U, Y)
    stack = StackedSimulation(family).fit(U, Y)
    assert_allclose(stack.weights_, [0.5, 0.5])
    with pytest.raises(ValueError, match="need a noise model"):
        stack.simulate(U[0], Y[0][:1], return_std=True)


# -- parallel ------------------------------------------------------------------------
def test_results_are_identical_with_one_and_two_jobs(records):
    U, Y = records
    kwargs = dict(physics=CountingPhysics(), n_init=N_INIT, stack=True)
    family = [*_family(), ("corrected", corrected)]
    one = SimulationSearchCV(family, n_jobs=1, **kwargs).fit(U, Y)
    two = SimulationSearchCV(family, n_jobs=2, **kwargs).fit(U, Y)
    for key, value in one.cv_results_.items():
        if "time" in key:
            continue
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            assert_array_equal(value, two.cv_results_[key], err_msg=key)
        else:
            assert list(value) == list(two.cv_results_[key]), key
    assert_array_equal(one.stack_fold_weights_, two.stack_fold_weights_)
    assert one.best_index_ == two.best_index_
    assert_array_equal(
        one.simulate(U[0], Y[0][:N_INIT]), two.simulate(U[0], Y[0][:N_INIT])
    )


class Warns(Gain):
    """A gain whose fit warns, as a physics that stops short does."""

    def fit(self, U, Y):
        warnings.warn("stopped short on this fold", ConvergenceWarning, stacklevel=2)
        return super().fit(U, Y)


class WarningPhysics(CountingPhysics):
    def fit(self, U, Y):
        warnings.warn("the physics stopped short", ConvergenceWarning, stacklevel=2)
        return super().fit(U, Y)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_the_folds_warnings_reach_the_caller_from_every_worker(records, n_jobs):
    # In worker processes (n_jobs=2) a fold's warnings would be lost; they are
    # raised again in the caller, once per fold, as with n_jobs=1.
    U, Y = records
    family = [("gain", Warns()), ("corrected", corrected)]
    search = SimulationSearchCV(
        family, physics=WarningPhysics(), n_init=N_INIT, n_jobs=n_jobs
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        search.fit(U, Y)
    messages = [str(w.message) for w in caught if w.category is ConvergenceWarning]
    n_splits = search.n_splits_
    # Each fold's fit of the gain and of the shared physics, then the refit's.
    refit = search.best_candidate_ == "gain"
    assert messages.count("stopped short on this fold") == n_splits + refit
    assert messages.count("the physics stopped short") == n_splits + (not refit)


# -- parameters and the scikit-learn API ---------------------------------------------
@pytest.mark.parametrize(
    "params, match",
    [
        ({"scoring": "r2"}, "The 'scoring' parameter of SimulationSearchCV.*Got 'r2'"),
        ({"n_init": 0}, "The 'n_init' parameter of SimulationSearchCV.*Got 0"),
        ({"cv": 1}, "The 'cv' parameter of SimulationSearchCV.*Got 1"),
        ({"stack": "yes"}, "The 'stack' parameter of SimulationSearchCV.*Got 'yes'"),
        ({"candidates": ()}, "The 'candidates' parameter.*Got \\(\\)"),
        ({"candidates": []}, "candidates=\\[\\]"),
        (
            {"candidates": [("arx", ARX(), {"alpha": [1]})]},
            "candidates\\[0\\] \\('arx'\\) has param_grid keys \\['alpha'\\]",
        ),
        (
            {"candidates": [("arx", ARX()), ("arx", Gain())]},
            "candidates\\[1\\] has name 'arx', which is repeated",
        ),
        (
            {"candidates": [("stacked", ARX())], "stack": True},
            "name 'stacked', which names the stack",
        ),
        ({"candidates": [("c", corrected)]}, "but physics=None"),
        (
            {"candidates": [("c", corrected, {"gain": [1]})], "physics": ARX()},
            "factory that cannot take \\(physics, gain=...\\)",
        ),
        ({"candidates": [("arx", ARX(), {"n_lags": []})]}, "param_grid"),
        ({"candidates": [("arx", "ARX")]}, "has estimator 'ARX'"),
        (
            {"cv": RecordBlockSplit(4, n_init=3), "n_init": 2},
            "n_init=2 differs from cv.n_init=3",
        ),
    ],
)
def test_bad_parameters_raise_naming_parameter_and_value(records, params, match):
    U, Y = records
    kwargs = {"candidates": [("arx", ARX())], **params}
    with pytest.raises(ValueError, match=match):
        SimulationSearchCV(**kwargs).fit(U, Y)


def test_cv_as_an_int_or_a_splitter(records):
    U, Y = records
    a = SimulationSearchCV([("g", Gain())], cv=3, n_init=N_INIT).fit(U, Y)
    b = SimulationSearchCV([("g", Gain())], cv=RecordBlockSplit(3, n_init=N_INIT)).fit(
        U, Y
    )
    assert a.n_splits_ == b.n_splits_ == 3
    assert_array_equal(
        a.cv_results_["mean_test_score"], b.cv_results_["mean_test_score"]
    )


def test_clone_and_scikit_learn_api_checks():
    search = SimulationSearchCV(_family(), physics=ARX(), n_init=N_INIT, stack=True)
    cloned = clone(search)
    assert cloned.get_params()["n_init"] == N_INIT
    assert cloned.candidates[0][1] is not search.candidates[0][1]
    assert cloned.candidates[0][2] == {"n_lags": [1, 2]}
    for est in (search, StackedSimulation([("a", Gain())], weights=[1.0])):
        name = type(est).__name__
        estimator_checks.check_no_attributes_set_in_init(name, est)
        estimator_checks.check_get_params_invariance(name, est)
        estimator_checks.check_set_params(name, est)
        estimator_checks.check_estimator_cloneable(name, est)
        estimator_checks.check_estimator_repr(name, est)
        estimator_checks.check_do_not_raise_errors_in_init_or_set_params(name, est)


def test_record_meta_estimators_are_left_out_of_the_common_checks():
    names = {name for name, _ in all_estimators()}
    meta = {"SimulationFit", "SimulationSearchCV", "StackedSimulation"}
    assert not names & meta
    assert set(RECORD_META_ESTIMATORS) == meta


class Seeded(Gain):
    """A Gain that records the seed of each fit."""

    SEEDS = []

    def __init__(self, scale=1.0, random_state=None):
        super().__init__(scale=scale)
        self.random_state = random_state

    def fit(self, U, Y):
        Seeded.SEEDS.append(self.random_state)
        return super().fit(U, Y)


def seeded_correction(physics, damping=1.0, random_state=None):
    Seeded.SEEDS.append(("factory", random_state))
    return Correction(physics, damping=damping)


def test_fold_k_fits_at_the_runs_seed_plus_k_and_the_refit_at_the_seed(records):
    U, Y = records
    Seeded.SEEDS.clear()
    search = SimulationSearchCV(
        [("seeded", Seeded()), ("corrected", seeded_correction)],
        physics=ARX(),
        n_init=N_INIT,
        random_state=10,
    ).fit(U, Y)
    n = search.n_splits_
    fits = [s for s in Seeded.SEEDS if not isinstance(s, tuple)]
    made = [s[1] for s in Seeded.SEEDS if isinstance(s, tuple)]
    assert fits[:n] == [10 + k for k in range(n)]
    assert made[:n] == [10 + k for k in range(n)]
    # The refit (of whichever won) is at the run's seed itself.
    assert (fits[n:] or made[n:]) == [10]
    # Without random_state the candidates keep their own.
    Seeded.SEEDS.clear()
    SimulationSearchCV([("seeded", Seeded(random_state=3))], n_init=N_INIT).fit(U, Y)
    assert set(Seeded.SEEDS) == {3}


def test_best_oof_runs_are_the_samples_its_score_is_computed_on(records):
    U, Y = records
    search = SimulationSearchCV(
        [("arx", ARX(), {"n_lags": [1, 2]})], n_init=N_INIT
    ).fit(U, Y)
    splitter = RecordBlockSplit(search.n_splits_, n_init=N_INIT)
    for k, (_, test) in enumerate(splitter.split(U, Y)):
        _, Y_test = take_pieces(U, Y, test)
        measured = np.concatenate([np.ravel(y)[N_INIT:] for y in Y_test])
        runs = search.best_oof_runs_[k]
        assert runs.shape == measured.shape
        rmse = np.sqrt(np.mean((runs - measured) ** 2))
        assert rmse == pytest.approx(
            search.cv_results_[f"split{k}_test_score"][search.best_index_]
        )
