"""StateSpaceHybridRegressor: contract, determinism, errors, transactions.

The DC motor comparison with the physics alone and the windowed hybrids is
benchmarks/bench_state_space_hybrid.py; the slow test runs it.
"""

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from sklearn.base import clone

from skhybrid.domain import StateSpaceModel
from skhybrid.exceptions import TrainingDivergedError
from skhybrid.hybrid import StateSpaceHybridRegressor
from skhybrid.hybrid._state_space_module import ACTIVATIONS
from skhybrid.preprocessing import make_windows

# These tests train a few epochs on toy records to check the contract, not the
# correction: where it does not beat the physics the hybrid says so
# (UnhelpfulCorrectionWarning), which the tests of that guarantee check.
pytestmark = pytest.mark.filterwarnings(
    "ignore::skhybrid.exceptions.UnhelpfulCorrectionWarning"
)


def decay(x, u, *, xp, a):
    return a * x + u


def oscillator(x, u, *, xp, omega):
    return xp.stack([x[:, 1], -(omega**2) * x[:, 0] + u[:, 0]], axis=1)


def _records(n=4, length=80, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n, length, 1))
    y = np.zeros((n, length, 1))
    for t in range(length - 1):
        y[:, t + 1] = 0.8 * y[:, t] + u[:, t] + 0.1 * np.sin(3 * y[:, t])
    return u, y


def _physics(**kwargs):
    return StateSpaceModel(
        decay, {"a": 0.5}, state_names=["y"], observed=["y"], time="discrete", **kwargs
    )


def _model(**kwargs):
    params = dict(n_init=3, horizon=5, max_epochs=4, random_state=0)
    params.update(kwargs)
    return StateSpaceHybridRegressor(_physics(), **params)


def test_simulate_contract_and_forms():
    u, y = _records()
    model = _model().fit_simulation(u, y)
    sim = model.simulate(u, y[:, :5])
    assert sim.shape == y.shape
    np.testing.assert_array_equal(sim[:, :5], y[:, :5])
    assert np.all(np.isfinite(sim))
    as_list = model.simulate([u[0], u[1][:50]], [y[0, :3], y[1, :4]])
    assert [a.shape for a in as_list] == [(80, 1), (50, 1)]
    np.testing.assert_allclose(as_list[0], model.simulate(u[0], y[0, :3]))
    assert model.simulate(u[0], y[0, :3]).shape == (80, 1)


def test_improves_on_the_physics_it_starts_from():
    u, y = _records(n=6, length=120)
    model = _model(max_epochs=40, lr=3e-3, horizon=10, patience=40).fit_simulation(u, y)
    ut, yt = _records(n=3, length=120, seed=1)
    physics = _physics(n_init=3).fit_simulation(u, y)
    err_physics = np.sqrt(np.mean((physics.simulate(ut, yt[:, :3]) - yt) ** 2))
    err_hybrid = np.sqrt(np.mean((model.simulate(ut, yt[:, :3]) - yt) ** 2))
    assert err_hybrid < err_physics


def test_observed_states_start_from_the_last_measured_sample():
    # A prior far off (the physics' estimate is biased wherever the physics is
    # wrong) moves only the latent states; the observed ones start measured.
    u, y = _records()
    model = _model(lr=1e-12, max_epochs=1, physics_initial_state=True)
    model.fit_simulation(u, y)
    import torch

    Yw, Uw = torch.as_tensor(y[:, :3]), torch.as_tensor(u[:, :2])
    prior = torch.full((len(y), 1), 50.0, dtype=torch.float64)
    with torch.no_grad():
        x = model.module_.encode(Yw, Uw, prior)
    np.testing.assert_allclose(x.numpy(), y[:, 2], atol=1e-8)


