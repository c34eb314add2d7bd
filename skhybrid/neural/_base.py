"""BaseNeuralRegressor: the training protocol shared by the neural estimators."""

import warnings
from numbers import Integral, Real

import numpy as np
import torch
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.preprocessing import StandardScaler
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted
from skorch import NeuralNetRegressor
from skorch.callbacks import LRScheduler
from skorch.dataset import Dataset
from skorch.helper import predefined_split
from torch.optim.lr_scheduler import ReduceLROnPlateau

from skhybrid.losses import OBJECTIVES, needs_time_order
from skhybrid.neural._callbacks import BatchIterator, DivergenceCheck
from skhybrid.neural._modules import ObjectiveLoss, RolloutModule
from skhybrid.neural._pretraining import CandidateEarlyStopping, finetune
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import SimulatorMixin
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    Interval,
    StrOptions,
    _fit_context,
    validate_data,
)
from skhybrid.utils._transaction import TransactionalFitMixin

__all__ = ["BaseNeuralRegressor"]

# Rows per forward pass at prediction time: bounds memory, not results (the
# module runs in eval mode and in float64, see _forward).
_PREDICT_CHUNK = 8192


#: The training-protocol parameters every neural estimator shares, written once
#: and filled into each class docstring by :func:`fill_training_docstring`.
TRAINING_PARAMETERS_DOC = """\
    objective : {"mse", "ljung_box", "mse+ljung_box", "ljung_box_q"}, default="mse"
        Training objective on the standardised residuals (see
        :mod:`skhybrid.losses.base`). An objective with a Ljung-Box term assumes
        the rows are in time order and trains on contiguous blocks of rows, never
        on shuffled rows.
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term; must be smaller than ``batch_size``.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    ljung_box_segment_length : int or None, default=None
        With ``"ljung_box"`` or ``"mse+ljung_box"``, each training batch holds
        ``batch_size`` shuffled rows, on which the MSE is computed, followed by
        ``batch_size // ljung_box_segment_length`` segments of this many
        consecutive rows drawn from random places, on which the Ljung-Box term
        is computed (autocovariances within each segment, pooled; see
        :class:`~skhybrid.neural._callbacks.BatchIterator`). Must be larger
        than ``ljung_box_lags``. None trains on contiguous blocks of
        ``batch_size`` rows, as ``"ljung_box_q"`` always does; other objectives
        ignore it.
    ljung_box_scaling : {"target", "per_output"}, default="target"
        Scale of each output's autocovariance norm in the Ljung-Box term.
        ``"target"``: the scale of the standardised targets, the MSE's (see
        ``target_scaling``). ``"per_output"``: divided by the variance of that
        output's standardised training target, fixed at the start of ``fit``,
        so that every output's whiteness counts alike however large its
        residual.
    mse_pretraining : bool, default=False
        With an objective that has a Ljung-Box term, train in two phases: first
        on the MSE alone (shuffled batches, learning-rate schedule and early
        stopping as usual), then, from the best weights of that phase and with
        its optimiser state and learning rate, on the objective itself for up
        to ``max_epochs`` more epochs, with batch normalisation frozen at the
        statistics of the first phase. The second phase's early stopping counts
        the pretrained weights as its first candidate, so the weights kept are
        never worse on the validation objective than the MSE solution. A
        Ljung-Box term then refines an accurate model instead of shaping one
        from scratch; ``history_`` holds both phases. Ignored with
        ``objective="mse"``.
    lr : float, default=0.01
        Initial learning rate of Adam.
    max_epochs : int, default=200
        Most passes over the training rows.
    batch_size : int, default=512
        Rows per mini-batch.
    validation_fraction : float, default=0.2
        Fraction of the rows, taken from the END (the most recent rows), whose
        loss drives the learning-rate schedule, early stopping and the choice of
        the best weights. 0 trains on all rows and monitors the training loss.
    target_scaling : {"per_output", "shared"}, default="per_output"
        How targets are standardised for training. ``"per_output"`` divides each
        output by its own standard deviation, so every output counts the same (the
        usual choice for states in different units). ``"shared"`` divides all
        outputs by one scale (the root mean square of their standard deviations),
        so the loss weighs errors in the outputs' own units, like a physics
        stage's least squares: the choice for a residual stage, where outputs the
        physics already explains hold only noise that per-output scaling would
        blow up to unit variance.
    horizon : int, default=1
        Steps of the training loss. 1 trains one step ahead (the paper's
        protocol). ``T > 1`` trains by simulation error: from every row that
        starts ``T`` consecutive rows of one experiment (rows that continue each
        other, found in the data; see
        :meth:`skhybrid.preprocessing.WindowLayout.horizon_starts`), the network
        is rolled ``T`` steps, feeding back its own predictions with the measured
        inputs, and the loss is the MSE over the whole horizon (truncated
        back-propagation through time). Needs time-ordered windows and
        ``objective="mse"``; ``CyclicRegressor`` supports 1 only.
    target : {"state", "increment"}, default="state"
        What the network learns. ``"state"``: the next state ``y``.
        ``"increment"``: the change ``y - x``, where ``x`` is the newest state of
        the row (the first ``n_outputs`` columns of its newest step, see
        :class:`~skhybrid.preprocessing.WindowLayout`); ``predict`` returns
        ``x + network(X)``. For a slowly varying state (small time step) the
        increment is a tiny fraction of the state and the network spends its
        accuracy on it instead of on reproducing ``x``. A network without
        ``n_steps`` (``DenseRegressor``) finds the window length from the rows
        (the one under which consecutive rows continue each other, else 1). With
        ``horizon > 1`` each simulated step adds the predicted increment to the
        simulated state. ``CyclicRegressor`` supports ``"state"`` only.
    patience : int or None, default=30
        Epochs without improvement of the monitored loss before training stops
        (early stopping); ``None`` trains for ``max_epochs``.
    lr_patience : int, default=10
        Epochs without improvement before the learning rate is reduced.
    lr_factor : float, default=0.5
        Factor applied to the learning rate on a plateau.
    callbacks : list of skorch callbacks or None, default=None
        Extra :mod:`skorch.callbacks`, run after the built-in ones.
    random_state : int, RandomState instance or None, default=None
        Seeds the initial weights and the shuffling, without touching torch's
        global random state. The same seed gives bitwise-identical predictions
        on CPU.
    device : {"cpu", "cuda"}, default="cpu"
        Where the network trains and predicts.
    verbose : int, default=0
        0 is silent; 1 or more shows a progress bar and skorch's table of epochs."""

