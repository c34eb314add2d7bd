"""The torch modules behind the neural estimators.

Every module maps standardised float32 rows ``X`` of shape ``(n, n_features)`` to
``(n, n_outputs)`` and applies batch normalisation at its input, as in the paper's
protocol (appendix A). They are plain :class:`torch.nn.Module` subclasses, so the
hybrid ensemble can train them jointly with the parameters of a domain model.
"""

import torch
from torch import nn

from skhybrid.losses import mse, objective_value

__all__ = [
    "CycleTrainingModule",
    "CyclicLoss",
    "CyclicModule",
    "MLPModule",
    "ObjectiveLoss",
    "RecurrentModule",
    "SequenceObjectiveLoss",
]

_CELLS = {"gru": nn.GRU, "lstm": nn.LSTM, "rnn": nn.RNN}


class MLPModule(nn.Module):
    """Batch norm at the input, then ``Linear -> ReLU`` hidden layers, linear head.

    Parameters
    ----------
    n_features : int
        Input width.
    n_outputs : int
        Output width.
    hidden_layer_sizes : sequence of int
        Widths of the hidden layers; empty for a linear model (after batch norm).
    """

    def __init__(self, n_features, n_outputs, hidden_layer_sizes):
        super().__init__()
        layers = [nn.BatchNorm1d(n_features)]
        width = n_features
        for size in hidden_layer_sizes:
            layers += [nn.Linear(width, int(size)), nn.ReLU()]
            width = int(size)
        layers.append(nn.Linear(width, n_outputs))
        self.layers = nn.Sequential(*layers)

    def forward(self, X):
        return self.layers(X)

    def lockstep_signature(self):
        """What its forward pass reads besides its layers: nothing.

        Members of one structure train as one batched call where fits run in
        lockstep (:mod:`skhybrid.neural._lockstep`).
        """
        return ()


class RecurrentModule(nn.Module):
    """A recurrent network over the time steps of a row, linear head on the last one.

    A row of ``n_steps * n_step_features`` columns is read as ``n_steps`` time steps,
    oldest first (the data convention of :mod:`skhybrid.preprocessing`). Each step's
    features go through batch norm (statistics shared across steps), then the
    stacked recurrent layers; a linear layer maps the hidden state after the newest
    step to the outputs.

    It has no ``lockstep_signature``: members of fits run in lockstep train
    one by one (:mod:`skhybrid.neural._lockstep`), as ``torch.func.vmap`` has
    no batching rule for torch's recurrent layers (``aten::gru`` and the
    others, on CPU and GPU alike).

    Parameters
    ----------
    n_step_features : int
        Columns of one time step.
    n_steps : int
        Time steps per row.
    n_outputs : int
        Output width.
    cell : {"gru", "lstm", "rnn"}
        Recurrent cell.
    hidden_size : int
        Hidden units per layer.
    num_layers : int
        Stacked recurrent layers.
    """

    def __init__(
        self, n_step_features, n_steps, n_outputs, cell, hidden_size, num_layers
    ):
        super().__init__()
        self.n_steps = n_steps
        self.n_step_features = n_step_features
        self.batch_norm = nn.BatchNorm1d(n_step_features)
        self.rnn = _CELLS[cell](
            input_size=n_step_features,
            hidden_size=hidden_size,
            num_layers=num_layers,
            batch_first=True,
        )
        self.head = nn.Linear(hidden_size, n_outputs)

    def forward(self, X):
        n = X.shape[0]
        steps = self.batch_norm(X.reshape(n * self.n_steps, self.n_step_features))
        out, _ = self.rnn(steps.reshape(n, self.n_steps, self.n_step_features))
        return self.head(out[:, -1, :])


class CyclicModule(nn.Module):
    """An encoder ``X -> y`` and a decoder ``y -> X``; calling it runs the encoder.

    Parameters
    ----------
    n_features : int
        Input width (the decoder's output width).
    n_outputs : int
        Output width (the decoder's input width).
    hidden_layer_sizes : sequence of int
        Hidden layers of the encoder.
    decoder_layer_sizes : sequence of int
        Hidden layers of the decoder.
    """

    def __init__(self, n_features, n_outputs, hidden_layer_sizes, decoder_layer_sizes):
        super().__init__()
        self.encoder = MLPModule(n_features, n_outputs, hidden_layer_sizes)
        self.decoder = MLPModule(n_outputs, n_features, decoder_layer_sizes)

    def forward(self, X):
        return self.encoder(X)

    def reconstruct(self, y):
        """Decode (standardised) outputs back to (standardised) inputs."""
        return self.decoder(y)

    def lockstep_signature(self):
        """What its forward pass reads besides its layers: nothing.

        See :meth:`MLPModule.lockstep_signature`.
        """
        return ()