def test_auto_stride_takes_a_sub_sequence_every_quarter_horizon(monkeypatch):
    seen = {}
    original = StateSpaceHybridRegressor._fit_windows

    def spy(self, physics, Ytr, *args):
        seen[self.stride] = len(Ytr)
        return original(self, physics, Ytr, *args)

    monkeypatch.setattr(StateSpaceHybridRegressor, "_fit_windows", spy)
    u, y = _records(n=1, length=1200)
    for stride in ("auto", 2, 1):
        _model(horizon=8, stride=stride, max_epochs=1).fit_simulation(u, y)
    # 960 training samples (the last fifth validates): (960 - 11) // 2 + 1
    # starts at a quarter horizon, enough for about 500 sub-sequences.
    assert seen == {1: 950, 2: 475, "auto": 475}
    # A short record gives too few at a quarter horizon: one at every sample.
    seen.clear()
    u, y = _records(n=1, length=120)
    for stride in ("auto", 2):
        _model(horizon=8, stride=stride, max_epochs=1).fit_simulation(u, y)
    assert seen == {2: 43, "auto": 86}


def test_same_seed_same_model():
    u, y = _records()
    a = _model().fit_simulation(u, y).simulate(u, y[:, :3])
    b = _model().fit_simulation(u, y).simulate(u, y[:, :3])
    np.testing.assert_array_equal(a, b)


def test_train_physics_false_holds_the_warm_start():
    u, y = _records()
    model = _model(train_physics=False).fit_simulation(u, y)
    assert model.params_ == pytest.approx(model.physics_.params_)
    assert model.params_init_ == pytest.approx(model.physics_.params_)


def test_physics_lr_sets_the_physical_parameters_own_rate():
    u, y = _records()
    settings = dict(max_epochs=10, lr=0.01, patience=None)
    held = _model(physics_lr=0.0, **settings).fit_simulation(u, y)
    assert held.params_ == pytest.approx(held.params_init_, abs=0, rel=0)
    # The history reports the networks' rate.
    assert held.history_[0, "event_lr"] == 0.01
    moved = {
        rate: abs(
            _model(physics_lr=rate, **settings).fit_simulation(u, y).params_["a"]
            - held.params_init_["a"]
        )
        for rate in (1e-5, None)
    }
    # Adam moves ``a`` about ``rate * |a|`` per step: the networks' rate moves it
    # far more than a hundredth of it.
    assert 0 < moved[1e-5] < moved[None] / 10


@pytest.mark.parametrize("physics_lr", [-1e-3, "fast"])
def test_bad_physics_lr_is_named(physics_lr):
    u, y = _records()
    with pytest.raises((ValueError, TypeError), match="physics_lr"):
        _model(physics_lr=physics_lr).fit_simulation(u, y)


def _hidden_mode(n, length, seed):
    # The output's decay misses a slow state w that the input drives.
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n, length, 1))
    y, w = np.zeros((n, length, 1)), np.zeros((n, 1))
    for t in range(length - 1):
        y[:, t + 1] = 0.7 * y[:, t] + u[:, t] + 0.5 * w
        w = 0.97 * w + 0.2 * u[:, t]
    return u, y


def test_augmented_states_carry_a_state_the_physics_lacks():
    u, y = _hidden_mode(8, 200, 0)
    ut, yt = _hidden_mode(4, 200, 1)
    errors = {}
    for n_aug in (0, 1):
        model = _model(
            n_init=10, horizon=30, n_augmented_states=n_aug, max_epochs=100
        ).fit_simulation(u, y)
        sim = model.simulate(ut, yt[:, :10])
        errors[n_aug] = np.sqrt(np.mean((sim - yt)[:, 10:] ** 2))
    # Measured: 0.33 without, 0.03 with the augmented state.
    assert errors[1] < 0.3 * errors[0]


def test_augmented_states_start_as_the_physics():
    # Before training, a hybrid with augmented states simulates as one without.
    u, y = _records()
    start = dict(lr=1e-12, max_epochs=1)
    plain = _model(**start).fit_simulation(u, y)
    model = _model(n_augmented_states=2, **start).fit_simulation(u, y)
    assert model.best_epoch_ == plain.best_epoch_ == 0
    for init in ("measured", "least_squares"):
        np.testing.assert_allclose(
            model.simulate(u, y[:, :5], init=init),
            plain.simulate(u, y[:, :5], init=init),
            atol=1e-10,
        )


