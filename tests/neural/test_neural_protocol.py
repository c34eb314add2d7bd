"""The training protocol shared by the neural regressors (BaseNeuralRegressor)."""

import pickle

import numpy as np
import pytest
import torch
from numpy.testing import assert_allclose, assert_array_equal
from skorch.callbacks import Callback

from skhybrid.exceptions import TrainingDivergedError
from skhybrid.neural import CyclicRegressor, DenseRegressor, RNNRegressor
from skhybrid.neural._callbacks import BatchIterator

TINY = dict(max_epochs=4, batch_size=32, lr=0.01)


def _tiny(cls, **params):
    arch = {
        DenseRegressor: dict(hidden_layer_sizes=(8,)),
        CyclicRegressor: dict(hidden_layer_sizes=(8,)),
        RNNRegressor: dict(hidden_size=4, num_layers=1),
    }[cls]
    return cls(**{**arch, **TINY, **params})


def _assert_best_epoch_kept(model, monitor):
    """The kept epoch is the best: no later one beat it by early stopping's margin.

    skorch's early stopping counts an epoch as better only where it improves
    on the best so far by more than its relative threshold (1e-4), so the kept
    epoch's loss may exceed a later one's by less than that.
    """
    losses = np.asarray(model.history_[:, monitor])
    best = losses[model.best_epoch_ - 1]
    assert best <= losses[: model.best_epoch_].min()
    assert np.all(losses[model.best_epoch_ :] >= best * (1 - 1e-4))


@pytest.fixture
def data(rng):
    X = rng.uniform(-1, 1, size=(200, 3))
    y = X[:, 0] - 2 * X[:, 1] ** 2 + 0.1 * rng.standard_normal(200)
    return X, y


class Recorder(Callback):
    """Records what skorch hands the callbacks: datasets and training batches."""

    def on_train_begin(self, net, **kwargs):
        self.batches = []
        self.datasets = None

    def on_epoch_begin(self, net, dataset_train=None, dataset_valid=None, **kwargs):
        if self.datasets is None:
            self.datasets = (dataset_train, dataset_valid)

    def on_batch_begin(self, net, batch=None, training=False, **kwargs):
        if training:
            self.batches.append(batch[0].clone())


class InterruptAt(Callback):
    """Raise KeyboardInterrupt (as Ctrl-C) after the first batch of an epoch."""

    def __init__(self, epoch):
        self.epoch = epoch

    def on_batch_end(self, net, training=False, **kwargs):
        if training and len(net.history) == self.epoch:
            raise KeyboardInterrupt


class PoisonWeights(Callback):
    """Make the first layer's weights NaN after the first batch."""

    def on_batch_end(self, net, training=False, **kwargs):
        if training:
            with torch.no_grad():
                next(net.module_.parameters()).fill_(float("nan"))


@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_same_seed_bitwise_identical_and_global_rng_untouched(cls, data):
    X, y = data
    torch.manual_seed(123)
    state = torch.get_rng_state()
    first = _tiny(cls, random_state=7).fit(X, y).predict(X)
    assert torch.equal(torch.get_rng_state(), state)
    second = _tiny(cls, random_state=7).fit(X, y).predict(X)
    assert_array_equal(first, second)
    other = _tiny(cls, random_state=8).fit(X, y).predict(X)
    assert not np.array_equal(first, other)


@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_output_shapes_and_dtype(cls, data):
    X, y = data
    model = _tiny(cls, random_state=0).fit(X.astype(np.float32), y)
    pred = model.predict(X)
    assert pred.shape == (200,) and pred.dtype == np.float64
    Y = np.column_stack([y, 2 * y])
    pred2 = _tiny(cls, random_state=0).fit(X, Y).predict(X)
    assert pred2.shape == (200, 2) and pred2.dtype == np.float64
    assert model.n_features_in_ == 3 and model.n_outputs_ == 1


def test_predictions_in_original_units(data):
    X, y = data
    y_big = 1e4 * y + 5e5
    model = _tiny(DenseRegressor, random_state=0, max_epochs=30).fit(X, y_big)
    pred = model.predict(X)
    assert abs(pred.mean() - y_big.mean()) < 0.1 * y_big.std()
    assert_allclose(model.y_mean_, [y_big.mean()])
    assert_allclose(model.y_scale_, [y_big.std()])
    assert model.score(X, y_big) > 0.5


