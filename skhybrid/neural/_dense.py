"""DenseRegressor: a multilayer perceptron trained with the paper's protocol."""

from numbers import Integral

from skhybrid.neural._base import BaseNeuralRegressor
from skhybrid.neural._modules import MLPModule

__all__ = ["DenseRegressor"]


def _check_layer_sizes(name, sizes):
    """Validate a sequence of hidden layer widths; return it as a tuple of int."""
    try:
        sizes = tuple(sizes)
    except TypeError:
        sizes = None
    if sizes is None or not all(
        isinstance(s, Integral) and not isinstance(s, bool) and s >= 1 for s in sizes
    ):
        raise ValueError(
            f"{name} must be a sequence of positive integers (layer widths); "
            f"got {name}={sizes if sizes is not None else '?'!r}."
        )
    return tuple(int(s) for s in sizes)


class DenseRegressor(BaseNeuralRegressor):
    """Multilayer perceptron regressor (the paper's dense network), skorch-backed.

    Batch normalisation at the input, then ``Linear -> ReLU`` hidden layers and a
    linear output layer. Trains with the paper's protocol: Adam with ``lr=0.01``,
    the learning rate halved after 10 epochs without improvement of the
    validation loss, early stopping after 30 with the best weights restored,
    mini-batches of 512 rows, validation on the last 20 % of the (time-ordered)
    rows. Inputs and targets are standardised inside; predictions come back in the
    units of ``y`` as float64.

    Parameters
    ----------
    hidden_layer_sizes : tuple of int, default=(256,) * 10
        Widths of the hidden layers. The default is the paper's 10 layers of 256
        units (about 600,000 weights: roughly 0.1 s per epoch of 5,000 rows on
        two CPU cores); a few layers of 32 to 64 units train much faster and often
        suffice for residual stages.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        Training objective on the standardised residuals (see
        :mod:`skhybrid.losses.base`). An objective with a Ljung-Box term assumes
        the rows are in time order and trains on contiguous blocks of rows, never
        on shuffled rows.
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term; must be smaller than ``batch_size``.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
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
        0 is silent; 1 or more shows a progress bar and skorch's table of epochs.
    Attributes
    ----------
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
        Mean and scale used to standardise ``y``.
    See Also
    --------
    RNNRegressor : a recurrent network over the time steps of each row.
    CyclicRegressor : an encoder trained together with an inverse (decoder) model.
    sklearn.neural_network.MLPRegressor : scikit-learn's own perceptron.

    Notes
    -----
    ``fit`` builds a :class:`skorch.NeuralNetRegressor` (``net_``) around the
    module of :meth:`_make_module`; the estimator itself is a plain scikit-learn
    estimator, so it clones, pickles and takes part in pipelines and grid searches
    like any other. A loss that becomes NaN or infinite stops training with
    :class:`~skhybrid.exceptions.TrainingDivergedError` (lower ``lr``). Pressing
    Ctrl-C during ``fit`` stops training and keeps the best weights so far; the
    estimator is then fitted and usable.

    References
    ----------
    The training protocol follows appendix A of the method paper (Keras there).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.neural import DenseRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(500, 2))
    >>> y = np.sin(3 * X[:, 0]) + X[:, 1] ** 2
    >>> model = DenseRegressor(hidden_layer_sizes=(32, 32), max_epochs=20,
    ...                        batch_size=32, random_state=0).fit(X, y)
    >>> model.predict(X[:3]).shape
    (3,)
    >>> bool(model.score(X, y) > 0.9)
    True
    """

    _parameter_constraints = {
        **BaseNeuralRegressor._parameter_constraints,
        "hidden_layer_sizes": ["array-like"],
    }

    def __init__(
        self,
        hidden_layer_sizes=(256,) * 10,
        *,
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
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
    ):
        super().__init__(
            objective=objective,
            ljung_box_lags=ljung_box_lags,
            ljung_box_weight=ljung_box_weight,
            lr=lr,
            max_epochs=max_epochs,
            batch_size=batch_size,
            validation_fraction=validation_fraction,
            target_scaling=target_scaling,
            patience=patience,
            lr_patience=lr_patience,
            lr_factor=lr_factor,
            callbacks=callbacks,
            random_state=random_state,
            device=device,
            verbose=verbose,
        )
        self.hidden_layer_sizes = hidden_layer_sizes

    def _check_architecture(self, n_features, n_outputs):
        _check_layer_sizes("hidden_layer_sizes", self.hidden_layer_sizes)

    def _make_module(self, n_features, n_outputs):
        """A fresh :class:`MLPModule`: standardised ``(n, n_features)`` to outputs.

        Parameters
        ----------
        n_features : int
            Input width.
        n_outputs : int
            Output width.

        Returns
        -------
        module : torch.nn.Module
            Freshly initialised (from torch's global random generator).
        """
        sizes = _check_layer_sizes("hidden_layer_sizes", self.hidden_layer_sizes)
        return MLPModule(int(n_features), int(n_outputs), sizes)