@pytest.mark.parametrize("value", [-1, 1.5, "two"])
def test_bad_n_augmented_states_is_named(value):
    u, y = _records()
    with pytest.raises((ValueError, TypeError), match="n_augmented_states"):
        _model(n_augmented_states=value).fit_simulation(u, y)


def test_bounded_parameters_start_at_their_values_however_near_a_bound():
    from skhybrid.hybrid._parameters import BoundedParameters

    theta0 = np.array([5e-11, 2.0, -3e-12, 0.3, 1.5, 5e-11, 0.5 - 5e-11])
    lower = np.array([0.0, 0.0, -np.inf, 0.0, -np.inf, 0.0, 0.0])
    upper = np.array([np.inf, np.inf, 0.0, 1.0, np.inf, 0.5, 0.5])
    params = BoundedParameters(theta0, lower, upper)
    values = params().detach().numpy()
    np.testing.assert_allclose(values, theta0, rtol=1e-9)
    # The gap to the nearest bound, not only the value, starts where it was.
    np.testing.assert_allclose(0.5 - values[-1], 5e-11, rtol=1e-3)


def test_latent_state_and_physics_free_encoder():
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (3, 100, 1))
    truth = StateSpaceModel(
        oscillator,
        {"omega": 2.0},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.1,
        fixed=("omega",),
    ).fit_simulation(u, np.zeros((3, 100, 1)))
    y = truth.simulate_from_state(u, [[0.3, 0.0], [0.0, 0.5], [-0.2, 0.1]])
    physics = StateSpaceModel(
        oscillator, {"omega": 1.8}, state_names=["p", "v"], observed=["p"], dt=0.1
    )
    for prior in (True, False):
        model = StateSpaceHybridRegressor(
            physics,
            n_init=5,
            horizon=10,
            max_epochs=3,
            encoder_epochs=3,
            physics_initial_state=prior,
            correction_states=["v"],
            random_state=0,
        ).fit_simulation(u, y)
        assert model.simulate(u, y[:, :5]).shape == y.shape


def test_windows_fit_predict_and_simulate():
    u, y = _records()
    X, target = make_windows(list(y), list(u), n_steps=3)
    model = StateSpaceHybridRegressor(
        _physics(), n_steps=3, max_epochs=3, random_state=0
    ).fit(X, target[:, 0])
    pred = model.predict(X[:5])
    assert pred.shape == (5,)
    assert model.simulate(u[0], y[0, :3]).shape == (80, 1)
    records = _model().fit_simulation(u, y)
    with pytest.raises(ValueError, match="n_init=3"):
        StateSpaceHybridRegressor(
            _physics(), n_init=3, n_steps=2, max_epochs=1
        ).fit_simulation(u, y).predict(make_windows(list(y), list(u), n_steps=2)[0])
    assert records.predict is not None


