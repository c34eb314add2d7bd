"""HybridEnsembleRegressor: joint training of physics parameters and a network."""

import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from skorch.callbacks import Callback

from skhybrid.domain import LinearStateSpaceModel, ParametricModel
from skhybrid.exceptions import TrainingDivergedError
from skhybrid.hybrid import HybridEnsembleRegressor
from skhybrid.neural import DenseRegressor

DT = 0.05
K_TRUE, C_TRUE = 9.81, 0.5


def oscillator(X, *, k, c, xp=np):
    """One Euler step of a damped pendulum: rows [theta, omega, u]."""
    th, om, u = X[:, 0], X[:, 1], X[:, 2]
    return xp.stack([th + DT * om, om + DT * (-k * xp.sin(th) - c * om + u)], axis=1)


def oscillator_numpy_only(X, *, k, c):
    return oscillator(X, k=k, c=c)


def growth(X, *, k, xp=np):
    return xp.exp(k * X[:, :1])


def make_oscillator(n, seed, sigma=0.01):
    rng = np.random.default_rng(seed)
    X = np.column_stack(
        [rng.uniform(-2, 2, n), rng.uniform(-3, 3, n), rng.uniform(-2, 2, n)]
    )
    Y = oscillator(X, k=K_TRUE, c=C_TRUE) + sigma * rng.standard_normal((n, 2))
    return X, Y


def ensemble(**kwargs):
    params = dict(
        domain=ParametricModel(
            oscillator,
            {"k": 1.5 * K_TRUE, "c": 0.5 * C_TRUE},  # both start 50 % off
            bounds={"k": (0.0, 100.0), "c": (0.0, 10.0)},
        ),
        neural=DenseRegressor(hidden_layer_sizes=(8,)),
        max_epochs=60,
        batch_size=256,
        random_state=0,
    )
    params.update(kwargs)
    return HybridEnsembleRegressor(**params)


@pytest.fixture(scope="module")
def data():
    return make_oscillator(800, seed=0)


@pytest.fixture(scope="module")
def fitted(data):
    return ensemble().fit(*data)


def test_done_when_recovers_theta_within_5_percent(fitted):
    """Done-when: the physics is right, the parameters start 50 % off."""
    assert abs(fitted.params_["k"] / K_TRUE - 1) < 0.05
    assert abs(fitted.params_["c"] / C_TRUE - 1) < 0.05
    assert fitted.free_params_ == ["k", "c"]


def test_params_std_from_final_jacobian(fitted):
    std = fitted.params_std_
    assert set(std) == {"k", "c"}
    assert all(np.isfinite(v) and v > 0 for v in std.values())
    # Close to the least-squares errors of the physics alone (the network is small).
    ls_std = fitted.domain_.params_std_
    for name in std:
        assert 1 / 3 < std[name] / ls_std[name] < 3
    assert fitted.params_cov_.shape == (2, 2)
    # The truth lies within a few standard errors.
    assert abs(fitted.params_["k"] - K_TRUE) < 10 * std["k"] + 0.05 * K_TRUE


def test_decompose_sums_to_predict(fitted, data):
    X, _ = data
    parts = fitted.decompose(X[:50])
    assert parts.stage_names == ["domain", "neural"]
    assert parts.domain.shape == parts.neural.shape == (50, 2)
    assert_allclose(parts.domain + parts.neural, fitted.predict(X[:50]), atol=1e-10)
    assert_allclose(
        parts.domain, oscillator(X[:50], **fitted.params_), rtol=0, atol=1e-12
    )


def test_same_random_state_identical_predictions(data):
    X, Y = data
    a = ensemble(max_epochs=5).fit(X, Y).predict(X)
    b = ensemble(max_epochs=5).fit(X, Y).predict(X)
    c = ensemble(max_epochs=5, random_state=1).fit(X, Y).predict(X)
    assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_bounds_respected(data):
    X, Y = data
    model = ensemble(
        domain=ParametricModel(
            oscillator, {"k": 5.0, "c": 0.25}, bounds={"k": (1.0, 8.0)}
        ),
        max_epochs=20,
    ).fit(X, Y)
    assert 1.0 <= model.params_["k"] <= 8.0  # the truth, 9.81, is out of bounds


def test_fixed_params_held(data):
    X, Y = data
    model = ensemble(
        domain=ParametricModel(oscillator, {"k": 5.0, "c": 0.25}, fixed=("c",)),
        max_epochs=10,
    ).fit(X, Y)
    assert model.params_["c"] == 0.25
    assert model.params_std_["c"] == 0.0
    assert model.free_params_ == ["k"]
    assert abs(model.params_["k"] / K_TRUE - 1) < 0.2


def test_without_warm_start_starts_from_initial_values(data):
    X, Y = data
    model = ensemble(warm_start_domain=False, max_epochs=3).fit(X, Y)
    assert model.params_init_ == {"k": 1.5 * K_TRUE, "c": 0.5 * C_TRUE}
    # Training moved k towards the truth.
    assert abs(model.params_["k"] - K_TRUE) < abs(1.5 * K_TRUE - K_TRUE)