class CycleTrainingModule(nn.Module):
    """What skorch trains for a :class:`CyclicModule`: both halves in one pass.

    ``forward(X)`` returns ``(y_hat, decoder(y_hat), X)`` so that the criterion sees
    the prediction, the reconstruction and the input it must reproduce. Gradients of
    the cycle term flow through ``y_hat`` into the encoder as well: the cycle loss
    asks the encoder for predictions from which the input can be recovered.
    """

    def __init__(self, cyclic):
        super().__init__()
        self.cyclic = cyclic

    def forward(self, X):
        y_hat = self.cyclic.encoder(X)
        return y_hat, self.cyclic.decoder(y_hat), X

    def lockstep_signature(self):
        """What its forward pass reads besides its layers: nothing.

        See :meth:`MLPModule.lockstep_signature`.
        """
        return ()


class ObjectiveLoss(nn.Module):
    """A training objective of :mod:`skhybrid.losses` as a torch criterion.

    ``forward(y_pred, y_true)`` returns ``objective_value(y_true - y_pred, ...)``;
    with a Ljung-Box term the rows of a batch must be in time order, or end in
    segments that are (``segment_count``).

    Parameters
    ----------
    objective : {"mse", "ljung_box", "mse+ljung_box"}
        The objective.
    lags : int
        Ljung-Box lags.
    ljung_box_weight : float
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    segment_length : int or None, default=None
        Rows of a segment (see ``segment_count``).
    ljung_box_scale : sequence of float or None, default=None
        Divisor of each output's autocovariance norm (see
        :func:`~skhybrid.losses.objective_value`).
    segment_count : int or None, default=None
        In training mode, with ``segment_length``, a batch of more than
        ``segment_count * segment_length`` rows ends in that many segments of
        ``segment_length`` consecutive rows after shuffled rows (the batches of
        :class:`~skhybrid.neural._callbacks.BatchIterator` with
        ``segment_length``): the MSE is the mean over the shuffled rows, and
        the Ljung-Box term is computed on the segments, with the
        autocovariances pooled within them. In eval mode (the validation
        stretch), and without segments, the batch is one series.
    """

    def __init__(
        self,
        objective="mse",
        lags=20,
        ljung_box_weight=1.0,
        segment_length=None,
        ljung_box_scale=None,
        segment_count=None,
    ):
        super().__init__()
        self.objective = objective
        self.lags = lags
        self.ljung_box_weight = ljung_box_weight
        self.segment_length = segment_length
        self.ljung_box_scale = ljung_box_scale
        self.segment_count = segment_count

    def forward(self, y_pred, y_true):
        scale = self.ljung_box_scale
        if scale is not None:
            scale = torch.as_tensor(scale, dtype=y_pred.dtype, device=y_pred.device)
        kwargs = {"lags": self.lags, "ljung_box_scale": scale}
        k, m = self.segment_count, self.segment_length
        residuals = y_true - y_pred
        if (
            self.training
            and k
            and m
            and self.objective in ("ljung_box", "mse+ljung_box")
            and residuals.shape[0] > k * m
        ):
            term = objective_value(
                residuals[-k * m :], "ljung_box", segments=k, **kwargs
            )
            if self.objective == "ljung_box":
                return term
            # The MSE of the shuffled rows only: the segments' rows are few
            # independent stretches, and half the batch's weight on them made
            # the MSE's gradient noisier (measured, docs/losses.md).
            return mse(residuals[: -k * m]) + self.ljung_box_weight * term
        return objective_value(
            residuals,
            self.objective,
            ljung_box_weight=self.ljung_box_weight,
            **kwargs,
        )


class SequenceObjectiveLoss(ObjectiveLoss):
    """A training objective on simulated sequences, as a torch criterion.

    ``forward(y_pred, y_true)`` takes ``(n, T, n_outputs)`` tensors: ``n``
    simulated sub-sequences of ``T`` steps. The MSE is the mean over every step
    of every sequence; a Ljung-Box term is computed within each sequence (or
    each ``segment_length`` stretch of it, the remainder left out of the term)
    and pooled over them (:func:`~skhybrid.losses.objective_value` with
    ``segments``), so a residual autocorrelation never spans two sequences.

    Parameters
    ----------
    objective : {"mse", "ljung_box", "mse+ljung_box", "ljung_box_q"}
        The objective.
    lags : int
        Ljung-Box lags.
    ljung_box_weight : float
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    segment_length : int or None, default=None
        Steps of each series of the Ljung-Box term; None takes whole sequences.
    ljung_box_scale : sequence of float or None, default=None
        Divisor of each output's autocovariance norm.
    """

    def __init__(
        self,
        objective="mse",
        lags=20,
        ljung_box_weight=1.0,
        segment_length=None,
        ljung_box_scale=None,
    ):
        super().__init__(
            objective, lags, ljung_box_weight, segment_length, ljung_box_scale
        )

    def forward(self, y_pred, y_true):
        residuals = y_true - y_pred
        if self.objective == "mse":
            return mse(residuals)
        n, T, p = residuals.shape
        m = self.segment_length or T
        per = T // m
        series = residuals[:, : per * m].reshape(n * per * m, p)
        scale = self.ljung_box_scale
        if scale is not None:
            scale = torch.as_tensor(scale, dtype=y_pred.dtype, device=y_pred.device)
        term = objective_value(
            series,
            "ljung_box" if self.objective == "mse+ljung_box" else self.objective,
            lags=self.lags,
            segments=n * per,
            ljung_box_scale=scale,
        )
        if self.objective == "mse+ljung_box":
            return mse(residuals) + self.ljung_box_weight * term
        return term