def test_predict_gives_torch_no_read_only_array(monkeypatch):
    """A read-only X (a memmap) is copied before torch shares its memory.

    torch.as_tensor over a non-writable array makes a writable tensor over
    read-only memory (torch warns once per process, so the warning itself cannot
    be asserted here): every array predict hands torch must be writable.
    """
    import torch

    u, y = _records()
    X, target = make_windows(list(y), list(u), n_steps=3)
    model = StateSpaceHybridRegressor(
        _physics(), n_steps=3, max_epochs=2, random_state=0
    ).fit(X, target[:, 0])
    expected = model.predict(X)
    as_tensor = torch.as_tensor
    read_only = []

    def checked(data, *args, **kwargs):
        if isinstance(data, np.ndarray) and not data.flags.writeable:
            read_only.append(data.shape)
        return as_tensor(data, *args, **kwargs)

    monkeypatch.setattr(torch, "as_tensor", checked)
    X_read_only = X.copy()
    X_read_only.setflags(write=False)
    np.testing.assert_array_equal(model.predict(X_read_only), expected)
    assert read_only == []


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"correction_states": ["nope"]}, r"correction_states=\['nope'\]"),
        ({"corrected_states": [3]}, r"corrected_states=\[3\]"),
        ({"hidden_layer_sizes": (0,)}, r"hidden_layer_sizes=\(0,\)"),
        ({"horizon": 500}, r"n_init \+ horizon = 3 \+ 500"),
        ({"correction_form": "state"}, r"correction_form"),
        ({"activation": "sigmoid"}, r"activation.*'sigmoid'"),
        ({"validation_split": "head"}, r"validation_split"),
        ({"stride": "every"}, r"stride"),
        ({"stride": 0}, r"stride"),
    ],
)
def test_bad_settings_raise_naming_parameter_and_value(kwargs, match):
    u, y = _records()
    with pytest.raises(ValueError, match=match):
        _model(**kwargs).fit_simulation(u, y)


@pytest.mark.parametrize("activation", ["relu", "elu", "silu"])
def test_activation_is_the_correction_networks(activation):
    u, y = _records()
    model = _model(activation=activation, max_epochs=2).fit_simulation(u, y)
    correction = model.module_.correction
    kinds = {type(layer).__name__ for layer in correction}
    assert kinds == {"Linear", ACTIVATIONS[activation].__name__}
    # The encoder keeps its tanh; only the correction's hidden layers change.
    assert "Tanh" in {type(layer).__name__ for layer in model.module_.encoder}
    assert np.all(np.isfinite(model.simulate(u, y[:, :3])))


def test_solve_ivp_physics_is_rejected():
    physics = StateSpaceModel(
        oscillator,
        {"omega": 2.0},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.1,
        method="solve_ivp",
    )
    u, y = _records()
    with pytest.raises(ValueError, match="method='solve_ivp'"):
        StateSpaceHybridRegressor(physics, n_init=3, horizon=5).fit_simulation(u, y)


def test_simulate_needs_n_init_samples():
    u, y = _records()
    model = _model().fit_simulation(u, y)
    with pytest.raises(ValueError, match="n_init=3"):
        model.simulate(u[0], y[0, :2])


@pytest.mark.parametrize(
    "kwargs", [{}, {"validation_split": "records", "validation_fraction": 0.34}]
)
def test_records_too_short_to_use_are_named(kwargs):
    # A record shorter than n_init was dropped without a word (and, held out
    # for validation, failed inside torch with a shape mismatch).
    u, y = _records(n=3)
    U, Y = [u[0], u[1], u[2][:2]], [y[0], y[1], y[2][:2]]
    model = _model(warm_start_physics=False, **kwargs)
    with pytest.warns(UserWarning, match=r"uses none of record 2 \(2 samples, fewer"):
        model.fit_simulation(U, Y)
    assert np.all(np.isfinite(model.simulate(u[0], y[0, :3])))


def test_records_all_too_short_raise_with_their_lengths():
    u, y = _records(n=2)
    with pytest.raises(ValueError, match=r"n_init \+ horizon = 3 \+ 5 = 8.*\[6, 7\]"):
        _model(warm_start_physics=False).fit_simulation(
            [u[0, :6], u[1, :7]], [y[0, :6], y[1, :7]]
        )


def test_diverging_training_raises():
    u, y = _records()
    model = _model(lr=1e4, max_epochs=20, correction_scale=10.0, patience=20)
    with pytest.raises(TrainingDivergedError):
        model.fit_simulation(u, y)


