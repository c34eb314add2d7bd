"""One report on a model's residuals: error, whiteness, independence, pass or fail."""

from dataclasses import dataclass

import numpy as np

from skhybrid.diagnostics._tests import (
    _RESIDUALS_OF_PREDICTIONS,
    CrossCorrelationResult,
    WhitenessResult,
    _as_2d,
    _check_alpha,
    _predict_like,
    ljung_box_test,
    residual_input_correlation,
    rmse_db,
)
from skhybrid.preprocessing import newest_step
from skhybrid.utils._docstrings import fill_doc

__all__ = ["DiagnosticReport", "diagnose", "diagnose_predictions"]

#: What diagnose and diagnose_predictions return.
_REPORT_RETURNED = """\
report : DiagnosticReport
    RMSE, tests and verdict; print it or call ``to_frame()``."""


def _names(names, count, prefix, param):
    if names is None:
        return tuple(f"{prefix}{i}" for i in range(count))
    names = tuple(str(name) for name in names)
    if len(names) != count:
        raise ValueError(
            f"{param} must name each of the {count} columns; got {param}={names!r}."
        )
    return names


@dataclass(frozen=True, eq=False)
class DiagnosticReport:
    """Residual diagnostics of one model on one data set.

    Built by :func:`diagnose` or :func:`diagnose_predictions`; read it through its
    ``repr``, :meth:`to_frame` or the fields below.

    Parameters
    ----------
    rmse : ndarray of shape (n_outputs,)
        Root mean squared error of each output.
    rmse_db : ndarray of shape (n_outputs,)
        ``20 * log10(rmse)``.
    whiteness : WhitenessResult
        Ljung-Box test per output.
    independence : CrossCorrelationResult or None
        Cross-correlation of the residuals with the inputs; ``None`` when there
        are no inputs.
    alpha : float
        Family-wise significance level of :attr:`passed`.
    n_samples : int
        Number of residuals.
    output_names : tuple of str
        Name of each output.
    input_names : tuple of str
        Name of each input (empty without inputs).
    estimator_name : str or None
        Name shown in the ``repr``.

    Attributes
    ----------
    n_tests : int
        Number of tests in the verdict: one whiteness test per output and one
        independence test per (output, input) pair.
    level : float
        ``alpha / n_tests``: the level each p-value is compared with.

    See Also
    --------
    diagnose : Builds the report from an estimator.
    diagnose_predictions : Builds it from predictions.

    Notes
    -----
    The verdict combines ``n_tests`` tests with Bonferroni's correction: each
    p-value must be at least ``alpha / n_tests``. A model whose residuals are white
    and independent of the inputs then passes with probability at least
    ``1 - alpha``, however many outputs and inputs it has. (The ``passed`` fields
    of ``whiteness`` and ``independence`` test each output at ``alpha`` itself.)

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.diagnostics import diagnose_predictions
    >>> rng = np.random.default_rng(0)
    >>> y = rng.standard_normal((500, 2))
    >>> report = diagnose_predictions(y, 0.9 * y, lags=10)
    >>> report.passed
    True
    >>> report.to_frame().columns[:2].tolist()
    ['rmse', 'rmse_db']
    """

    rmse: np.ndarray
    rmse_db: np.ndarray
    whiteness: WhitenessResult
    independence: CrossCorrelationResult | None
    alpha: float
    n_samples: int
    output_names: tuple
    input_names: tuple
    estimator_name: str | None = None

    @property
    def n_tests(self):
        n_outputs = self.rmse.shape[0]
        return n_outputs * (1 + len(self.input_names))

    @property
    def level(self):
        return self.alpha / self.n_tests

    @property
    def white(self):
        """Per output, whether the Ljung-Box p-value is at least :attr:`level`."""
        return self.whiteness.pvalue >= self.level

    @property
    def independent(self):
        """Per output, whether every input's p-value is at least :attr:`level`."""
        if self.independence is None:
            return np.ones(self.rmse.shape[0], dtype=bool)
        return np.all(self.independence.pvalue >= self.level, axis=1)

    @property
    def passed(self):
        """The verdict: every output white and independent of every input."""
        return bool(np.all(self.white) and np.all(self.independent))

    def to_frame(self):
        """One row per output: error, test statistics, p-values and verdicts.

        Returns
        -------
        frame : pandas.DataFrame
            Columns ``rmse``, ``rmse_db``, ``ljung_box_stat``, ``ljung_box_pvalue``,
            ``white``, ``independence_pvalue`` (the smallest over inputs; NaN
            without inputs), ``worst_input``, ``independent`` and ``passed``,
            indexed by output name.
        """
        import pandas as pd

        if self.independence is None:
            ind_p = np.full(self.rmse.shape[0], np.nan)
            worst = [None] * self.rmse.shape[0]
        else:
            ind_p = self.independence.pvalue.min(axis=1)
            worst = [
                self.input_names[i] for i in self.independence.pvalue.argmin(axis=1)
            ]
        frame = pd.DataFrame(
            {
                "rmse": self.rmse,
                "rmse_db": self.rmse_db,
                "ljung_box_stat": self.whiteness.statistic,
                "ljung_box_pvalue": self.whiteness.pvalue,
                "white": self.white,
                "independence_pvalue": ind_p,
                "worst_input": worst,
                "independent": self.independent,
                "passed": self.white & self.independent,
            },
            index=pd.Index(self.output_names, name="output"),
        )
        return frame

    def __repr__(self):
        name = self.estimator_name or "predictions"
        header = (
            f"DiagnosticReport({name}: n_samples={self.n_samples}, "
            f"lags={self.whiteness.lags}, inputs={len(self.input_names)})"
        )
        width = max(6, *(len(n) for n in self.output_names))
        head = f"  {'output':<{width}}  {'rmse':>10}  {'dB':>7}  {'LB p':>8}  "
        rows = [head + f"{'indep p':>8}  verdict"]
        ind_p = (
            self.independence.pvalue.min(axis=1)
            if self.independence is not None
            else np.full(self.rmse.shape[0], np.nan)
        )
        for j, out in enumerate(self.output_names):
            problems = []
            if not self.white[j]:
                problems.append("not white")
            if not self.independent[j]:
                problems.append("input-correlated")
            verdict = "ok" if not problems else ", ".join(problems)
            ind = "-" if np.isnan(ind_p[j]) else f"{ind_p[j]:.3g}"
            rows.append(
                f"  {out:<{width}}  {self.rmse[j]:>10.4g}  {self.rmse_db[j]:>7.2f}  "
                f"{self.whiteness.pvalue[j]:>8.3g}  {ind:>8}  {verdict}"
            )
        verdict = "PASSED" if self.passed else "FAILED"
        footer = (
            f"  {verdict} at alpha={self.alpha:g} (Bonferroni over {self.n_tests} "
            f"tests: each p-value must be >= {self.level:.3g})"
        )
        return "\n".join([header, *rows, footer])


