"""HybridBoostingRegressor: stages, stage inputs, scores, decomposition, noise."""

import pickle

import joblib
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.linear_model import Ridge
from sklearn.model_selection import GridSearchCV, KFold
from sklearn.neighbors import KNeighborsRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa.arima_process import ArmaProcess

from skhybrid.domain import LinearStateSpaceModel, ParametricModel
from skhybrid.exceptions import NonWhiteResidualWarning
from skhybrid.hybrid import HybridBoostingRegressor, StageWhiteness
from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor
from skhybrid.preprocessing import make_windows


def linear(X, *, a, b, xp=np):
    return a * X[:, 0] + b * X[:, 1]


def make_additive(n, rng, sigma=0.05):
    """``y = f(X; a=0.8, b=0.5) + g(X) + noise``: g is smooth, the physics lacks it."""
    X = rng.uniform(-1, 1, size=(n, 2))
    g = 0.3 * np.sin(2.5 * X[:, 0]) * np.cos(1.5 * X[:, 1])
    y = 0.8 * X[:, 0] + 0.5 * X[:, 1] + g + sigma * rng.standard_normal(n)
    return X, y


def dense(**kwargs):
    params = dict(hidden_layer_sizes=(16,), max_epochs=30, batch_size=64)
    params.update(kwargs)
    return DenseRegressor(**params, random_state=0)


class Recorder(RegressorMixin, BaseEstimator):
    """Predicts the column mean of y; records the X it was fitted on."""

    def fit(self, X, y):
        self.X_fit_ = np.array(X)
        self.mean_ = np.mean(y, axis=0)
        return self

    def predict(self, X):
        return np.broadcast_to(self.mean_, (len(X), *np.shape(self.mean_))).copy()


@pytest.fixture(scope="module")
def additive():
    rng = np.random.default_rng(42)
    return make_additive(1200, rng), make_additive(500, rng)


@pytest.fixture(scope="module")
def fitted(additive):
    (X, y), _ = additive
    booster = HybridBoostingRegressor(
        [
            ("physics", ParametricModel(linear, {"a": 0.4, "b": 1.0})),
            ("dense", dense()),
        ],
        noise_model="gaussian",
    )
    return booster.fit(X, y)


# -- decomposition and predictions ---------------------------------------------------
def test_decompose_sums_to_predict(fitted, additive):
    _, (Xt, _) = additive
    parts = fitted.decompose(Xt)
    assert parts.stage_names == ["physics", "dense"]
    assert parts.physics.shape == parts.dense.shape == (Xt.shape[0],)
    assert_allclose(parts.physics + parts.dense, fitted.predict(Xt), rtol=0, atol=1e-10)
    assert_array_equal(parts.total, fitted.predict(Xt))


def test_staged_predict(fitted, additive):
    _, (Xt, _) = additive
    staged = list(fitted.staged_predict(Xt))
    parts = fitted.decompose(Xt)
    assert len(staged) == 2
    assert_allclose(staged[0], parts.physics, rtol=0, atol=1e-12)
    assert_allclose(staged[-1], fitted.predict(Xt), rtol=0, atol=1e-12)


def test_stage_scores_and_domain_params(fitted):
    assert fitted.stage_scores_.shape == (2,)
    assert fitted.stage_scores_[1] < fitted.stage_scores_[0] < fitted.baseline_score_
    assert fitted.dropped_stages_ == []
    physics = fitted.stages_[0][1]
    assert fitted.domain_params_ == physics.params_
    assert set(fitted.domain_params_std_) == {"a", "b"}
    assert all(0 < v < 0.05 for v in fitted.domain_params_std_.values())


def test_residual_whiteness_matches_statsmodels(fitted, additive):
    (X, y), _ = additive
    white = fitted.residual_whiteness_
    assert isinstance(white, StageWhiteness)
    assert white.stage_names == ("physics", "dense")
    assert white.statistic.shape == white.pvalue.shape == (2, 1)
    residual = y - fitted.decompose(X).physics
    table = acorr_ljungbox(residual, lags=[white.lags])
    assert_allclose(white.statistic[0, 0], table["lb_stat"].iloc[0], rtol=1e-10)
    assert_allclose(white.pvalue[0, 0], table["lb_pvalue"].iloc[0], rtol=1e-10)