def test_validation_rows_are_the_last_ones(data):
    X, y = data
    X = X.copy()
    X[:, 0] = np.arange(200.0)  # the time index
    rec = Recorder()
    model = _tiny(
        DenseRegressor, validation_fraction=0.25, callbacks=[rec], random_state=0
    ).fit(X, y)
    train, valid = rec.datasets
    assert (len(train), len(valid)) == (150, 50)
    t_valid = valid.X[:, 0].numpy() * model.x_scale_[0] + model.x_mean_[0]
    assert_allclose(t_valid, np.arange(150.0, 200.0), atol=1e-3)
    assert "valid_loss" in model.history_[-1]
    _assert_best_epoch_kept(model, "valid_loss")


@pytest.mark.parametrize("fraction, n_samples", [(0.0, 200), (0.2, 6)])
def test_no_validation_split_monitors_train_loss(fraction, n_samples, data):
    X, y = data
    model = _tiny(DenseRegressor, validation_fraction=fraction, random_state=0)
    model.fit(X[:n_samples], y[:n_samples])
    assert "valid_loss" not in model.history_[-1]
    _assert_best_epoch_kept(model, "train_loss")


def test_mse_shuffles_rows_ljung_box_keeps_blocks_in_order(data):
    X, y = data
    X = X.copy()
    X[:, 0] = np.arange(200.0)
    for objective, contiguous in [("mse", False), ("mse+ljung_box", True)]:
        rec = Recorder()
        _tiny(
            DenseRegressor,
            objective=objective,
            ljung_box_lags=5,
            validation_fraction=0,
            max_epochs=2,
            random_state=0,
            callbacks=[rec],
        ).fit(X, y)
        steps = [np.diff(b[:, 0].numpy()) for b in rec.batches]
        in_order = all(np.allclose(s, s[0], rtol=1e-4) and s[0] > 0 for s in steps)
        assert in_order == contiguous, objective
        # every row is used once per epoch
        assert sum(len(b) for b in rec.batches) == 2 * 200


def test_batch_iterator_blocks_and_tails():
    from skorch.dataset import Dataset

    ds = Dataset(torch.arange(103.0)[:, None], torch.zeros(103, 1))
    blocks = BatchIterator(ds, batch_size=25, shuffle=True, contiguous=True)
    sizes = [len(xb) for xb, _ in blocks]
    assert len(blocks) == 4 and sum(sizes) == 103 and min(sizes) >= 25
    rows = BatchIterator(ds, batch_size=51, shuffle=False)
    # rows spread evenly over ceil(103 / 51) = 3 batches: no tiny last batch
    assert [len(xb) for xb, _ in rows] == [34, 34, 35]
    for n, batch in [(3600, 512), (3520, 512), (3600, 450), (1000, 999), (6, 2)]:
        sizes = [
            len(xb)
            for xb, _ in BatchIterator(
                Dataset(torch.zeros(n, 1), torch.zeros(n, 1)), batch_size=batch
            )
        ]
        assert sum(sizes) == n and max(sizes) - min(sizes) <= 1 and min(sizes) >= 2
        assert max(sizes) <= batch
    seen = torch.cat([xb for xb, _ in BatchIterator(ds, batch_size=10, shuffle=True)])
    assert torch.equal(torch.sort(seen[:, 0]).values, torch.arange(103.0))


def test_batch_iterator_segments():
    from skorch.dataset import Dataset

    n, m = 1030, 50
    ds = Dataset(torch.arange(float(n))[:, None], torch.zeros(n, 1))
    it = BatchIterator(
        ds, batch_size=200, shuffle=True, contiguous=True, segment_length=m
    )
    # ceil(1030 / 200) = 6 batches of shuffled rows, each followed by 4 segments
    assert len(it) == 6
    torch.manual_seed(0)
    offsets = set()
    for _ in range(3):
        batches = [xb[:, 0] for xb, _ in it]
        shuffled = torch.cat([b[: len(b) - 4 * m] for b in batches])
        # every row once among the shuffled rows, in random order
        assert torch.equal(torch.sort(shuffled).values, torch.arange(float(n)))
        assert not torch.all(torch.diff(shuffled) == 1)
        segments = torch.stack([b[len(b) - 4 * m :].reshape(4, m) for b in batches])
        assert torch.all(torch.diff(segments, dim=2) == 1)  # in order inside
        starts = segments[:, :, 0].reshape(-1)
        # 24 segments from the 20 of the pass: all 20 once before any again
        assert len(torch.unique(starts[:20])) == 20
        assert len(torch.unique(starts)) == 20
        offsets.update((starts % m).tolist())
        assert len({float(v) for v in starts % m}) == 1  # one cut per pass
    assert len(offsets) > 1  # the cuts move between passes
    # not shuffled (validation), or too few rows: blocks as before
    plain = BatchIterator(ds, batch_size=200, contiguous=True, segment_length=m)
    assert [len(xb) for xb, _ in plain] == [206] * 5
    small = Dataset(torch.arange(60.0)[:, None], torch.zeros(60, 1))
    short = BatchIterator(small, 200, shuffle=True, contiguous=True, segment_length=m)
    assert [len(xb) for xb, _ in short] == [60]