@fill_doc(
    report_returned=_REPORT_RETURNED,
    residuals_of_predictions=_RESIDUALS_OF_PREDICTIONS,
)
def diagnose_predictions(
    y_true,
    y_pred,
    *,
    inputs=None,
    lags=20,
    alpha=0.05,
    output_names=None,
    input_names=None,
    estimator_name=None,
):
    """Diagnose residuals ``y_true - y_pred`` of precomputed predictions.

    Parameters
    ----------
    %(residuals_of_predictions)s
    inputs : array-like of shape (n_samples,) or (n_samples, n_inputs) or None, \
            default=None
        Inputs aligned with the rows, for the independence test; ``None`` skips
        it.
    lags : int, default=20
        Lags of the Ljung-Box test and of the cross-correlation.
    alpha : float, default=0.05
        Family-wise significance level of the verdict (see
        :class:`DiagnosticReport`).
    output_names, input_names : sequence of str or None, default=None
        Column names for the report; ``None`` gives ``y0, y1, ...`` and ``u0,
        u1, ...``.
    estimator_name : str or None, default=None
        Name shown in the report.

    Returns
    -------
    %(report_returned)s

    See Also
    --------
    diagnose : The same from a fitted estimator and data.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.diagnostics import diagnose_predictions
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(1000)
    >>> y = rng.standard_normal(1000) + 0.5 * np.roll(u, 1)
    >>> report = diagnose_predictions(y, np.zeros(1000), inputs=u, lags=10)
    >>> report.passed
    False
    >>> report.to_frame()["independent"].tolist()
    [False]
    """
    yt = _as_2d(y_true, "y_true")
    yp = _as_2d(y_pred, "y_pred")
    if yt.shape != yp.shape:
        raise ValueError(
            f"y_true and y_pred must have the same shape; got y_true with shape "
            f"{np.shape(y_true)} and y_pred with shape {np.shape(y_pred)}."
        )
    alpha = _check_alpha(alpha)
    residuals = yt - yp
    output_names = _names(output_names, yt.shape[1], "y", "output_names")
    whiteness = ljung_box_test(residuals, lags=lags, alpha=alpha)
    if inputs is None:
        independence, input_names = None, ()
    else:
        independence = residual_input_correlation(
            residuals, inputs, lags=lags, alpha=alpha
        )
        input_names = _names(input_names, independence.ccf.shape[2], "u", "input_names")
    db = rmse_db(yt, yp)
    return DiagnosticReport(
        rmse=np.sqrt(np.mean(residuals**2, axis=0)),
        rmse_db=db,
        whiteness=whiteness,
        independence=independence,
        alpha=alpha,
        n_samples=yt.shape[0],
        output_names=output_names,
        input_names=input_names,
        estimator_name=estimator_name,
    )