def test_divergence_names_lr():
    rng = np.random.default_rng(0)
    X = rng.uniform(0.5, 2.0, size=(100, 1))
    y = np.exp(2.0 * X[:, 0])
    model = HybridEnsembleRegressor(
        # One Adam step of lr * |k| pushes k up to 1e5: exp overflows.
        ParametricModel(growth, {"k": 1.0}),
        DenseRegressor(hidden_layer_sizes=(4,)),
        lr=1e5,
        max_epochs=20,
        warm_start_domain=False,
        random_state=0,
    )
    with pytest.raises(TrainingDivergedError, match=r"lr=100000"):
        model.fit(X, y)


def test_domain_without_xp_raises(data):
    X, Y = data
    model = ensemble(domain=ParametricModel(oscillator_numpy_only, {"k": 5, "c": 1}))
    with pytest.raises(ValueError, match="xp"):
        model.fit(X, Y)


def test_ljung_box_objective_on_contiguous_blocks(data):
    X, Y = data
    model = ensemble(objective="mse+ljung_box", ljung_box_lags=10, max_epochs=3)
    model.fit(X, Y)
    assert len(model.loss_curve_) == model.n_epochs_ <= 3
    with pytest.raises(ValueError, match="ljung_box_lags=300"):
        ensemble(objective="ljung_box", ljung_box_lags=300).fit(X, Y)


def test_linear_state_space_domain_and_pickle():
    rng = np.random.default_rng(0)
    X = rng.standard_normal((300, 3))
    # Every coefficient and offset non-zero: on exact data a zero one is fitted
    # at rounding level, and the identifiability check cannot tell its scale.
    A = np.array([[0.9, 0.1], [-0.2, 0.8]])
    Y = X[:, :2] @ A.T + 0.5 * X[:, 2:] + [0.3, -0.1]
    model = HybridEnsembleRegressor(
        LinearStateSpaceModel(),
        DenseRegressor(hidden_layer_sizes=(4,)),
        max_epochs=5,
        random_state=0,
    ).fit(X, Y)
    assert model.params_["A"].shape == (2, 2)
    assert model.params_std_["A"].shape == (2, 2)
    again = pickle.loads(pickle.dumps(model))
    assert_array_equal(again.predict(X), model.predict(X))


def test_decomposition_display_from_ensemble(fitted, data, pyplot):
    from skhybrid.diagnostics import DecompositionDisplay

    X, Y = data
    display = DecompositionDisplay.from_estimator(fitted, X[:100], Y[:100])
    assert {"domain", "neural", "total"} <= set(display.lines_)


class _BatchSizes(Callback):
    def initialize(self):
        self.sizes = []
        return self

    def on_batch_begin(self, net, batch=None, training=False, **kwargs):
        if training:
            self.sizes.append(len(batch[0]))


class _CtrlCAtEpoch(Callback):
    def __init__(self, epoch):
        self.epoch = epoch

    def on_epoch_end(self, net, **kwargs):
        if len(net.history) == self.epoch:
            raise KeyboardInterrupt


def test_ensemble_batches_are_of_equal_size(data):
    X, Y = data  # 800 rows: 640 train, 160 validate
    sizes = _BatchSizes()
    ensemble(max_epochs=2, callbacks=[sizes]).fit(X, Y)
    # 640 rows at batch_size=256: three batches of 213-214 rows, not 256, 256, 128.
    assert len(sizes.sizes) == 6 and sum(sizes.sizes[:3]) == 640
    assert max(sizes.sizes) - min(sizes.sizes) <= 1


def test_validation_slice_is_the_last_rows(data):
    X, Y = data
    model = ensemble(max_epochs=4, patience=None).fit(X, Y)
    assert model.n_epochs_ == 4 == len(model.validation_scores_)
    assert list(model.history_[:, "valid_loss"]) == model.validation_scores_
    # The validation loss is the objective on the last 20 % of the rows.
    stop = 640
    valid = model.validation_scores_[model.best_epoch_ - 1]
    r = (Y[stop:] - model.predict(X[stop:])) / model.y_scale_
    assert_allclose(np.mean(r**2), valid, rtol=1e-6)
    # Without a split the training loss is monitored.
    alone = ensemble(max_epochs=2, validation_fraction=0.0).fit(X, Y)
    assert alone.validation_scores_ is None
    assert "valid_loss" not in alone.history_[-1]


def test_early_stopping_on_validation_keeps_the_best_epoch(data):
    X, Y = data
    model = ensemble(max_epochs=200, patience=3, lr=0.05).fit(X, Y)
    assert model.n_epochs_ < 200
    scores = model.validation_scores_
    assert model.best_epoch_ == int(np.argmin(scores)) + 1
    assert model.n_epochs_ - model.best_epoch_ == 3


def test_physics_parameters_are_parameters_of_one_module(fitted):
    import torch

    module = fitted.net_.module_
    names = dict(module.named_parameters())
    assert "params.z" in names and any(k.startswith("net.") for k in names)
    with torch.no_grad():
        theta = module.theta().numpy()
    assert_allclose(theta, fitted.domain_.pack_params(fitted.params_))