def test_segmented_ljung_box_training(data):
    from skhybrid.losses import mse, objective_value

    X, y = data
    X = X.copy()
    X[:, 0] = np.arange(200.0)
    rec = Recorder()
    model = _tiny(
        DenseRegressor,
        objective="mse+ljung_box",
        ljung_box_lags=5,
        ljung_box_segment_length=8,
        ljung_box_scaling="per_output",
        batch_size=32,
        validation_fraction=0.2,
        max_epochs=2,
        random_state=0,
        callbacks=[rec],
    ).fit(X, y)
    # 160 training rows: 5 batches of 32 shuffled rows and 4 segments of 8
    assert [len(b) for b in rec.batches] == [64] * 10
    for b in rec.batches:
        # the rows are standardised: consecutive rows differ by one step
        steps = np.diff(b[32:, 0].numpy().reshape(4, 8), axis=1)
        assert np.allclose(steps, steps[0, 0], rtol=1e-4) and steps[0, 0] > 0
        assert not np.all(np.diff(b[:32, 0].numpy()) > 0)
    criterion = model.net_.criterion_
    assert (criterion.segment_length, criterion.segment_count) == (8, 4)
    scale = criterion.ljung_box_scale
    target = (y[:160] - model.y_mean_[0]) / model.y_scale_[0]
    assert_allclose(scale, [np.var(target)], rtol=1e-5)
    r = torch.randn(64, 1, dtype=torch.float64)
    zero = torch.zeros(64, 1, dtype=torch.float64)
    kw = dict(lags=5, ljung_box_scale=scale)
    # training: the MSE over the shuffled rows, the Ljung-Box term over the 4
    # segments
    criterion.train()
    assert_allclose(
        float(criterion(zero, r)),
        float(mse(r[:32]) + objective_value(r[32:], "ljung_box", segments=4, **kw)),
        rtol=1e-10,
    )
    # eval mode (the validation stretch) treats the batch as one series
    criterion.eval()
    assert_allclose(
        float(criterion(zero, r)),
        float(objective_value(r, "mse+ljung_box", **kw)),
        rtol=1e-10,
    )
    # the shuffled rows never enter the Ljung-Box term
    criterion.train()
    shuffled = r.clone()
    shuffled[:32] = shuffled[torch.randperm(32)]
    assert_allclose(float(criterion(zero, shuffled)), float(criterion(zero, r)))


def test_keyboard_interrupt_keeps_best_weights(data):
    X, y = data
    params = dict(random_state=3, lr=0.003, validation_fraction=0.2)
    interrupted = _tiny(DenseRegressor, callbacks=[InterruptAt(3)], **params)
    with pytest.warns(UserWarning, match="interrupted"):
        interrupted.set_params(max_epochs=50).fit(X, y)
    assert interrupted.n_epochs_ == 2
    assert interrupted.best_epoch_ == 2
    # the same seed trained for exactly 2 epochs has the same weights
    two_epochs = _tiny(DenseRegressor, **params).set_params(max_epochs=2).fit(X, y)
    assert_array_equal(interrupted.predict(X), two_epochs.predict(X))
    assert np.isfinite(interrupted.score(X, y))
    pickle.loads(pickle.dumps(interrupted)).predict(X)


def test_diverged_loss_raises_naming_lr(data):
    X, y = data
    model = _tiny(DenseRegressor, lr=0.02, callbacks=[PoisonWeights()])
    with pytest.raises(TrainingDivergedError, match=r"lr=0\.02") as info:
        model.fit(X, y)
    assert isinstance(info.value, ValueError)


def test_huge_learning_rate_diverges(data):
    X, y = data
    model = DenseRegressor(
        hidden_layer_sizes=(64, 64, 64), lr=1e12, max_epochs=20, batch_size=16
    )
    with pytest.raises(TrainingDivergedError, match="lr=1e"):
        model.fit(X, 1e3 * y)


