"""Initial windows fitted by least squares through the model, batched over trajectories.

A free run started from one noisy measured window carries that window's noise into
every later step. When more measured samples than the window are known (an
initialisation record of ``n_init > n_steps`` samples), the states of the first
window can instead be chosen so that the model's own free run through the whole
initialisation record matches the measurements best: the least-squares initial
state of prediction-error methods, for any next-state predictor.

The fit is a Levenberg-Marquardt iteration run separately for every trajectory,
with a central-difference Jacobian whose perturbations advance all trajectories in
one batched rollout. Trajectories never share a step size or a stopping rule, so a
batch gives the same result as separate calls.
"""

import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning

__all__ = ["fit_initial_windows"]

_MAX_ITER = 50
_RTOL = 1e-12


def _window_residuals(rollout, Z, Y, n_init, n_steps):
    """Free run from the first windows ``Z``, minus the measurements, masked.

    Returns ``(n, N * s)`` residuals (zero beyond each trajectory's record) and
    their cost per trajectory (infinite where the free run is not finite).
    """
    n, k = Z.shape[:2]
    Y_run = Y.copy()
    Y_run[:, :k] = Z
    with np.errstate(all="ignore"):
        Y_run = rollout(Y_run)
    mask = np.arange(Y.shape[1])[None, :, None] < n_init[:, None, None]
    r = np.where(mask, Y_run - Y, 0.0).reshape(n, -1)
    finite = np.all(np.isfinite(r), axis=1)
    r[~finite] = 0.0
    cost = np.where(finite, np.sum(r**2, axis=1), np.inf)
    return r, cost


def fit_initial_windows(rollout, Y, n_init, n_steps, *, rel_step=1e-6):
    """Least-squares first windows of each trajectory's initialisation record.

    Parameters
    ----------
    rollout : callable
        ``rollout(Y) -> Y`` fills ``Y[:, t]`` for ``n_steps <= t < n_init`` by free
        run from ``Y[:, :n_steps]``, batched over trajectories, leaving non-finite
        values where the model diverges.
    Y : ndarray of shape (n_trajectories, n_times, n_states)
        Measured states; row ``i`` holds ``n_init[i]`` measured steps.
    n_init : ndarray of int of shape (n_trajectories,)
        Measured steps of each trajectory.
    n_steps : int
        Steps of the model's window.
    rel_step : float, default=1e-6
        Relative step of the central differences; about the cube root of the
        model's machine epsilon (larger for a float32 network).

    Returns
    -------
    Y_fit : ndarray of shape (n_trajectories, n_times, n_states)
        The model's free run over each initialisation record from the fitted
        first window (the measured values beyond the record are kept).
    """
    n, _, s = Y.shape
    k = int(n_steps)
    Z = Y[:, :k].copy()
    d = k * s
    r, cost = _window_residuals(rollout, Z, Y, n_init, k)
    if not np.all(np.isfinite(cost)):
        return Y
    lam = np.full(n, 1e-3)
    done = np.zeros(n, dtype=bool)
    for _ in range(_MAX_ITER):
        # Central differences, every trajectory perturbed at once.
        h = rel_step * np.maximum(1.0, np.abs(Z.reshape(n, d)))
        J = np.empty((n, r.shape[1], d))
        for j in range(d):
            step = np.zeros((n, d))
            step[:, j] = h[:, j]
            r_plus, _ = _window_residuals(
                rollout, Z + step.reshape(n, k, s), Y, n_init, k
            )
            r_minus, _ = _window_residuals(
                rollout, Z - step.reshape(n, k, s), Y, n_init, k
            )
            J[:, :, j] = (r_plus - r_minus) / (2.0 * h[:, j, None])
        A = np.einsum("nmi,nmj->nij", J, J)
        g = np.einsum("nmi,nm->ni", J, r)
        diag = np.einsum("nii->ni", A)
        damped = A + (lam[:, None] * np.maximum(diag, 1e-12))[:, :, None] * np.eye(d)
        delta = -np.linalg.solve(damped, g[:, :, None])[:, :, 0]
        delta[done] = 0.0
        Z_new = Z + delta.reshape(n, k, s)
        r_new, cost_new = _window_residuals(rollout, Z_new, Y, n_init, k)
        better = (cost_new < cost) & ~done
        gain = np.where(better, cost - cost_new, 0.0)
        small = np.linalg.norm(delta, axis=1) <= _RTOL ** 0.5 * (
            np.linalg.norm(Z.reshape(n, d), axis=1) + _RTOL
        )
        converged = ~done & (small | (better & (gain <= _RTOL * cost)))
        Z[better] = Z_new[better]
        r[better], cost[better] = r_new[better], cost_new[better]
        lam = np.where(better, lam / 3.0, lam * 4.0)
        done |= converged | (cost == 0.0) | (lam > 1e12)
        if done.all():
            break
    else:
        warnings.warn(
            f"the least-squares initial windows of {int((~done).sum())} of {n} "
            f"trajectories did not converge in {_MAX_ITER} iterations; their "
            "simulation starts from the last iterate.",
            ConvergenceWarning,
            stacklevel=3,
        )
    Y_fit = Y.copy()
    Y_fit[:, :k] = Z
    with np.errstate(all="ignore"):
        return rollout(Y_fit)
