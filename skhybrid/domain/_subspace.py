"""A linear state-space start from a subspace fit (N4SID).

:func:`subspace_state_space` identifies ``x(t+1) = A x(t) + B u(t)``,
``y(t) = C x(t)`` from one record with the N4SID algorithm of the ``nfoursid``
package (PO-MOESP), and returns it as a :class:`StateSpaceModel` with latent
states, whose parameters start at the subspace estimate. ``fit_simulation``
then refines them by the simulation (output) error, and the state-space hybrid
trains through the same equations: the best linear approximation of a
block-structured system, the start that PNLSS and SUBNET's initialisations use.
"""

import warnings
from numbers import Integral

import numpy as np
import pandas as pd
from nfoursid.nfoursid import NFourSID
from nfoursid.utils import Utils

from skhybrid.domain._state_space import StateSpaceModel
from skhybrid.utils._array_api import is_torch
from skhybrid.utils._validation import as_columns, first_not_finite

__all__ = ["linear_output", "linear_state_update", "subspace_state_space"]

# What the returned model sets itself; a caller's keyword would contradict it.
_OWN = ("rhs", "params", "state_names", "observed", "output", "time", "method")


def _matrix(params, prefix, rows, cols, xp):
    """The matrix ``prefix_i_j`` of ``params``.

    Shape ``(rows, cols)`` where every entry is a scalar (a fit's trial, a
    torch training step), ``(n_rows, rows, cols)`` where some entries hold one
    value per row (``vectorized`` Jacobians give every row its own parameter
    set).
    """
    values = [params[f"{prefix}_{i}_{j}"] for i in range(rows) for j in range(cols)]
    if is_torch(xp):
        # A trained parameter is a tensor already (converting it would copy it
        # and warn); a fixed one is a float.
        values = [v if hasattr(v, "requires_grad") else xp.asarray(v) for v in values]
        if all(v.ndim == 0 for v in values):
            return xp.reshape(xp.stack(values), (rows, cols))
        stacked = xp.stack(xp.broadcast_tensors(*values), axis=-1)
        return xp.reshape(stacked, (-1, rows, cols))
    try:
        flat = np.asarray(values, dtype=float)
    except ValueError:  # scalars beside per-row arrays
        flat = np.stack(np.broadcast_arrays(*values))
    if flat.ndim == 1:
        return flat.reshape(rows, cols)
    return flat.T.reshape(-1, rows, cols)


def _times(M, x, xp):
    """``M x`` for every row of ``x`` (``M`` one matrix, or one per row)."""
    if is_torch(xp) and M.dtype != x.dtype:  # torch multiplies like with like
        M = M.to(x.dtype)
    if M.ndim == 2:
        return x @ M.T
    return xp.sum(M * x[:, None, :], axis=2)


def _vector(params, prefix, size, xp):
    """The vector ``prefix_i`` of ``params`` (a matrix of one column, as above)."""
    M = _matrix(
        {f"{prefix}_{i}_0": params[f"{prefix}_{i}"] for i in range(size)},
        prefix,
        size,
        1,
        xp,
    )
    return M[..., 0]


def _count(params, prefix):
    """How many entries ``prefix_0``, ``prefix_1``, ... the parameters hold."""
    n = 0
    while f"{prefix}_{n}" in params:
        n += 1
    return n


def linear_state_update(x, u, *, xp, **params):
    """``x(t+1) = A x(t) + B u(t) + x_bias`` with the entries named in ``params``.

    ``A`` is ``a_i_j``, ``B`` is ``b_i_k`` and the constant ``x_bias_i`` (the
    inputs' mean through ``B``), for ``n_states = x.shape[1]`` and
    ``n_inputs = u.shape[1]``: the state equation of
    :func:`subspace_state_space`'s model.
    """
    n_x, n_u = x.shape[1], u.shape[1]
    A = _matrix(params, "a", n_x, n_x, xp)
    B = _matrix(params, "b", n_x, n_u, xp)
    return _times(A, x, xp) + _times(B, u, xp) + _vector(params, "x_bias", n_x, xp)


def linear_output(x, *, xp, **params):
    """``y(t) = C x(t) + y_bias`` with ``C`` named ``c_j_i`` in ``params``."""
    n_y = _count(params, "y_bias")
    C = _matrix(params, "c", n_y, x.shape[1], xp)
    return _times(C, x, xp) + _vector(params, "y_bias", n_y, xp)


def _as_record(name, values):
    """``values`` as a finite 2-D float array ``(n_times, n_columns)``."""
    if isinstance(values, (list, tuple)) and values and np.ndim(values[0]) >= 2:
        raise TypeError(
            f"{name} must be one record (an array of shape (n_times,) or "
            f"(n_times, n_columns)), not a list of {len(values)} records; pass "
            "the longest record, then fit_simulation on all of them."
        )
    array = as_columns(values, name)
    bad = first_not_finite({name: array})
    if bad is not None:
        raise ValueError(f"{name} holds NaN or infinite values ({bad}).")
    return array


