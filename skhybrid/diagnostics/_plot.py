"""The paper's figures as scikit-learn style Display objects.

- :class:`ResidualACFDisplay`: residual autocorrelation per output with its
  confidence band and the Ljung-Box p-value (the paper's Fig. 5 and 8);
- :class:`RMSEBoxDisplay`: box plots of RMSE in dB over short windows, one box per
  model (Fig. 3, 4, 6, 7 and 9);
- :class:`DecompositionDisplay`: a trajectory split into its domain part, neural
  parts and noise band.

matplotlib is imported inside ``plot`` only, so it stays an optional dependency.
"""

from collections.abc import Mapping
from inspect import signature

import numpy as np

from skhybrid.diagnostics._tests import (
    _as_2d,
    ljung_box_test,
    residual_acf,
    rmse_db,
)
from skhybrid.utils._plotting import output_names as _output_names
from skhybrid.utils._plotting import panels as _panels

__all__ = ["DecompositionDisplay", "RMSEBoxDisplay", "ResidualACFDisplay"]


def _format_pvalue(p):
    """``p = 0.0312``; tiny values as ``p < 0.0001`` (their digits mean nothing)."""
    return "p < 0.0001" if p < 1e-4 else f"p = {p:.3g}"


def _predictions_like(y_pred, y_true, name):
    pred = _as_2d(y_pred, name)
    if pred.shape != y_true.shape:
        raise ValueError(
            f"{name} must have the shape of y_true {y_true.shape}; got "
            f"{np.shape(y_pred)}."
        )
    return pred