#: The fitted attributes every neural estimator shares.
FITTED_ATTRIBUTES_DOC = """\
    net_ : skorch.NeuralNetRegressor
        The trained skorch net (its ``module_`` in eval mode).
    history_ : skorch.History
        Per-epoch records: ``history_[:, "train_loss"]`` and, with a validation
        split, ``history_[:, "valid_loss"]`` (standardised units).
    n_epochs_ : int
        Epochs completed.
    best_epoch_ : int
        Epoch (1-based) whose weights were kept: the lowest monitored loss.
    n_features_in_ : int
        Number of columns of ``X`` seen in ``fit``.
    n_outputs_ : int
        Number of target columns.
    x_mean_, x_scale_ : ndarray of shape (n_features,)
        Mean and scale used to standardise ``X``.
    y_mean_, y_scale_ : ndarray of shape (n_outputs,)
        Mean and scale used to standardise ``y``."""


def fill_training_docstring(doc):
    """Fill the shared parameter and attribute sections into a class docstring.

    Parameters
    ----------
    doc : str
        A docstring holding the lines ``    %(training_parameters)s`` and
        ``    %(fitted_attributes)s``.

    Returns
    -------
    doc : str
        The docstring with both sections written out.
    """
    return doc.replace("    %(training_parameters)s", TRAINING_PARAMETERS_DOC).replace(
        "    %(fitted_attributes)s", FITTED_ATTRIBUTES_DOC
    )


