"""The training engine: one skorch net, one protocol, for every network in skhybrid.

Every trained torch model of the package goes through :func:`train_module`: the
dense, recurrent and cyclic regressors, the joint physics-and-network module of
:class:`~skhybrid.hybrid.HybridEnsembleRegressor` and the state-space hybrid
(:class:`~skhybrid.hybrid.StateSpaceHybridRegressor`, whose samples are simulated
sub-sequences). The engine builds one :class:`skorch.NeuralNetRegressor` with the
paper's protocol (Adam, a plateau schedule of the learning rate, early stopping
that restores the best epoch, a divergence check, Ctrl-C stops training and keeps
the best weights) from the estimator's *training parameters*, which are declared
once here (:data:`TRAINING_PARAMETERS`: default, constraint and documentation)
and shared by every estimator that trains a network.
"""

import contextlib
import threading
import warnings
from dataclasses import dataclass
from numbers import Integral, Real
from types import SimpleNamespace

import numpy as np
import torch
from sklearn.utils import check_random_state
from skorch import NeuralNetRegressor
from skorch.callbacks import LRScheduler
from skorch.dataset import Dataset, unpack_data
from skorch.helper import predefined_split
from skorch.utils import to_tensor
from torch.optim.lr_scheduler import ReduceLROnPlateau

from skhybrid.losses import OBJECTIVES, needs_time_order
from skhybrid.neural._callbacks import BatchIterator, DivergenceCheck
from skhybrid.neural._lockstep import lockstep_backward, lockstep_infer
from skhybrid.neural._modules import ObjectiveLoss, SequenceObjectiveLoss
from skhybrid.neural._pretraining import (
    CandidateEarlyStopping,
    finetune,
    propose_candidate,
)
from skhybrid.utils._compile import CompiledOrEager
from skhybrid.utils._lockstep import current_member
from skhybrid.utils._sklearn_compat import Interval, StrOptions

__all__ = [
    "TRAINING_PARAMETERS",
    "TrainingParameter",
    "check_device",
    "check_sequence_objective",
    "check_time_ordered_rows",
    "draw_seed",
    "record_training",
    "rng_devices",
    "seeded",
    "train_module",
    "training_constraints",
    "training_parameters_doc",
    "validation_rows",
]


@dataclass(frozen=True)
class TrainingParameter:
    """One shared training parameter: its default, constraints and documentation.

    Parameters
    ----------
    default : object
        The default value.
    constraints : list
        The scikit-learn parameter constraints.
    kind : str
        The type line of its numpydoc entry (before ``, default=``).
    doc : str
        Its description, one paragraph per line group, unindented.
    """

    default: object
    constraints: list
    kind: str
    doc: str


