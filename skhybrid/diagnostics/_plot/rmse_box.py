"""Box plots of RMSE in dB over short windows: :class:`RMSEBoxDisplay`.

matplotlib is imported inside ``plot`` only, so it stays an optional dependency.
"""

import numpy as np

from skhybrid.diagnostics._plot._common import (
    _OUTPUT_AXES,
    _OUTPUT_PANELS_ATTRIBUTES,
    _check_models,
    _checked_predictions,
    _store_panels,
)
from skhybrid.diagnostics._tests import _predict_like, rmse_db
from skhybrid.utils._docstrings import fill_doc
from skhybrid.utils._plotting import output_names as _output_names
from skhybrid.utils._plotting import panels as _panels

__all__ = ["RMSEBoxDisplay"]

#: What every constructor of RMSEBoxDisplay passes on to ``plot``, and returns.
_FROM_DOCS = {
    "box_options": _OUTPUT_AXES
    + """
whis : tuple of (float, float), default=(5, 95)
    Percentiles at the whisker ends.
bxp_kwargs : dict or None, default=None
    See :meth:`plot`.""",
    "plotted_display": """\
display : RMSEBoxDisplay
    The plotted display.""",
}

#: The windows of the constructors that score predictions.
_WINDOWS = """\
window : int, default=100
    Samples per window; the last, shorter window is dropped.
output_names : list of str or None, default=None
    Panel titles."""


def _check_whis(whis):
    try:
        low, high = (float(v) for v in whis)
    except (TypeError, ValueError):
        low = high = None
    if low is None or not 0.0 <= low < 25.0 or not 75.0 < high <= 100.0:
        raise ValueError(
            "whis must be a pair of percentiles (low, high) with 0 <= low < 25 and "
            f"75 < high <= 100; got whis={whis!r}."
        )
    return low, high


