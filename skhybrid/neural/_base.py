"""BaseNeuralRegressor: the training protocol shared by the neural estimators."""

import textwrap
from numbers import Integral

import numpy as np
import torch
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from skhybrid.neural._modules import ObjectiveLoss, RolloutModule
from skhybrid.neural.engine import (
    check_device,
    check_time_ordered_rows,
    record_training,
    train_module,
    training_constraints,
    training_parameters_doc,
    validation_rows,
)
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import SimulatorMixin
from skhybrid.utils._docstrings import fill_docstring
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

#: What the network learns and over how many steps: parameters of the row
#: networks (and the joint ensemble's ``horizon``), beside the shared training
#: parameters of :mod:`skhybrid.neural.engine`.
NETWORK_PARAMETERS_DOC = """\
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
        simulated state. ``CyclicRegressor`` supports ``"state"`` only."""

#: The training parameters every neural estimator takes: the engine's shared
#: ones, then the networks' own.
TRAINING_PARAMETERS_DOC = training_parameters_doc() + "\n" + NETWORK_PARAMETERS_DOC

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
    interrupted_ : bool
        Whether a Ctrl-C cut the training short (the best epoch so far was
        kept, and a ``UserWarning`` said so).
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
    return fill_docstring(
        doc,
        training_parameters=textwrap.dedent(TRAINING_PARAMETERS_DOC),
        fitted_attributes=textwrap.dedent(FITTED_ATTRIBUTES_DOC),
    )


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

    #: Whether the module of ``_make_module`` has a ``lockstep_signature``, so
    #: that the networks of fits run in lockstep train as one batched call.
    _module_in_lockstep = False

    _parameter_constraints = {
        **training_constraints(),
        "horizon": [Interval(Integral, 1, None, closed="left")],
        "target": [StrOptions({"state", "increment"})],
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
        patience=30,
        lr_patience=10,
        lr_factor=0.5,
        callbacks=None,
        random_state=None,
        device="cpu",
        verbose=0,
        horizon=1,
        target="state",
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

    @property
    def fits_in_lockstep(self):
        """Whether a search fits this model's folds side by side: on a GPU.

        There, in threads of one process, the folds' networks train as one
        batched call (:mod:`skhybrid.neural._lockstep`), each with its own
        data, weights, optimiser, early stopping and schedule, and each getting
        what it gets alone up to floating point; a step of all of them costs
        about one where small kernels are launch-bound. On a CPU the batched
        call was slower than the folds in turn (a scratch measurement of four
        dense folds on one thread), so the folds are spread over the search's
        workers instead. A network that cannot be batched (the
        recurrent layers of :class:`~skhybrid.neural.RNNRegressor`) never
        fits in lockstep.
        """
        return self._module_in_lockstep and self.device == "cuda"

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
        rollout = None
        if self.horizon > 1:
            rollout, Xt, yt, n_valid = self._horizon_data(X, y2, Xt, yt, n_valid)
        valid = None
        if n_valid:
            stop = Xt.shape[0] - n_valid
            valid = (Xt[stop:], yt[stop:])
            Xt, yt = Xt[:stop], yt[:stop]

        def make_module():
            module = self._training_module(self._make_module(n_features, n_outputs))
            return module if rollout is None else RolloutModule(module, *rollout)

        criterion, criterion_kwargs = self._criterion()
        net = train_module(
            self,
            make_module,
            Xt,
            yt,
            valid=valid,
            criterion=criterion,
            criterion_kwargs=criterion_kwargs,
        )
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