#: The training parameters every network-training estimator accepts, in the
#: order of their signatures.
TRAINING_PARAMETERS = {
    "objective": TrainingParameter(
        "mse",
        [StrOptions(set(OBJECTIVES))],
        '{"mse", "ljung_box", "mse+ljung_box", "ljung_box_q"}',
        """Training objective on the standardised residuals (see
:mod:`skhybrid.losses.base`). An objective with a Ljung-Box term needs time
order: row models train on contiguous blocks of rows (or segments, see
``ljung_box_segment_length``), never on shuffled rows; sequence models (the
state-space hybrid) compute it within each simulated sub-sequence.""",
    ),
    "ljung_box_lags": TrainingParameter(
        20,
        [Interval(Integral, 1, None, closed="left")],
        "int",
        """Lags of the Ljung-Box term; must be smaller than ``batch_size`` (rows) or
than the simulated horizon (sequences).""",
    ),
    "ljung_box_weight": TrainingParameter(
        1.0,
        [Interval(Real, 0, None, closed="left")],
        "float",
        """Weight of the Ljung-Box term in ``"mse+ljung_box"``.""",
    ),
    "ljung_box_segment_length": TrainingParameter(
        None,
        [Interval(Integral, 2, None, closed="left"), None],
        "int or None",
        """With ``"ljung_box"`` or ``"mse+ljung_box"``: for row models, each training
batch holds ``batch_size`` shuffled rows, on which the MSE is computed, followed
by ``batch_size // ljung_box_segment_length`` segments of this many consecutive
rows drawn from random places, on which the Ljung-Box term is computed
(autocovariances within each segment, pooled; see
:class:`~skhybrid.neural._callbacks.BatchIterator`); for sequence models, each
simulated sub-sequence is cut into segments of this length. Must be larger than
``ljung_box_lags``. None trains row models on contiguous blocks of
``batch_size`` rows, as ``"ljung_box_q"`` always does, and takes each whole
sub-sequence as one series; other objectives ignore it.""",
    ),
    "ljung_box_scaling": TrainingParameter(
        "target",
        [StrOptions({"target", "per_output"})],
        '{"target", "per_output"}',
        """Scale of each output's autocovariance norm in the Ljung-Box term.
``"target"``: the scale of the standardised targets, the MSE's (see
``target_scaling``). ``"per_output"``: divided by the variance of that output's
standardised training target, fixed at the start of ``fit``, so that every
output's whiteness counts alike however large its residual.""",
    ),
    "mse_pretraining": TrainingParameter(
        False,
        ["boolean"],
        "bool",
        """With an objective that has a Ljung-Box term, train in two phases: first on
the MSE alone (learning-rate schedule and early stopping as usual), then, from
the best weights of that phase and with its optimiser state and learning rate,
on the objective itself for up to ``max_epochs`` more epochs, with batch
normalisation frozen at the statistics of the first phase. The second phase's
early stopping counts the pretrained weights as its first candidate, so the
weights kept are never worse on the validation objective than the MSE
solution; ``history_`` holds both phases. Ignored with ``objective="mse"``.""",
    ),
    "lr": TrainingParameter(
        0.01,
        [Interval(Real, 0, None, closed="neither")],
        "float",
        """Initial learning rate of Adam.""",
    ),
    "max_epochs": TrainingParameter(
        200,
        [Interval(Integral, 1, None, closed="left")],
        "int",
        """Most passes over the training samples.""",
    ),
    "batch_size": TrainingParameter(
        512,
        [Interval(Integral, 2, None, closed="left"), None],
        "int or None",
        """Samples per mini-batch (rows, or sub-sequences for sequence models);
None puts every training sample in one batch.""",
    ),
    "validation_fraction": TrainingParameter(
        0.2,
        [Interval(Real, 0, 1, closed="left")],
        "float",
        """Fraction of the data, taken from the END (the most recent samples), whose
loss drives the learning-rate schedule, early stopping and the choice of the
best weights. 0 trains on all samples and monitors the training loss.""",
    ),
    "target_scaling": TrainingParameter(
        "per_output",
        [StrOptions({"per_output", "shared"})],
        '{"per_output", "shared"}',
        """How targets are scaled for training. ``"per_output"`` divides each output
by its own scale, so every output counts the same (the usual choice for
states in different units). ``"shared"`` divides all outputs by one scale (the
root mean square of their scales), so the loss weighs errors in the outputs'
own units, like a physics stage's least squares: the choice for a residual
stage, where outputs the physics already explains hold only noise that
per-output scaling would blow up to unit variance.""",
    ),
    "patience": TrainingParameter(
        30,
        [Interval(Integral, 1, None, closed="left"), None],
        "int or None",
        """Epochs without improvement of the monitored loss before training stops
(early stopping); ``None`` trains for ``max_epochs``.""",
    ),
    "lr_patience": TrainingParameter(
        10,
        [Interval(Integral, 0, None, closed="left")],
        "int",
        """Epochs without improvement before the learning rate is reduced.""",
    ),
    "lr_factor": TrainingParameter(
        0.5,
        [Interval(Real, 0, 1, closed="neither")],
        "float",
        """Factor applied to the learning rate on a plateau.""",
    ),
    "callbacks": TrainingParameter(
        None,
        [list, None],
        "list of skorch callbacks or None",
        """Extra :mod:`skorch.callbacks`, run after the built-in ones.""",
    ),
    "random_state": TrainingParameter(
        None,
        ["random_state"],
        "int, RandomState instance or None",
        """Seeds the initial weights and the shuffling, without touching torch's
global random state. The same seed gives bitwise-identical results on CPU.""",
    ),
    "device": TrainingParameter(
        "cpu",
        [StrOptions({"cpu", "cuda"})],
        '{"cpu", "cuda"}',
        """Where the network trains and predicts.""",
    ),
    "verbose": TrainingParameter(
        0,
        ["verbose"],
        "int",
        """0 is silent; 1 or more shows a progress bar and skorch's table of
epochs.""",
    ),
}


