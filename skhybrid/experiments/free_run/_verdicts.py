"""The report reads its own numbers: a verdict in words beside each test.

A p-value or a coverage alone asks the reader to know what it means. Each
function here turns one figure of a run's residual tests into one line: white
or not at 5 %, whether the inputs still explain the residuals, whether the
band is too narrow or too wide, and what a standard error from the Jacobian
assumes.
"""

__all__ = [
    "ALPHA",
    "COVERAGE_TOLERANCE",
    "coverage_verdict",
    "input_verdict",
    "standard_error_caveat",
    "whiteness_verdict",
]

#: Level of every test the report reads.
ALPHA = 0.05
#: A band whose coverage is within this of its level is "about right".
COVERAGE_TOLERANCE = 0.02


def _percent(value):
    return f"{100 * value:.0f} %"


def whiteness_verdict(pvalue, alpha=ALPHA):
    """The Ljung-Box test's reading: white or not at ``alpha``.

    Parameters
    ----------
    pvalue : float or None
        The test's p-value (None where it was not computed).
    alpha : float, default=ALPHA
        The level.

    Returns
    -------
    verdict : str
        For example ``"not white at 5 %: the residuals are correlated in
        time"``.

    Examples
    --------
    >>> from skhybrid.experiments.free_run._verdicts import whiteness_verdict
    >>> whiteness_verdict(0.4)
    'white at 5 %'
    >>> whiteness_verdict(0.0)
    'not white at 5 %: the residuals are correlated in time'
    """
    if pvalue is None:
        return "not tested (too few finite residuals)"
    if pvalue < alpha:
        return f"not white at {_percent(alpha)}: the residuals are correlated in time"
    return f"white at {_percent(alpha)}"


def input_verdict(pvalue, alpha=ALPHA):
    """The cross-correlation test's reading: do the inputs still explain them?

    Parameters
    ----------
    pvalue : float or None
        The smallest p-value of the residual-input cross-correlations (None
        where it was not computed).
    alpha : float, default=ALPHA
        The level.

    Returns
    -------
    verdict : str
        ``"inputs still explain the residuals at 5 %: dynamics from the inputs
        are missing"`` or ``"no input dependence left at 5 %"``.
    """
    if pvalue is None:
        return "input dependence not tested"
    if pvalue < alpha:
        return (
            f"inputs still explain the residuals at {_percent(alpha)}: dynamics "
            "from the inputs are missing"
        )
    return f"no input dependence left at {_percent(alpha)}"


def coverage_verdict(coverage, level, tolerance=COVERAGE_TOLERANCE):
    """A simulation band's reading: too narrow, about right or too wide.

    Parameters
    ----------
    coverage : float or None
        Share of the samples inside the band (None where the free run failed).
    level : float
        The band's nominal probability.
    tolerance : float, default=COVERAGE_TOLERANCE
        A coverage within this of ``level`` is about right.

    Returns
    -------
    verdict : str
        For example ``"the band covers 91 % of the samples against its 95 %:
        too narrow"``.

    Examples
    --------
    >>> from skhybrid.experiments.free_run._verdicts import coverage_verdict
    >>> coverage_verdict(0.908, 0.95)
    'the band covers 91 % of the samples against its 95 %: too narrow'
    """
    if coverage is None:
        return "no coverage (the free run failed)"
    text = (
        f"the band covers {_percent(coverage)} of the samples against its "
        f"{_percent(level)}"
    )
    if coverage < level - tolerance:
        return f"{text}: too narrow"
    if coverage > level + tolerance:
        return f"{text}: too wide"
    return f"{text}: about right"


def standard_error_caveat(pvalue, alpha=ALPHA):
    """What the physics' standard errors assume, and whether its residuals agree.

    Parameters
    ----------
    pvalue : float or None
        Ljung-Box p-value of the physics' own out-of-fold residuals (None
        where they were not tested).
    alpha : float, default=ALPHA
        The level.

    Returns
    -------
    caveat : str
        The standard errors are conditional on the model's structure (its
        equations taken as true); where its residuals are not white, a
        warning that the structure misses something and the errors understate
        the uncertainty.
    """
    caveat = (
        "standard errors from the Jacobian, conditional on the physics' "
        "structure: they assume its equations are right"
    )
    if pvalue is not None and pvalue < alpha:
        return (
            f"{caveat}. Warning: its residuals are not white at "
            f"{_percent(alpha)} (Ljung-Box p = {pvalue:.3g}): the structure misses "
            "something, and these errors understate the uncertainty"
        )
    if pvalue is None:
        return f"{caveat} (its residuals' whiteness was not tested)"
    return f"{caveat}; its residuals are white at {_percent(alpha)}"
