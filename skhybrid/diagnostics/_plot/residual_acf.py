"""Residual autocorrelation per output: :class:`ResidualACFDisplay`.

matplotlib is imported inside ``plot`` only, so it stays an optional dependency.
"""

import numpy as np

from skhybrid.diagnostics._plot._common import (
    _OUTPUT_AXES,
    _OUTPUT_PANELS_ATTRIBUTES,
    _predictions_like,
    _store_panels,
)
from skhybrid.diagnostics._tests import (
    _RESIDUALS_OF_PREDICTIONS,
    _as_2d,
    _predict_like,
    ljung_box_test,
    residual_acf,
)
from skhybrid.utils._docstrings import fill_doc
from skhybrid.utils._plotting import output_names as _output_names
from skhybrid.utils._plotting import panels as _panels

__all__ = ["ResidualACFDisplay"]

#: What both constructors of ResidualACFDisplay take, pass on to ``plot`` and
#: return.
_FROM_DOCS = {
    "lags_alpha": """\
lags : int, default=20
    Largest lag drawn and lags of the Ljung-Box test.
alpha : float, default=0.05
    The band has coverage ``1 - alpha``.""",
    "output_axes": _OUTPUT_AXES,
    "plot_options": """\
output_names : list of str or None, default=None
    Panel titles.
stem_kwargs, band_kwargs : dict or None, default=None
    See :meth:`plot`.""",
    "plotted_display": """\
display : ResidualACFDisplay
    The plotted display.""",
}


def _format_pvalue(p):
    """``p = 0.0312``; tiny values as ``p < 0.0001`` (their digits mean nothing)."""
    return "p < 0.0001" if p < 1e-4 else f"p = {p:.3g}"


@fill_doc(output_panels_attributes=_OUTPUT_PANELS_ATTRIBUTES)
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
    %(output_panels_attributes)s
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
        return _store_panels(self, fig, axes)

    @classmethod
    @fill_doc(**_FROM_DOCS, residuals_of_predictions=_RESIDUALS_OF_PREDICTIONS)
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
        %(residuals_of_predictions)s
        %(lags_alpha)s
        bartlett_confint : bool, default=False
            ``False`` draws the white-noise band ``z / sqrt(n)`` (a test of
            whiteness lag by lag, MATLAB's ``resid``); ``True`` widens it by
            Bartlett's formula (statsmodels' ``plot_acf``).
        %(output_axes)s
        name : str or None, default=None
            Prefixed to the titles.
        %(plot_options)s

        Returns
        -------
        %(plotted_display)s
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
    @fill_doc(**_FROM_DOCS)
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
        %(lags_alpha)s
        bartlett_confint : bool, default=False
            See :meth:`from_predictions`.
        %(output_axes)s
        name : str or None, default=None
            Prefixed to the titles; ``None`` uses the estimator's class name.
        %(plot_options)s

        Returns
        -------
        %(plotted_display)s
        """
        return cls.from_predictions(
            y,
            _predict_like(estimator, X, y),
            lags=lags,
            alpha=alpha,
            bartlett_confint=bartlett_confint,
            ax=ax,
            name=type(estimator).__name__ if name is None else name,
            output_names=output_names,
            stem_kwargs=stem_kwargs,
            band_kwargs=band_kwargs,
        )