def training_constraints():
    """The scikit-learn constraints of the shared training parameters.

    Returns
    -------
    constraints : dict
        Parameter name to its list of constraints.
    """
    return {name: list(p.constraints) for name, p in TRAINING_PARAMETERS.items()}


def _entry(name, default, kind, text):
    default = f'"{default}"' if isinstance(default, str) else repr(default)
    body = "\n".join(
        ("        " + line) if line else "" for line in text.strip().splitlines()
    )
    return f"    {name} : {kind}, default={default}\n{body}"


def training_parameters_doc(overrides=None):
    """The numpydoc entries of the shared training parameters.

    Parameters
    ----------
    overrides : dict or None, default=None
        ``{name: (default, reason)}`` for parameters whose default differs in an
        estimator because the parameter means something else there; the reason
        is appended to the entry.

    Returns
    -------
    doc : str
        The entries, indented for a class docstring's Parameters section.
    """
    overrides = overrides or {}
    entries = []
    for name, p in TRAINING_PARAMETERS.items():
        default, text = p.default, p.doc
        if name in overrides:
            default, reason = overrides[name]
            text = f"{text}\n{reason}"
        entries.append(_entry(name, default, p.kind, text))
    return "\n".join(entries)


class _Net(NeuralNetRegressor):
    """skorch's regressor, remembering whether a Ctrl-C cut its training short.

    skorch ends training on ``KeyboardInterrupt`` (its early stopping raises one
    too) and keeps the weights it has; ``interrupted_`` tells the two apart.
    """

    #: Keep batch normalisation in eval mode while training (running statistics
    #: used and left alone), as when fine-tuning; set by ``finetune``.
    freeze_batch_norm = False
    #: :func:`torch.compile`'s keyword arguments for the module's forward pass
    #: in training and validation, or None (eager); set by ``train_module``.
    compile_kwargs = None

    def compiled_module(self):
        """The module compiled by :func:`torch.compile` (built at first use), or None.

        The compiled module shares the module's parameters and buffers:
        ``module_`` stays the eager module, so the optimiser, the state dicts
        of early stopping and the pickles are the eager module's. Where the
        compilation fails, a warning says so and the module runs eagerly.
        """
        if self.compile_kwargs is None:
            return None
        compiled = self.__dict__.get("_compiled_module")
        if compiled is None or compiled.eager is not self.module_:
            compiled = CompiledOrEager(
                self.module_, self.compile_kwargs, "the network's forward pass"
            )
            # Around skorch's __setattr__, which would register a torch module
            # as a part of the net (moved, saved and pickled with it).
            object.__setattr__(self, "_compiled_module", compiled)
        return compiled

    def __getstate__(self):
        # A compiled module does not pickle (nor deep-copy); it is rebuilt
        # where the net trains again.
        state = super().__getstate__()
        state.pop("_compiled_module", None)
        return state

    def _set_training(self, training=True):
        super()._set_training(training)
        if training and self.freeze_batch_norm:
            for layer in self.module_.modules():
                if isinstance(layer, torch.nn.modules.batchnorm._BatchNorm):
                    layer.eval()

    def infer(self, x, **fit_params):
        """The module's output on batch ``x``, computed with the other members'
        where fits train in lockstep (:mod:`skhybrid.neural._lockstep`)."""
        if fit_params or current_member() is None:
            compiled = None if fit_params else self.compiled_module()
            if compiled is None:
                return super().infer(x, **fit_params)
            x = to_tensor(x, device=self.device)
            if self.compile_kwargs.get("dynamic") is None:
                # The batches differ in size (by a row in training; validation
                # is one batch of its own): one graph for every size, not one
                # each, unless the caller chose static or dynamic shapes.
                torch._dynamo.maybe_mark_dynamic(x, 0)
            return compiled(x)
        return lockstep_infer(self.module_, to_tensor(x, device=self.device))

    def train_step_single(self, batch, **fit_params):
        """skorch's training step, its backward pass run with the other members'."""
        if fit_params or current_member() is None:
            return super().train_step_single(batch, **fit_params)
        self._set_training(True)
        Xi, yi = unpack_data(batch)
        y_pred = self.infer(Xi)
        loss = self.get_loss(y_pred, yi, X=Xi, training=True)
        lockstep_backward(loss)
        return {"loss": loss, "y_pred": y_pred}

    def fit_loop(self, X, y=None, epochs=None, **fit_params):
        self.interrupted_ = False
        try:
            return super().fit_loop(X, y, epochs=epochs, **fit_params)
        except KeyboardInterrupt:
            stopper = dict(self.callbacks_).get("early_stopping")
            stopped = stopper is not None and stopper.misses_ >= stopper.patience
            self.interrupted_ = not stopped
            raise