def test_unstable_validation_run_is_not_a_diverged_training(monkeypatch):
    # The validation tails run free far beyond the horizon, where a model can be
    # unstable for a few epochs while its training is sound: such an epoch is
    # not kept, and training goes on; only the training loss stops a blow-up.
    from skhybrid.neural import engine

    u, y = _records()
    calls = []
    original = engine.training_callbacks

    def spy(est, monitor, free_run_validation=False):
        calls.append(free_run_validation)
        return original(est, monitor, free_run_validation)

    monkeypatch.setattr(engine, "training_callbacks", spy)
    model = _model(validation_fraction=0.3).fit_simulation(u, y)
    check = dict(model.net_.callbacks_)["divergence_check"]
    assert calls[-1] is True and check.keys == ("train_loss",)

    # A history whose validation loss blows up passes; its training loss not.
    def end_epoch(epoch, train_loss, valid_loss):
        row = {"epoch": epoch, "train_loss": train_loss, "valid_loss": valid_loss}
        check.on_epoch_end(SimpleNamespace(history=[row]))

    check.on_train_begin(model.net_)
    end_epoch(1, 0.5, 0.4)
    end_epoch(2, 0.4, 1e12)
    with pytest.raises(TrainingDivergedError, match="train loss grew"):
        end_epoch(3, 1e12, 0.3)


def test_interrupt_leaves_previous_model(monkeypatch):
    u, y = _records()
    model = _model().fit_simulation(u, y)
    before = model.simulate(u, y[:, :3])
    state = dict(model.__dict__)

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(StateSpaceHybridRegressor, "_train", interrupt)
    with pytest.raises(KeyboardInterrupt):
        model.set_params(horizon=4).fit_simulation(u, y)
    with pytest.raises(KeyboardInterrupt):
        X, target = make_windows(list(y), list(u), n_steps=1)
        model.fit(X, target[:, 0])
    assert model.__dict__.keys() == state.keys()
    np.testing.assert_array_equal(model.simulate(u, y[:, :3]), before)


@pytest.mark.slow
def test_dc_motor_state_space_hybrid_beats_physics_and_windowed_models():
    """Issue 14: the state-space hybrid beats the three others in free run.

    The benchmark itself (benchmarks/bench_state_space_hybrid.py, seed 0, its full
    budget: about 2 minutes on 2 cores): on the held-out records' free runs the
    hybrid (horizon chosen on the training records' validation tails) has a
    lower load-angle RMSE than the physics alone, the windowed hybrid trained
    one step ahead and the network alone. With a much smaller budget (10 epochs,
    4 records) the hybrid is not better than its physics; see the guide.
    """
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_state_space_hybrid import run

    results = run(verbose=False)
    hybrid = next(v for k, v in results.items() if k.startswith("state-space"))
    others = [v for k, v in results.items() if not k.startswith("state-space")]
    assert len(others) == 3
    assert all(np.isfinite(others))
    assert hybrid < min(others)


def _zero_network_but_bias(module, bias):
    import torch

    with torch.no_grad():
        for layer in module:
            if isinstance(layer, torch.nn.Linear):
                layer.weight.zero_()
                layer.bias.zero_()
        layer.bias.copy_(torch.as_tensor(bias))


