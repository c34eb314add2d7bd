"""SimulationDisplay: a free-run simulation against measured data."""

import numpy as np

from skhybrid.utils._docstrings import fill_doc
from skhybrid.utils._plotting import output_names as _output_names
from skhybrid.utils._plotting import panels as _panels

__all__ = ["SimulationDisplay"]

#: What both constructors of SimulationDisplay pass on, and return.
_FROM_DOCS = {
    "time_axes_names": """\
time : array-like of shape (n_times,) or None, default=None
    Time axis.
ax : array of matplotlib Axes or None, default=None
    Where to draw.
output_names : list of str or None, default=None
    Panel titles.""",
    "drawn_display": """\
display : SimulationDisplay
    The drawn display.""",
}


def _as_2d(array, name):
    array = np.asarray(array, dtype=float)
    array = array[:, None] if array.ndim == 1 else array
    if array.ndim != 2:
        raise ValueError(
            f"{name} must be 1-D or 2-D (n_times, n_outputs) for one experiment; got "
            f"shape {array.shape}."
        )
    return array


class SimulationDisplay:
    """Measured output, free-run simulation, its band and the error over time.

    Top row: the measured output (dots), the simulation (line) and, when a
    standard deviation is given, the band ``simulation +- n_std * std``; a
    vertical line marks the end of the measured initial window. Bottom row: the
    simulation error over time with its RMSE after the initial window in the
    title. One column per output.

    Create it with :meth:`from_estimator` (simulates for you) or
    :meth:`from_predictions`, then :meth:`plot` draws it again on other Axes.

    Parameters
    ----------
    y_true : ndarray of shape (n_times, n_outputs)
        Measured outputs.
    y_sim : ndarray of shape (n_times, n_outputs)
        Simulated outputs (the mean over sample paths, where there are some).
    y_std : ndarray of shape (n_times, n_outputs) or None, default=None
        Standard deviation over sample paths: draws the band.
    n_init : int, default=0
        Length of the measured initial window; the RMSE skips it.
    time : ndarray of shape (n_times,) or None, default=None
        Time axis; sample indices when None.
    output_names : list of str or None, default=None
        Panel titles.
    estimator_name : str or None, default=None
        Legend label of the simulation.

    Attributes
    ----------
    rmse_ : ndarray of shape (n_outputs,)
        Free-run RMSE of each output after the initial window.
    figure_ : matplotlib Figure
        The figure drawn on.
    axes_ : ndarray of matplotlib Axes of shape (2, n_outputs)
        The Axes drawn on.

    Examples
    --------
    >>> import numpy as np
    >>> import matplotlib.pyplot as plt
    >>> from skhybrid.simulation import SimulationDisplay
    >>> t = np.arange(100)
    >>> y = np.sin(0.1 * t)
    >>> disp = SimulationDisplay.from_predictions(y, y + 0.01, n_init=5)
    >>> disp.rmse_.round(3)
    array([0.01])
    >>> plt.close(disp.figure_)
    """

    def __init__(
        self,
        *,
        y_true,
        y_sim,
        y_std=None,
        n_init=0,
        time=None,
        output_names=None,
        estimator_name=None,
    ):
        self.y_true = y_true
        self.y_sim = y_sim
        self.y_std = y_std
        self.n_init = n_init
        self.time = time
        self.output_names = output_names
        self.estimator_name = estimator_name

    def plot(self, ax=None, *, n_std=2.0):
        """Draw the panels.

        Parameters
        ----------
        ax : array of matplotlib Axes or None, default=None
            ``2 * n_outputs`` Axes (top row first); None makes a new figure.
        n_std : float, default=2.0
            Half-width of the band in standard deviations.

        Returns
        -------
        display : SimulationDisplay
            This object, with ``figure_``, ``axes_`` and ``rmse_`` set.
        """
        y_true = _as_2d(self.y_true, "y_true")
        y_sim = _as_2d(self.y_sim, "y_sim")
        if y_sim.shape != y_true.shape:
            raise ValueError(
                f"y_sim must have the shape of y_true {y_true.shape}; got "
                f"{y_sim.shape}."
            )
        n_times, n_outputs = y_true.shape
        time = np.arange(n_times) if self.time is None else np.asarray(self.time)
        names = _output_names(self.output_names, n_outputs)
        label = self.estimator_name or "simulation"
        fig, axes = _panels(
            ax,
            2,
            n_outputs,
            "SimulationDisplay.plot",
            panel_size=(6.0, 2.8),
            sharex=True,
        )
        error = y_sim - y_true
        after = slice(int(self.n_init), None)
        self.rmse_ = np.sqrt(np.mean(error[after] ** 2, axis=0))
        for j in range(n_outputs):
            top, bottom = axes[0, j], axes[1, j]
            top.plot(
                time, y_true[:, j], ".", color="0.45", markersize=2.5, label="measured"
            )
            top.plot(time, y_sim[:, j], color="C3", linewidth=1.2, label=label)
            bottom.plot(time, error[:, j], color="C3", linewidth=1.0)
            if self.y_std is not None:
                std = _as_2d(self.y_std, "y_std")[:, j]
                top.fill_between(
                    time,
                    y_sim[:, j] - n_std * std,
                    y_sim[:, j] + n_std * std,
                    color="C3",
                    alpha=0.18,
                    linewidth=0,
                    label=f"+-{n_std:g} std",
                )
                bottom.fill_between(
                    time,
                    -n_std * std,
                    n_std * std,
                    color="C3",
                    alpha=0.18,
                    linewidth=0,
                )
            for axis in (top, bottom):
                if self.n_init:
                    axis.axvline(
                        time[int(self.n_init) - 1],
                        color="0.6",
                        linestyle=":",
                        linewidth=1,
                    )
            bottom.axhline(0.0, color="0.3", linewidth=0.8)
            top.set_title(names[j], fontsize="medium")
            bottom.set_title(f"error (RMSE {self.rmse_[j]:.3g})", fontsize="small")
            bottom.set_xlabel("time")
        axes[0, 0].legend(fontsize="small", loc="best")
        self.figure_, self.axes_ = fig, axes
        return self

    @classmethod
    @fill_doc(**_FROM_DOCS)
    def from_predictions(
        cls,
        y_true,
        y_sim,
        *,
        y_std=None,
        n_init=0,
        time=None,
        ax=None,
        output_names=None,
        name=None,
    ):
        """Plot a simulation already computed.

        Parameters
        ----------
        y_true : array-like of shape (n_times,) or (n_times, n_outputs)
            Measured outputs.
        y_sim : array-like of shape (n_times,) or (n_times, n_outputs)
            Simulated outputs.
        y_std : array-like of shape (n_times, n_outputs) or None, default=None
            Standard deviation over sample paths.
        n_init : int, default=0
            Length of the measured initial window.
        %(time_axes_names)s
        name : str or None, default=None
            Legend label of the simulation.

        Returns
        -------
        %(drawn_display)s
        """
        return cls(
            y_true=y_true,
            y_sim=y_sim,
            y_std=y_std,
            n_init=n_init,
            time=time,
            output_names=output_names,
            estimator_name=name,
        ).plot(ax=ax)

    @classmethod
    @fill_doc(**_FROM_DOCS)
    def from_estimator(
        cls,
        estimator,
        inputs,
        y_true,
        *,
        n_init,
        init="measured",
        return_std=False,
        random_state=None,
        time=None,
        ax=None,
        output_names=None,
        name=None,
    ):
        """Simulate one experiment with ``estimator`` and plot it.

        Parameters
        ----------
        estimator : fitted estimator with ``simulate``
            The model.
        inputs : array-like of shape (n_times, n_inputs)
            Inputs of the experiment.
        y_true : array-like of shape (n_times, n_outputs)
            Measured outputs; the first ``n_init`` start the simulation.
        n_init : int
            Length of the measured initial window.
        init : {"measured", "least_squares"}, default="measured"
            How the simulation starts (see :func:`skhybrid.simulation.simulate`).
        return_std : bool, default=False
            Draw the band of sample paths (needs a noise model).
        random_state : int, RandomState instance or None, default=None
            Seed of the sample paths.
        %(time_axes_names)s
        name : str or None, default=None
            Legend label; the estimator's class name when None.

        Returns
        -------
        %(drawn_display)s
        """
        y_true = _as_2d(y_true, "y_true")
        out = estimator.simulate(
            inputs,
            y_true[:n_init],
            init=init,
            return_std=return_std,
            random_state=random_state,
        )
        y_sim, y_std = out if return_std else (out, None)
        return cls.from_predictions(
            y_true,
            y_sim,
            y_std=y_std,
            n_init=n_init,
            time=time,
            ax=ax,
            output_names=output_names,
            name=type(estimator).__name__ if name is None else name,
        )