def _progress_bar():
    """skorch's ProgressBar, or None where tqdm (which it needs) is missing."""
    try:
        import tqdm  # noqa: F401
        from skorch.callbacks import ProgressBar
    except ImportError:  # pragma: no cover - tqdm is a dependency of skorch
        return None
    return ProgressBar()


def validation_rows(n_samples, validation_fraction, min_rows):
    """Number of validation rows taken from the end of the rows (0 for none).

    Parameters
    ----------
    n_samples : int
        Rows of the data.
    validation_fraction : float
        Fraction of the rows to validate on.
    min_rows : int
        Fewest rows either part may have; below it there is no split.

    Returns
    -------
    n_valid : int
        Validation rows, the last ones; 0 trains on all rows.
    """
    n_valid = int(np.floor(n_samples * validation_fraction))
    if n_valid < min_rows or n_samples - n_valid < min_rows:
        return 0
    return n_valid


def training_callbacks(est, monitor, free_run_validation=False):
    """The built-in skorch callbacks of the training protocol, then the user's.

    Parameters
    ----------
    est : estimator
        Has the shared training parameters.
    monitor : {"valid_loss", "train_loss"}
        The loss that drives the schedule and early stopping.
    free_run_validation : bool, default=False
        Whether the validation loss is a free run longer than what the model
        trains on: then the divergence check watches the training loss alone
        (see :func:`train_module`).

    Returns
    -------
    callbacks : list of (str, skorch.callbacks.Callback)
        Divergence check, plateau schedule, early stopping (restoring the best
        epoch), a progress bar when verbose, and ``est.callbacks``.
    """
    callbacks = [
        (
            "divergence_check",
            DivergenceCheck(
                est.lr,
                keys=("train_loss",)
                if free_run_validation
                else ("train_loss", "valid_loss"),
            ),
        ),
        (
            "lr_scheduler",
            LRScheduler(
                policy=ReduceLROnPlateau,
                monitor=monitor,
                factor=est.lr_factor,
                patience=est.lr_patience,
            ),
        ),
        (
            "early_stopping",
            CandidateEarlyStopping(
                monitor=monitor,
                patience=est.patience or est.max_epochs + 1,
                load_best=True,
            ),
        ),
    ]
    if est.verbose:
        bar = _progress_bar()
        if bar is not None:
            callbacks.append(("progress_bar", bar))
    for i, cb in enumerate(est.callbacks or []):
        callbacks.append((f"user_{i}", cb))
    return callbacks