def test_early_stopping_and_lr_schedule(data):
    X, _ = data
    rng = np.random.default_rng(0)
    noise = rng.standard_normal(200)  # nothing to learn: validation loss stalls
    model = _tiny(
        DenseRegressor, max_epochs=200, patience=6, lr_patience=2, random_state=0
    ).fit(X, noise)
    assert model.n_epochs_ < 200
    assert model.n_epochs_ - model.best_epoch_ == 6
    lrs = [g["lr"] for g in model.net_.optimizer_.param_groups]
    assert lrs[0] < 0.01


def test_verbose(data, capsys):
    X, y = data
    _tiny(DenseRegressor, verbose=0).fit(X, y)
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    _tiny(DenseRegressor, verbose=1).fit(X, y)
    captured = capsys.readouterr()
    assert "train_loss" in captured.out and "valid_loss" in captured.out


@pytest.mark.parametrize(
    "params, match",
    [
        (dict(hidden_layer_sizes=(8, 0)), "hidden_layer_sizes"),
        (dict(hidden_layer_sizes=(8, 2.5)), "hidden_layer_sizes"),
        (dict(objective="ljung_box", ljung_box_lags=40), "batch_size=32"),
        (
            dict(objective="ljung_box", ljung_box_lags=5, ljung_box_segment_length=5),
            "ljung_box_segment_length=5",
        ),
        (dict(ljung_box_segment_length=1), "ljung_box_segment_length"),
        (dict(ljung_box_scaling="each"), "ljung_box_scaling"),
        (dict(objective="l2"), "objective"),
        (dict(lr=-1.0), "lr"),
        (dict(validation_fraction=1.0), "validation_fraction"),
    ],
)
def test_bad_parameters_raise(params, match, data):
    X, y = data
    with pytest.raises(ValueError, match=match):
        _tiny(DenseRegressor, **params).fit(X, y)


def test_ljung_box_needs_more_rows_than_lags(data):
    X, y = data
    model = _tiny(DenseRegressor, objective="ljung_box", ljung_box_lags=20)
    with pytest.raises(ValueError, match=r"ljung_box_lags=20.*n_samples=10"):
        model.fit(X[:10], y[:10])


def test_cuda_unavailable_raises(data):
    if torch.cuda.is_available():
        pytest.skip("CUDA is available here")
    X, y = data
    with pytest.raises(ValueError, match="device='cuda'"):
        _tiny(DenseRegressor, device="cuda").fit(X, y)


@pytest.mark.gpu
@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_cuda(cls, data):
    if not torch.cuda.is_available():
        pytest.skip("needs CUDA")
    X, y = data
    model = _tiny(cls, device="cuda", random_state=0, max_epochs=20).fit(X, y)
    assert next(model.net_.module_.parameters()).is_cuda
    pred = model.predict(X)
    assert pred.dtype == np.float64 and model.score(X, y) > 0.5
    restored = pickle.loads(pickle.dumps(model))
    assert_allclose(restored.predict(X), pred, rtol=1e-6)


@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_make_module_contract(cls):
    est = _tiny(cls, hidden_layer_sizes=(5, 7)) if cls is not RNNRegressor else None
    est = est or _tiny(cls, n_steps=2)
    torch.manual_seed(0)
    module = est.make_module(4, 3)
    assert isinstance(module, torch.nn.Module)
    module.train()
    out = module(torch.randn(10, 4))
    assert out.shape == (10, 3) and out.dtype == torch.float32
    another = est.make_module(4, 3)
    to_vector = torch.nn.utils.parameters_to_vector
    assert not torch.equal(
        to_vector(module.parameters()), to_vector(another.parameters())
    )
    # The public method runs the subclass hook: same weights from the same seed.
    torch.manual_seed(1)
    public = to_vector(est.make_module(4, 3).parameters())
    torch.manual_seed(1)
    assert torch.equal(public, to_vector(est._make_module(4, 3).parameters()))


def test_make_module_checks_the_architecture():
    with pytest.raises(ValueError, match="n_steps"):
        RNNRegressor(n_steps=3).make_module(4, 1)


def test_ljung_box_q_ignores_segments(data):
    # The paper's Q cannot be pooled over segments: it keeps contiguous blocks.
    X, y = data
    rec = Recorder()
    model = _tiny(
        DenseRegressor,
        objective="ljung_box_q",
        ljung_box_lags=5,
        ljung_box_segment_length=8,
        validation_fraction=0,
        max_epochs=1,
        random_state=0,
        callbacks=[rec],
    ).fit(X, y)
    assert model.net_.criterion_.segment_count is None
    assert sum(len(b) for b in rec.batches) == 200


