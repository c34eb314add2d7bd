"""Training-loop plumbing handed to skorch: a batch iterator and callbacks."""

import math
from itertools import pairwise

import torch
from skorch.callbacks import Callback

from skhybrid.exceptions import TrainingDivergedError

__all__ = ["BatchIterator", "DivergenceCheck", "EpochProgress"]


class BatchIterator:
    """Mini-batches sliced straight from the tensors of a skorch ``Dataset``.

    skorch's default ``DataLoader`` fetches rows one at a time and collates them;
    slicing whole tensors removes that per-row cost (see
    ``benchmarks/bench_training_overhead.py``).

    Parameters
    ----------
    dataset : skorch.dataset.Dataset
        Holds tensors ``X`` and ``y`` (already on the training device).
    batch_size : int
        Rows per batch.
    shuffle : bool, default=False
        Shuffle before each pass.
    contiguous : bool, default=False
        ``False``: the rows are spread evenly over ``ceil(n / batch_size)``
        batches, whose sizes differ by at most one row (never a tiny last batch
        whose one noisy step per epoch could decide the result); with
        ``shuffle`` the rows are shuffled. ``True``: the rows are cut into
        ``max(1, n // batch_size)`` contiguous blocks of at least ``batch_size``
        rows, kept in time order inside each block; ``shuffle`` shuffles the order
        of the blocks only. Objectives with a Ljung-Box term use blocks.
    segment_length : int or None, default=None
        With ``shuffle`` (training): each batch of shuffled rows (as with
        ``contiguous=False``, whatever ``contiguous`` says) is followed by
        ``max(1, batch_size // segment_length)`` segments of ``segment_length``
        consecutive rows, each kept in time order, drawn from random places:
        each pass cuts the rows into segments from a random offset (so the cuts
        move from pass to pass) and deals them out in a random order, reusing
        them when the pass needs more. The shuffled rows give the batch the
        diversity of an MSE batch; the segments give a Ljung-Box objective time
        order (:class:`~skhybrid.neural._modules.ObjectiveLoss` with
        ``segment_count`` computes the MSE on the shuffled rows and the
        autocovariances within each segment). Ignored without ``shuffle`` or
        with fewer than ``2 * segment_length`` rows.
    at_least_batch_size : bool, default=False
        With ``contiguous=False``: spread the rows over ``max(1, n //
        batch_size)`` batches instead, each of at least ``batch_size`` rows
        (the batches of the sequence models, whose samples are long simulated
        sub-sequences: a rounded-up batch count would add a pass of work).
    generator : torch.Generator or None, default=None
        The (CPU) random generator of the shuffles; None draws from torch's
        global one. A net's own generator keeps its batches the same when
        other fits train beside it in threads of the same process.
    """

    def __init__(
        self,
        dataset,
        batch_size,
        shuffle=False,
        contiguous=False,
        segment_length=None,
        at_least_batch_size=False,
        generator=None,
    ):
        self.dataset = dataset
        self.batch_size = batch_size
        self.shuffle = shuffle
        self.contiguous = contiguous
        self.segment_length = segment_length
        self.at_least_batch_size = at_least_batch_size
        self.generator = generator

    def _randperm(self, n, device=None):
        """A permutation of ``n`` drawn from the iterator's generator."""
        perm = torch.randperm(n, generator=self.generator)
        return perm if device is None else perm.to(device)

    def _segmented(self, n):
        m = self.segment_length
        return bool(self.shuffle and m and n >= 2 * m)

    def _bounds(self, n, contiguous):
        if contiguous or self.at_least_batch_size:
            n_blocks = max(1, n // self.batch_size)
        else:
            n_blocks = max(1, math.ceil(n / self.batch_size))
            # Batch normalisation needs two rows per batch to train.
            n_blocks = max(1, min(n_blocks, n // 2))
        edges = [(i * n) // n_blocks for i in range(n_blocks + 1)]
        return list(pairwise(edges))

    def __len__(self):
        n = len(self.dataset.X)
        return len(self._bounds(n, self.contiguous and not self._segmented(n)))

    def __iter__(self):
        X, y = self.dataset.X, self.dataset.y
        n = len(X)
        if self._segmented(n):
            yield from self._iter_with_segments(X, y, n)
            return
        bounds = self._bounds(n, self.contiguous)
        if self.shuffle and not self.contiguous:
            perm = self._randperm(n, X.device)
            for start, stop in bounds:
                idx = perm[start:stop]
                yield X[idx], y[idx]
            return
        if self.shuffle:
            order = self._randperm(len(bounds)).tolist()
            bounds = [bounds[i] for i in order]
        for start, stop in bounds:
            yield X[start:stop], y[start:stop]

    def _iter_with_segments(self, X, y, n):
        m = self.segment_length
        bounds = self._bounds(n, contiguous=False)
        per_batch = max(1, self.batch_size // m)
        n_segments = n // m
        spare = n - n_segments * m
        offset = (
            int(torch.randint(spare + 1, (), generator=self.generator)) if spare else 0
        )
        need = len(bounds) * per_batch
        order = torch.cat(
            [self._randperm(n_segments) for _ in range(-(-need // n_segments))]
        )[:need]
        rows = torch.arange(m)
        perm = self._randperm(n, X.device)
        for i, (start, stop) in enumerate(bounds):
            starts = offset + order[i * per_batch : (i + 1) * per_batch] * m
            segments = (starts[:, None] + rows[None, :]).reshape(-1).to(X.device)
            idx = torch.cat([perm[start:stop], segments])
            yield X[idx], y[idx]


#: A loss this many times its first epoch's value (or 1, whichever is larger)
#: means the training blew up.
DIVERGENCE_GROWTH = 1e3
#: Losses are computed on standardised targets, where predicting the mean costs
#: about 1; a loss above this bound is a blow-up whatever the first epoch was.
DIVERGENCE_BOUND = 1e6


def check_divergence(loss, first, *, name, epoch, lr):
    """Raise TrainingDivergedError when ``loss`` is non-finite or has blown up.

    Parameters
    ----------
    loss : float
        The loss of this epoch.
    first : float or None
        The same loss at the first epoch (None at the first epoch itself).
    name : str
        What the loss is, for the message ("train loss", "valid loss").
    epoch : int
        The epoch, for the message.
    lr : float
        The learning rate, for the advice in the message.
    """
    advice = (
        f"lower lr (for example to lr={lr / 10:g}) or check the data for extreme "
        "values."
    )
    if not math.isfinite(loss):
        raise TrainingDivergedError(
            f"the {name} became {loss} at epoch {epoch} with lr={lr}; {advice}"
        )
    grew = first is not None and loss > DIVERGENCE_GROWTH * max(1.0, first)
    if loss > DIVERGENCE_BOUND or grew:
        raise TrainingDivergedError(
            f"the {name} grew to {loss:.3g} at epoch {epoch} with lr={lr} (first "
            f"epoch: {first if first is not None else loss:.3g}; losses are on "
            f"standardised targets, where predicting the mean costs about 1); the "
            f"training blew up: {advice}"
        )


class DivergenceCheck(Callback):
    """Stop training with :class:`~skhybrid.exceptions.TrainingDivergedError`.

    Checks the epoch's training loss (and validation loss, where there is one
    and ``keys`` names it): a NaN or infinite value, a loss more than
    ``DIVERGENCE_GROWTH`` times the first epoch's (or 1), or above
    ``DIVERGENCE_BOUND``, means the weights have blown up, usually because the
    learning rate is too large. A blow-up that stays finite is caught too.

    Parameters
    ----------
    lr : float
        The learning rate, for the advice of the message.
    keys : tuple of str, default=("train_loss", "valid_loss")
        The history's losses to check.
    """

    def __init__(self, lr, keys=("train_loss", "valid_loss")):
        self.lr = lr
        self.keys = keys

    def on_train_begin(self, net, **kwargs):
        self.first_ = {}

    def on_epoch_end(self, net, **kwargs):
        row = net.history[-1]
        for key in self.keys:
            value = row.get(key)
            if value is None:
                continue
            check_divergence(
                value,
                self.first_.get(key),
                name=key.replace("_", " "),
                epoch=row["epoch"],
                lr=self.lr,
            )
            self.first_.setdefault(key, value)


class EpochProgress(Callback):
    """Report every epoch's number, budget and losses to ``sink``.

    A skorch callback that can be pickled into a worker process with the network
    it watches: after each epoch it calls ``sink.emit(event)`` with the event
    ``{"kind": "epoch", "name": name, "epoch": k, "max_epochs": n,
    "train_loss": ..., "valid_loss": ...}`` (``valid_loss`` None without a
    validation part); ``epoch`` counts from 1 in each training (a fine-tuning
    phase started by ``partial_fit`` counts its own). Early stopping may end the
    training before ``max_epochs``.

    Parameters
    ----------
    sink : object
        Anything with ``emit(event)`` (the run's progress,
        :mod:`skhybrid.experiments.run._progress`).
    name : str
        What is trained (the model's name).
    """

    def __init__(self, sink, name):
        self.sink = sink
        self.name = name

    def on_train_begin(self, net, **kwargs):
        """Remember where this training starts in the network's history.

        A fine-tuning phase (``partial_fit``) continues the history: its epochs
        are counted from its own start, against its own budget.

        Parameters
        ----------
        net : skorch.NeuralNet
            The network about to train.
        **kwargs
            What skorch passes besides (unused).
        """
        self.start_ = len(net.history)

    def on_epoch_end(self, net, **kwargs):
        """Emit the epoch's event to the sink.

        Parameters
        ----------
        net : skorch.NeuralNet
            The network that ended an epoch.
        **kwargs
            What skorch passes besides (unused).
        """
        row = net.history[-1]
        start = getattr(self, "start_", 0)

        def loss(key):
            value = row.get(key)
            return None if value is None else float(value)

        self.sink.emit(
            {
                "kind": "epoch",
                "name": self.name,
                "epoch": len(net.history) - start,
                "max_epochs": int(net.max_epochs),
                "train_loss": loss("train_loss"),
                "valid_loss": loss("valid_loss"),
            }
        )