# --------------------------------------------------------------------------------------
# residual autocorrelation
# --------------------------------------------------------------------------------------
class ResidualACFDisplay:
    """Residual autocorrelation per output with its band and Ljung-Box p-value.

    The paper's Fig. 5 and 8: one panel per output, the autocorrelation as stems
    with the zero lag suppressed, a shaded confidence band around zero, and the
    Ljung-Box p-value in each title (``p < 0.0001`` below that). White residuals
    keep (almost) every stem inside the band and have a large p-value.

    Build it with :meth:`from_estimator` or :meth:`from_predictions`; use the
    constructor to plot values computed elsewhere.

    Parameters
    ----------
    lags : ndarray of shape (n_lags,)
        Lags to draw; lag 0 is left out when plotting.
    acf : ndarray of shape (n_lags, n_outputs)
        Autocorrelation at each lag.
    band : ndarray of shape (n_lags, n_outputs)
        Half-width of the confidence band around zero at each lag.
    pvalue : ndarray of shape (n_outputs,)
        Ljung-Box p-value of each output, shown in the titles.
    ljung_box_lags : int or None, default=None
        Lags of the Ljung-Box test, shown in the titles when given.
    output_names : list of str or None, default=None
        Panel titles; ``None`` gives ``y`` or ``y0, y1, ...``.
    estimator_name : str or None, default=None
        Prefixed to the titles.

    Attributes
    ----------
    axes_ : ndarray of matplotlib Axes of shape (n_outputs,)
        One panel per output.
    ax_ : matplotlib Axes
        The first panel.
    figure_ : matplotlib Figure
        Figure holding the panels.
    stems_ : list of matplotlib LineCollection
        The stems, one collection per panel.
    markers_ : list of matplotlib Line2D
        The stem heads, one per panel.
    bands_ : list of matplotlib PolyCollection
        The confidence bands, one per panel.

    See Also
    --------
    residual_acf : The autocorrelation and band.
    ljung_box_test : The p-value.

    Notes
    -----
    Residuals must be in time order.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from skhybrid.diagnostics import ResidualACFDisplay
    >>> rng = np.random.default_rng(0)
    >>> y = rng.standard_normal((500, 2))
    >>> disp = ResidualACFDisplay.from_predictions(y, np.zeros_like(y), lags=15)
    >>> disp.axes_.shape
    (2,)
    >>> plt.close(disp.figure_)
    """

    def __init__(
        self,
        *,
        lags,
        acf,
        band,
        pvalue,
        ljung_box_lags=None,
        output_names=None,
        estimator_name=None,
    ):
        self.lags = lags
        self.acf = acf
        self.band = band
        self.pvalue = pvalue
        self.ljung_box_lags = ljung_box_lags
        self.output_names = output_names
        self.estimator_name = estimator_name

    def plot(self, ax=None, *, name=None, stem_kwargs=None, band_kwargs=None):
        """Draw the panels.

        Parameters
        ----------
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output; ``None`` makes a new figure.
        name : str or None, default=None
            Overrides ``estimator_name`` in the titles.
        stem_kwargs : dict or None, default=None
            Passed to ``Axes.vlines`` for the stems.
        band_kwargs : dict or None, default=None
            Passed to ``Axes.fill_between`` for the band.

        Returns
        -------
        display : ResidualACFDisplay
            This object, with the artists set.
        """
        lags = np.asarray(self.lags)
        acf = np.asarray(self.acf, dtype=float).reshape(lags.shape[0], -1)
        band = np.asarray(self.band, dtype=float).reshape(acf.shape)
        pvalue = np.asarray(self.pvalue, dtype=float).reshape(-1)
        keep = lags != 0  # zero lag is 1 by definition and would dwarf the rest
        n_outputs = acf.shape[1]
        if pvalue.shape[0] != n_outputs:
            raise ValueError(
                f"pvalue must hold one value per output ({n_outputs}); got "
                f"{pvalue.shape[0]}."
            )
        names = _output_names(self.output_names, n_outputs)
        name = self.estimator_name if name is None else name
        fig, axes = _panels(ax, 1, n_outputs, "ResidualACFDisplay.plot")
        axes = axes.ravel()
        stem_kwargs = {"colors": "C0", "linewidth": 1.5, **(stem_kwargs or {})}
        band_kwargs = {
            "color": "C0",
            "alpha": 0.2,
            "linewidth": 0,
            "label": "confidence band",
            **(band_kwargs or {}),
        }
        self.stems_, self.markers_, self.bands_ = [], [], []
        x = lags[keep]
        for j, axis in enumerate(axes):
            self.bands_.append(
                axis.fill_between(x, -band[keep, j], band[keep, j], **band_kwargs)
            )
            self.stems_.append(axis.vlines(x, 0.0, acf[keep, j], **stem_kwargs))
            (marker,) = axis.plot(
                x, acf[keep, j], "o", color=stem_kwargs["colors"], markersize=3.5
            )
            self.markers_.append(marker)
            axis.axhline(0.0, color="black", linewidth=0.8)
            lb = (
                "Ljung-Box"
                if self.ljung_box_lags is None
                else (f"Ljung-Box({self.ljung_box_lags})")
            )
            title = f"{names[j]}: {lb} {_format_pvalue(pvalue[j])}"
            if name:
                title = f"{name}\n{title}"
            axis.set_title(title, fontsize="medium")
            axis.set_xlabel("lag")
            if j == 0:
                axis.set_ylabel("residual autocorrelation")
        self.axes_ = axes
        self.ax_ = axes[0]
        self.figure_ = fig
        return self

    @classmethod
    def from_predictions(
        cls,
        y_true,
        y_pred,
        *,
        lags=20,
        alpha=0.05,
        bartlett_confint=False,
        ax=None,
        name=None,
        output_names=None,
        stem_kwargs=None,
        band_kwargs=None,
    ):
        """Plot the autocorrelation of ``y_true - y_pred``.

        Parameters
        ----------
        y_true : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs, in time order.
        y_pred : array-like of the same shape
            Predictions.
        lags : int, default=20
            Largest lag drawn and lags of the Ljung-Box test.
        alpha : float, default=0.05
            The band has coverage ``1 - alpha``.
        bartlett_confint : bool, default=False
            ``False`` draws the white-noise band ``z / sqrt(n)`` (a test of
            whiteness lag by lag, MATLAB's ``resid``); ``True`` widens it by
            Bartlett's formula (statsmodels' ``plot_acf``).
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output.
        name : str or None, default=None
            Prefixed to the titles.
        output_names : list of str or None, default=None
            Panel titles.
        stem_kwargs, band_kwargs : dict or None, default=None
            See :meth:`plot`.

        Returns
        -------
        display : ResidualACFDisplay
            The plotted display.
        """
        yt = _as_2d(y_true, "y_true")
        residuals = yt - _predictions_like(y_pred, yt, "y_pred")
        acf_res = residual_acf(
            residuals, lags, alpha=alpha, bartlett_confint=bartlett_confint
        )
        lb = ljung_box_test(residuals, lags, alpha=alpha)
        disp = cls(
            lags=acf_res.lags[1:],
            acf=acf_res.acf[1:],
            band=acf_res.band[1:],
            pvalue=lb.pvalue,
            ljung_box_lags=lb.lags,
            output_names=output_names,
            estimator_name=name,
        )
        return disp.plot(ax=ax, stem_kwargs=stem_kwargs, band_kwargs=band_kwargs)

    @classmethod
    def from_estimator(
        cls,
        estimator,
        X,
        y,
        *,
        lags=20,
        alpha=0.05,
        bartlett_confint=False,
        ax=None,
        name=None,
        output_names=None,
        stem_kwargs=None,
        band_kwargs=None,
    ):
        """Plot the autocorrelation of a fitted estimator's residuals on ``X, y``.

        Parameters
        ----------
        estimator : fitted estimator
            Anything with ``predict(X)``.
        X : array-like of shape (n_samples, n_features)
            Rows in time order.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Measured outputs.
        lags : int, default=20
            Largest lag drawn and lags of the Ljung-Box test.
        alpha : float, default=0.05
            The band has coverage ``1 - alpha``.
        bartlett_confint : bool, default=False
            See :meth:`from_predictions`.
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output.
        name : str or None, default=None
            Prefixed to the titles; ``None`` uses the estimator's class name.
        output_names : list of str or None, default=None
            Panel titles.
        stem_kwargs, band_kwargs : dict or None, default=None
            See :meth:`plot`.

        Returns
        -------
        display : ResidualACFDisplay
            The plotted display.
        """
        y_pred = np.asarray(estimator.predict(X))
        y_arr = np.asarray(y)
        if y_pred.size == y_arr.size:
            y_pred = y_pred.reshape(y_arr.shape)
        return cls.from_predictions(
            y,
            y_pred,
            lags=lags,
            alpha=alpha,
            bartlett_confint=bartlett_confint,
            ax=ax,
            name=type(estimator).__name__ if name is None else name,
            output_names=output_names,
            stem_kwargs=stem_kwargs,
            band_kwargs=band_kwargs,
        )