def test_predict_return_std_and_sample(fitted, additive):
    (X, y), (Xt, _) = additive
    mean, std = fitted.predict(Xt, return_std=True)
    assert_array_equal(mean, fitted.predict(Xt))
    residual = y - fitted.predict(X)
    assert_allclose(std, np.full(Xt.shape[0], residual.std(ddof=1)), rtol=1e-10)
    a = fitted.sample(Xt, random_state=0)
    assert_array_equal(a, fitted.sample(Xt, random_state=0))
    assert not np.array_equal(a, fitted.sample(Xt, random_state=1))
    assert_allclose(np.std(a - mean), residual.std(), rtol=0.1)


def test_no_noise_model_raises():
    X, y = make_additive(100, np.random.default_rng(0))
    booster = HybridBoostingRegressor([("lin", LinearStateSpaceModel())]).fit(X, y)
    with pytest.raises(ValueError, match="noise_model=None"):
        booster.sample(X)
    with pytest.raises(ValueError, match="noise_model=None"):
        booster.predict(X, return_std=True)


@pytest.mark.slow
def test_done_when_additive_system_rmse_within_10_percent_of_sigma():
    """Done-when: final held-out RMSE within 10 % of the noise sigma."""
    rng = np.random.default_rng(42)
    sigma = 0.05
    X, y = make_additive(3000, rng, sigma)
    Xt, yt = make_additive(2000, rng, sigma)
    booster = HybridBoostingRegressor(
        [
            ("physics", ParametricModel(linear, {"a": 0.4, "b": 1.0})),
            ("dense", dense(hidden_layer_sizes=(32, 32), max_epochs=200)),
        ]
    ).fit(X, y)
    rmse = np.sqrt(np.mean((booster.predict(Xt) - yt) ** 2))
    assert rmse <= 1.1 * sigma, rmse / sigma
    assert set(booster.domain_params_std_) == {"a", "b"}
    assert all(np.isfinite(v) and v > 0 for v in booster.domain_params_std_.values())
    parts = booster.decompose(Xt)
    assert_allclose(parts.physics + parts.dense, booster.predict(Xt), atol=1e-10)


