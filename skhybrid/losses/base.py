"""Training objectives of every stage: ``"mse"``, ``"ljung_box"``, ``"mse+ljung_box"``.

Each objective is written two ways from the same pieces, so that a least-squares
domain fit and a gradient-trained network minimise the same thing:

- :func:`objective_residuals` returns a vector whose sum of squares is the objective
  (what :func:`scipy.optimize.least_squares` takes);
- :func:`objective_value` returns the objective itself (what a torch optimiser takes).

With residuals ``r`` of shape ``(n, n_outputs)``:

- ``"mse"``: ``mean(r ** 2)`` over all samples and outputs (Eq. 5 up to a factor);
- ``"ljung_box"``: ``mean_j T_j``, the Ljung-Box-weighted norm of each output's
  autocovariances (:func:`~skhybrid.losses.autocovariance_norm`),
  ``T = sqrt(sum_k (n + 2) / (n - k) * gamma_k ** 2) = gamma_0 * sqrt(Q / n)``: the
  Ljung-Box statistic carried back to the residual's scale. It is invariant to the
  residual's offset, so alone it does not pull a model towards the data's mean;
- ``"mse+ljung_box"``: ``mse + ljung_box_weight * mean_j T_j``. Both terms are in
  the units of a mean square, so the weight means the same at any scale;
- ``"ljung_box_q"``: ``Q``, the paper's statistic itself summed over outputs
  (Eq. 7), kept to reproduce the paper. **It rewards noise**: ``Q`` is normalised
  by the residual's variance, so a model lowers it by adding noise that is
  independent of everything (the pure objective made a residual "white" by making
  it 8.6 times larger). Do not use it to fit a model you will use.

The Ljung-Box objectives cannot buy whiteness with noise: for any residual ``r`` and
independent white noise ``e``, the expected objective of ``r + e`` is not below the
objective of ``r`` (autocovariances of ``r + e`` have the expectation of those of
``r`` and the norm is convex; the MSE grows by the noise's variance). The earlier
``"mse+ljung_box"``, ``mse + w * mean_j(var_j * Q_j / n)``, divided by the
residual's own variance and therefore fell when noise was added to a strongly
autocorrelated residual; see ``docs/losses.md``.

Objectives with a Ljung-Box term need residuals in time order.
"""

from skhybrid.losses._ljung_box import (
    autocovariance_norm,
    ljung_box,
    weighted_autocorrelations,
)
from skhybrid.utils._array_api import get_namespace
from skhybrid.utils._docstrings import fill_doc

__all__ = [
    "OBJECTIVES",
    "check_objective",
    "mse",
    "needs_time_order",
    "objective_residuals",
    "objective_value",
]

OBJECTIVES = ("mse", "ljung_box", "mse+ljung_box", "ljung_box_q")


def check_objective(objective):
    """Raise a ValueError unless ``objective`` is one of :data:`OBJECTIVES`.

    Parameters
    ----------
    objective : str
        The objective's name.

    Returns
    -------
    objective : str
        ``objective`` itself, when it is valid.
    """
    if objective not in OBJECTIVES:
        raise ValueError(
            f"objective must be one of {OBJECTIVES}; got objective={objective!r}."
        )
    return objective


def needs_time_order(objective):
    """Whether ``objective`` depends on the order of the rows (has a Ljung-Box term).

    Parameters
    ----------
    objective : str
        One of :data:`OBJECTIVES`.

    Returns
    -------
    time_ordered : bool
        True when the objective holds a Ljung-Box term, which needs rows in time
        order.
    """
    return "ljung_box" in check_objective(objective)


def mse(residuals):
    """Mean squared residual over all samples and outputs.

    Parameters
    ----------
    residuals : ndarray or torch.Tensor of shape (n_samples,) or (n_samples, n_outputs)
        The residuals.

    Returns
    -------
    mse : float or torch.Tensor
        Their mean square (a 0-d tensor for torch input, differentiable).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import mse
    >>> float(mse(np.array([[1.0, -1.0], [3.0, 1.0]])))
    3.0
    """
    xp = get_namespace(residuals)
    return xp.mean(residuals**2)


def _as_2d(residuals):
    return residuals if residuals.ndim == 2 else residuals[:, None]


def _scaled_norms(r, lags, segments, scale, xp):
    """Each output's autocovariance norm, divided by ``scale`` when given."""
    norms = autocovariance_norm(r, lags, segments=segments)
    if scale is None:
        return norms
    scale = xp.asarray(scale, dtype=norms.dtype, device=getattr(norms, "device", None))
    scale = xp.reshape(scale, (-1,))
    if scale.shape[0] != norms.shape[0] or not bool(xp.all(scale > 0)):
        raise ValueError(
            f"ljung_box_scale must hold one positive value per output "
            f"(n_outputs={norms.shape[0]}); got ljung_box_scale={scale!r}."
        )
    return norms / scale


