"""CyclicRegressor: an encoder X -> y trained together with a decoder y -> X."""

from numbers import Real

import numpy as np
from sklearn.utils import check_array
from sklearn.utils.validation import check_is_fitted

from skhybrid.neural._base import BaseNeuralRegressor, fill_training_docstring
from skhybrid.neural._dense import _check_layer_sizes
from skhybrid.neural._modules import CycleTrainingModule, CyclicLoss, CyclicModule
from skhybrid.utils._sklearn_compat import Interval

__all__ = ["CyclicRegressor"]


class CyclicRegressor(BaseNeuralRegressor):
    """Cyclic (autoencoding) regressor: a forward model and its inverse, together.

    An encoder (a perceptron, as in :class:`DenseRegressor`) maps ``X`` to
    ``y_hat``; a decoder maps ``y_hat`` back to ``X``. Both train together on

        ``objective(y, y_hat) + cycle_weight * mean((X - decoder(y_hat)) ** 2)``

    in standardised units (the paper's cyclic method, section 3.3). The cycle term
    asks the encoder for predictions from which the inputs can be recovered, which
    regularises it; the decoder is a model of the inverse map, available as
    :meth:`inverse_predict`. Trains with the paper's protocol (see
    :class:`DenseRegressor`).

    Parameters
    ----------
    hidden_layer_sizes : tuple of int, default=(256,) * 10
        Hidden layers of the encoder (the paper's 10 layers of 256 units).
    decoder_layer_sizes : tuple of int or None, default=None
        Hidden layers of the decoder; ``None`` uses ``hidden_layer_sizes``.
    cycle_weight : float, default=0.01
        Weight of the reconstruction term (0 trains the encoder alone). Both
        terms are in standardised units: a good fit has an objective of about
        ``1 - R^2`` (0.01 or less), while a reconstruction of ``X`` that ``y``
        cannot determine stays of order 1, so large weights trade accuracy of
        ``predict`` for invertibility (``cycle_weight=1`` gave R^2 of 0.29 instead
        of 0.994 on the non-invertible ``y = x sin(3x)``). Adam's step sizes do
        not depend on the scale of the loss, so the decoder learns as well with a
        small weight.
    %(training_parameters)s

    Attributes
    ----------
    %(fitted_attributes)s

    See Also
    --------
    DenseRegressor : The encoder alone.
    RNNRegressor : A recurrent network over the time steps of each row.

    Notes
    -----
    ``predict`` runs the encoder, ``inverse_predict`` the decoder. The
    reconstruction is only as good as ``y`` is informative about ``X``: where
    several inputs lead to the same output, the decoder returns their average.
    ``history_`` records the total loss (objective plus cycle term).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.neural import CyclicRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(0, 1, size=(500, 1))
    >>> y = np.exp(X[:, 0])
    >>> model = CyclicRegressor(hidden_layer_sizes=(32, 32), max_epochs=20,
    ...                         batch_size=32, random_state=0).fit(X, y)
    >>> model.predict(X[:2]).shape
    (2,)
    >>> model.inverse_predict(y[:2]).shape
    (2, 1)
    """

    _module_in_lockstep = True

    _parameter_constraints = {
        **BaseNeuralRegressor._parameter_constraints,
        "hidden_layer_sizes": ["array-like"],
        "decoder_layer_sizes": ["array-like", None],
        "cycle_weight": [Interval(Real, 0, None, closed="left")],
    }

    def __init__(
        self,
        hidden_layer_sizes=(256,) * 10,
        *,
        decoder_layer_sizes=None,
        cycle_weight=0.01,
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
        self.decoder_layer_sizes = decoder_layer_sizes
        self.cycle_weight = cycle_weight

    def _layer_sizes(self):
        encoder = _check_layer_sizes("hidden_layer_sizes", self.hidden_layer_sizes)
        if self.decoder_layer_sizes is None:
            return encoder, encoder
        decoder = _check_layer_sizes("decoder_layer_sizes", self.decoder_layer_sizes)
        return encoder, decoder

    def _check_architecture(self, n_features, n_outputs):
        self._layer_sizes()

    def _make_module(self, n_features, n_outputs):
        """A fresh :class:`CyclicModule`; calling it runs the encoder.

        Parameters
        ----------
        n_features : int
            Input width.
        n_outputs : int
            Output width.

        Returns
        -------
        module : torch.nn.Module
            Maps standardised ``(n, n_features)`` float32 rows to ``(n, n_outputs)``
            (the encoder); ``module.reconstruct(y)`` runs the decoder and
            ``module.encoder`` / ``module.decoder`` are the two halves.
        """
        encoder, decoder = self._layer_sizes()
        return CyclicModule(int(n_features), int(n_outputs), encoder, decoder)

    def _check_increment(self):
        raise ValueError(
            "CyclicRegressor supports target='state' only (its decoder maps the "
            f"predicted state back to the row); got target={self.target!r}. Use "
            "DenseRegressor or RNNRegressor for target='increment'."
        )

    def _training_module(self, module):
        if self.horizon > 1:
            raise ValueError(
                f"CyclicRegressor trains one step ahead; got horizon={self.horizon}. "
                "Use DenseRegressor or RNNRegressor for horizon > 1."
            )
        return CycleTrainingModule(module)

    def _criterion(self):
        return CyclicLoss, {"cycle_weight": self.cycle_weight}

    def _fitted_module(self):
        return self.net_.module_.cyclic

    def inverse_predict(self, y):
        """Reconstruct the inputs from outputs with the decoder (the inverse model).

        Parameters
        ----------
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Outputs, in the units of the ``y`` seen in ``fit``.

        Returns
        -------
        X_rec : ndarray of shape (n_samples, n_features)
            Float64 reconstruction of the inputs, in the units of ``X``.
        """
        check_is_fitted(self)
        y = _check_y(y, self.n_outputs_)
        X_rec = self._forward(
            self._fitted_module().decoder, y, self.y_mean_, self.y_scale_
        )
        X_rec *= self.x_scale_
        X_rec += self.x_mean_
        return X_rec


def _check_y(y, n_outputs):
    y = check_array(y, ensure_2d=False, dtype=np.float64, input_name="y")
    if y.ndim == 1:
        y = y.reshape(-1, 1)
    if y.ndim != 2 or y.shape[1] != n_outputs:
        raise ValueError(
            f"y has shape {y.shape}; the model was fitted with n_outputs_={n_outputs} "
            "target columns, so y must be (n_samples,) for one output or "
            "(n_samples, n_outputs_)."
        )
    return y


CyclicRegressor.__doc__ = fill_training_docstring(CyclicRegressor.__doc__)