def record_training(est, net):
    """Set ``net_``, ``history_``, ``n_epochs_``, ``best_epoch_``, ``interrupted_``.

    The interrupt semantics of every network in skhybrid: a Ctrl-C during
    training stops it, the weights of the best epoch so far are kept, the fit
    returns a usable model with ``interrupted_ = True`` and a ``UserWarning``
    says so; on a refit the previous model is replaced by the one cut short
    (as skorch does). Early stopping, which skorch implements with the same
    exception, is not an interrupt.

    Parameters
    ----------
    est : estimator
        The estimator being fitted.
    net : skorch.NeuralNet
        Its trained net (from :func:`train_module`).
    """
    net.module_.eval()
    est.net_ = net
    est.history_ = net.history
    est.n_epochs_ = sum("train_loss" in row for row in net.history)
    est.best_epoch_ = int(dict(net.callbacks_)["early_stopping"].best_epoch_)
    est.interrupted_ = bool(getattr(net, "interrupted_", False))
    if est.interrupted_:
        warnings.warn(
            f"training of {type(est).__name__} was interrupted (Ctrl-C) after "
            f"{est.n_epochs_} epochs; the model keeps the weights of its best "
            f"epoch so far ({est.best_epoch_}).",
            UserWarning,
            stacklevel=3,
        )


def check_time_ordered_rows(est, n_samples):
    """Fewest training rows ``est``'s objective needs; checks its batches too.

    A Ljung-Box objective computes autocovariances within each block of
    ``batch_size`` rows (``None``: all rows), so a block and the data must be
    longer than ``ljung_box_lags``. Other objectives need two rows.

    Parameters
    ----------
    est : estimator
        Has ``objective``, ``ljung_box_lags``, ``ljung_box_segment_length`` and
        ``batch_size``.
    n_samples : int
        Training rows.

    Returns
    -------
    min_rows : int
        ``ljung_box_lags + 1`` for a Ljung-Box objective, else 2.
    """
    if not needs_time_order(est.objective):
        return 2
    min_rows = est.ljung_box_lags + 1
    _check_segment(est)
    if est.batch_size is not None and est.batch_size <= est.ljung_box_lags:
        raise ValueError(
            f"batch_size={est.batch_size} must be larger than "
            f"ljung_box_lags={est.ljung_box_lags}: objective="
            f"{est.objective!r} computes autocorrelations within each "
            "block of batch_size rows."
        )
    if n_samples < min_rows:
        raise ValueError(
            f"ljung_box_lags={est.ljung_box_lags} must be smaller than the "
            f"number of samples, n_samples={n_samples}."
        )
    return min_rows


def _check_segment(est):
    segment = est.ljung_box_segment_length
    if segment is not None and segment <= est.ljung_box_lags:
        raise ValueError(
            f"ljung_box_segment_length={segment} must be larger than "
            f"ljung_box_lags={est.ljung_box_lags}: objective={est.objective!r} "
            "computes autocovariances within each segment."
        )


def check_sequence_objective(est, horizon):
    """Check a sequence model's objective against its simulated horizon.

    Parameters
    ----------
    est : estimator
        Has the shared training parameters.
    horizon : int
        Simulated steps per training sub-sequence.
    """
    if not needs_time_order(est.objective):
        return
    _check_segment(est)
    length = est.ljung_box_segment_length or horizon
    if length <= est.ljung_box_lags:
        raise ValueError(
            f"ljung_box_lags={est.ljung_box_lags} must be smaller than the "
            f"simulated series each Ljung-Box term is computed on: horizon="
            f"{horizon}"
            + (
                f" cut into ljung_box_segment_length={est.ljung_box_segment_length}"
                if est.ljung_box_segment_length
                else ""
            )
            + "."
        )


def check_device(device):
    """Raise a ValueError for ``device='cuda'`` without a CUDA device.

    Parameters
    ----------
    device : {"cpu", "cuda"}
        The requested device.
    """
    if device == "cuda" and not torch.cuda.is_available():
        raise ValueError(
            "device='cuda' but torch finds no CUDA device "
            "(torch.cuda.is_available() is False); use device='cpu'."
        )


def rng_devices(device):
    """The CUDA devices whose random state :func:`torch.random.fork_rng` forks.

    Parameters
    ----------
    device : {"cpu", "cuda"}
        The training device.

    Returns
    -------
    devices : list of int
        The current CUDA device for ``"cuda"``, none for ``"cpu"``.
    """
    if device == "cuda":
        return [torch.cuda.current_device()]
    return []


#: Held while a fit draws from torch's global random state: fits may train side
#: by side in threads of one process (:mod:`skhybrid.utils._lockstep`).
_GLOBAL_RNG = threading.RLock()