class CyclicLoss(ObjectiveLoss):
    """``objective(y, y_hat) + cycle_weight * mse(X, decoder(y_hat))``.

    Takes the output ``(y_hat, X_reconstructed, X)`` of :class:`CycleTrainingModule`.

    Parameters
    ----------
    *args, **kwargs
        :class:`ObjectiveLoss`'s.
    cycle_weight : float, default=1.0
        Weight of the reconstruction's mean squared error.
    """

    def __init__(self, *args, cycle_weight=1.0, **kwargs):
        super().__init__(*args, **kwargs)
        self.cycle_weight = cycle_weight

    def forward(self, y_pred, y_true):
        y_hat, X_rec, X = y_pred
        loss = super().forward(y_hat, y_true)
        return loss + self.cycle_weight * torch.mean((X_rec - X) ** 2)


class RolloutModule(nn.Module):
    """Simulates ``horizon`` steps through a one-step network, for training.

    The input row holds a standardised start window (``n_features`` columns)
    followed by the raw inputs of the next ``horizon - 1`` steps; the output is
    the standardised prediction of every step, ``(n, horizon * n_outputs)``. At
    each step the window moves in raw units (each column of a window is
    standardised with its own statistics, so shifting standardised values would
    mix scales): the prediction enters as the newest state, the next input
    beside it, the oldest step leaves. Gradients flow through the whole horizon
    (truncated back-propagation through time, as SUBNET and dynoNet train).

    Parameters
    ----------
    net : torch.nn.Module
        The one-step network on standardised rows.
    layout : skhybrid.preprocessing.WindowLayout
        The rows' layout.
    horizon : int
        Steps simulated from each start.
    x_mean, x_scale, y_mean, y_scale : ndarray
        The standardisation of rows and targets.
    increment : bool, default=False
        Whether the network predicts the (standardised) increment of the newest
        state of its row. Each step then adds it to the simulated state, and the
        output is ``(state - x0) / y_scale`` per step, with ``x0`` the newest
        state of the start window: its residuals are the simulation errors.
    """

    def __init__(
        self,
        net,
        layout,
        horizon,
        x_mean,
        x_scale,
        y_mean,
        y_scale,
        increment=False,
    ):
        super().__init__()
        self.net = net
        self.layout = layout
        self.horizon = horizon
        self.increment = increment
        for name, value in (
            ("x_mean", x_mean),
            ("x_scale", x_scale),
            ("y_mean", y_mean),
            ("y_scale", y_scale),
        ):
            self.register_buffer(name, torch.as_tensor(value, dtype=torch.float32))

    def forward(self, Z):
        n_features = self.layout.n_features
        X = Z[:, :n_features]
        U = Z[:, n_features:].reshape(Z.shape[0], self.horizon - 1, -1)
        preds = []
        start = None
        for k in range(self.horizon):
            pred = self.net(X)
            raw = X * self.x_scale + self.x_mean
            state = pred * self.y_scale + self.y_mean
            if self.increment:
                newest = self.layout.newest_states(raw)
                start = newest if start is None else start
                state = newest + state
                preds.append((state - start) / self.y_scale)
            else:
                preds.append(pred)
            if k < self.horizon - 1:
                raw = self.layout.shift(raw, state, U[:, k] if U.shape[2] else None)
                X = (raw - self.x_mean) / self.x_scale
        return torch.cat(preds, dim=1)

    def lockstep_signature(self):
        """What its forward pass reads besides its tensors, or None.

        The layout, horizon and target, and the network's own signature; None
        (each member alone) where the network has none. See
        :meth:`MLPModule.lockstep_signature`.
        """
        net = getattr(self.net, "lockstep_signature", lambda: None)()
        if net is None:
            return None
        return (repr(self.layout), self.horizon, self.increment, net)