def test_rhs_correction_is_integrated_with_the_physics():
    """correction_form="rhs" adds c * S / dt * net to dx/dt inside the RK4 steps."""
    import torch

    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (3, 60, 1))
    truth = StateSpaceModel(
        oscillator,
        {"omega": 2.0},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.1,
        n_substeps=3,
        fixed=("omega",),
    ).fit_simulation(u, np.zeros((3, 60, 1)))
    y = truth.simulate_from_state(u, np.zeros((3, 2)))
    model = StateSpaceHybridRegressor(
        truth,
        n_init=4,
        horizon=5,
        max_epochs=1,
        correction_form="rhs",
        train_physics=False,
        # Trained from the physics exactly, so that one epoch is not replaced
        # by the physics (whose module has no correction to test).
        physics_initial_state=True,
        random_state=0,
    ).fit_simulation(u, y)
    bias = np.array([0.0, 0.7])
    _zero_network_but_bias(model.correction_, bias)
    rate = model.correction_scale * model.step_scale_ * bias / 0.1

    def pushed(x, u, *, xp, omega):
        return oscillator(x, u, xp=xp, omega=omega) + xp.asarray(rate)

    reference = StateSpaceModel(
        pushed,
        {"omega": 2.0},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.1,
        n_substeps=3,
        fixed=("omega",),
    ).fit_simulation(u, y)
    x = rng.normal(size=(5, 2))
    with torch.no_grad():
        got = model.module_.advance(
            torch.as_tensor(x), torch.as_tensor(u[0, :5]), model._params_t
        ).numpy()
    np.testing.assert_allclose(got, reference.step(x, u[0, :5]), rtol=1e-12)
    # The "step" form adds the same correction after the step instead (the
    # fitted module holds the form it was built with).
    model.module_.continuous_correction = False
    with torch.no_grad():
        after = model.module_.advance(
            torch.as_tensor(x), torch.as_tensor(u[0, :5]), model._params_t
        ).numpy()
    expected = (
        truth.step(x, u[0, :5]) + model.correction_scale * model.step_scale_ * bias
    )
    np.testing.assert_allclose(after, expected, rtol=1e-12)
    assert not np.allclose(got, after)


def test_rhs_and_step_corrections_agree_on_discrete_physics():
    u, y = _records()
    a = _model(correction_form="rhs").fit_simulation(u, y).simulate(u, y[:, :3])
    b = _model(correction_form="step").fit_simulation(u, y).simulate(u, y[:, :3])
    np.testing.assert_array_equal(a, b)


def test_validation_split_records_holds_out_whole_records(monkeypatch):
    u, y = _records(n=4, length=80)
    seen = {}
    original = StateSpaceHybridRegressor._train

    def spy(self, module, windows_train, windows_valid, *args):
        seen["train"], seen["valid"] = windows_train[0], windows_valid[0]
        return original(self, module, windows_train, windows_valid, *args)

    monkeypatch.setattr(StateSpaceHybridRegressor, "_train", spy)
    _model(validation_split="records", validation_fraction=0.25).fit_simulation(u, y)
    np.testing.assert_array_equal(seen["valid"], y[3:])  # the last record, whole
    assert len(seen["train"]) == 3 * (80 - (3 + 5) + 1)  # the others, no tail
    _model(validation_fraction=0.25).fit_simulation(u, y)
    np.testing.assert_array_equal(seen["valid"], y[:, 60:])  # "tail": every tail


def test_validation_split_records_needs_a_record_to_train_on():
    u, y = _records(n=1)
    with pytest.raises(ValueError, match=r"validation_split='records'.*1 record"):
        _model(validation_split="records").fit_simulation(u, y)


def test_simulate_from_state_starts_as_its_physics_and_keeps_its_correction():
    u, y = _records(n=6, length=120)
    ut, yt = _records(n=3, length=120, seed=1)
    start = np.zeros((3, 1))  # the records start at rest: their true state
    # Untrained, the correction is zero: the physics' own run at params_.
    untrained = _model(max_epochs=1, lr=1e-12).fit_simulation(u, y)
    physics = untrained.physics_
    np.testing.assert_allclose(
        untrained.simulate_from_state(ut, start),
        physics.set_params(params=untrained.params_).simulate_from_state(ut, start),
        atol=1e-9,
    )
    # Trained, the run from the state carries the correction. (The missing
    # term is a bounded sine, which tanh fits in 40 epochs better than the
    # default SiLU: 0.60 against 0.75 of the physics' error.)
    model = _model(
        max_epochs=40, lr=3e-3, horizon=10, patience=40, activation="tanh"
    ).fit_simulation(u, y)
    fitted = _physics(n_init=3).fit_simulation(u, y)

    def rmse(sim):
        return np.sqrt(np.mean((sim - yt)[:, 3:] ** 2))

    err_hybrid = rmse(model.simulate_from_state(ut, start))
    assert err_hybrid < 0.7 * rmse(fitted.simulate_from_state(ut, start))
    # ... as well as its run from a measured window (measured: 0.0733, 0.0734).
    assert abs(err_hybrid - rmse(model.simulate(ut, yt[:, :3]))) < 0.05 * err_hybrid
    # Forms: one record, a list; the state estimated on a window.
    np.testing.assert_allclose(
        model.simulate_from_state(ut[0], [0.0]), model.simulate_from_state(ut, start)[0]
    )
    x0 = model.estimate_initial_state(ut[:, :3], yt[:, :3])
    assert x0.shape == (3, 1)
    runs = model.simulate_from_state([ut[0], ut[1][:50]], x0[:2])
    assert [r.shape for r in runs] == [(120, 1), (50, 1)]