def test_ctrl_c_keeps_the_best_state_and_warns(data):
    X, Y = data
    model = ensemble(max_epochs=50, callbacks=[_CtrlCAtEpoch(3)])
    with pytest.warns(UserWarning, match=r"interrupted \(Ctrl-C\) after 3 epochs"):
        model.fit(X, Y)
    assert model.n_epochs_ == 3
    assert model.predict(X[:5]).shape == (5, 2)


def test_diverging_refit_keeps_the_previous_model(data):
    X, Y = data
    model = ensemble(max_epochs=3).fit(X, Y)
    before, params = model.predict(X), dict(model.params_)
    model.set_params(lr=1e8)
    with pytest.raises(TrainingDivergedError):
        model.fit(X, Y)
    assert_array_equal(model.predict(X), before)
    assert model.params_ == params


def test_cuda_without_a_device_raises(data):
    import torch

    if torch.cuda.is_available():
        pytest.skip("a CUDA device is present")
    with pytest.raises(ValueError, match="device='cuda'"):
        ensemble(device="cuda").fit(*data)


@pytest.mark.parametrize(
    "params, match",
    [
        ({"validation_fraction": 1.0}, "validation_fraction"),
        ({"lr_factor": 2.0}, "lr_factor"),
        ({"device": "tpu"}, "device"),
        ({"neural": "dense"}, "neural"),
    ],
)
def test_bad_parameters_name_themselves(data, params, match):
    with pytest.raises(ValueError, match=match):
        ensemble(**params).fit(*data)


def test_horizon_rollout_equals_free_run_simulation():
    import torch

    from skhybrid.hybrid._ensemble import HybridRollout
    from skhybrid.preprocessing import WindowLayout

    rng = np.random.default_rng(0)
    Y, U = [], []
    for _ in range(3):
        u = np.repeat(rng.uniform(-1, 1, 6), 25)[:120, None]
        x = np.zeros((120, 2))
        for t in range(119):
            p, v = x[t]
            v2 = v + 0.05 * (-4 * p - 0.1 * v - p**3 + u[t, 0])
            x[t + 1] = [p + 0.05 * v2, v2]
        Y.append(x[:, :1] + 0.01 * rng.standard_normal((120, 1)))
        U.append(u)
    X, y = WindowLayout(1, 1, 3).make_rows(Y, U)
    model = HybridEnsembleRegressor(
        LinearStateSpaceModel(n_steps=3),
        DenseRegressor(hidden_layer_sizes=(8,)),
        horizon=4,
        max_epochs=3,
        batch_size=64,
        random_state=0,
    ).fit(X, y)
    rollout = model.net_.module_
    assert isinstance(rollout, HybridRollout)
    start = 10
    Z = np.concatenate([X[start], U[0][start + 3 : start + 6, 0]])
    with torch.no_grad():
        rollout.eval()
        out = rollout(torch.as_tensor(Z[None, :])).numpy().ravel()
    sim = model.simulate(U[0][: start + 7], Y[0][: start + 3])
    assert_allclose(out * model.y_scale_, sim[start + 3 : start + 7, 0], rtol=1e-6)
    with pytest.raises(ValueError, match="objective='mse' only"):
        model.set_params(objective="ljung_box", batch_size=100).fit(X, y)
    perm = np.random.default_rng(0).permutation(len(X))
    with pytest.raises(ValueError, match="horizon=4: no 4 consecutive rows"):
        model.set_params(objective="mse").fit(X[perm], y[perm])


class _CtrlC(Callback):
    """Raise KeyboardInterrupt (what Ctrl-C raises) at a batch of an epoch."""

    def __init__(self, epoch):
        self.epoch = epoch

    def on_batch_end(self, net, **kwargs):
        if len(net.history) >= self.epoch:
            raise KeyboardInterrupt


@pytest.mark.parametrize(
    "kwargs, epoch",
    [
        ({}, 3),
        # During the fine-tuning phase that follows the MSE pretraining.
        (
            {
                "objective": "mse+ljung_box",
                "mse_pretraining": True,
                "patience": 3,
                "ljung_box_lags": 5,
            },
            -2,
        ),
    ],
    ids=["mid-batch", "fine-tuning"],
)
def test_ctrl_c_during_a_refit_marks_the_model_and_warns(kwargs, epoch):
    def line(X, *, a, xp=np):
        return a * X[:, 1]

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (200, 2))
    y = np.sin(2 * X[:, 0]) + X[:, 1] + 0.1 * rng.standard_normal(200)
    model = HybridEnsembleRegressor(
        ParametricModel(line, {"a": 0.5}),
        DenseRegressor((8,)),
        max_epochs=20,
        random_state=0,
        **kwargs,
    ).fit(X, y)
    assert model.interrupted_ is False
    epoch = epoch if epoch > 0 else model.n_epochs_ + epoch
    with pytest.warns(UserWarning, match="interrupted"):
        model.set_params(callbacks=[_CtrlC(epoch)]).fit(X, y)
    assert model.interrupted_ is True
    assert model.n_epochs_ == epoch - 1  # cut during the epoch-th epoch
    assert np.all(np.isfinite(model.predict(X)))
