"""DenseRegressor: a multilayer perceptron trained with the paper's protocol."""

from numbers import Integral

from skhybrid.neural._base import BaseNeuralRegressor, fill_training_docstring
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
    %(training_parameters)s

    Attributes
    ----------
    %(fitted_attributes)s

    See Also
    --------
    RNNRegressor : A recurrent network over the time steps of each row.
    CyclicRegressor : An encoder trained together with an inverse (decoder) model.
    sklearn.neural_network.MLPRegressor : Scikit-learn's own perceptron.

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

    _module_in_lockstep = True

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
        super().__init__(
            objective=objective,
            ljung_box_lags=ljung_box_lags,
            ljung_box_weight=ljung_box_weight,
            ljung_box_segment_length=ljung_box_segment_length,
            ljung_box_scaling=ljung_box_scaling,
            mse_pretraining=mse_pretraining,
            lr=lr,
            max_epochs=max_epochs,
            batch_size=batch_size,
            validation_fraction=validation_fraction,
            target_scaling=target_scaling,
            horizon=horizon,
            target=target,
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


DenseRegressor.__doc__ = fill_training_docstring(DenseRegressor.__doc__)
