"""The one initial-state solver: least squares per trajectory, evaluated in batches.

A free run started from one noisy measured window carries that window's noise into
every later step. When more measured samples than the window are known (an
initialisation record), the starting state can instead be chosen so that the
model's own free run through the whole record matches the measurements best: the
least-squares initial state of prediction-error methods. Every such estimate of
the package goes through :func:`fit_initial_states`: ``simulate(init=
"least_squares")`` (the first window of any next-state predictor),
:meth:`~skhybrid.domain.StateSpaceModel.estimate_initial_state` (the latent
states of a physics model) and the state-space hybrid's physics prior.
"""

import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning

__all__ = ["fit_initial_states"]

#: Outer (Jacobian) iterations per trajectory before a ConvergenceWarning.
MAX_ITER = 100
#: Damped steps tried per Jacobian before a trajectory counts as stalled.
MAX_TRIES = 10
#: Stop when an accepted step is this small relative to the estimate ...
XTOL = 1e-10
#: ... or lowers the cost by less than this fraction of it.
FTOL = 1e-6


def _costs(residuals, Z, index):
    """Residuals ``(n, m)`` of the rows ``Z`` and their costs (inf where not finite)."""
    with np.errstate(all="ignore"):
        r = np.asarray(residuals(Z, index), dtype=np.float64).reshape(len(index), -1)
    finite = np.all(np.isfinite(r), axis=1)
    with np.errstate(all="ignore"):
        squares = np.sum(np.where(finite[:, None], r, 0.0) ** 2, axis=1)
    return r, np.where(finite, squares, np.inf)


