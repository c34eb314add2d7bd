"""The second phase of ``mse_pretraining``: fine-tuning on a Ljung-Box objective.

The first phase is an ordinary MSE fit (skorch's ``fit``); :func:`finetune` then
switches the criterion and the batches to the estimator's objective, freezes
batch normalisation and goes on with skorch's ``partial_fit``, which keeps the
weights, the optimiser's state and its (possibly reduced) learning rate. Early
stopping starts from the pretrained weights as a candidate
(:class:`CandidateEarlyStopping`), so the weights kept are never worse on the
validation objective than the MSE solution.
"""

import math
from copy import deepcopy

from skorch.callbacks import EarlyStopping
from skorch.dataset import Dataset

__all__ = [
    "CandidateEarlyStopping",
    "finetune",
    "propose_candidate",
    "validation_loss",
]


class CandidateEarlyStopping(EarlyStopping):
    """skorch's ``EarlyStopping``, optionally seeded with a candidate.

    Set ``candidate_ = (score, epoch, weights)`` before a training run and the
    run starts as if an epoch had already scored ``score`` with the module's
    ``weights`` (a state dict): later epochs must beat it to be kept, and when
    none does its weights are restored at the end (with ``load_best``). The
    candidate is used by one run only.
    """

    def on_train_begin(self, net, **kwargs):
        super().on_train_begin(net, **kwargs)
        candidate = getattr(self, "candidate_", None)
        self.candidate_ = None
        if candidate is None:
            return
        score, epoch, weights = candidate
        self.dynamic_threshold_ = self._calc_new_threshold(score)
        self.best_epoch_ = epoch
        if self.load_best:
            self.best_model_weights_ = weights


def validation_loss(net, X, y):
    """The loss of the net's current weights on ``X``, ``y``, as skorch records it.

    Parameters
    ----------
    net : skorch.NeuralNet
        An initialised net.
    X, y : torch.Tensor
        Samples and targets, batched by the net's validation iterator.

    Returns
    -------
    loss : float
        The mean loss over the samples (weighted by batch size).
    """
    total, count = 0.0, 0
    for batch in net.get_iterator(Dataset(X, y), training=False):
        n = len(batch[1])
        total += net.validation_step(batch)["loss"].item() * n
        count += n
    return total / count


def propose_candidate(net, X, y, *, epoch):
    """Make the module's current weights early stopping's first candidate.

    Parameters
    ----------
    net : skorch.NeuralNet
        An initialised net whose callbacks include ``"early_stopping"``, a
        :class:`CandidateEarlyStopping`.
    X, y : torch.Tensor
        Where the weights are scored (the monitored data).
    epoch : int
        The epoch recorded as the candidate's (0: the starting weights).
    """
    score = validation_loss(net, X, y)
    if score is not None and math.isfinite(score):
        stopper = dict(net.callbacks_)["early_stopping"]
        stopper.candidate_ = (score, epoch, deepcopy(net.module_.state_dict()))


def finetune(net, X, y, objective, segment_length, *, sequences=False, valid=None):
    """Continue a net trained on the MSE with ``objective``.

    Parameters
    ----------
    net : skorch.NeuralNet
        Fitted with ``criterion__objective="mse"``, its best weights restored; its
        callbacks include ``"early_stopping"``, a :class:`CandidateEarlyStopping`.
    X, y : torch.Tensor
        The training tensors ``net`` was fitted on.
    objective : str
        The objective with a Ljung-Box term to go on with.
    segment_length : int or None
        Segments of the Ljung-Box term of row models (see ``BatchIterator``);
        None trains on contiguous blocks of rows.
    sequences : bool, default=False
        Whether the samples are simulated sub-sequences: the batches stay as
        they are (each sequence is a series of its own).
    valid : tuple of torch.Tensor or None, default=None
        The validation tensors of the first phase; the pretrained weights'
        loss on them is the second phase's first candidate.

    Returns
    -------
    net : skorch.NeuralNet
        Trained for up to ``net.max_epochs`` more epochs; ``net.history`` holds
        both phases.
    """
    # Attributes, not set_params: set_params on the criterion would
    # re-initialise the optimiser and lose its state and learning rate.
    net.criterion_.objective = objective
    if not sequences:
        net.iterator_train__segment_length = segment_length
        net.iterator_train__contiguous = segment_length is None
    if valid is not None:
        stopper = dict(net.callbacks_)["early_stopping"]
        propose_candidate(net, *valid, epoch=stopper.best_epoch_)
    # The batches of this phase end in segments of consecutive rows; batch
    # normalisation would take its statistics from them too, and that alone
    # (Ljung-Box weight 0) made the DC motor's validation loss 24 % worse after
    # one epoch at a learning rate of 2e-5. Frozen, it keeps the statistics of
    # the MSE phase's shuffled rows, the usual practice when fine-tuning.
    net.freeze_batch_norm = True
    net.partial_fit(X, y, epochs=net.max_epochs)
    return net
