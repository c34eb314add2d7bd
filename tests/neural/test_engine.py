"""One training engine: shared parameters, one loop, the state-space hybrid on it."""

import inspect
import re
from pathlib import Path

import numpy as np
import pytest
from skorch.callbacks import Callback

import skhybrid
from skhybrid.domain import StateSpaceModel
from skhybrid.exceptions import TrainingDivergedError
from skhybrid.hybrid import HybridEnsembleRegressor, StateSpaceHybridRegressor
from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor
from skhybrid.neural.engine import TRAINING_PARAMETERS, training_constraints

# The state-space hybrids here train a few epochs to check the engine (Ctrl-C,
# refits, phases), not the correction: where it does not beat the physics the
# hybrid says so, which tests/hybrid checks.
pytestmark = pytest.mark.filterwarnings(
    "ignore::skhybrid.exceptions.UnhelpfulCorrectionWarning"
)

TRAINERS = [
    DenseRegressor,
    RNNRegressor,
    CyclicRegressor,
    HybridEnsembleRegressor,
    StateSpaceHybridRegressor,
]


def _documented(cls):
    """``{name: (type line, description)}`` of the class docstring's Parameters."""
    from numpydoc.docscrape import ClassDoc

    return {
        p.name: (p.type, " ".join(" ".join(p.desc).split()))
        for p in ClassDoc(cls)["Parameters"]
    }


@pytest.mark.parametrize("cls", TRAINERS, ids=lambda c: c.__name__)
def test_every_trainer_takes_the_shared_training_parameters(cls):
    signature = inspect.signature(cls.__init__).parameters
    constraints = cls._parameter_constraints
    docs = _documented(cls)
    shared = training_constraints()
    for name, spec in TRAINING_PARAMETERS.items():
        assert name in signature, f"{cls.__name__} lacks {name}"
        assert repr(constraints[name]) == repr(shared[name]), name
        kind, text = docs[name]
        assert kind.startswith(spec.kind), (name, kind)
        # The shared text, then (where the default differs) the reason.
        assert text.startswith(" ".join(spec.doc.split())), name
        default = signature[name].default
        literal = f'"{default}"' if isinstance(default, str) else repr(default)
        assert kind.endswith(f"default={literal}"), (cls.__name__, name, kind)
        if default != spec.default:
            assert len(text) > len(" ".join(spec.doc.split())) + 20, (
                f"{cls.__name__}.{name} defaults to {default!r} instead of "
                f"{spec.default!r} without saying why in its docstring"
            )


def test_only_the_state_space_hybrid_has_other_defaults_with_reasons():
    differing = {}
    for cls in TRAINERS:
        signature = inspect.signature(cls.__init__).parameters
        for name, spec in TRAINING_PARAMETERS.items():
            if signature[name].default != spec.default:
                differing.setdefault(cls.__name__, set()).add(name)
    # A batch of sub-sequences, epochs over simulated horizons, a patience set
    # on the missing-physics suite: see its docstring.
    assert differing == {
        "StateSpaceHybridRegressor": {
            "max_epochs",
            "batch_size",
            "patience",
            "lr_patience",
        }
    }


def test_gradient_steps_live_in_the_engine_only():
    root = Path(skhybrid.__file__).parent
    pattern = re.compile(r"optimizer\.step|\.step\(\)|\.backward\(")
    found = [
        str(path.relative_to(root))
        for path in root.rglob("*.py")
        if pattern.search(path.read_text())
    ]
    # The engine itself hands the loop to skorch: no module of ours steps.
    # The one backward pass of ours is the engine's own for fits trained in
    # lockstep (skorch's step, its backward run with the other members').
    assert found == ["neural/_lockstep.py"]
    lockstep = (root / "neural" / "_lockstep.py").read_text()
    assert not re.search(r"optimizer\.step|\.step\(\)", lockstep)


def _oscillator(x, u, *, xp, omega):
    return xp.stack([x[:, 1], -(omega**2) * x[:, 0] + u[:, 0]], axis=1)


def _records(n_records=4, n_times=80, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n_records, n_times, 1))
    truth = StateSpaceModel(
        _oscillator,
        {"omega": 2.0},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.1,
        n_substeps=2,
        fixed=("omega",),
    ).fit_simulation(u, np.zeros((n_records, n_times, 1)))
    y = truth.simulate_from_state(u, rng.normal(scale=0.3, size=(n_records, 2)))
    return u, y + 0.05 * np.tanh(3 * y)


def _physics():
    return StateSpaceModel(
        _oscillator,
        {"omega": 1.8},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.1,
        n_substeps=2,
        n_init=4,
        max_nfev=20,
    )


class Recorder(Callback):
    def initialize(self):
        self.epochs_ = 0
        return self

    def on_epoch_end(self, net, **kwargs):
        self.epochs_ += 1


class InterruptAt(Callback):
    def __init__(self, epoch):
        self.epoch = epoch

    def on_epoch_end(self, net, **kwargs):
        if len(net.history) >= self.epoch:
            raise KeyboardInterrupt


def test_state_space_hybrid_trains_on_the_engine(capsys):
    u, y = _records(n_times=100)
    recorder = Recorder()
    model = StateSpaceHybridRegressor(
        _physics(),
        n_init=4,
        horizon=12,
        hidden_layer_sizes=(8,),
        objective="mse+ljung_box",
        ljung_box_lags=5,
        ljung_box_weight=0.1,
        max_epochs=3,
        patience=None,
        device="cpu",
        callbacks=[recorder],
        verbose=1,
        random_state=0,
    ).fit_simulation(u, y)
    assert recorder.epochs_ == 3 == model.n_epochs_
    assert len(model.history_) == 3
    assert np.all(np.isfinite(model.history_[:, "valid_loss"]))
    assert 0 <= model.best_epoch_ <= 3
    assert "train_loss" in capsys.readouterr().out  # skorch's table of epochs
    assert model.simulate(u, y[:, :4]).shape == y.shape


