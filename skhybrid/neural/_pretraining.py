"""The second phase of ``mse_pretraining``: fine-tuning on a Ljung-Box objective.

The first phase is an ordinary MSE fit (skorch's ``fit``); :func:`finetune` then
switches the criterion and the batches to the estimator's objective, freezes
batch normalisation and goes on with skorch's ``partial_fit``, which keeps the
weights, the optimiser's state and its (possibly reduced) learning rate. Early
stopping starts from the pretrained weights as a candidate
(:class:`CandidateEarlyStopping`), so the weights kept are never worse on the
validation objective than the MSE solution.
"""

from copy import deepcopy

from skorch.callbacks import EarlyStopping

__all__ = ["CandidateEarlyStopping", "finetune"]


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


def _validation_loss(net, X, y):
    """The validation loss of the current weights, as skorch records it."""
    _, valid = net.get_split_datasets(X, y)
    if valid is None:
        return None
    total, count = 0.0, 0
    for batch in net.get_iterator(valid, training=False):
        n = len(batch[1])
        total += net.validation_step(batch)["loss"].item() * n
        count += n
    return total / count


def finetune(net, X, y, objective, segment_length):
    """Continue a net trained on the MSE with ``objective``.

    Parameters
    ----------
    net : skorch.NeuralNet
        Fitted with ``criterion__objective="mse"`` on shuffled batches, its best
        weights restored; its callbacks include ``"early_stopping"``, a
        :class:`CandidateEarlyStopping`.
    X, y : torch.Tensor
        The tensors ``net`` was fitted on (the validation split is taken from
        them as in the first phase).
    objective : str
        The objective with a Ljung-Box term to go on with.
    segment_length : int or None
        Segments of the Ljung-Box term (see ``BatchIterator``); None trains on
        contiguous blocks of rows.

    Returns
    -------
    net : skorch.NeuralNet
        Trained for up to ``net.max_epochs`` more epochs; ``net.history`` holds
        both phases.
    """
    # Attributes, not set_params: set_params on the criterion would
    # re-initialise the optimiser and lose its state and learning rate.
    net.criterion_.objective = objective
    net.iterator_train__segment_length = segment_length
    net.iterator_train__contiguous = segment_length is None
    stopper = dict(net.callbacks_)["early_stopping"]
    score = _validation_loss(net, X, y)
    if score is not None:
        stopper.candidate_ = (
            score,
            stopper.best_epoch_,
            deepcopy(net.module_.state_dict()),
        )
    # The batches of this phase end in segments of consecutive rows; batch
    # normalisation would take its statistics from them too, and that alone
    # (Ljung-Box weight 0) made the DC motor's validation loss 24 % worse after
    # one epoch at a learning rate of 2e-5. Frozen, it keeps the statistics of
    # the MSE phase's shuffled rows, the usual practice when fine-tuning.
    net.freeze_batch_norm = True
    net.partial_fit(X, y, epochs=net.max_epochs)
    return net
