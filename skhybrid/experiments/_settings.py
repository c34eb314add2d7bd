"""Sizes and training budgets of the experiments: the full run and ``--quick``."""

from dataclasses import asdict, dataclass, replace

__all__ = ["ExperimentSettings"]


@dataclass(frozen=True)
class ExperimentSettings:
    """Sizes, architectures and training budget shared by every model of a run.

    Chosen before looking at any test set: the architectures follow the paper's
    appendix A scaled to a CPU budget, and every network stops early on a
    validation slice taken from the end of its training rows.

    Parameters
    ----------
    n_train : int
        Training rows.
    n_test : int
        Rows of each test set (interpolative, extrapolative).
    n_steps : int
        Time steps per row (the window the RNN reads).
    max_epochs : int
        Most epochs of any network.
    patience : int
        Epochs without validation improvement before early stopping.
    dense_layers : tuple of int
        Hidden layers of the dense and cyclic networks.
    rnn_hidden : int
        Hidden units per recurrent layer.
    rnn_layers : int
        Recurrent layers.
    batch_size : int
        Mini-batch size.
    window : int
        Samples per short window of the RMSE-in-dB box plots.
    lags : int
        Ljung-Box lags of the losses and the whiteness tests.
    seed : int
        Seed of data and models.
    noise_type : {"measurement", "process"} or None
        Where the simulators' noise enters (see
        :func:`skhybrid.datasets.make_pendulum`): ``"measurement"`` on the measured
        states, the paper's setting, or ``"process"`` into the dynamics, so that
        the true equations' one-step residual is white. ``None`` takes the
        system's default: process noise for the double pendulum, whose whiteness
        claim is testable only then, measurement noise elsewhere.
    """

    n_train: int = 25_000
    n_test: int = 25_000
    n_steps: int = 4
    max_epochs: int = 200
    patience: int = 30
    dense_layers: tuple = (128, 128, 128)
    rnn_hidden: int = 50
    rnn_layers: int = 2
    batch_size: int = 512
    window: int = 200
    lags: int = 20
    seed: int = 0
    noise_type: str | None = None

    @classmethod
    def full(cls, seed=0):
        """The default run: the paper's data sizes on a CPU training budget."""
        return cls(seed=seed)

    @classmethod
    def quick(cls, seed=0):
        """A small run that finishes within a minute on two cores."""
        return cls(
            n_train=3_000,
            n_test=2_000,
            max_epochs=12,
            patience=5,
            dense_layers=(32, 32),
            rnn_hidden=16,
            rnn_layers=1,
            batch_size=256,
            window=100,
            seed=seed,
        )

    @property
    def is_full(self):
        """Whether these are the full run's settings (any seed and noise type)."""
        from dataclasses import replace

        full = replace(type(self).full(), noise_type=None)
        return replace(self, seed=0, noise_type=None) == full

    def with_seed(self, seed):
        """The same settings with another seed.

        Parameters
        ----------
        seed : int
            Seed of the data and the models.

        Returns
        -------
        settings : ExperimentSettings
            A copy with ``seed``.
        """
        return replace(self, seed=seed)

    def to_dict(self):
        """The settings as a JSON-ready dict.

        Returns
        -------
        settings : dict
            Every field, tuples as lists.
        """
        out = asdict(self)
        out["dense_layers"] = list(self.dense_layers)
        return out