# --------------------------------------------------------------------------------------
# RMSE box plots
# --------------------------------------------------------------------------------------
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


def _check_models(mapping, name):
    if not isinstance(mapping, Mapping) or len(mapping) == 0:
        raise TypeError(
            f"{name} must be a non-empty dict mapping model names to arrays; got "
            f"{type(mapping).__name__}."
        )
    return mapping


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
    axes_ : ndarray of matplotlib Axes of shape (n_outputs,)
        One panel per output.
    ax_ : matplotlib Axes
        The first panel.
    figure_ : matplotlib Figure
        Figure holding the panels.
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
        self.axes_ = axes
        self.ax_ = axes[0]
        self.figure_ = fig
        return self

    @classmethod
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
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output.
        whis : tuple of (float, float), default=(5, 95)
            Percentiles at the whisker ends.
        bxp_kwargs : dict or None, default=None
            See :meth:`plot`.

        Returns
        -------
        display : RMSEBoxDisplay
            The plotted display.
        """
        disp = cls(rmse_db=rmse_db, output_names=output_names, window=window)
        return disp.plot(ax=ax, whis=whis, bxp_kwargs=bxp_kwargs)

    @classmethod
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
        window : int, default=100
            Samples per window; the last, shorter window is dropped.
        output_names : list of str or None, default=None
            Panel titles.
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output.
        whis : tuple of (float, float), default=(5, 95)
            Percentiles at the whisker ends.
        bxp_kwargs : dict or None, default=None
            See :meth:`plot`.

        Returns
        -------
        display : RMSEBoxDisplay
            The plotted display.
        """
        preds = _check_models(y_pred, "y_pred")
        yt = _as_2d(y_true, "y_true")
        scores = {
            model: rmse_db(
                yt, _predictions_like(pred, yt, f"y_pred[{model!r}]"), window=window
            )
            for model, pred in preds.items()
        }
        return cls.from_rmse_db(
            scores,
            output_names=output_names,
            window=window,
            ax=ax,
            whis=whis,
            bxp_kwargs=bxp_kwargs,
        )

    @classmethod
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
        window : int, default=100
            Samples per window; the last, shorter window is dropped.
        output_names : list of str or None, default=None
            Panel titles.
        ax : matplotlib Axes, array of Axes or None, default=None
            One Axes per output.
        whis : tuple of (float, float), default=(5, 95)
            Percentiles at the whisker ends.
        bxp_kwargs : dict or None, default=None
            See :meth:`plot`.

        Returns
        -------
        display : RMSEBoxDisplay
            The plotted display.
        """
        models = _check_models(estimators, "estimators")
        y_arr = np.asarray(y)
        preds = {}
        for model, est in models.items():
            pred = np.asarray(est.predict(X))
            preds[model] = (
                pred.reshape(y_arr.shape) if pred.size == y_arr.size else pred
            )
        return cls.from_predictions(
            y,
            preds,
            window=window,
            output_names=output_names,
            ax=ax,
            whis=whis,
            bxp_kwargs=bxp_kwargs,
        )


# --------------------------------------------------------------------------------------
# decomposition of a trajectory
# --------------------------------------------------------------------------------------
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
        self.axes_ = axes
        self.ax_ = axes[0, 0]
        self.figure_ = fig
        return self

    @classmethod
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
        n_std : float, default=2.0
            Half-width of the band in standard deviations.
        time : array-like of shape (n_samples,) or None, default=None
            Horizontal axis; ``None`` uses the sample index.
        ax : array of matplotlib Axes or None, default=None
            ``2 * n_outputs`` Axes.
        name : str or None, default=None
            Figure title.
        output_names : list of str or None, default=None
            Panel titles.

        Returns
        -------
        display : DecompositionDisplay
            The plotted display.
        """
        parts = _check_models(parts, "parts")
        yt = _as_2d(y_true, "y_true")
        arrays = {
            key: _predictions_like(val, yt, f"parts[{key!r}]")
            for key, val in parts.items()
        }
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
        n_std : float, default=2.0
            Half-width of the band in standard deviations.
        time : array-like of shape (n_samples,) or None, default=None
            Horizontal axis; ``None`` uses the sample index.
        ax : array of matplotlib Axes or None, default=None
            ``2 * n_outputs`` Axes.
        name : str or None, default=None
            Figure title; ``None`` uses the estimator's class name.
        output_names : list of str or None, default=None
            Panel titles.

        Returns
        -------
        display : DecompositionDisplay
            The plotted display.
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