def test_simulate_from_state_names_a_bad_state():
    u, y = _records()
    model = _model().fit_simulation(u, y)
    with pytest.raises(ValueError, match=r"states must have shape \(4, 1\)"):
        model.simulate_from_state(u, np.zeros((4, 2)))


def _exact_records(seed=0, n=4, length=100):
    # The physics (a = 0.8) is the whole truth: a correction can only fit noise.
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n, length, 1))
    y = np.zeros((n, length, 1))
    for t in range(length - 1):
        y[:, t + 1] = 0.8 * y[:, t] + u[:, t]
    return u, y + 0.05 * rng.standard_normal(y.shape)


@pytest.mark.parametrize("physics_initial_state", [True, False])
def test_a_correction_that_cannot_help_leaves_the_physics(physics_initial_state):
    from skhybrid.exceptions import UnhelpfulCorrectionWarning

    u, y = _exact_records()
    model = _model(
        n_init=5,
        horizon=10,
        lr=0.05,
        max_epochs=3,
        physics_initial_state=physics_initial_state,
        encoder_epochs=2,
    )
    # Without latent states the warning points to them, with them it does not.
    with pytest.warns(
        UnhelpfulCorrectionWarning,
        match=r"correction_helped_ is False.*latent states.*n_augmented_states=2",
    ):
        model.fit_simulation(u, y)
    assert model.correction_helped_ is False
    with pytest.warns(UnhelpfulCorrectionWarning) as record:
        clone(model).set_params(n_augmented_states=1).fit_simulation(u, y)
    assert not any("n_augmented_states=2" in str(w.message) for w in record)
    assert model.validation_loss_ <= model.physics_validation_loss_
    # On its validation pieces (the last 20 % of every record, simulated from
    # their first n_init samples) the hybrid is no worse than its physics.
    tail_u, tail_y = u[:, 80:], y[:, 80:]
    hybrid = model.simulate(tail_u, tail_y[:, :5])
    physics = model.physics_.simulate(tail_u, tail_y[:, :5])
    error = np.sqrt(np.mean((hybrid - tail_y)[:, 5:] ** 2))
    assert error <= np.sqrt(np.mean((physics - tail_y)[:, 5:] ** 2)) + 1e-12
    if not physics_initial_state:
        # The encoder's two epochs of pre-training leave the start far from
        # the physics' own state estimate: the hybrid becomes its physics.
        assert model.module_.physics_only
    if model.module_.physics_only:
        np.testing.assert_allclose(hybrid, physics, rtol=0, atol=1e-12)
        assert model.params_ == model.params_init_


def test_a_correction_that_helps_says_so():
    import warnings

    from skhybrid.exceptions import UnhelpfulCorrectionWarning

    u, y = _records(length=120)  # the physics misses 0.1 sin(3 y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnhelpfulCorrectionWarning)
        model = _model(horizon=10, max_epochs=20).fit_simulation(u, y)
    assert model.correction_helped_ is True
    assert model.best_epoch_ > 0
    assert model.validation_loss_ < model.physics_validation_loss_
    assert not model.module_.physics_only
