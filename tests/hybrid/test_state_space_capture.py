"""StateSpaceHybridRegressor's captured rollout (``compile_rollout``).

The forward pass traces whole (no graph break), a compiled training (the step
or the whole rollout) gives the eager one's history and weights, the fitted
model pickles without anything compiled, ``"auto"`` compiles the step only
where the training is long, a failed compilation falls back to eager with a
warning, and the training batches stay on the training device.
"""

import pickle

import numpy as np
import pytest
import torch
from numpy.testing import assert_allclose

from skhybrid.domain import StateSpaceModel
from skhybrid.hybrid import StateSpaceHybridRegressor
from skhybrid.hybrid._state_space import (
    COMPILE_MIN_STEPS,
    RECOMPILE_LIMIT,
    _room_for_recompiles,
)
from skhybrid.neural._callbacks import BatchIterator
from tests.hybrid.test_state_space_hybrid import _model, _records, oscillator

# The tiny fits here train a few epochs, where the correction rightly does not
# help and the output function's initial states may not converge.
pytestmark = [
    pytest.mark.filterwarnings(
        "ignore::skhybrid.exceptions.UnhelpfulCorrectionWarning"
    ),
    pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning"),
]

# The models are float64: a compiled training reorders a few floating-point
# operations (fused kernels), and the difference stays near rounding after a
# few epochs.
RTOL = 1e-9


def _position(x, *, xp, omega):
    return xp.sin(x[:, 0:1]) + 0.0 * omega


def _oscillator(**kwargs):
    return StateSpaceModel(
        oscillator,
        {"omega": 1.0},
        state_names=["p", "v"],
        dt=0.1,
        **{"observed": ["p"], **kwargs},
    )


HYBRIDS = {
    "discrete, augmented state": lambda: _model(n_augmented_states=1),
    "rk4, correction in the equations": lambda: StateSpaceHybridRegressor(
        _oscillator(n_substeps=2), correction_form="rhs", n_augmented_states=1
    ),
    "euler, physics' initial state": lambda: StateSpaceHybridRegressor(
        _oscillator(method="euler", fixed=("omega",)),
        physics_initial_state=True,
        train_physics=False,
    ),
    "output function": lambda: StateSpaceHybridRegressor(
        _oscillator(observed=None, output=_position)
    ),
}


def _fitted(make):
    u, y = _records()
    model = make().set_params(
        n_init=3, horizon=5, max_epochs=1, encoder_epochs=1, random_state=0
    )
    model.fit_simulation(u, y)
    module = model.module_
    prior = None
    if module.has_prior:
        prior = torch.zeros((len(y), module.n_physics_states), dtype=torch.float64)
    Z = module.pack(torch.as_tensor(y[:, :8]), torch.as_tensor(u[:, :8]), prior)
    return module, Z


@pytest.mark.parametrize("name", list(HYBRIDS))
def test_forward_pass_traces_without_graph_break(name):
    module, Z = _fitted(HYBRIDS[name])
    torch._dynamo.reset()
    explained = torch._dynamo.explain(module)(Z)
    assert explained.graph_break_count == 0, explained.break_reasons
    assert explained.graph_count == 1
    # One whole graph, run by dynamo's eager backend: the eager numbers.
    whole = torch.compile(module, fullgraph=True, backend="eager")
    with torch.no_grad():
        assert_allclose(whole(Z).numpy(), module(Z).numpy(), rtol=0, atol=0)
    # So does one sample's step, compiled alone with ``compile_rollout="step"``.
    Y, U, prior = module.unpack(Z)
    k = module.n_init
    x = module.encode(Y[:, :k], U[:, : k - 1], prior)
    params = module.physical_params()
    explained = torch._dynamo.explain(module.step)(x, U[:, k - 1], params)
    assert explained.graph_break_count == 0, explained.break_reasons


@pytest.mark.parametrize("kind", ["step", "whole"])
def test_compiled_training_matches_eager(kind):
    u, y = _records()
    eager = _model(compile_rollout=False, n_augmented_states=1).fit_simulation(u, y)
    torch._dynamo.reset()
    compiled = _model(compile_rollout=kind, n_augmented_states=1)
    compiled.fit_simulation(u, y)
    assert eager.rollout_compiled_ is None and compiled.rollout_compiled_ == kind
    assert_allclose(compiled.loss_curve_, eager.loss_curve_, rtol=RTOL)
    assert_allclose(compiled.validation_scores_, eager.validation_scores_, rtol=RTOL)
    state = eager.module_.state_dict()
    for name, value in compiled.module_.state_dict().items():
        assert_allclose(value.numpy(), state[name].numpy(), rtol=RTOL, atol=1e-12)
    # Fitted models are pickled (joblib): nothing compiled is left in them,
    # and the restored model simulates as the eager-trained twin does.
    assert type(compiled.module_) is type(eager.module_)
    assert "_compiled_module" not in compiled.net_.__dict__
    assert "_compiled_step" not in compiled.module_.__dict__
    restored = pickle.loads(pickle.dumps(compiled))
    assert_allclose(
        restored.simulate(u, y[:, :3]), eager.simulate(u, y[:, :3]), rtol=1e-7
    )


def test_a_compiled_step_is_neither_pickled_nor_lost_by_pickling():
    module, _ = _fitted(HYBRIDS["discrete, augmented state"])
    module.compile_step({})  # torch.compile compiles at the first call only
    restored = pickle.loads(pickle.dumps(module))
    assert "_compiled_step" in module.__dict__
    assert "_compiled_step" not in restored.__dict__
    module.compile_step(None)
    assert "_compiled_step" not in module.__dict__