# -- unhelpful stages ----------------------------------------------------------------
def test_drop_unhelpful_stages():
    """A 1-nearest-neighbour stage on white noise overfits: dropped when asked."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(400, 2))
    y = 0.8 * X[:, 0] - 0.3 * X[:, 1] + 0.1 * rng.standard_normal(400)
    stages = [
        ("physics", LinearStateSpaceModel()),
        ("knn", KNeighborsRegressor(n_neighbors=1)),
    ]
    kept = HybridBoostingRegressor(stages, stage_input="window").fit(X, y)
    assert kept.stage_scores_[1] > kept.stage_scores_[0]  # the measured harm
    assert [n for n, _ in kept.stages_] == ["physics", "knn"]
    assert kept.dropped_stages_ == []

    dropped = HybridBoostingRegressor(
        stages, stage_input="window", drop_unhelpful_stages=True
    ).fit(X, y)
    assert dropped.dropped_stages_ == ["knn"]
    assert dropped.decompose(X).stage_names == ["physics"]
    assert_allclose(dropped.stage_scores_, kept.stage_scores_)
    assert_array_equal(dropped.predict(X), kept.decompose(X).physics)


# -- stage inputs --------------------------------------------------------------------
def _ar_windows(n_steps, n=300, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, size=(n, 1))
    x = np.zeros((n, 1))
    for t in range(n - 1):
        x[t + 1] = 0.7 * x[t] + 0.5 * u[t] + 0.05 * rng.standard_normal()
    return make_windows(x, u, n_steps=n_steps)


@pytest.mark.parametrize(
    "stage_input, width",
    [("window", 2), ("window+prediction", 3), ("window+prediction+residuals", 4)],
)
def test_stage_input_layout(stage_input, width):
    """Extra columns appended per step: pred_p then res_p (see the docstring)."""
    X, y = _ar_windows(n_steps=3)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel(n_steps=3)), ("rec", Recorder())],
        stage_input=stage_input,
        n_steps=3,
        validation_fraction=None,
    ).fit(X, y)
    Z = booster.stages_[1][1].X_fit_
    assert Z.shape == (X.shape[0], 3 * width)
    steps = Z.reshape(-1, 3, width)
    assert_array_equal(steps[:, :, :2], X.reshape(-1, 3, 2))
    if width == 2:
        return
    physics = booster.stages_[0][1]
    # pred_p: the physics' prediction from step p (it reads the newest step only,
    # so a sub-window ending at p gives it exactly).
    for p in range(3):
        sub = np.tile(X[:, 2 * p : 2 * p + 2], 3)
        assert_allclose(steps[:, p, 2], physics.predict(sub)[:, 0], atol=1e-12)
    if width == 4:
        for p in range(2):
            known = X[:, 2 * (p + 1)]  # state of step p + 1
            assert_allclose(steps[:, p, 3], known - steps[:, p, 2], atol=1e-12)
        assert_array_equal(steps[:, 2, 3], 0.0)


def test_stage_input_residuals_n_steps_1_has_no_residual_slot():
    X, y = _ar_windows(n_steps=1)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel()), ("rec", Recorder())]
    ).fit(X, y)
    Z = booster.stages_[1][1].X_fit_
    assert Z.shape[1] == X.shape[1] + 1
    assert_allclose(Z[:, -1], booster.stages_[0][1].predict(X[: Z.shape[0]])[:, 0])


def test_rnn_stage_on_augmented_windows():
    """An RNN stage reshapes the augmented rows cleanly (n_steps equal steps)."""
    X, y = _ar_windows(n_steps=4)
    booster = HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel(n_steps=4)),
            ("rnn", RNNRegressor(hidden_size=4, num_layers=1, n_steps=4, max_epochs=2)),
        ],
        n_steps=4,
        random_state=0,
    ).fit(X, y)
    assert booster.stages_[1][1].n_features_in_ == 4 * (2 + 1 + 1)
    parts = booster.decompose(X[:7])
    assert_allclose(parts.physics + parts.rnn, booster.predict(X[:7]), atol=1e-10)
    # Rows carry their own history: predictions do not depend on row order.
    perm = np.random.default_rng(0).permutation(X.shape[0])
    assert_allclose(booster.predict(X[perm]), booster.predict(X)[perm], atol=1e-12)


def test_n_steps_mismatch_raises():
    X, y = _ar_windows(n_steps=3)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel(n_steps=3)), ("nn", dense())], n_steps=3
    )
    booster.set_params(nn=RNNRegressor(n_steps=2))
    with pytest.raises(ValueError, match=r"nn__n_steps=3"):
        booster.fit(X, y)


@pytest.mark.parametrize(
    "stages, match",
    [
        ([], "at least one"),
        ([("total", LinearStateSpaceModel())], "reserved"),
        ([("a", LinearStateSpaceModel()), ("a", Recorder())], "not unique"),
        ([("a__b", LinearStateSpaceModel())], "__"),
        ([("a", LinearStateSpaceModel)], "instance"),
    ],
)
def test_bad_stages_raise(stages, match):
    X, y = make_additive(50, np.random.default_rng(0))
    with pytest.raises((ValueError, TypeError), match=match):
        HybridBoostingRegressor(stages).fit(X, y)


# -- parameters, composition, persistence ---------------------------------------------
def test_nested_params():
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel()), ("rnn", RNNRegressor())]
    )
    assert booster.get_params()["rnn__hidden_size"] == 50
    booster.set_params(rnn__hidden_size=32, rnn__objective="ljung_box")
    assert booster.named_stages.rnn.hidden_size == 32
    assert booster.named_stages.rnn.objective == "ljung_box"
    assert booster.get_params()["rnn__objective"] == "ljung_box"


def test_same_random_state_same_predictions(additive):
    (X, y), (Xt, _) = additive
    stages = [
        ("physics", LinearStateSpaceModel()),
        ("dense", DenseRegressor(hidden_layer_sizes=(8,), max_epochs=5)),
    ]
    a = HybridBoostingRegressor(stages, random_state=3).fit(X, y).predict(Xt)
    b = HybridBoostingRegressor(stages, random_state=3).fit(X, y).predict(Xt)
    c = HybridBoostingRegressor(stages, random_state=4).fit(X, y).predict(Xt)
    assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert stages[1][1].random_state is None  # the user's stage is left untouched


@pytest.mark.parametrize("n_jobs", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_pipeline_grid_search_clone_pickle_joblib(tmp_path, n_jobs):
    """Done-when: Pipeline, GridSearchCV(n_jobs=2), clone, pickle and joblib."""
    rng = np.random.default_rng(0)
    X, y = make_additive(300, rng)
    X = X * [10.0, 0.1] + [5.0, -1.0]  # badly scaled columns: the scaler matters
    stages = [
        ("physics", LinearStateSpaceModel()),
        ("dense", DenseRegressor(hidden_layer_sizes=(8,), max_epochs=5)),
    ]
    pipe = make_pipeline(StandardScaler(), HybridBoostingRegressor(stages))
    pipe.set_params(hybridboostingregressor__random_state=0)
    search = GridSearchCV(
        pipe,
        {"hybridboostingregressor__dense__objective": ["mse", "mse+ljung_box"]},
        cv=KFold(2),
        n_jobs=n_jobs,
    )
    search.fit(X, y)
    assert search.best_params_["hybridboostingregressor__dense__objective"] in (
        "mse",
        "mse+ljung_box",
    )
    model = search.best_estimator_
    expected = model.predict(X)

    refit = clone(model).fit(X, y)
    assert_array_equal(refit.predict(X), expected)

    assert_array_equal(pickle.loads(pickle.dumps(model)).predict(X), expected)
    path = tmp_path / "model.joblib"
    joblib.dump(model, path)
    assert_array_equal(joblib.load(path).predict(X), expected)


# -- noise models --------------------------------------------------------------------
def _ar1_data(n, phi, sigma, seed):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 2))
    e = ArmaProcess([1, -phi], [1]).generate_sample(
        n, scale=sigma, distrvs=rng.standard_normal, burnin=200
    )
    return X, 0.8 * X[:, 0] + 0.5 * X[:, 1] + e


def test_done_when_ar1_noise(global_random_seed):
    """Done-when: AR(1) coefficient within 0.05, sampled residual std within 5 %."""
    phi, sigma = 0.7, 0.1
    X, y = _ar1_data(5000, phi, sigma, global_random_seed)
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel())], noise_model="ar", random_state=0
    ).fit(X, y)
    noise = booster.noise_model_
    assert noise.lags_[0].tolist() == [1]
    assert abs(noise.coef_[0][0] - phi) < 0.05
    residual = y - booster.predict(X)
    drawn = booster.sample(X, random_state=global_random_seed) - booster.predict(X)
    assert abs(drawn.std() / residual.std() - 1) < 0.05
    # The AR model's stationary std is what predict reports.
    _, std = booster.predict(X[:5], return_std=True)
    assert abs(std[0] / residual.std() - 1) < 0.05
    # Its draws are autocorrelated like the residual.
    lag1 = np.corrcoef(drawn[:-1], drawn[1:])[0, 1]
    assert abs(lag1 - phi) < 0.05


def test_gaussian_noise_multi_output_covariance():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(3000, 3))
    cov = np.array([[0.04, 0.02], [0.02, 0.09]])
    e = rng.multivariate_normal([0, 0], cov, size=3000)
    Y = X[:, :2] @ np.array([[0.9, 0.1], [0.0, 0.8]]).T + e
    booster = HybridBoostingRegressor(
        [("physics", LinearStateSpaceModel())], noise_model="gaussian"
    ).fit(X, Y)
    assert_allclose(booster.noise_model_.cov_, cov, atol=0.01)
    draws = booster.sample(X, random_state=0) - booster.predict(X)
    assert draws.shape == (3000, 2)
    assert_allclose(np.cov(draws, rowvar=False), cov, atol=0.01)
    _, std = booster.predict(X[:4], return_std=True)
    assert std.shape == (4, 2)


def test_gaussian_noise_on_correlated_residual_warns():
    X, y = _ar1_data(1000, 0.9, 0.1, 0)
    with pytest.warns(NonWhiteResidualWarning, match="noise_model='ar'"):
        HybridBoostingRegressor(
            [("physics", LinearStateSpaceModel())], noise_model="gaussian"
        ).fit(X, y)


# -- the cyclic method ---------------------------------------------------------------
def test_cyclic_stage_inverse_predict():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(600, 2))
    y = 0.8 * X[:, 0] + 0.5 * X[:, 1] + 0.3 * np.sin(3 * X[:, 0])
    booster = HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel()),
            (
                "cyclic",
                CyclicRegressor(hidden_layer_sizes=(16,), max_epochs=20),
            ),
        ],
        random_state=0,
    ).fit(X, y)
    part = booster.decompose(X).cyclic
    X_rec = booster.inverse_predict(part)
    assert X_rec.shape == X.shape
    # The booster strips the columns it appended to the cyclic stage's input.
    stage = booster.stages_[1][1]
    full = stage.inverse_predict(part)
    assert full.shape == (X.shape[0], X.shape[1] + 1)
    assert_array_equal(X_rec, full[:, :2])
    assert np.all(np.isfinite(X_rec))
    with pytest.raises(ValueError, match="stage='physics'"):
        booster.inverse_predict(part, stage="physics")


def test_inverse_predict_without_cyclic_stage_raises(fitted):
    with pytest.raises(ValueError, match="CyclicRegressor"):
        fitted.inverse_predict(np.zeros(3))


# -- the decomposition Display (skhybrid.diagnostics) relies on decompose ------------
def test_decomposition_display_from_booster(fitted, additive, pyplot):
    from skhybrid.diagnostics import DecompositionDisplay

    _, (Xt, yt) = additive
    display = DecompositionDisplay.from_estimator(fitted, Xt[:100], yt[:100])
    assert {"physics", "dense", "total"} <= set(display.lines_)


# -- invariants ----------------------------------------------------------------------
@settings(max_examples=25, deadline=None)
@given(
    n_steps=st.integers(1, 3),
    n_outputs=st.integers(1, 2),
    n_inputs=st.integers(0, 2),
    stage_input=st.sampled_from(
        ["window", "window+prediction", "window+prediction+residuals"]
    ),
    seed=st.integers(0, 2**16),
)
def test_decompose_invariants(n_steps, n_outputs, n_inputs, stage_input, seed):
    """Parts sum to predict, staged_predict ends at predict, row order is free."""
    rng = np.random.default_rng(seed)
    width = n_outputs + n_inputs
    X = rng.standard_normal((60, n_steps * width))
    y = rng.standard_normal((60, n_outputs))
    y = y[:, 0] if n_outputs == 1 else y
    booster = HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel(n_steps=n_steps)),
            ("ridge", Ridge(alpha=1.0)),
            ("knn", KNeighborsRegressor(n_neighbors=3)),
        ],
        stage_input=stage_input,
        n_steps=n_steps,
    ).fit(X, y)
    parts = booster.decompose(X)
    total = sum(parts[name] for name in parts.stage_names)
    assert_allclose(total, booster.predict(X), rtol=0, atol=1e-10)
    assert_allclose(list(booster.staged_predict(X))[-1], parts.total, atol=1e-12)
    perm = rng.permutation(60)
    assert_allclose(booster.predict(X[perm]), booster.predict(X)[perm], atol=1e-10)


def test_decomposition_display_without_noise_model(pyplot):
    """The booster without a noise model still draws, with the residual band."""
    from skhybrid.diagnostics import DecompositionDisplay
    from skhybrid.hybrid import HybridBoostingRegressor

    rng = np.random.default_rng(0)
    X = rng.standard_normal((200, 2))
    y = X @ [1.0, -2.0] + np.sin(3 * X[:, 0]) + 0.1 * rng.standard_normal(200)
    booster = HybridBoostingRegressor(
        [("linear", Ridge()), ("ridge2", Ridge(alpha=10.0))], stage_input="window"
    ).fit(X, y)
    disp = DecompositionDisplay.from_estimator(booster, X[:50], y[:50])
    assert disp.figure_ is not None