@contextlib.contextmanager
def seeded(seed, device="cpu"):
    """Torch's global random state seeded with ``seed`` inside, restored after.

    One thread at a time: a fit builds its modules in here, so that fits
    training side by side in threads each get the weights they get alone.

    Parameters
    ----------
    seed : int
        Seed for :func:`torch.manual_seed`.
    device : {"cpu", "cuda"}, default="cpu"
        The training device (its CUDA random state is forked too).

    Yields
    ------
    None
        Control, with torch's global random state seeded.
    """
    with _GLOBAL_RNG, torch.random.fork_rng(devices=rng_devices(device)):
        torch.manual_seed(seed)
        yield


def draw_seed(random_state):
    """A torch seed drawn from ``random_state`` (one draw per fit).

    Parameters
    ----------
    random_state : int, RandomState instance or None
        The estimator's ``random_state``.

    Returns
    -------
    seed : int
        Seed for :func:`torch.manual_seed`.
    """
    return int(check_random_state(random_state).randint(np.iinfo(np.int32).max))


def train_module(
    est,
    make_module,
    X,
    y,
    *,
    valid=None,
    sequences=False,
    criterion=None,
    criterion_kwargs=None,
    optimizer_kwargs=None,
    start_as_candidate=False,
    seed=None,
    overrides=None,
    compile_kwargs=None,
    free_run_validation=False,
):
    """Train a torch module with the estimator's training protocol.

    The one training loop of the package: the module is built inside a forked
    torch random state seeded from ``est.random_state``, wrapped in a skorch net
    with the protocol's callbacks and trained; with ``est.mse_pretraining`` and an
    objective with a Ljung-Box term, the second phase fine-tunes on the objective.

    Parameters
    ----------
    est : estimator
        Holds the shared training parameters (:data:`TRAINING_PARAMETERS`).
    make_module : callable
        ``make_module() -> torch.nn.Module``, called inside the seeded random
        state; the module maps a batch of ``X`` to predictions of ``y``.
    X, y : torch.Tensor
        Training samples and targets, on ``est.device``. For row models ``X`` is
        ``(n, n_features)`` in time order; for sequence models (``sequences``)
        each sample is one sub-sequence and ``y`` is ``(n, T, n_outputs)``.
    valid : tuple of torch.Tensor or None, default=None
        ``(X_valid, y_valid)`` monitoring training (validated in one batch
        where the objective needs time order, or for sequences); None monitors
        the training loss.
    sequences : bool, default=False
        Whether the samples are sub-sequences: batches are shuffled samples,
        and a Ljung-Box term is computed within each simulated sequence
        (:class:`~skhybrid.neural._modules.SequenceObjectiveLoss`).
    criterion : type or None, default=None
        The criterion class; None is :class:`ObjectiveLoss` for rows and
        :class:`SequenceObjectiveLoss` for sequences. It takes the objective's
        keyword arguments.
    criterion_kwargs : dict or None, default=None
        More keyword arguments of the criterion.
    optimizer_kwargs : dict or None, default=None
        More ``optimizer__*`` settings of skorch (for example parameter groups).
    start_as_candidate : bool, default=False
        Score the module before training and keep it unless an epoch beats it
        (the state-space hybrid starts as its physics model).
    seed : int or None, default=None
        Seed of the module and the batches; None draws one from
        ``est.random_state``.
    overrides : dict or None, default=None
        Training parameters to use instead of ``est``'s (for a phase that trains
        part of a model, such as the state-space hybrid's encoder pre-training).
    compile_kwargs : dict or None, default=None
        Keyword arguments of :func:`torch.compile`, which then compiles the
        module's forward pass in training and validation (not where fits
        train in lockstep, whose batched call stays eager); None runs it
        eagerly. Without a ``dynamic`` entry the batch dimension is marked
        dynamic. The net's ``module_`` stays the eager module, sharing its
        parameters with the compiled one, which is dropped when training ends.
    free_run_validation : bool, default=False
        Whether ``valid`` is a free run longer than the training samples (the
        state-space hybrid's whole validation tails against its sub-sequences
        of ``horizon`` steps). A model can be unstable over the long run for a
        few epochs while its training is sound; its validation loss then blows
        up, the epoch is not kept (the kept weights are the best on
        validation), and training goes on. The divergence check then watches
        the training loss alone, which still stops a training that blows up.

    Returns
    -------
    net : skorch.NeuralNetRegressor
        The trained net, its best weights restored.
    """
    settings = {name: getattr(est, name) for name in TRAINING_PARAMETERS}
    settings.update(overrides or {})
    p = SimpleNamespace(**settings)
    check_device(p.device)
    time_ordered = needs_time_order(p.objective)
    pretrain = p.mse_pretraining and time_ordered
    n = X.shape[0]
    batch_size = n if p.batch_size is None else min(p.batch_size, n)
    segment = (
        p.ljung_box_segment_length
        if p.objective
        in (
            "ljung_box",
            "mse+ljung_box",
        )
        else None
    )
    lb_scale = None
    if time_ordered and p.ljung_box_scaling == "per_output":
        flat = y.reshape(-1, y.shape[-1]) if sequences else y
        variance = flat.double().var(dim=0, unbiased=False).cpu().numpy()
        # An output without variance has nothing to whiten: leave it at 1.
        lb_scale = np.where(variance > 0, variance, 1.0).tolist()
    kwargs = {
        "objective": "mse" if pretrain else p.objective,
        "lags": p.ljung_box_lags,
        "ljung_box_weight": p.ljung_box_weight,
        "segment_length": segment,
        "ljung_box_scale": lb_scale,
    }
    if sequences:
        criterion = criterion or SequenceObjectiveLoss
        iterator = {
            "iterator_train__contiguous": False,
            "iterator_train__at_least_batch_size": True,
        }
        row_segment = None
    else:
        criterion = criterion or ObjectiveLoss
        kwargs["segment_count"] = max(1, batch_size // segment) if segment else None
        iterator = {
            "iterator_train__contiguous": time_ordered and not segment and not pretrain,
            "iterator_train__segment_length": None if pretrain else segment,
        }
        row_segment = segment
    kwargs.update(criterion_kwargs or {})
    if valid is not None:
        train_split = predefined_split(Dataset(*valid))
        whole = time_ordered or sequences
        valid_batch_size = len(valid[0]) if whole else batch_size
        monitor = "valid_loss"
    else:
        train_split, valid_batch_size, monitor = None, batch_size, "train_loss"
    seed = draw_seed(p.random_state) if seed is None else seed
    with seeded(seed, p.device):
        module = make_module()
        # The batches draw from the net's own generator, which goes on from
        # here as the global state would: a fit trains as before, and fits
        # training beside it in threads do not take its draws.
        generator = torch.Generator()
        generator.set_state(torch.get_rng_state())
    net = _Net(
        module=module,
        criterion=criterion,
        **{f"criterion__{k}": v for k, v in kwargs.items()},
        optimizer=torch.optim.Adam,
        **{f"optimizer__{k}": v for k, v in (optimizer_kwargs or {}).items()},
        lr=p.lr,
        max_epochs=p.max_epochs,
        batch_size=batch_size,
        train_split=train_split,
        iterator_train=BatchIterator,
        iterator_train__shuffle=True,
        iterator_train__generator=generator,
        **iterator,
        iterator_valid=BatchIterator,
        iterator_valid__contiguous=time_ordered and not sequences,
        iterator_valid__batch_size=valid_batch_size,
        callbacks=training_callbacks(p, monitor, free_run_validation),
        device=p.device,
        verbose=p.verbose,
    )
    net.compile_kwargs = compile_kwargs
    if start_as_candidate:
        net.initialize()
        propose_candidate(net, *(valid or (X, y)), epoch=0)
        # skorch catches KeyboardInterrupt (Ctrl-C, and its own early
        # stopping) and restores the best weights on the way out.
        net.partial_fit(X, y, epochs=p.max_epochs)
    else:
        net.fit(X, y)
    if pretrain and not net.interrupted_:
        finetune(
            net,
            X,
            y,
            p.objective,
            row_segment,
            sequences=sequences,
            valid=valid,
        )
    # The fitted net keeps no compiled module (it would not pickle).
    net.__dict__.pop("_compiled_module", None)
    return net