@fill_doc(output_panels_attributes=_OUTPUT_PANELS_ATTRIBUTES)
class RMSEBoxDisplay:
    """Box plots of RMSE in dB over short windows, one box per model.

    The paper's Fig. 3, 4, 6, 7 and 9: the test period is cut into consecutive
    windows, each window scored by ``20 log10(RMSE)``, and each model's scores
    drawn as a box (median, 25th and 75th percentiles), whiskers at the 5th and
    95th percentiles and the mean as a triangle; one panel per output. A box lower
    down is a smaller error; a tall box an error that varies over the test period.

    Parameters
    ----------
    rmse_db : dict of str to ndarray of shape (n_windows, n_outputs)
        Per-window RMSE in dB of each model, in the order to draw.
    output_names : list of str or None, default=None
        Panel titles.
    window : int or None, default=None
        Window length (samples), shown in the y label when given.

    Attributes
    ----------
    %(output_panels_attributes)s
    boxes_ : list of dict
        What ``Axes.bxp`` returned for each panel (keys ``"boxes"``,
        ``"medians"``, ``"whiskers"``, ``"means"``, ...).

    See Also
    --------
    rmse_db : The per-window scores.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from skhybrid.diagnostics import RMSEBoxDisplay
    >>> rng = np.random.default_rng(0)
    >>> y = rng.standard_normal((1000, 2))
    >>> preds = {"good": y + 0.01 * rng.standard_normal(y.shape),
    ...          "poor": y + 0.3 * rng.standard_normal(y.shape)}
    >>> disp = RMSEBoxDisplay.from_predictions(y, preds, window=50)
    >>> len(disp.boxes_[0]["boxes"])
    2
    >>> plt.close(disp.figure_)
    """

    def __init__(self, *, rmse_db, output_names=None, window=None):
        self.rmse_db = rmse_db
        self.output_names = output_names
        self.window = window

    def plot(self, ax=None, *, whis=(5, 95), bxp_kwargs=None, ylabel=None):
        """Draw the panels.

        Parameters
        ----------
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output; ``None`` makes a new figure.
        whis : tuple of (float, float), default=(5, 95)
            Percentiles at which the whiskers end (exactly, not at the nearest
            data point).
        bxp_kwargs : dict or None, default=None
            Passed to ``Axes.bxp``, over the defaults ``showmeans=True`` (a
            triangle), ``showfliers=False`` and ``patch_artist=True``.
        ylabel : str or None, default=None
            Label of the y axes.

        Returns
        -------
        display : RMSEBoxDisplay
            This object, with the artists set.
        """
        models = _check_models(self.rmse_db, "rmse_db")
        low, high = _check_whis(whis)
        values = {}
        for model, arr in models.items():
            arr = np.asarray(arr, dtype=float)
            values[model] = arr[:, None] if arr.ndim == 1 else arr
            if values[model].ndim != 2 or values[model].shape[0] == 0:
                raise ValueError(
                    f"rmse_db[{model!r}] must have shape (n_windows, n_outputs) with "
                    f"n_windows >= 1; got shape {np.shape(arr)}."
                )
            if not np.all(np.isfinite(values[model])):
                raise ValueError(
                    f"rmse_db[{model!r}] has non-finite values; an exact prediction "
                    "scores -inf dB and cannot be drawn."
                )
        n_outputs = {arr.shape[1] for arr in values.values()}
        if len(n_outputs) != 1:
            raise ValueError(
                "every model in rmse_db must have the same number of outputs; got "
                f"{ {m: a.shape[1] for m, a in values.items()} }."
            )
        n_outputs = n_outputs.pop()
        names = _output_names(self.output_names, n_outputs)
        width = max(4.0, 0.55 * len(values) + 1.0)
        fig, axes = _panels(
            ax, 1, n_outputs, "RMSEBoxDisplay.plot", panel_size=(width, 3.8)
        )
        axes = axes.ravel()
        kwargs = {
            "showmeans": True,
            "showfliers": False,
            "patch_artist": True,
            "widths": 0.6,
            "meanprops": {
                "marker": "^",
                "markerfacecolor": "white",
                "markeredgecolor": "black",
                "markersize": 7,
            },
            "medianprops": {"color": "black", "linewidth": 1.5},
            "boxprops": {"facecolor": "C0", "alpha": 0.6},
            **(bxp_kwargs or {}),
        }
        if ylabel is None:
            ylabel = "RMSE [dB]"
            if self.window is not None:
                ylabel = f"RMSE over {self.window}-sample windows [dB]"
        labels = list(values)
        positions = np.arange(1, len(labels) + 1)
        self.boxes_ = []
        for j, axis in enumerate(axes):
            box_stats = []
            for model in labels:
                scores = values[model][:, j]
                q = np.percentile(scores, [low, 25, 50, 75, high])
                box_stats.append(
                    {
                        "label": model,
                        "whislo": q[0],
                        "q1": q[1],
                        "med": q[2],
                        "q3": q[3],
                        "whishi": q[4],
                        "mean": scores.mean(),
                        "fliers": scores[(scores < q[0]) | (scores > q[4])],
                    }
                )
            self.boxes_.append(axis.bxp(box_stats, positions=positions, **kwargs))
            axis.set_xticks(positions)
            axis.set_xticklabels(labels, rotation=45, ha="right")
            axis.set_title(names[j], fontsize="medium")
            axis.grid(axis="y", alpha=0.3)
            if j == 0:
                axis.set_ylabel(ylabel)
        return _store_panels(self, fig, axes)

    @classmethod
    @fill_doc(**_FROM_DOCS)
    def from_rmse_db(
        cls,
        rmse_db,
        *,
        output_names=None,
        window=None,
        ax=None,
        whis=(5, 95),
        bxp_kwargs=None,
    ):
        """Plot precomputed per-window scores.

        Parameters
        ----------
        rmse_db : dict of str to array-like of shape (n_windows, n_outputs)
            Per-window RMSE in dB of each model (for example from
            ``rmse_db(y, y_pred, window=...)`` or a benchmark's CSV).
        output_names : list of str or None, default=None
            Panel titles.
        window : int or None, default=None
            Window length, shown in the y label.
        %(box_options)s

        Returns
        -------
        %(plotted_display)s
        """
        disp = cls(rmse_db=rmse_db, output_names=output_names, window=window)
        return disp.plot(ax=ax, whis=whis, bxp_kwargs=bxp_kwargs)

    @classmethod
    @fill_doc(**_FROM_DOCS, windows=_WINDOWS)
    def from_predictions(
        cls,
        y_true,
        y_pred,
        *,
        window=100,
        output_names=None,
        ax=None,
        whis=(5, 95),
        bxp_kwargs=None,
    ):
        """Score each model's predictions over consecutive windows and plot them.

        Parameters
        ----------
        y_true : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs over the test period, in time order.
        y_pred : dict of str to array-like of the same shape
            Each model's predictions, in the order to draw.
        %(windows)s
        %(box_options)s

        Returns
        -------
        %(plotted_display)s
        """
        yt, preds = _checked_predictions(y_pred, y_true, "y_pred")
        scores = {model: rmse_db(yt, pred, window=window) for model, pred in preds}
        return cls.from_rmse_db(
            scores,
            output_names=output_names,
            window=window,
            ax=ax,
            whis=whis,
            bxp_kwargs=bxp_kwargs,
        )

    @classmethod
    @fill_doc(**_FROM_DOCS, windows=_WINDOWS)
    def from_estimator(
        cls,
        estimators,
        X,
        y,
        *,
        window=100,
        output_names=None,
        ax=None,
        whis=(5, 95),
        bxp_kwargs=None,
    ):
        """Score fitted estimators on ``X, y`` over consecutive windows and plot.

        Parameters
        ----------
        estimators : dict of str to fitted estimator
            Models to compare, in the order to draw.
        X : array-like of shape (n_samples, n_features)
            Test rows in time order.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs.
        %(windows)s
        %(box_options)s

        Returns
        -------
        %(plotted_display)s
        """
        models = _check_models(estimators, "estimators")
        y_arr = np.asarray(y)
        preds = {model: _predict_like(est, X, y_arr) for model, est in models.items()}
        return cls.from_predictions(
            y,
            preds,
            window=window,
            output_names=output_names,
            ax=ax,
            whis=whis,
            bxp_kwargs=bxp_kwargs,
        )