def test_state_space_hybrid_objective_is_checked_against_its_horizon():
    u, y = _records()
    model = StateSpaceHybridRegressor(
        _physics(), n_init=4, horizon=10, objective="mse+ljung_box"
    )
    with pytest.raises(ValueError, match="ljung_box_lags=20 must be smaller"):
        model.fit_simulation(u, y)


def test_state_space_hybrid_mse_pretraining_then_ljung_box():
    u, y = _records(n_records=6, n_times=120, seed=1)
    kwargs = dict(
        n_init=4, horizon=40, hidden_layer_sizes=(8,), max_epochs=4, random_state=0
    )
    mse = StateSpaceHybridRegressor(_physics(), **kwargs).fit_simulation(u, y)
    lb = StateSpaceHybridRegressor(
        _physics(),
        objective="ljung_box",
        ljung_box_lags=5,
        mse_pretraining=True,
        **kwargs,
    ).fit_simulation(u, y)
    # Two phases in one history; the second starts from the first's best.
    assert lb.n_epochs_ > mse.n_epochs_
    assert np.all(np.isfinite(lb.simulate(u, y[:, :4])))


def test_state_space_hybrid_ctrl_c_keeps_the_best_epoch():
    u, y = _records()
    model = StateSpaceHybridRegressor(
        _physics(),
        n_init=4,
        horizon=10,
        hidden_layer_sizes=(8,),
        max_epochs=20,
        patience=None,
        callbacks=[InterruptAt(2)],
        random_state=0,
    )
    with pytest.warns(UserWarning, match="interrupted"):
        model.fit_simulation(u, y)
    assert model.n_epochs_ == 2
    assert model.best_epoch_ <= 2
    assert np.all(np.isfinite(model.simulate(u, y[:, :4])))


def test_state_space_hybrid_failed_refit_leaves_the_model_intact():
    u, y = _records()
    model = StateSpaceHybridRegressor(
        _physics(),
        n_init=4,
        horizon=10,
        hidden_layer_sizes=(8,),
        max_epochs=2,
        random_state=0,
    ).fit_simulation(u, y)
    before = model.simulate(u, y[:, :4])
    params = dict(model.params_)
    model.set_params(lr=1e12, max_epochs=5)
    with pytest.raises(TrainingDivergedError):
        model.fit_simulation(u, y)
    np.testing.assert_array_equal(model.simulate(u, y[:, :4]), before)
    assert model.params_ == params


def test_state_space_hybrid_same_seed_same_model():
    u, y = _records()
    kwargs = dict(n_init=4, horizon=10, hidden_layer_sizes=(8,), max_epochs=2)
    a = StateSpaceHybridRegressor(_physics(), random_state=3, **kwargs)
    b = StateSpaceHybridRegressor(_physics(), random_state=3, **kwargs)
    np.testing.assert_array_equal(
        a.fit_simulation(u, y).simulate(u, y[:, :4]),
        b.fit_simulation(u, y).simulate(u, y[:, :4]),
    )


def _rows(n=300, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (n, 2))
    return X, np.sin(2 * X[:, 0]) + X[:, 1]


def _interruptible(cls, callbacks):
    from skhybrid.domain import ParametricModel

    common = dict(max_epochs=30, patience=None, callbacks=callbacks, random_state=0)
    if cls is HybridEnsembleRegressor:

        def line(X, *, a, xp=np):
            return a * X[:, 1]

        return cls(ParametricModel(line, {"a": 0.5}), DenseRegressor((8,)), **common)
    if cls is StateSpaceHybridRegressor:
        return cls(_physics(), n_init=4, horizon=10, hidden_layer_sizes=(8,), **common)
    extra = {"n_steps": 1} if cls is RNNRegressor else {}
    return cls(**extra, **common).set_params(
        **{"hidden_layer_sizes": (8,)} if cls is not RNNRegressor else {}
    )


def _fit(model):
    if isinstance(model, StateSpaceHybridRegressor):
        u, y = _records()
        return model.fit_simulation(u, y)
    return model.fit(*_rows())


@pytest.mark.parametrize("cls", TRAINERS, ids=lambda c: c.__name__)
def test_ctrl_c_semantics_are_the_same_for_every_trainer(cls):
    done = _fit(_interruptible(cls, None))
    assert done.interrupted_ is False
    # A refit cut short by Ctrl-C replaces the previous model with the one cut
    # short (skorch's semantics), says so, and is usable.
    with pytest.warns(UserWarning, match="interrupted"):
        _fit(done.set_params(callbacks=[InterruptAt(2)]))
    assert done.interrupted_ is True
    assert done.n_epochs_ == 2
    assert 0 <= done.best_epoch_ <= 2


def test_a_booster_says_when_a_stage_was_cut_short():
    from skhybrid.domain import ParametricModel
    from skhybrid.hybrid import HybridBoostingRegressor

    def line(X, *, a, xp=np):
        return a * X[:, 1]

    X, y = _rows()
    stages = [
        ("physics", ParametricModel(line, {"a": 0.5})),
        ("dense", DenseRegressor((8,), max_epochs=30, random_state=0)),
    ]
    booster = HybridBoostingRegressor(stages).fit(X, y)
    assert booster.interrupted_ is False
    booster.set_params(dense__callbacks=[InterruptAt(2)])
    with pytest.warns(UserWarning, match="interrupted"):
        booster.fit(X, y)
    assert booster.interrupted_ is True
    assert booster["dense"].n_epochs_ == 2
