"""Training-loop plumbing handed to skorch: a batch iterator and callbacks."""

import math
from itertools import pairwise

import torch
from skorch.callbacks import Callback

from skhybrid.exceptions import TrainingDivergedError

__all__ = ["BatchIterator", "DivergenceCheck"]


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
        ``False``: batches of ``batch_size`` rows; with ``shuffle`` the rows are
        shuffled; a last batch of a single row joins the one before it (batch
        normalisation needs two rows to train). ``True``: the rows are cut into
        ``max(1, n // batch_size)`` contiguous blocks of at least ``batch_size``
        rows, kept in time order inside each block; ``shuffle`` shuffles the order
        of the blocks only. Objectives with a Ljung-Box term use blocks.
    """

    def __init__(self, dataset, batch_size, shuffle=False, contiguous=False):
        self.dataset = dataset
        self.batch_size = batch_size
        self.shuffle = shuffle
        self.contiguous = contiguous

    def _bounds(self, n):
        if self.contiguous:
            n_blocks = max(1, n // self.batch_size)
            edges = [(i * n) // n_blocks for i in range(n_blocks + 1)]
        else:
            edges = [*range(0, n, self.batch_size), n]
            if len(edges) > 2 and edges[-1] - edges[-2] == 1:
                del edges[-2]
        return list(pairwise(edges))

    def __len__(self):
        return len(self._bounds(len(self.dataset.X)))

    def __iter__(self):
        X, y = self.dataset.X, self.dataset.y
        n = len(X)
        bounds = self._bounds(n)
        if self.shuffle and not self.contiguous:
            perm = torch.randperm(n, device=X.device)
            for start, stop in bounds:
                idx = perm[start:stop]
                yield X[idx], y[idx]
            return
        if self.shuffle:
            order = torch.randperm(len(bounds)).tolist()
            bounds = [bounds[i] for i in order]
        for start, stop in bounds:
            yield X[start:stop], y[start:stop]


class DivergenceCheck(Callback):
    """Stop training with :class:`~skhybrid.exceptions.TrainingDivergedError`.

    Checks the epoch's training loss (and validation loss, where there is one): a
    NaN or infinite value means the weights have blown up, usually because the
    learning rate is too large.
    """

    def __init__(self, lr):
        self.lr = lr

    def on_epoch_end(self, net, **kwargs):
        row = net.history[-1]
        for key in ("train_loss", "valid_loss"):
            value = row.get(key)
            if value is not None and not math.isfinite(value):
                raise TrainingDivergedError(
                    f"the {key.replace('_', ' ')} became {value} at epoch "
                    f"{row['epoch']} with lr={self.lr}; lower lr (for example to "
                    f"lr={self.lr / 10:g}) or check the data for extreme values."
                )
