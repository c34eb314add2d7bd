"""Which parameter combinations the data leave undetermined: a check after every fit."""

import os
import sys
import warnings

import numpy as np
import sklearn

from skhybrid.exceptions import IdentifiabilityWarning

__all__ = ["check_identifiability"]


def warn_if_unidentifiable(estimator, jacobian, spec, theta, tol=1e-6):
    """Warn with the combination a nearly singular Jacobian at the fit leaves free.

    Parameters
    ----------
    estimator : object
        The fitted model (named in the warning).
    jacobian : ndarray of shape (n_residuals, n_free)
        Jacobian of the residuals with respect to the free parameters at the fit.
    spec : _ParameterSpec
        The parameters' names, shapes and scales.
    theta : ndarray of shape (n_free,)
        The fitted free parameters.
    tol : float, default=1e-6
        See :func:`check_identifiability`.
    """
    if spec.n_free < 2:
        return
    names = _free_labels(spec)
    # Relative units: each column times its parameter's size. A parameter
    # fitted at (or near) zero keeps a floor of its start's size, or its
    # column would vanish and a well-determined zero (an intercept of 0) would
    # read as undetermined; scaling a column never hides a true dependence.
    scale = np.maximum(np.abs(theta), 1e-3 * spec.scale)
    message = check_identifiability(jacobian * scale, names, tol=tol)
    if message:
        warnings.warn(
            f"{type(estimator).__name__}: {message}",
            IdentifiabilityWarning,
            stacklevel=4,
        )


def _user_stacklevel():
    """``stacklevel`` of the first frame outside skhybrid and scikit-learn.

    The fits reach the least squares through decorators and re-entrant
    clones of varying depth; a fixed level would point into them.
    """
    internal = (
        os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
        os.path.dirname(os.path.abspath(sklearn.__file__)),
    )
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(internal):
        frame, level = frame.f_back, level + 1
    return level


def warn_if_underdetermined(estimator, n_residuals, n_free, *, remedy=""):
    """Warn where a fit has no more residuals than free parameters.

    Such a fit can pass through every sample (an in-sample error near zero)
    while its parameters are set by the noise, and simulate far off elsewhere;
    nothing in the result says so.

    Parameters
    ----------
    estimator : object
        The model being fitted (named in the warning).
    n_residuals : int
        Residuals the fit minimises (samples times outputs).
    n_free : int
        Free parameters it fits.
    remedy : str, default=""
        What lowers this model's number of parameters, appended to the advice.

    Returns
    -------
    underdetermined : bool
        Whether it warned.
    """
    if n_free == 0 or n_residuals > n_free:
        return False
    warnings.warn(
        f"{type(estimator).__name__} fits {n_free} free parameters to only "
        f"{n_residuals} residuals, which cannot determine them: the fit can "
        "interpolate the data (an in-sample error near zero) and simulate far off "
        "elsewhere. Fit on more samples, or fit fewer parameters"
        f"{' (' + remedy + ')' if remedy else ''}.",
        IdentifiabilityWarning,
        stacklevel=_user_stacklevel(),
    )
    return True


def _free_labels(spec):
    labels = []
    for name in spec.free:
        shape = spec.shapes[name]
        if shape:
            labels.extend(f"{name}[{i}]" for i in range(int(np.prod(shape))))
        else:
            labels.append(name)
    return labels


def check_identifiability(jacobian, names, *, tol=1e-6):
    """Describe the parameter combination a nearly singular Jacobian leaves free.

    Parameters
    ----------
    jacobian : array-like of shape (n_residuals, n_params)
        Jacobian of the residuals with respect to the parameters in relative
        units (each column multiplied by its parameter's value), so that its
        singular values do not depend on the parameters' units.
    names : sequence of str
        Name of each parameter (column).
    tol : float, default=1e-6
        The Jacobian is nearly singular where its smallest singular value is
        below ``tol`` times its largest.

    Returns
    -------
    message : str or None
        None when the parameters are identifiable; otherwise a sentence naming
        the parameters along the right-singular vector of the smallest singular
        value and the combination the data determine (``a*b`` where ``a`` and
        ``b`` move in opposite relative directions, ``a/b`` where they move
        together).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import check_identifiability
    >>> u = np.linspace(0, 1, 20)
    >>> a, b = 2.0, 3.0
    >>> J = np.column_stack([a * b * u, a * b * u])  # d(a b u)/d log a, / d log b
    >>> print(check_identifiability(J, ["a", "b"]))
    only the combination a*b is determined: parameters 'a' and 'b' move together \
without changing the fit (smallest/largest singular value < 1e-12; null direction in \
relative units: +0.71 a, -0.71 b). Fix one of them or reparametrise.
    """
    J = np.asarray(jacobian, dtype=float)
    names = list(names)
    if J.ndim != 2 or J.shape[1] != len(names) or J.shape[1] == 0:
        raise ValueError(
            f"jacobian must have one column per name; got shape {J.shape} and "
            f"{len(names)} names."
        )
    if not np.all(np.isfinite(J)):
        return None
    s_all = np.linalg.svd(J, compute_uv=False)
    s_max = float(s_all[0]) if s_all.size else 0.0
    if s_max == 0:
        return (
            f"no parameter changes the fit: {', '.join(map(repr, names))} are not "
            "determined by the data."
        )
    # The null direction is the last row of V^T; only a wide Jacobian needs the
    # full V^T to hold it, and a tall one must not build its (huge) full U.
    _, s, vt = np.linalg.svd(J, full_matrices=J.shape[0] < J.shape[1])
    s_min = float(s[-1]) if J.shape[0] >= J.shape[1] else 0.0
    ratio = s_min / s_max
    if ratio >= tol:
        return None
    v = vt[-1]
    dominant = np.flatnonzero(np.abs(v) >= 0.1 * np.max(np.abs(v)))
    v = v * np.sign(v[dominant[0]])  # the first named parameter moves up
    direction = ", ".join(f"{v[i]:+.2f} {names[i]}" for i in dominant)
    shown = "< 1e-12" if ratio < 1e-12 else f"{ratio:.2g}"
    detail = (
        f"(smallest/largest singular value {shown}; null direction in relative "
        f"units: {direction}). Fix one of them or reparametrise."
    )
    if dominant.size == 1:
        return (
            f"parameter {names[dominant[0]]!r} does not change the fit: the data do "
            f"not determine it {detail}"
        )
    if dominant.size == 2:
        i, j = dominant
        op = "*" if v[i] * v[j] < 0 else "/"
        combination = f"{names[i]}{op}{names[j]}"
        return (
            f"only the combination {combination} is determined: parameters "
            f"{names[i]!r} and {names[j]!r} move together without changing the fit "
            f"{detail}"
        )
    quoted = ", ".join(repr(names[i]) for i in dominant)
    return (
        f"only a combination of {quoted} is determined: these parameters move "
        f"together without changing the fit {detail}"
    )
