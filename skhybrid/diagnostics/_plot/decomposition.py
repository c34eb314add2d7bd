"""A trajectory split into its parts: :class:`DecompositionDisplay`.

matplotlib is imported inside ``plot`` only, so it stays an optional dependency.
"""

from inspect import signature

import numpy as np

from skhybrid.diagnostics._plot._common import (
    _check_models,
    _checked_predictions,
    _predictions_like,
    _store_panels,
)
from skhybrid.utils._docstrings import fill_doc
from skhybrid.utils._plotting import output_names as _output_names
from skhybrid.utils._plotting import panels as _panels

__all__ = ["DecompositionDisplay"]

#: What both constructors of DecompositionDisplay take and return.
_FROM_DOCS = {
    "band_time_axes": """\
n_std : float, default=2.0
    Half-width of the band in standard deviations.
time : array-like of shape (n_samples,) or None, default=None
    Horizontal axis; ``None`` uses the sample index.
ax : array of matplotlib Axes or None, default=None
    ``2 * n_outputs`` Axes.""",
    "plotted_display": """\
display : DecompositionDisplay
    The plotted display.""",
}


class DecompositionDisplay:
    """A trajectory split into a domain part, neural parts and a noise band.

    For each output, the top panel draws the measured output, the first (domain)
    part and the total prediction; the bottom panel draws what the domain part
    leaves (measured minus domain part, as dots), each later (neural) part, and
    the noise band ``total +- n_std * std`` shifted by the domain part, so the
    band sits around the neural correction at the scale where it can be seen.
    Dots inside the band are what the noise model calls noise.

    Parameters
    ----------
    time : ndarray of shape (n_samples,)
        Horizontal axis.
    y_true : ndarray of shape (n_samples, n_outputs)
        Measured outputs.
    parts : dict of str to ndarray of shape (n_samples, n_outputs)
        Additive parts in stage order; the first is the domain part.
    total : ndarray of shape (n_samples, n_outputs)
        The prediction (the sum of the parts).
    lower, upper : ndarray of shape (n_samples, n_outputs)
        Edges of the noise band around ``total``.
    band_label : str, default="noise band"
        Legend entry of the band.
    output_names : list of str or None, default=None
        Panel titles.
    estimator_name : str or None, default=None
        Figure title.

    Attributes
    ----------
    axes_ : ndarray of matplotlib Axes of shape (2, n_outputs)
        Top row: trajectory; bottom row: what the domain part leaves.
    ax_ : matplotlib Axes
        The first top panel.
    figure_ : matplotlib Figure
        Figure holding the panels.
    lines_ : dict of str to list of matplotlib Line2D
        Lines per part name, plus ``"measured"`` and ``"total"``; one per output.
    bands_ : list of matplotlib PolyCollection
        The noise band of each output.

    See Also
    --------
    ResidualACFDisplay : Whether the final residuals are white.

    Notes
    -----
    :meth:`from_estimator` relies on ``estimator.decompose(X)`` returning a
    :class:`~sklearn.utils.Bunch` with ``stage_names`` (stage names in order), one
    key per stage holding its additive part and ``total`` (their sum, equal to
    ``predict(X)``), as :class:`~skhybrid.hybrid.HybridBoostingRegressor` does; this
    module does not import :mod:`skhybrid.hybrid`.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from skhybrid.diagnostics import DecompositionDisplay
    >>> t = np.linspace(0, 10, 300)
    >>> physics = np.sin(t)
    >>> correction = 0.1 * np.sin(5 * t)
    >>> y = physics + correction + 0.02 * np.random.default_rng(0).standard_normal(300)
    >>> disp = DecompositionDisplay.from_decomposition(
    ...     {"physics": physics, "rnn": correction}, y, time=t)
    >>> disp.axes_.shape
    (2, 1)
    >>> plt.close(disp.figure_)
    """

    def __init__(
        self,
        *,
        time,
        y_true,
        parts,
        total,
        lower,
        upper,
        band_label="noise band",
        output_names=None,
        estimator_name=None,
    ):
        self.time = time
        self.y_true = y_true
        self.parts = parts
        self.total = total
        self.lower = lower
        self.upper = upper
        self.band_label = band_label
        self.output_names = output_names
        self.estimator_name = estimator_name

    def plot(self, ax=None, *, name=None):
        """Draw the panels.

        Parameters
        ----------
        ax : array of matplotlib Axes or None, default=None
            ``2 * n_outputs`` Axes (top row first); ``None`` makes a new figure.
        name : str or None, default=None
            Overrides ``estimator_name`` as the figure title.

        Returns
        -------
        display : DecompositionDisplay
            This object, with the artists set.
        """
        parts = _check_models(self.parts, "parts")
        y_true = np.asarray(self.y_true, dtype=float)
        y_true = y_true[:, None] if y_true.ndim == 1 else y_true
        time = np.asarray(self.time, dtype=float)
        n_outputs = y_true.shape[1]

        def as_2d(arr):
            return np.asarray(arr, dtype=float).reshape(y_true.shape)

        parts = {key: as_2d(val) for key, val in parts.items()}
        total, lower, upper = (as_2d(a) for a in (self.total, self.lower, self.upper))
        names = _output_names(self.output_names, n_outputs)
        name = self.estimator_name if name is None else name
        fig, axes = _panels(
            ax,
            2,
            n_outputs,
            "DecompositionDisplay.plot",
            panel_size=(6.0, 2.8),
            sharex=True,
        )
        stage_names = list(parts)
        first = stage_names[0]
        later = stage_names[1:]
        domain = parts[first]
        self.lines_ = {"measured": [], "total": [], **{s: [] for s in stage_names}}
        self.bands_ = []
        for j in range(n_outputs):
            top, bottom = axes[0, j], axes[1, j]
            (meas,) = top.plot(
                time,
                y_true[:, j],
                ".",
                color="0.45",
                markersize=2.5,
                label="measured",
            )
            (dom,) = top.plot(
                time, domain[:, j], color="C0", linewidth=1.5, label=first
            )
            (tot,) = top.plot(
                time,
                total[:, j],
                color="C3",
                linewidth=1.0,
                linestyle="--",
                label="total",
            )
            self.lines_["measured"].append(meas)
            self.lines_[first].append(dom)
            self.lines_["total"].append(tot)
            top.set_title(names[j], fontsize="medium")

            self.bands_.append(
                bottom.fill_between(
                    time,
                    lower[:, j] - domain[:, j],
                    upper[:, j] - domain[:, j],
                    color="C3",
                    alpha=0.18,
                    linewidth=0,
                    label=self.band_label,
                )
            )
            bottom.plot(
                time,
                y_true[:, j] - domain[:, j],
                ".",
                color="0.45",
                markersize=2.5,
                label=f"measured - {first}",
            )
            for k, stage in enumerate(later):
                (line,) = bottom.plot(
                    time,
                    parts[stage][:, j],
                    color=f"C{k + 1}",
                    linewidth=1.3,
                    label=stage,
                )
                self.lines_[stage].append(line)
            bottom.axhline(0.0, color="black", linewidth=0.6)
            bottom.set_xlabel("time")
            if j == 0:
                top.set_ylabel("output")
                bottom.set_ylabel(f"left by {first}")
        axes[0, 0].legend(loc="upper right", fontsize="small")
        axes[1, 0].legend(loc="upper right", fontsize="small")
        if name:
            fig.suptitle(name)
        return _store_panels(self, fig, axes)

    @classmethod
    @fill_doc(**_FROM_DOCS)
    def from_decomposition(
        cls,
        parts,
        y_true,
        *,
        total=None,
        std=None,
        n_std=2.0,
        time=None,
        ax=None,
        name=None,
        output_names=None,
    ):
        """Plot additive parts of a prediction against the measured output.

        Parameters
        ----------
        parts : dict of str to array-like of shape (n_samples,) or \
                (n_samples, n_outputs)
            Additive parts in stage order; the first is the domain part.
        y_true : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs.
        total : array-like or None, default=None
            The prediction; ``None`` sums the parts.
        std : array-like of shape (n_samples,) or (n_samples, n_outputs) or None, \
                default=None
            Predictive standard deviation of a noise model. ``None`` uses the
            standard deviation of ``y_true - total`` per output (a constant band).
        %(band_time_axes)s
        name : str or None, default=None
            Figure title.
        output_names : list of str or None, default=None
            Panel titles.

        Returns
        -------
        %(plotted_display)s
        """
        yt, checked = _checked_predictions(parts, y_true, "parts")
        arrays = dict(checked)
        if total is None:
            total = sum(arrays.values())
        else:
            total = _predictions_like(total, yt, "total")
        if std is None:
            std = np.broadcast_to(np.std(yt - total, axis=0), yt.shape)
            band_label = f"±{n_std:g} std of residual"
        else:
            std = np.asarray(std, dtype=float)
            std = std[:, None] if std.ndim == 1 else std
            try:
                std = np.broadcast_to(std, yt.shape)
            except ValueError as exc:
                raise ValueError(
                    f"std must have shape (n_samples,) or {yt.shape}; got "
                    f"{np.shape(std)}."
                ) from exc
            band_label = f"±{n_std:g} std of noise model"
        if time is None:
            time = np.arange(yt.shape[0])
        time = np.asarray(time, dtype=float)
        if time.shape != (yt.shape[0],):
            raise ValueError(
                f"time must have shape ({yt.shape[0]},); got {time.shape}."
            )
        disp = cls(
            time=time,
            y_true=yt,
            parts=arrays,
            total=total,
            lower=total - n_std * std,
            upper=total + n_std * std,
            band_label=band_label,
            output_names=output_names,
            estimator_name=name,
        )
        return disp.plot(ax=ax)

    @classmethod
    @fill_doc(**_FROM_DOCS)
    def from_estimator(
        cls,
        estimator,
        X,
        y,
        *,
        n_std=2.0,
        time=None,
        ax=None,
        name=None,
        output_names=None,
    ):
        """Plot a fitted hybrid estimator's decomposition on ``X, y``.

        Parameters
        ----------
        estimator : fitted estimator with ``decompose(X)``
            Returns a Bunch with ``stage_names``, one key per stage and
            ``total``. Where ``predict(X, return_std=True)`` exists, its standard
            deviation draws the band; else the residual's.
        X : array-like of shape (n_samples, n_features)
            Rows in time order.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs.
        %(band_time_axes)s
        name : str or None, default=None
            Figure title; ``None`` uses the estimator's class name.
        output_names : list of str or None, default=None
            Panel titles.

        Returns
        -------
        %(plotted_display)s
        """
        if not callable(getattr(estimator, "decompose", None)):
            raise TypeError(
                f"estimator must have a decompose(X) method (a hybrid model); got "
                f"{type(estimator).__name__}."
            )
        bunch = estimator.decompose(X)
        stage_names = list(bunch["stage_names"])
        parts = {stage: bunch[stage] for stage in stage_names}
        std = None
        try:
            has_std = "return_std" in signature(estimator.predict).parameters
        except (TypeError, ValueError):  # pragma: no cover - builtins
            has_std = False
        # A booster fitted without a noise model has predict(return_std=...) but no
        # standard deviation to give: fall back to the residual's spread then.
        if has_std and getattr(estimator, "noise_model_", True) is not None:
            _, std = estimator.predict(X, return_std=True)
        return cls.from_decomposition(
            parts,
            y,
            total=bunch.get("total"),
            std=std,
            n_std=n_std,
            time=time,
            ax=ax,
            name=type(estimator).__name__ if name is None else name,
            output_names=output_names,
        )
