"""RNNRegressor: a recurrent network over the time steps of each row."""

from numbers import Integral

from skhybrid.neural._base import BaseNeuralRegressor, fill_training_docstring
from skhybrid.neural._modules import RecurrentModule
from skhybrid.preprocessing import step_width
from skhybrid.utils._sklearn_compat import Interval, StrOptions

__all__ = ["RNNRegressor"]


class RNNRegressor(BaseNeuralRegressor):
    """Recurrent network regressor (GRU, LSTM or Elman RNN), skorch-backed.

    A row of ``X`` is a window of ``n_steps`` time steps, oldest first (the data
    convention of :mod:`skhybrid.preprocessing`); the network reads it as a
    sequence of shape ``(n_steps, n_features // n_steps)``, with batch
    normalisation of each step's features at the input, and a linear layer maps
    the hidden state after the newest step to the outputs. History comes from the
    window, not from neighbouring rows, so predictions never depend on row order.
    Trains with the paper's protocol (see :class:`DenseRegressor`).

    Parameters
    ----------
    cell : {"gru", "lstm", "rnn"}, default="gru"
        Recurrent cell: :class:`torch.nn.GRU`, :class:`torch.nn.LSTM` or
        :class:`torch.nn.RNN` (tanh).
    hidden_size : int, default=50
        Hidden units per recurrent layer (the paper: 50).
    num_layers : int, default=2
        Stacked recurrent layers. The paper used 10; with ``lr=0.01`` a stack of
        10 GRU layers trained poorly in our tests (held-out R^2 of 0.32 against
        0.993 with 2 layers on ``y = x sin(3x)``, 5,000 rows), so the default is 2.
        ``num_layers=10, lr=0.001`` reproduces the paper's architecture (R^2
        0.993 there, about 6 times slower).
    n_steps : int, default=1
        Time steps per row; ``n_features`` must be a multiple of it.
    %(training_parameters)s

    Attributes
    ----------
    %(fitted_attributes)s

    See Also
    --------
    DenseRegressor : A multilayer perceptron on the flattened row.
    skhybrid.preprocessing.make_windows : Builds windows of ``n_steps`` steps.

    Notes
    -----
    ``fit`` builds a :class:`skorch.NeuralNetRegressor` (``net_``). A loss that
    becomes NaN or infinite stops training with
    :class:`~skhybrid.exceptions.TrainingDivergedError`; Ctrl-C during ``fit``
    keeps the best weights so far.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.neural import RNNRegressor
    >>> from skhybrid.preprocessing import make_windows
    >>> t = np.arange(600) * 0.1
    >>> X, y = make_windows(np.sin(t)[:, None], np.cos(0.5 * t)[:, None], n_steps=3)
    >>> model = RNNRegressor(hidden_size=16, num_layers=1, n_steps=3,
    ...                      max_epochs=20, batch_size=64, random_state=0)
    >>> model.fit(X, y.ravel()).predict(X[:2]).shape
    (2,)
    """

    _parameter_constraints = {
        **BaseNeuralRegressor._parameter_constraints,
        "cell": [StrOptions({"gru", "lstm", "rnn"})],
        "hidden_size": [Interval(Integral, 1, None, closed="left")],
        "num_layers": [Interval(Integral, 1, None, closed="left")],
        "n_steps": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(
        self,
        cell="gru",
        *,
        hidden_size=50,
        num_layers=2,
        n_steps=1,
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
        self.cell = cell
        self.hidden_size = hidden_size
        self.num_layers = num_layers
        self.n_steps = n_steps

    def _check_architecture(self, n_features, n_outputs):
        step_width(n_features, self.n_steps)

    def _make_module(self, n_features, n_outputs):
        """A fresh :class:`RecurrentModule` for rows of ``n_features`` columns.

        Parameters
        ----------
        n_features : int
            Input width; a multiple of ``n_steps``.
        n_outputs : int
            Output width.

        Returns
        -------
        module : torch.nn.Module
            Maps standardised ``(n, n_features)`` float32 rows to ``(n, n_outputs)``;
            freshly initialised from torch's global random generator.
        """
        if self.cell not in ("gru", "lstm", "rnn"):
            raise ValueError(
                f"cell must be 'gru', 'lstm' or 'rnn'; got cell={self.cell!r}."
            )
        return RecurrentModule(
            n_step_features=step_width(int(n_features), self.n_steps),
            n_steps=self.n_steps,
            n_outputs=int(n_outputs),
            cell=self.cell,
            hidden_size=self.hidden_size,
            num_layers=self.num_layers,
        )


RNNRegressor.__doc__ = fill_training_docstring(RNNRegressor.__doc__)
