"""The stochastic part of a chosen model: what is left, its noise model, its band.

A hybrid model is physics, a learned correction and a stochastic model of what is
left. For the model a run chose, this module reads the free-run residuals of the
validation blocks (never a test record), tests them (Ljung-Box whiteness, and the
cross-correlation with the inputs that tells missing input dynamics from
coloured noise), fits an autoregressive noise model to them, and turns that
model into a simulation band: ``y_sim + mean +- z * std``, with ``std`` the noise
model's stationary standard deviation. On each test record the band's
**coverage** is the share of scored samples inside it: a correct model with an
honest noise model covers about the nominal level; a band that covers 60 % is
reported as such.
"""

import numpy as np
from scipy.stats import norm

from skhybrid.diagnostics import ljung_box_test, residual_input_correlation
from skhybrid.hybrid import AutoRegressiveNoise

__all__ = ["BAND_LEVEL", "band_coverage", "fit_noise", "residual_tests"]

#: Nominal level of the simulation band.
BAND_LEVEL = 0.95

#: Lags of the whiteness and cross-correlation tests (fewer for short records).
LAGS = 20


def _lags(n):
    return int(max(1, min(LAGS, n // 5)))


def residual_tests(residuals, inputs):
    """Whiteness and input independence of one stretch of free-run residuals.

    Parameters
    ----------
    residuals : ndarray of shape (n_samples,)
        Measured minus simulated output, in time order, after the initialisation
        window.
    inputs : ndarray of shape (n_samples, n_inputs)
        The inputs at the same samples.

    Returns
    -------
    tests : dict
        ``n_samples``, ``ljung_box_pvalue`` (and ``lags``),
        ``input_correlation_pvalue``, ``max_abs_input_correlation`` and its
        ``input_correlation_band``; ``None`` values where the stretch is too
        short or not finite.
    """
    r = np.ravel(np.asarray(residuals, dtype=float))
    u = np.asarray(inputs, dtype=float).reshape(len(r), -1)
    out = {
        "n_samples": int(r.size),
        "lags": None,
        "ljung_box_pvalue": None,
        "input_correlation_pvalue": None,
        "max_abs_input_correlation": None,
        "input_correlation_band": None,
    }
    if r.size < 30 or not np.all(np.isfinite(r)) or np.ptp(r) == 0:
        return out
    lags = _lags(r.size)
    out["lags"] = lags
    out["ljung_box_pvalue"] = float(ljung_box_test(r, lags=lags).pvalue[0])
    if np.all(np.ptp(u, axis=0) > 0):
        cross = residual_input_correlation(r, u, lags=lags)
        out["input_correlation_pvalue"] = float(np.min(cross.pvalue))
        out["max_abs_input_correlation"] = float(np.max(np.abs(cross.ccf)))
        out["input_correlation_band"] = float(np.max(cross.band))
    return out


def fit_noise(residuals):
    """An autoregressive noise model of the validation residuals.

    The blocks are joined end to end (a few lag products cross a junction).

    Parameters
    ----------
    residuals : list of ndarray
        Free-run residuals of each validation block after its initialisation
        window.

    Returns
    -------
    noise : AutoRegressiveNoise or None
        Fitted; None where fewer than 12 finite residuals are left.
    description : dict
        ``lags``, ``coef``, ``innovation_std``, ``mean`` and ``std`` (the
        stationary standard deviation, infinite for a non-stationary fit).
    """
    joined = np.concatenate([np.ravel(r) for r in residuals]) if residuals else []
    joined = np.asarray(joined, dtype=float)
    joined = joined[np.isfinite(joined)]
    if joined.size < 12:
        return None, {"fitted": False, "reason": "fewer than 12 finite residuals"}
    noise = AutoRegressiveNoise().fit(joined[:, None])
    return noise, {
        "fitted": True,
        "lags": noise.lags_[0].tolist(),
        "coef": noise.coef_[0].tolist(),
        "innovation_std": float(noise.sigma_[0]),
        "mean": float(noise.mean_[0]),
        "std": float(noise.std()[0]),
        "n_samples": int(joined.size),
    }


def band_coverage(y, y_sim, n_init, noise, level=BAND_LEVEL):
    """The simulation band of ``y_sim`` and the share of ``y`` inside it.

    Parameters
    ----------
    y, y_sim : ndarray of shape (n_times,)
        Measured and simulated outputs of one record.
    n_init : int
        Samples of the initialisation window (not scored).
    noise : AutoRegressiveNoise
        The noise model of the validation residuals.
    level : float, default=BAND_LEVEL
        Nominal probability of the band.

    Returns
    -------
    lower, upper : ndarray of shape (n_times,)
        The band.
    coverage : float or None
        Share of the samples after ``n_init`` inside the band; None where the
        free run failed.
    """
    y, y_sim = np.ravel(y).astype(float), np.ravel(y_sim).astype(float)
    half = norm.ppf(0.5 + level / 2) * float(noise.std()[0])
    centre = y_sim + float(noise.mean_[0])
    lower, upper = centre - half, centre + half
    scored = slice(n_init, None)
    if not np.all(np.isfinite(y_sim[scored])):
        return lower, upper, None
    inside = (y[scored] >= lower[scored]) & (y[scored] <= upper[scored])
    return lower, upper, float(np.mean(inside))
