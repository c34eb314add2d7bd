"""One array namespace for NumPy arrays and torch tensors.

Equations and losses in skhybrid are written once against the Python array API
standard (``xp.sin``, ``xp.fft.rfft``, ...). :func:`get_namespace` returns the
namespace of the arrays it is given: NumPy for :func:`scipy.optimize.least_squares`,
torch for gradient-based training and exact Jacobians by automatic differentiation.
"""

import inspect

import numpy as np

from skhybrid.utils._sklearn_compat import array_api_compat

__all__ = ["get_namespace", "is_torch", "takes_xp", "to_numpy"]


def get_namespace(*arrays):
    """Return the array-API namespace of ``arrays``.

    Parameters
    ----------
    *arrays : ndarray or torch.Tensor
        Arrays of one library; Python scalars and ``None`` are ignored.

    Returns
    -------
    xp : module
        An array-API compatible namespace (``array_api_compat.numpy`` or
        ``array_api_compat.torch``).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.utils import get_namespace
    >>> xp = get_namespace(np.ones(3))
    >>> float(xp.sum(xp.sin(np.zeros(3))))
    0.0
    """
    arrays = [a for a in arrays if a is not None and not isinstance(a, (int, float))]
    if not arrays:
        return array_api_compat.array_namespace(np.empty(0))
    return array_api_compat.array_namespace(*arrays)


def is_torch(xp):
    """Whether ``xp`` is the torch namespace."""
    return "torch" in getattr(xp, "__name__", "")


def to_numpy(array):
    """Return ``array`` (NumPy array or torch tensor, any device) as a NumPy array.

    Parameters
    ----------
    array : array-like or torch.Tensor
        The array; a tensor is detached and copied to the CPU.

    Returns
    -------
    array : ndarray
        The NumPy array.
    """
    if hasattr(array, "detach"):
        return array.detach().cpu().numpy()
    return np.asarray(array)


def takes_xp(func, *, default):
    """Whether ``func`` takes the array namespace as its keyword ``xp``.

    A user's equations written against :func:`get_namespace`'s namespace take
    ``xp=``; plain NumPy ones do not, and are called without it.

    Parameters
    ----------
    func : callable
        The user's function.
    default : bool
        The answer where ``func``'s signature cannot be read (a builtin, say).

    Returns
    -------
    takes : bool
        True where ``func`` has a parameter ``xp`` or takes ``**kwargs``.
    """
    try:
        signature = inspect.signature(func)
    except (TypeError, ValueError):
        return default
    return "xp" in signature.parameters or any(
        p.kind is inspect.Parameter.VAR_KEYWORD for p in signature.parameters.values()
    )
