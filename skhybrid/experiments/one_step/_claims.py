"""The paper's claims, checked on a run's numbers and reported as passed or failed.

Each system states its own claims (:class:`~skhybrid.experiments.OneStepWindows`'s
``claims``, in its module of :mod:`skhybrid.benchmarks`); :func:`check_claims`,
which the report and the command line call, asks the system for them.
"""

__all__ = ["check_claims"]


def check_claims(result):
    """The paper's claims for ``result``'s system, each with passed and detail.

    Parameters
    ----------
    result : ExperimentResult
        A finished run of one system.

    Returns
    -------
    claims : list of dict
        Keys ``claim``, ``passed`` (None on a ``--quick`` run: the claims are
        not evaluated on quick settings) and ``detail``; empty for a system
        that states none.
    """
    claims = result.system.claims(result)
    if not claims:
        return []
    if getattr(result.settings, "quick", False):
        # The claims are about the full run; on small data and few epochs a
        # "fails" would only say the settings are small.
        for item in claims:
            item["passed"] = None
            item["detail"] = f"not evaluated on quick settings; {item['detail']}"
    return claims