def _solve(A, b):
    """``A[i] x[i] = -b[i]`` for every row; a singular row gives NaN, not an error.

    LAPACK solves each matrix of a batch on its own, so the rows are solved one
    by one only when one of them is singular, and the others get the same
    solution either way.
    """
    with np.errstate(all="ignore"):
        try:
            return -np.linalg.solve(A, b[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            out = np.full(b.shape, np.nan)
            for i in range(len(b)):
                try:
                    out[i] = -np.linalg.solve(A[i], b[i])
                except np.linalg.LinAlgError:
                    pass
            return out


def fit_initial_states(residuals, x0, *, rel_step=None, max_iter=MAX_ITER):
    """Least-squares estimates of many independent small problems, one per trajectory.

    Minimises ``sum(residuals(z)[i] ** 2)`` over ``z[i]`` separately for every
    trajectory ``i``: a Levenberg-Marquardt iteration per trajectory whose model
    evaluations (the free runs) are batched over all trajectories still
    iterating. A trajectory's iterates depend only on its own residuals, so a
    batch gives what separate calls give, whatever the other trajectories do (a
    diverging or badly conditioned trajectory included), up to the rounding of
    the caller's batched evaluation.

    Parameters
    ----------
    residuals : callable
        ``residuals(Z, index) -> R``: ``Z`` of shape ``(n_rows, n_params)`` holds
        candidate estimates and ``index`` of shape ``(n_rows,)`` the trajectory
        each row belongs to (rows repeat trajectories); ``R`` of shape
        ``(n_rows, n_residuals)`` holds the residuals of each row, computed from
        that row alone. Non-finite residuals mark a candidate as unusable.
    x0 : array-like of shape (n_trajectories, n_params)
        Starting estimates.
    rel_step : float or None, default=None
        Relative step of the central differences, ``h = rel_step * max(1,
        |z|)``; ``None`` uses the cube root of float64's machine epsilon (about
        6e-6). A model computing in float32 needs the cube root of float32's
        (about 5e-3).
    max_iter : int, default=100
        Jacobian evaluations per trajectory; a
        :class:`~sklearn.exceptions.ConvergenceWarning` names how many
        trajectories were still iterating then.

    Returns
    -------
    z : ndarray of shape (n_trajectories, n_params)
        The estimates; a trajectory whose residuals are not finite at ``x0``
        keeps ``x0``.
    converged : ndarray of bool of shape (n_trajectories,)
        Whether each trajectory met the stopping rule (False where the residuals
        at ``x0`` are not finite or ``max_iter`` ran out).

    Notes
    -----
    One difference scheme, one damping rule and one stopping rule, the same for
    every caller:

    - **Jacobian**: central differences with the step ``h_j = rel_step *
      max(1, |z_j|)``; the ``2 * n_params`` perturbed candidates of all
      iterating trajectories are evaluated in one call of ``residuals``.
    - **Damping** (Marquardt): the step solves ``(J'J + lam * D) dz = -J'r``
      with ``D`` the diagonal of ``J'J`` (floored at ``1e-12`` times its largest
      entry). ``lam`` starts at ``1e-3``; a step that lowers the cost is
      accepted and divides ``lam`` by 10; a rejected one multiplies it by 10 and
      is retried with the same Jacobian, at most 10 times.
    - **Stopping**, per trajectory: the cost is zero; or the gradient ``J'r`` is
      zero; or an accepted step is smaller than ``1e-10 * (|z| + 1e-10)``; or it
      lowers the cost by less than ``1e-6`` of it (Gauss-Newton converges
      quadratically on smooth problems, so the estimate is then far closer than
      that; on non-smooth physics such as a backlash, where the gains stay
      small, it ends the crawl); or 10 damped steps in a row fail to lower the
      cost (it cannot be lowered within rounding).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.simulation import fit_initial_states
    >>> targets = np.array([[1.0, 2.0], [3.0, -1.0]])
    >>> def residuals(Z, index):
    ...     T = targets[index]
    ...     return np.hstack([Z - T, Z**3 - T**3])
    >>> z, converged = fit_initial_states(residuals, np.zeros((2, 2)) + 0.5)
    >>> np.round(z, 6).tolist(), converged.tolist()
    ([[1.0, 2.0], [3.0, -1.0]], [True, True])
    """
    Z = np.array(x0, dtype=np.float64, ndmin=2)
    n, d = Z.shape
    if rel_step is None:
        rel_step = float(np.finfo(np.float64).eps) ** (1 / 3)
    converged = np.zeros(n, dtype=bool)
    if n == 0 or d == 0:
        converged[:] = True
        return Z, converged
    r, cost = _costs(residuals, Z, np.arange(n))
    active = np.isfinite(cost) & (cost > 0)
    converged[np.isfinite(cost) & (cost == 0)] = True
    lam = np.full(n, 1e-3)
    eye = np.eye(d)
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        z = Z[idx]
        # Central differences: 2 d candidates per trajectory, one batch.
        h = rel_step * np.maximum(1.0, np.abs(z))  # (a, d)
        steps = eye[None] * h[:, None, :]  # (a, d, d): row j perturbs z_j
        cand = np.concatenate([z[:, None] + steps, z[:, None] - steps], axis=1)
        R, _ = _costs(residuals, cand.reshape(-1, d), np.repeat(idx, 2 * d))
        R = R.reshape(idx.size, 2 * d, -1)
        J = np.swapaxes((R[:, :d] - R[:, d:]) / (2.0 * h[:, :, None]), 1, 2)
        J = np.where(np.isfinite(J), J, 0.0)  # (a, m, d)
        A = np.einsum("ami,amj->aij", J, J)
        g = np.einsum("ami,am->ai", J, r[idx])
        diag = np.einsum("aii->ai", A)
        floor = 1e-12 * np.max(diag, axis=1, keepdims=True)
        D = np.maximum(diag, floor)
        flat = ~np.any(g != 0.0, axis=1) | ~np.any(D > 0, axis=1)
        converged[idx[flat]] = True
        active[idx[flat]] = False
        trying = ~flat
        for _ in range(MAX_TRIES):
            t = np.flatnonzero(trying)
            if t.size == 0:
                break
            rows = idx[t]
            damped = A[t] + (lam[rows, None] * D[t])[:, :, None] * eye
            delta = _solve(damped, g[t])
            ok = np.all(np.isfinite(delta), axis=1)
            trial = z[t] + np.where(ok[:, None], delta, 0.0)
            r_new, cost_new = _costs(residuals, trial, rows)
            better = ok & (cost_new < cost[rows])
            acc = rows[better]
            gain = cost[acc] - cost_new[better]
            small = np.linalg.norm(delta[better], axis=1) <= XTOL * (
                np.linalg.norm(z[t][better], axis=1) + XTOL
            )
            Z[acc], r[acc] = trial[better], r_new[better]
            stop = small | (gain <= FTOL * cost[acc]) | (cost_new[better] == 0)
            cost[acc] = cost_new[better]
            lam[acc] = np.maximum(lam[acc] / 10.0, 1e-12)
            converged[acc[stop]] = True
            active[acc[stop]] = False
            lam[rows[~better]] *= 10.0
            trying[t[better]] = False
        # Stalled: no damped step lowered the cost.
        stalled = idx[trying]
        converged[stalled] = True
        active[stalled] = False
    if np.any(active):
        warnings.warn(
            f"the least-squares initial states of {int(active.sum())} of {n} "
            f"trajectories did not converge in max_iter={max_iter} iterations; "
            "they keep the last iterate.",
            ConvergenceWarning,
            stacklevel=3,
        )
    return Z, converged