def _default_inputs(X, n_outputs, n_steps):
    """The input columns of each row's newest step (the data convention)."""
    step = newest_step(X, n_steps)
    if step.shape[1] <= n_outputs:
        return None
    return step[:, n_outputs:]


@fill_doc(report_returned=_REPORT_RETURNED)
def diagnose(
    estimator,
    X,
    y,
    *,
    inputs=None,
    lags=20,
    alpha=0.05,
    n_steps=None,
    output_names=None,
    input_names=None,
):
    """Diagnose a fitted estimator's one-step residuals on data in time order.

    Computes the RMSE (and in dB) per output, the Ljung-Box whiteness test per
    output and the independence test of the residuals against the inputs, and a
    verdict at a stated family-wise significance level.

    Parameters
    ----------
    estimator : fitted estimator
        Anything with ``predict(X)``.
    X : array-like of shape (n_samples, n_features)
        Rows in time order (windows of the data convention: each step
        ``[states, inputs]``, oldest step first).
    y : array-like of shape (n_samples,) or (n_samples, n_outputs)
        Measured next states.
    inputs : array-like of shape (n_samples, n_inputs), "X" or None, default=None
        What the residuals are tested against. ``None`` takes the input columns
        of each row's newest step under the data convention (the columns after
        the first ``n_outputs`` of the last ``n_features / n_steps`` columns) and
        skips the test when there are none; ``"X"`` takes every column of ``X``;
        an array is used as given. Pass an array for data that do not follow the
        convention.
    lags : int, default=20
        Lags of the Ljung-Box test and of the cross-correlation.
    alpha : float, default=0.05
        Family-wise significance level of the verdict.
    n_steps : int or None, default=None
        Time steps per row, for ``inputs=None``; ``None`` reads
        ``estimator.n_steps`` where it exists and uses 1 otherwise.
    output_names, input_names : sequence of str or None, default=None
        Column names for the report.

    Returns
    -------
    %(report_returned)s

    See Also
    --------
    diagnose_predictions : The same from precomputed predictions.
    ResidualACFDisplay : The residual autocorrelation as a figure.

    Notes
    -----
    The residual tests assume the rows are consecutive time steps of one
    trajectory; shuffled rows make any residual look white.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.diagnostics import diagnose
    >>> from skhybrid.domain import LinearStateSpaceModel
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 601)
    >>> x = np.zeros(601)
    >>> for t in range(600):
    ...     x[t + 1] = 0.9 * x[t] + 0.5 * u[t] + 0.05 * rng.standard_normal()
    >>> X, y = np.column_stack([x[:-1], u[:-1]]), x[1:]
    >>> model = LinearStateSpaceModel().fit(X, y)
    >>> report = diagnose(model, X, y, lags=10)
    >>> report.passed
    True
    >>> print(report)  # doctest: +ELLIPSIS
    DiagnosticReport(LinearStateSpaceModel: n_samples=600, lags=10, inputs=1)
      output        rmse       dB      LB p   indep p  verdict
      y0         0.04...   -26...    ...  ok
      PASSED at alpha=0.05 (Bonferroni over 2 tests: each p-value must be >= 0.025)
    """
    X_arr = np.asarray(X)
    if X_arr.ndim != 2:
        raise ValueError(
            f"X must be 2-D (n_samples, n_features); got an array with shape "
            f"{X_arr.shape}."
        )
    y_arr = _as_2d(y, "y")
    y_pred = _predict_like(estimator, X, y_arr)
    if isinstance(inputs, str):
        if inputs != "X":
            raise ValueError(
                f"inputs must be None, 'X' or an array; got inputs={inputs!r}."
            )
        inputs = X_arr.astype(np.float64)
    elif inputs is None:
        if n_steps is None:
            n_steps = getattr(estimator, "n_steps", 1)
        inputs = _default_inputs(X_arr.astype(np.float64), y_arr.shape[1], n_steps)
    return diagnose_predictions(
        y_arr,
        y_pred,
        inputs=inputs,
        lags=lags,
        alpha=alpha,
        output_names=output_names,
        input_names=input_names,
        estimator_name=type(estimator).__name__,
    )