def _n4sid(U, Y, order, block_rows):
    """``A, B, C`` (with ``D = 0``) and the unconstrained ``D`` of one record.

    ``nfoursid`` builds the block Hankel matrices and their QR decomposition
    (PO-MOESP); the state sequence is then read from the observability
    estimate by a thin SVD (``nfoursid``'s own takes the full one, whose
    ``(n_times, n_times)`` factor does not fit in memory beyond some ten
    thousand samples), and ``[A B]`` and ``C`` are its least-squares fits with
    no direct feedthrough.
    """
    n_u, n_y = U.shape[1], Y.shape[1]
    frame = pd.DataFrame(
        np.hstack([U, Y]),
        columns=[f"u{k}" for k in range(n_u)] + [f"y{j}" for j in range(n_y)],
    )
    fit = NFourSID(
        frame,
        output_columns=[f"y{j}" for j in range(n_y)],
        input_columns=[f"u{k}" for k in range(n_u)],
        num_block_rows=block_rows,
    )
    fit.subspace_identification()
    past = np.vstack(
        [
            Utils.block_hankel_matrix(U, block_rows),
            Utils.block_hankel_matrix(Y, block_rows),
        ]
    )
    observability = fit.R32 @ np.linalg.pinv(fit.R22) @ past
    _, singular, vh = np.linalg.svd(observability, full_matrices=False)
    # The states at samples block_rows .. n_times - 1, one column each.
    X = (np.sqrt(singular[:order])[:, None] * vh[:order])[:, :-1]
    now, later = X[:, :-1].T, X[:, 1:].T
    u_now = U[block_rows : block_rows + len(now)]
    y_now = Y[block_rows : block_rows + len(now)]
    AB = np.linalg.lstsq(np.hstack([now, u_now]), later, rcond=None)[0].T
    C = np.linalg.lstsq(now, y_now, rcond=None)[0].T
    D = np.linalg.lstsq(np.hstack([now, u_now]), y_now, rcond=None)[0].T[:, order:]
    return AB[:, :order], AB[:, order:], C, D