class LossRecorder(Callback):
    """Records the criterion's objective and the batch sizes of each epoch."""

    def on_train_begin(self, net, **kwargs):
        if not hasattr(self, "epochs"):
            self.epochs = []

    def on_epoch_begin(self, net, **kwargs):
        self.epochs.append((net.criterion_.objective, []))

    def on_batch_begin(self, net, batch=None, training=False, **kwargs):
        if training:
            self.epochs[-1][1].append(len(batch[0]))


#: A Ljung-Box objective on segments, for the tests of ``mse_pretraining``.
SEGMENTED = dict(
    objective="mse+ljung_box",
    ljung_box_lags=5,
    ljung_box_segment_length=8,
    batch_size=32,
    random_state=0,
)


@pytest.mark.parametrize("cls", [DenseRegressor, RNNRegressor, CyclicRegressor])
def test_mse_pretraining_trains_the_mse_first_then_the_objective(cls, data):
    X, y = data
    params = dict(SEGMENTED, max_epochs=3)
    if cls is RNNRegressor:
        params["n_steps"] = 1
    rec = LossRecorder()
    model = _tiny(cls, mse_pretraining=True, callbacks=[rec], **params).fit(X, y)
    # phase 1: 3 epochs of the MSE on shuffled batches of 32 (160 rows);
    # phase 2: 3 epochs of the objective, each batch 32 shuffled rows + 4 segments
    assert [objective for objective, _ in rec.epochs] == ["mse"] * 3 + [
        "mse+ljung_box"
    ] * 3
    assert all(sizes == [32] * 5 for _, sizes in rec.epochs[:3])
    assert all(sizes == [64] * 5 for _, sizes in rec.epochs[3:])
    assert model.n_epochs_ == 6 and len(model.history_) == 6
    # the first phase is the MSE fit itself, bit for bit
    plain = _tiny(cls, **{**params, "objective": "mse"}).fit(X, y)
    assert_allclose(
        model.history_[:3, "valid_loss"], plain.history_[:, "valid_loss"], rtol=1e-6
    )


def test_mse_pretraining_keeps_the_mse_weights_when_finetuning_does_worse(data):
    # An absurd learning rate after pretraining makes every fine-tuning epoch
    # worse than the pretrained weights: those must be the ones kept.
    X, y = data

    class BlowUpLearningRate(Callback):
        def on_train_begin(self, net, **kwargs):
            if net.criterion_.objective != "mse":
                for group in net.optimizer_.param_groups:
                    group["lr"] = 5.0

    params = dict(SEGMENTED, ljung_box_weight=0.0, max_epochs=8)
    plain = _tiny(DenseRegressor, **{**params, "objective": "mse"}).fit(X, y)
    model = _tiny(
        DenseRegressor,
        mse_pretraining=True,
        patience=3,
        callbacks=[BlowUpLearningRate()],
        **params,
    ).fit(X, y)
    assert model.n_epochs_ > 8
    assert model.best_epoch_ == plain.best_epoch_
    assert_allclose(model.predict(X), plain.predict(X), rtol=1e-10)


def test_mse_pretraining_is_ignored_by_the_mse(data):
    X, y = data
    a = _tiny(DenseRegressor, mse_pretraining=True, random_state=0).fit(X, y)
    b = _tiny(DenseRegressor, random_state=0).fit(X, y)
    assert a.n_epochs_ == b.n_epochs_
    assert_allclose(a.predict(X), b.predict(X), rtol=1e-12)


def test_mse_pretraining_freezes_batch_norm_while_finetuning(data):
    # The fine-tuning batches end in segments of consecutive rows: batch
    # normalisation must neither normalise with their statistics nor learn them.
    X, y = data
    seen = []

    class BatchNormState(Callback):
        def on_batch_end(self, net, training=False, **kwargs):
            if training:
                layer = net.module_.layers[0]
                seen.append(
                    (
                        net.criterion_.objective,
                        layer.training,
                        layer.running_mean.clone(),
                    )
                )

    _tiny(
        DenseRegressor,
        mse_pretraining=True,
        max_epochs=2,
        callbacks=[BatchNormState()],
        **SEGMENTED,
    ).fit(X, y)
    pretraining = [s for s in seen if s[0] == "mse"]
    finetuning = [s for s in seen if s[0] != "mse"]
    assert pretraining and finetuning
    assert all(training for _, training, _ in pretraining)
    assert not any(training for _, training, _ in finetuning)
    # running statistics move while pretraining, not while fine-tuning
    assert not torch.equal(pretraining[0][2], pretraining[-1][2])
    assert all(torch.equal(s[2], finetuning[0][2]) for s in finetuning)