class _Net(NeuralNetRegressor):
    """skorch's regressor, remembering whether a Ctrl-C cut its training short.

    skorch ends training on ``KeyboardInterrupt`` (its early stopping raises one
    too) and keeps the weights it has; ``interrupted_`` tells the two apart.
    """

    #: Keep batch normalisation in eval mode while training (running statistics
    #: used and left alone), as when fine-tuning; set by ``finetune``.
    freeze_batch_norm = False

    def _set_training(self, training=True):
        super()._set_training(training)
        if training and self.freeze_batch_norm:
            for layer in self.module_.modules():
                if isinstance(layer, torch.nn.modules.batchnorm._BatchNorm):
                    layer.eval()

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


def training_callbacks(est, monitor):
    """The built-in skorch callbacks of the training protocol, then the user's.

    Parameters
    ----------
    est : estimator
        Has ``lr``, ``lr_factor``, ``lr_patience``, ``patience``, ``max_epochs``,
        ``verbose`` and ``callbacks``.
    monitor : {"valid_loss", "train_loss"}
        The loss that drives the schedule and early stopping.

    Returns
    -------
    callbacks : list of (str, skorch.callbacks.Callback)
        Divergence check, plateau schedule, early stopping (restoring the best
        epoch), a progress bar when verbose, and ``est.callbacks``.
    """
    callbacks = [
        ("divergence_check", DivergenceCheck(est.lr)),
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
    """Set ``net_``, ``history_``, ``n_epochs_``, ``best_epoch_``; warn on Ctrl-C.

    Parameters
    ----------
    est : estimator
        The estimator being fitted.
    net : _Net
        Its trained skorch net.
    """
    net.module_.eval()
    est.net_ = net
    est.history_ = net.history
    est.n_epochs_ = sum("train_loss" in row for row in net.history)
    est.best_epoch_ = int(dict(net.callbacks_)["early_stopping"].best_epoch_)
    if getattr(net, "interrupted_", False):
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
        Has ``objective``, ``ljung_box_lags`` and ``batch_size``.
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
    segment = getattr(est, "ljung_box_segment_length", None)
    if segment is not None and segment <= est.ljung_box_lags:
        raise ValueError(
            f"ljung_box_segment_length={segment} must be larger than "
            f"ljung_box_lags={est.ljung_box_lags}: objective={est.objective!r} "
            "computes autocovariances within each segment."
        )
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


class BaseNeuralRegressor(
    SimulatorMixin,
    TransactionalFitMixin,
    VersionedPickleMixin,
    RegressorMixin,
    BaseEstimator,
):
    """Base class of the skorch-backed neural regressors.

    A subclass builds its network in ``_make_module``; this class holds the
    training protocol of the paper (appendix A), data handling and prediction. It
    is a plain :class:`~sklearn.base.BaseEstimator`: ``fit`` builds a
    :class:`skorch.NeuralNetRegressor` and stores it as ``net_``.

    Training protocol:

    - inputs and targets are standardised with the training rows' mean and
      standard deviation (``x_mean_``, ``x_scale_``, ``y_mean_``, ``y_scale_``);
      the network trains in float32 on standardised data; ``predict`` runs a
      float64 copy of the weights (so a row's prediction does not depend on the
      rows predicted with it) and returns float64 in the original units;
    - Adam with learning rate ``lr``; the learning rate is multiplied by
      ``lr_factor`` when the monitored loss has not improved for ``lr_patience``
      epochs (``ReduceLROnPlateau``); training stops when it has not improved for
      ``patience`` epochs, and the weights of the best epoch are restored;
    - the monitored loss is the validation loss on the LAST ``validation_fraction``
      of the rows (rows are assumed in time order, so this is the most recent
      stretch of data; never a random or leading slice). When
      ``validation_fraction=0``, or when the training or the validation part would
      be too small (fewer than 2 rows, or for a Ljung-Box objective no more than
      ``ljung_box_lags`` rows), the model trains on all rows and monitors the
      training loss instead;
    - with ``objective="mse"`` the rows are shuffled into mini-batches of
      ``batch_size``; an objective with a Ljung-Box term needs time order, so the
      rows are cut into contiguous blocks of at least ``batch_size`` rows, kept in
      order inside each block (only the order of the blocks is shuffled), or,
      with ``ljung_box_segment_length``, a batch is shuffled rows for the MSE
      plus segments in time order for the Ljung-Box term; the validation loss is
      computed on the whole validation stretch at once.

    For joint training (``HybridEnsembleRegressor``) and other torch code, the
    public :meth:`make_module` returns the estimator's network as a fresh
    :class:`torch.nn.Module`. Subclasses implement it through the hook
    ``_make_module(n_features, n_outputs)`` (same signature and contract).

    Parameters
    ----------
    %(training_parameters)s
    """

    _is_abstract_base = True

    _parameter_constraints = {
        "objective": [StrOptions(set(OBJECTIVES))],
        "ljung_box_lags": [Interval(Integral, 1, None, closed="left")],
        "ljung_box_weight": [Interval(Real, 0, None, closed="left")],
        "ljung_box_segment_length": [Interval(Integral, 2, None, closed="left"), None],
        "ljung_box_scaling": [StrOptions({"target", "per_output"})],
        "mse_pretraining": ["boolean"],
        "lr": [Interval(Real, 0, None, closed="neither")],
        "max_epochs": [Interval(Integral, 1, None, closed="left")],
        "batch_size": [Interval(Integral, 2, None, closed="left")],
        "validation_fraction": [Interval(Real, 0, 1, closed="left")],
        "patience": [Interval(Integral, 1, None, closed="left"), None],
        "lr_patience": [Interval(Integral, 0, None, closed="left")],
        "lr_factor": [Interval(Real, 0, 1, closed="neither")],
        "callbacks": [list, None],
        "random_state": ["random_state"],
        "device": [StrOptions({"cpu", "cuda"})],
        "target_scaling": [StrOptions({"per_output", "shared"})],
        "horizon": [Interval(Integral, 1, None, closed="left")],
        "target": [StrOptions({"state", "increment"})],
        "verbose": ["verbose"],
    }

    def __init__(
        self,
        *,
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
        ljung_box_segment_length=None,
        ljung_box_scaling="target",
        mse_pretraining=False,
        lr=0.01,
        max_epochs=200,
        batch_size=512,
        validation_fraction=0.2,
        target_scaling="per_output",
        horizon=1,
        target="state",
        patience=30,
        lr_patience=10,
        lr_factor=0.5,
        callbacks=None,
        random_state=None,
        device="cpu",
        verbose=0,
    ):
        self.objective = objective
        self.ljung_box_lags = ljung_box_lags
        self.ljung_box_weight = ljung_box_weight
        self.ljung_box_segment_length = ljung_box_segment_length
        self.ljung_box_scaling = ljung_box_scaling
        self.mse_pretraining = mse_pretraining
        self.lr = lr
        self.max_epochs = max_epochs
        self.batch_size = batch_size
        self.validation_fraction = validation_fraction
        self.target_scaling = target_scaling
        self.horizon = horizon
        self.target = target
        self.patience = patience
        self.lr_patience = lr_patience
        self.lr_factor = lr_factor
        self.callbacks = callbacks
        self.random_state = random_state
        self.device = device
        self.verbose = verbose

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

    # -- what subclasses provide -------------------------------------------------
    def _make_module(self, n_features, n_outputs):
        """A fresh torch module mapping standardised X to standardised y."""
        raise NotImplementedError

    def make_module(self, n_features, n_outputs):
        """A freshly initialised network with this estimator's architecture.

        The stable contract for training the network inside other torch code
        (:class:`~skhybrid.hybrid.HybridEnsembleRegressor` trains it jointly
        with physics parameters). The module maps standardised rows of shape
        ``(n, n_features)`` to ``(n, n_outputs)`` (float32 parameters; call
        ``.double()`` for float64). It draws its initial weights from torch's
        global random generator: seed it inside :func:`torch.random.fork_rng`
        for repeatable weights. It needs no fitted state, so it can be called on
        an unfitted estimator; only the architecture hyperparameters are used,
        not the training settings.

        Parameters
        ----------
        n_features : int
            Columns of a row.
        n_outputs : int
            Outputs per row.

        Returns
        -------
        module : torch.nn.Module
            The network, in training mode.

        Raises
        ------
        ValueError
            When a hyperparameter is invalid or does not fit the data's shape.
        """
        self._validate_params()
        self._check_architecture(n_features, n_outputs)
        return self._make_module(n_features, n_outputs)

    def _check_architecture(self, n_features, n_outputs):
        """Raise a ValueError for hyperparameters that do not fit the data."""

    def _check_increment(self):
        """Hook: networks that cannot learn increments raise a ValueError."""

    def _training_module(self, module):
        """What skorch trains: the module itself, or a wrapper around it."""
        return module

    def _criterion(self):
        return ObjectiveLoss, {}

    def _fitted_module(self):
        """The fitted module that maps X to y."""
        module = self.net_.module_
        return module.net if isinstance(module, RolloutModule) else module

    def _horizon_data(self, X, y, Xt, yt, n_valid):
        """Start windows, future inputs and targets for ``horizon``-step training.

        The sub-sequences are found in the rows themselves
        (:meth:`~skhybrid.preprocessing.WindowLayout.horizon_starts`): a start is
        a row from which ``horizon`` rows follow that each continue the one before.
        A start whose horizon reaches into the validation tail of the rows
        validates; the others train.
        """
        if self.objective != "mse":
            raise ValueError(
                f"horizon={self.horizon} trains on simulated sub-sequences with "
                f"objective='mse' only; got objective={self.objective!r}."
            )
        n_steps = self.get_params(deep=False).get("n_steps")
        if self._increment_layout is not None:
            n_steps = self._increment_layout.n_steps
        if n_steps is None:
            # A network without n_steps (DenseRegressor) reads a flat row: find
            # the window length under which the rows continue each other most.
            candidates = [
                k
                for k in range(1, X.shape[1] + 1)
                if X.shape[1] % k == 0 and X.shape[1] // k >= y.shape[1]
            ]
            found = {
                k: WindowLayout.from_shapes(X.shape[1], y.shape[1], n_steps=k)
                for k in candidates
            }
            found = {
                k: (lay, lay.horizon_starts(X, y, self.horizon))
                for k, lay in found.items()
            }
            n_steps = max(found, key=lambda k: len(found[k][1]))
            layout, starts = found[n_steps]
        else:
            layout = WindowLayout.from_shapes(X.shape[1], y.shape[1], n_steps=n_steps)
            starts = layout.horizon_starts(X, y, self.horizon)
        if len(starts) == 0:
            raise ValueError(
                f"horizon={self.horizon}: no {self.horizon} consecutive rows of X "
                "continue each other (row i + 1 is row i shifted by one step with "
                f"y[i] as its newest state, in a layout of n_steps={n_steps}); pass "
                "time-ordered windows (skhybrid.preprocessing.make_windows) or "
                "horizon=1."
            )
        h = self.horizon
        future = starts[:, None] + np.arange(1, h)[None, :]
        newest = X[:, X.shape[1] - layout.step_width :][:, layout.n_states :]
        U = newest[future].reshape(len(starts), -1)
        Z = torch.cat([Xt[starts], self._to_tensor(U)], dim=1)
        steps = starts[:, None] + np.arange(h)[None, :]
        if self._increment_layout is None:
            targets = yt[steps].reshape(len(starts), -1)
        else:
            # The rollout returns (simulated state - start's newest state) /
            # y_scale_: its residuals are the simulation errors in the scale of
            # the increments.
            base = layout.newest_states(X[starts])
            rel = (y[steps] - base[:, None, :]) / self.y_scale_
            targets = self._to_tensor(rel.reshape(len(starts), -1))
        stop = X.shape[0] - n_valid
        n_valid_starts = int(np.sum(starts + h - 1 >= stop)) if n_valid else 0
        if n_valid_starts < 2 or len(starts) - n_valid_starts < 2:
            n_valid_starts = 0
        rollout = (layout, h, self.x_mean_, self.x_scale_, self.y_mean_, self.y_scale_)
        rollout = (*rollout, self._increment_layout is not None)
        return rollout, Z, targets, n_valid_starts

    def _find_increment_layout(self, X, y):
        """The layout whose newest state ``target="increment"`` adds to."""
        n_features, n_outputs = X.shape[1], y.shape[1]
        n_steps = self.get_params(deep=False).get("n_steps")
        if n_steps is None:
            # A flat row (DenseRegressor): the window length under which the
            # rows continue each other most, else one step.
            candidates = [
                k
                for k in range(1, n_features + 1)
                if n_features % k == 0 and n_features // k >= n_outputs
            ]
            counts = {
                k: int(
                    np.sum(
                        WindowLayout.from_shapes(
                            n_features, n_outputs, n_steps=k
                        ).continues(X, y)
                    )
                )
                for k in candidates
            }
            n_steps = max(counts, key=counts.get) if counts else 1
        if n_features % n_steps or n_features // n_steps < n_outputs:
            raise ValueError(
                f"target='increment' adds the network's output to the newest "
                f"state of each row, the first n_outputs={n_outputs} columns of "
                f"its newest step, but a row of n_features={n_features} columns "
                f"in n_steps={n_steps} step(s) cannot hold it; use "
                "target='state' or rows that carry the state."
            )
        return WindowLayout.from_shapes(n_features, n_outputs, n_steps=n_steps)

    # -- helpers -------------------------------------------------------------------
    def _check_device(self):
        check_device(self.device)

    def _rng_devices(self):
        return rng_devices(self.device)

    def _to_tensor(self, array):
        return torch.as_tensor(
            np.ascontiguousarray(array, dtype=np.float32), device=self.device
        )

    def _split(self, n_samples, min_rows):
        """Number of validation rows taken from the end (0 for none)."""
        return validation_rows(n_samples, self.validation_fraction, min_rows)

    # -- public API ----------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Train the network on time-ordered rows.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows in time order (see :mod:`skhybrid.preprocessing`); the last
            ``validation_fraction`` of them monitor training.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Targets.

        Returns
        -------
        self : object
            The fitted estimator.
        """
        X, y = validate_data(
            self,
            X,
            y,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
            ensure_min_samples=2,
        )
        self._check_device()
        y2 = y.reshape(-1, 1) if y.ndim == 1 else y
        n_samples, n_features = X.shape
        n_outputs = y2.shape[1]
        self._check_architecture(n_features, n_outputs)
        time_ordered = needs_time_order(self.objective)
        min_rows = check_time_ordered_rows(self, n_samples)

        self._increment_layout = None
        y_train = y2
        if self.target == "increment":
            self._check_increment()
            self._increment_layout = self._find_increment_layout(X, y2)
            y_train = y2 - self._increment_layout.newest_states(X)
        x_scaler = StandardScaler().fit(X)
        y_scaler = StandardScaler().fit(y_train)
        self.x_mean_, self.x_scale_ = x_scaler.mean_, x_scaler.scale_
        self.y_mean_, self.y_scale_ = y_scaler.mean_, y_scaler.scale_
        if self.target_scaling == "shared":
            shared = np.sqrt(np.mean(self.y_scale_**2))
            self.y_scale_ = np.full_like(self.y_scale_, shared if shared > 0 else 1.0)
        self.n_outputs_ = n_outputs
        self._y_1d = y.ndim == 1
        Xt = self._to_tensor((X - self.x_mean_) / self.x_scale_)
        yt = self._to_tensor((y_train - self.y_mean_) / self.y_scale_)

        n_valid = self._split(n_samples, min_rows)
        monitor = "valid_loss" if n_valid else "train_loss"
        rollout = None
        if self.horizon > 1:
            rollout, Xt, yt, n_valid = self._horizon_data(X, y2, Xt, yt, n_valid)
            monitor = "valid_loss" if n_valid else "train_loss"
        if n_valid:
            stop = Xt.shape[0] - n_valid
            train_split = predefined_split(Dataset(Xt[stop:], yt[stop:]))
            Xt, yt = Xt[:stop], yt[:stop]
            # A Ljung-Box validation loss is the statistic of the whole stretch.
            valid_batch_size = n_valid if time_ordered else self.batch_size
        else:
            train_split, valid_batch_size = None, self.batch_size

        callbacks = training_callbacks(self, monitor)

        criterion, criterion_kwargs = self._criterion()
        segmented = self.objective in ("ljung_box", "mse+ljung_box")
        segment = self.ljung_box_segment_length if segmented else None
        lb_scale = None
        if time_ordered and self.ljung_box_scaling == "per_output":
            variance = yt.double().var(dim=0, unbiased=False).cpu().numpy()
            # An output without variance has nothing to whiten: leave it at 1.
            lb_scale = np.where(variance > 0, variance, 1.0).tolist()
        pretrain = self.mse_pretraining and time_ordered
        seed = check_random_state(self.random_state).randint(np.iinfo(np.int32).max)
        with torch.random.fork_rng(devices=self._rng_devices()):
            torch.manual_seed(seed)
            module = self._training_module(self._make_module(n_features, n_outputs))
            if rollout is not None:
                module = RolloutModule(module, *rollout)
            net = _Net(
                module=module,
                criterion=criterion,
                criterion__objective="mse" if pretrain else self.objective,
                criterion__lags=self.ljung_box_lags,
                criterion__ljung_box_weight=self.ljung_box_weight,
                criterion__segment_length=segment,
                criterion__ljung_box_scale=lb_scale,
                criterion__segment_count=(
                    max(1, self.batch_size // segment) if segment else None
                ),
                **{f"criterion__{k}": v for k, v in criterion_kwargs.items()},
                optimizer=torch.optim.Adam,
                lr=self.lr,
                max_epochs=self.max_epochs,
                batch_size=self.batch_size,
                train_split=train_split,
                iterator_train=BatchIterator,
                iterator_train__shuffle=True,
                iterator_train__contiguous=(
                    time_ordered and not segment and not pretrain
                ),
                iterator_train__segment_length=None if pretrain else segment,
                iterator_valid=BatchIterator,
                iterator_valid__contiguous=time_ordered,
                iterator_valid__batch_size=valid_batch_size,
                callbacks=callbacks,
                device=self.device,
                verbose=self.verbose,
            )
            # skorch catches KeyboardInterrupt (Ctrl-C, and its own early
            # stopping) inside fit and restores the best weights on the way out.
            net.fit(Xt, yt)
            if pretrain and not net.interrupted_:
                finetune(net, Xt, yt, self.objective, segment)
        record_training(self, net)
        return self

    def _forward(self, module, X, mean, scale):
        """Run a module in eval mode on ``(X - mean) / scale``, in float64 chunks.

        The computation runs in float64 with float64 copies of the (float32-trained)
        weights passed through :func:`torch.func.functional_call`: float32 matrix
        products may round differently for different batch sizes, which would make
        a row's prediction depend on the other rows predicted with it. The module
        itself is neither copied nor changed, rows are standardised chunk by chunk
        and the output is written into one preallocated array, so the memory
        beyond the input and the output stays a few chunks' worth.
        """
        from torch.func import functional_call

        state = {
            name: (t.detach().to(torch.float64) if t.is_floating_point() else t)
            for name, t in (*module.named_parameters(), *module.named_buffers())
        }
        training = module.training
        module.eval()
        out = None
        try:
            with torch.no_grad():
                for start in range(0, X.shape[0], _PREDICT_CHUNK):
                    stop = start + _PREDICT_CHUNK
                    chunk = torch.as_tensor(
                        (X[start:stop] - mean) / scale,
                        dtype=torch.float64,
                        device=self.device,
                    )
                    part = functional_call(module, state, (chunk,)).cpu().numpy()
                    if out is None:
                        out = np.empty((X.shape[0], part.shape[1]))
                    out[start:stop] = part
        finally:
            module.train(training)
        return out

    def predict(self, X):
        """Predict with the trained network.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows laid out as in ``fit``.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Float64 predictions in the units of ``y``; 1-D when ``y`` was 1-D in
            ``fit``.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        y_pred = self._forward(self._fitted_module(), X, self.x_mean_, self.x_scale_)
        y_pred *= self.y_scale_
        y_pred += self.y_mean_
        if getattr(self, "_increment_layout", None) is not None:
            y_pred += self._increment_layout.newest_states(X)
        return y_pred[:, 0] if self._y_1d else y_pred


BaseNeuralRegressor.__doc__ = fill_training_docstring(BaseNeuralRegressor.__doc__)