def test_auto_compiles_the_step_only_for_a_long_training(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("torch.compile called for a short training")

    monkeypatch.setattr(torch, "compile", refuse)
    u, y = _records()
    model = _model(max_epochs=1).fit_simulation(u, y)
    assert model.compile_rollout == "auto" and model.rollout_compiled_ is None
    # The rule: batches per epoch, times the horizon, times max_epochs.
    model = _model(batch_size=10, horizon=20)
    n_sequences = 50  # 5 batches, 100 batch steps an epoch
    at_least = COMPILE_MIN_STEPS // 100
    compiles = model.set_params(max_epochs=at_least)._rollout_compilation(n_sequences)
    assert compiles == "step"
    assert (
        model.set_params(max_epochs=at_least - 1)._rollout_compilation(n_sequences)
        is None
    )
    assert model.set_params(compile_rollout=False)._rollout_compilation(10**9) is None
    assert model.set_params(compile_rollout="whole")._rollout_compilation(1) == "whole"
    assert model._compile_kwargs("whole") == {}
    on_gpu = _model(device="cuda", compile_rollout="whole")
    assert on_gpu._compile_kwargs("whole") == {"mode": "reduce-overhead"}
    assert on_gpu._compile_kwargs("step") == {}


def test_a_training_has_room_for_a_workers_graphs(monkeypatch):
    # A worker of a search compiles one graph per architecture, batch size and
    # grad mode; torch's default of 8 would leave its later fits eager.
    seen = []
    original = StateSpaceHybridRegressor._train_jointly

    def spy(self, *args):
        seen.append(torch._dynamo.config.recompile_limit)
        return original(self, *args)

    monkeypatch.setattr(StateSpaceHybridRegressor, "_train_jointly", spy)
    before = torch._dynamo.config.recompile_limit
    u, y = _records()
    _model(compile_rollout="step").fit_simulation(u, y)
    assert seen == [RECOMPILE_LIMIT] and RECOMPILE_LIMIT > 8
    # An eager training leaves torch's configuration alone.
    _model(compile_rollout=False).fit_simulation(u, y)
    assert seen[1:] == [before]
    assert torch._dynamo.config.recompile_limit == before
    with _room_for_recompiles():
        assert torch._dynamo.config.recompile_limit == RECOMPILE_LIMIT
    assert torch._dynamo.config.recompile_limit == before


@pytest.mark.parametrize("kind", ["step", "whole"])
def test_failed_compilation_warns_and_trains_eagerly(kind, monkeypatch):
    # Inductor without a C++ compiler fails at the first call, as here.
    def failing_compile(function, **kwargs):
        def compiled(*args):
            error = torch._dynamo.exc.BackendCompilerFailed.__new__(
                torch._dynamo.exc.BackendCompilerFailed
            )
            Exception.__init__(error, "inductor: no C++ compiler")
            raise error

        return compiled

    u, y = _records()
    eager = _model(compile_rollout=False).fit_simulation(u, y)
    monkeypatch.setattr(torch, "compile", failing_compile)
    what = {"step": "the hybrid's step", "whole": "the network's forward pass"}
    with pytest.warns(UserWarning, match=f"could not compile {what[kind]}"):
        fallen = _model(compile_rollout=kind).fit_simulation(u, y)
    assert fallen.rollout_compiled_ == kind
    assert_allclose(fallen.loss_curve_, eager.loss_curve_, rtol=0)
    assert np.isfinite(fallen.loss_curve_).all()


@pytest.mark.parametrize("value", ["yes", "rollout", True, 1, None])
def test_invalid_compile_rollout_raises(value):
    u, y = _records()
    with pytest.raises(ValueError, match=rf"'compile_rollout'.*Got {value!r}"):
        _model(compile_rollout=value).fit_simulation(u, y)


def test_batches_stay_on_the_training_device(monkeypatch):
    # The sub-sequences are packed on the device once (``_train``); skorch's
    # iteration slices that tensor batch by batch, never copying it back.
    seen = []
    original = BatchIterator.__iter__

    def spy(self):
        for batch in original(self):
            seen.append((self.dataset.X, *batch))
            yield batch

    monkeypatch.setattr(BatchIterator, "__iter__", spy)
    u, y = _records()
    model = _model(max_epochs=3, encoder_epochs=0).fit_simulation(u, y)
    device = torch.device(model.device)
    assert seen
    data = {id(whole) for whole, _, _ in seen}
    # One training tensor and one validation tensor, the same every epoch.
    assert len(data) == 2
    for whole, Xi, yi in seen:
        assert isinstance(whole, torch.Tensor) and whole.device == device
        assert isinstance(Xi, torch.Tensor) and Xi.device == device
        assert isinstance(yi, torch.Tensor) and yi.device == device


@pytest.mark.gpu
def test_cuda_captured_training_matches_cpu_eager():
    if not torch.cuda.is_available():
        pytest.skip("needs CUDA")
    u, y = _records()
    cpu = _model(compile_rollout=False).fit_simulation(u, y)
    torch._dynamo.reset()
    gpu = _model(device="cuda", compile_rollout="whole").fit_simulation(u, y)
    assert gpu.rollout_compiled_ == "whole"
    # float64 on both; CUDA's reductions add in another order.
    assert_allclose(gpu.loss_curve_, cpu.loss_curve_, rtol=1e-6)
    assert next(gpu.module_.parameters()).device.type == "cpu"
    restored = pickle.loads(pickle.dumps(gpu))
    assert_allclose(
        restored.simulate(u, y[:, :3]), cpu.simulate(u, y[:, :3]), rtol=1e-6
    )