def subspace_state_space(inputs, outputs, order, *, block_rows=None, **kwargs):
    """A linear state-space model of ``order`` states, started from a subspace fit.

    Identifies ``x(t+1) = A x(t) + B u(t)``, ``y(t) = C x(t)`` from one record by
    N4SID (PO-MOESP, the ``nfoursid`` package) on the record less its means, and
    returns it as a discrete-time :class:`StateSpaceModel` whose states are
    latent (each record's initial state is estimated from its first ``n_init``
    samples by least squares) and whose parameters start at the subspace
    estimate. The model is unfitted: ``fit_simulation`` refines every entry by
    the simulation error, the output-error fit, from that start. Use it as the
    best linear approximation of a block-structured system (a Wiener,
    Hammerstein or Wiener-Hammerstein chain) and as the physics of a
    :class:`~skhybrid.hybrid.StateSpaceHybridRegressor`, whose networks then
    learn the nonlinearity around it.

    The model has no direct feedthrough (``D = 0``): a sampled system's output
    answers its input a sample later. ``A``, ``B`` and ``C`` are fitted so, with
    a warning where a ``D`` would carry more than 10 % of the outputs'
    variation. The N4SID's state sequence is read by a thin SVD, so a record of
    100,000 samples takes seconds and little memory.

    Parameters
    ----------
    inputs : array-like of shape (n_times, n_inputs) or (n_times,)
        The record's inputs.
    outputs : array-like of shape (n_times, n_outputs) or (n_times,)
        The record's measured outputs.
    order : int
        Number of states.
    block_rows : int or None, default=None
        Block rows of the Hankel matrices; more than ``order``. None: ``max(10,
        2 * order)``.
    **kwargs
        Other parameters of :class:`StateSpaceModel` (``n_init``, ``max_nfev``,
        ``bounds``, ``fixed``, ``noise_model``, ``vectorized``, ...); the model
        sets ``rhs``, ``params``, ``state_names``, ``observed``, ``output``,
        ``time`` and ``method`` itself. ``vectorized`` defaults to True and
        ``identifiability_tol`` to 0: the states' basis is not unique (a
        similarity transform changes ``A``, ``B``, ``C`` and the biases, not the
        outputs), so the entries are not separately determined, by
        construction, and their standard errors mean nothing; the outputs and
        the poles are determined.

    Returns
    -------
    model : StateSpaceModel
        Unfitted; ``params`` holds ``a_i_j`` (``A``), ``b_i_k`` (``B``),
        ``c_j_i`` (``C``), ``x_bias_i`` and ``y_bias_j`` (the records' means:
        ``x_bias = -B mean(u)``, ``y_bias = mean(y)``), its equations are
        :func:`linear_state_update` and :func:`linear_output`.

    Raises
    ------
    ValueError
        If ``order`` or ``block_rows`` is not a positive integer, the record is
        too short for them, or the records hold NaN.
    TypeError
        If ``inputs`` or ``outputs`` is a list of records, or ``kwargs`` sets
        what the model sets itself.

    Warns
    -----
    UserWarning
        Where the subspace estimate is unstable (a pole on or outside the unit
        circle: a free run from it grows) or a ``D`` would have mattered.

    See Also
    --------
    StateSpaceModel.fit_simulation : The output-error fit that refines it.
    WienerHammersteinModel : A block-structured model started from a transfer
        function's output-error fit.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import subspace_state_space
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((600, 1))
    >>> y = np.zeros((600, 1))
    >>> for t in range(2, 600):  # poles 0.9 +- 0.3j
    ...     y[t] = 1.8 * y[t - 1] - 0.9 * y[t - 2] + 0.5 * u[t - 1]
    >>> model = subspace_state_space(u, y, order=2, n_init=10)
    >>> A = np.array([[model.params[f"a_{i}_{j}"] for j in range(2)] for i in range(2)])
    >>> np.round(np.sort(np.abs(np.linalg.eigvals(A))), 3)
    array([0.949, 0.949])
    >>> model = model.fit_simulation(u, y)
    >>> bool(model.rmse_ < 1e-6)
    True
    """
    if isinstance(order, bool) or not isinstance(order, Integral) or order < 1:
        raise ValueError(f"order must be a positive integer; got order={order!r}.")
    order = int(order)
    if block_rows is None:
        block_rows = max(10, 2 * order)
    if (
        isinstance(block_rows, bool)
        or not isinstance(block_rows, Integral)
        or block_rows <= order
    ):
        raise ValueError(
            f"block_rows must be an integer above order={order}; got "
            f"block_rows={block_rows!r}."
        )
    taken = sorted(set(kwargs) & set(_OWN))
    if taken:
        raise TypeError(
            f"subspace_state_space sets {', '.join(taken)} itself; got "
            f"{', '.join(f'{k}={kwargs[k]!r}' for k in taken)}."
        )
    U, Y = _as_record("inputs", inputs), _as_record("outputs", outputs)
    if len(U) != len(Y):
        raise ValueError(
            f"inputs and outputs must have the same number of samples; got "
            f"{len(U)} and {len(Y)}."
        )
    n_u, n_y = U.shape[1], Y.shape[1]
    needed = 2 * block_rows * (n_u + n_y + 1) + order
    if len(U) < needed:
        raise ValueError(
            f"The record is too short for block_rows={block_rows}: {len(U)} samples, "
            f"and the subspace fit needs at least {needed}; pass a smaller "
            "block_rows or a longer record."
        )
    u_mean, y_mean = U.mean(axis=0), Y.mean(axis=0)
    Uc, Yc = U - u_mean, Y - y_mean
    A, B, C, D = _n4sid(Uc, Yc, order, int(block_rows))
    radius = float(np.max(np.abs(np.linalg.eigvals(A))))
    if radius >= 1.0:
        warnings.warn(
            f"The subspace estimate of order {order} is unstable (largest pole "
            f"modulus {radius:.4g}): a free run from it grows. Try another order "
            "or block_rows, or fit_simulation on short segments.",
            UserWarning,
            stacklevel=2,
        )
    share = np.linalg.norm(Uc @ D.T) / max(np.linalg.norm(Yc), np.finfo(float).tiny)
    if share > 0.1:
        warnings.warn(
            f"A direct feedthrough D would carry {share:.0%} of the outputs' "
            "variation; the model has none (D = 0), so its outputs answer the "
            "inputs a sample late.",
            UserWarning,
            stacklevel=2,
        )
    params = {}
    params.update({f"a_{i}_{j}": A[i, j] for i in range(order) for j in range(order)})
    params.update({f"b_{i}_{k}": B[i, k] for i in range(order) for k in range(n_u)})
    params.update({f"c_{j}_{i}": C[j, i] for j in range(n_y) for i in range(order)})
    params.update({f"x_bias_{i}": -(B @ u_mean)[i] for i in range(order)})
    params.update({f"y_bias_{j}": y_mean[j] for j in range(n_y)})
    kwargs.setdefault("vectorized", True)
    # A realisation's basis is not unique (a similarity transform of the states
    # changes A, B, C and the biases, not the outputs): the Jacobian is singular
    # by construction, which is no finding to warn about.
    kwargs.setdefault("identifiability_tol", 0.0)
    kwargs.setdefault("initial_state", np.zeros(order))
    return StateSpaceModel(
        linear_state_update,
        {name: float(value) for name, value in params.items()},
        state_names=[f"x{i} (latent)" for i in range(order)],
        output=linear_output,
        time="discrete",
        **kwargs,
    )