#: The parameters :func:`objective_residuals` and :func:`objective_value` share.
_OBJECTIVE_PARAMETERS = """\
residuals : ndarray or torch.Tensor of shape (n_samples,) or (n_samples, n_outputs)
    Residuals ``y - y_pred`` in time order.
objective : {"mse", "ljung_box", "mse+ljung_box", "ljung_box_q"}, default="mse"
    The objective (see the module docstring).
lags : int, default=20
    Ljung-Box lags ``L``.
ljung_box_weight : float, default=1.0
    Weight of the Ljung-Box term in ``"mse+ljung_box"``.
segments : int, default=1
    Number of equal, consecutive segments the rows hold, each a series of its
    own: the autocovariances of the Ljung-Box term are summed within each
    segment and pooled (see :func:`~skhybrid.losses.autocovariance_norm`).
    The MSE part does not depend on it, nor does ``"ljung_box_q"``.
ljung_box_scale : array-like of shape (n_outputs,) or None, default=None
    Positive divisors of each output's autocovariance norm ``T_j`` in the
    ``"ljung_box"`` and ``"mse+ljung_box"`` terms (``mean_j T_j / s_j``):
    fixed scales, such as each output's target variance, that whiten every
    output alike whatever its size. None divides by 1. ``"ljung_box_q"``
    ignores it."""


@fill_doc(objective_parameters=_OBJECTIVE_PARAMETERS)
def objective_residuals(
    residuals,
    objective="mse",
    *,
    lags=20,
    ljung_box_weight=1.0,
    segments=1,
    ljung_box_scale=None,
):
    """Vector whose sum of squares equals :func:`objective_value`.

    Parameters
    ----------
    %(objective_parameters)s

    Returns
    -------
    vector : 1-D ndarray or torch.Tensor
        Scaled residuals (``r / sqrt(n * n_outputs)``) for the MSE part followed by
        ``sqrt(weight * T_j / n_outputs)`` for each output's autocovariance norm
        (or the weighted autocorrelations for ``"ljung_box_q"``).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import objective_residuals, objective_value
    >>> r = np.random.default_rng(0).standard_normal((50, 2))
    >>> v = objective_residuals(r, "mse+ljung_box", lags=5, ljung_box_weight=0.5)
    >>> bool(np.isclose((v ** 2).sum(), objective_value(r, "mse+ljung_box", lags=5,
    ...                                                  ljung_box_weight=0.5)))
    True
    """
    check_objective(objective)
    xp = get_namespace(residuals)
    r = _as_2d(residuals)
    parts = []
    if objective in ("mse", "mse+ljung_box"):
        parts.append(xp.reshape(r, (-1,)) / (r.shape[0] * r.shape[1]) ** 0.5)
    if objective == "ljung_box_q":
        parts.append(xp.reshape(weighted_autocorrelations(r, lags), (-1,)))
    elif objective in ("ljung_box", "mse+ljung_box"):
        weight = ljung_box_weight if objective == "mse+ljung_box" else 1.0
        norms = _scaled_norms(r, lags, segments, ljung_box_scale, xp)
        parts.append(xp.sqrt(weight * norms / r.shape[1]))
    return parts[0] if len(parts) == 1 else xp.concat(parts)


@fill_doc(objective_parameters=_OBJECTIVE_PARAMETERS)
def objective_value(
    residuals,
    objective="mse",
    *,
    lags=20,
    ljung_box_weight=1.0,
    segments=1,
    ljung_box_scale=None,
):
    """Value of a training objective on residuals (a 0-d array or tensor).

    Parameters
    ----------
    %(objective_parameters)s

    Returns
    -------
    value : 0-d ndarray or torch.Tensor
        Differentiable for torch input.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import objective_value
    >>> r = np.array([0.5, -0.5, 0.5, -0.5])
    >>> float(objective_value(r, "mse"))
    0.25
    """
    check_objective(objective)
    r = _as_2d(residuals)
    if objective == "mse":
        return mse(r)
    if objective == "ljung_box_q":
        return ljung_box(r, lags)
    xp = get_namespace(residuals)
    term = xp.mean(_scaled_norms(r, lags, segments, ljung_box_scale, xp))
    if objective == "ljung_box":
        return term
    return mse(r) + ljung_box_weight * term
