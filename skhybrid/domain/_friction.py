"""Friction forces to write into a model's equations (NumPy and torch alike).

Each function takes the velocity and the array namespace ``xp`` (as the
equations of :class:`~skhybrid.domain.StateSpaceModel` and
:class:`~skhybrid.domain.ParametricModel` receive it) and returns the friction
force opposing the motion, so that one line of an ``rhs`` chooses the model:
``acc = (force - asymmetric_friction(v, xp=xp, ...)) / M``. The sign of the
velocity is smoothed as ``tanh(v / eps)``, which keeps the equations
differentiable for least squares and for torch; ``eps`` is a velocity well below
the motion's (fix it with the model's ``fixed``).
"""

from numbers import Real

import numpy as np

__all__ = ["asymmetric_friction", "coulomb_viscous_friction", "stribeck_friction"]


def _check_positive(name, value, law):
    """Raise unless ``value`` (a number, an array or a CPU tensor) is > 0.

    ``eps = 0`` divides by zero (NaN at rest), a negative ``eps`` flips the
    friction's sign and ``vs = 0`` is NaN at rest: each would reach the fit as
    a silent NaN or a force that drives the motion. Tensors on an accelerator
    are not checked, which would synchronise every step of a training loop.
    """
    if isinstance(value, bool):
        raise TypeError(f"{name} of {law} must be a positive number; got {value!r}.")
    if isinstance(value, Real):
        ok = value > 0 and np.isfinite(value)
    elif isinstance(value, np.ndarray):
        ok = value.size == 0 or bool(np.all((value > 0) & np.isfinite(value)))
    elif getattr(getattr(value, "device", None), "type", None) == "cpu":
        ok = bool(((value > 0) & value.isfinite()).all())
    else:
        return
    if not ok:
        raise ValueError(
            f"{name} of {law} must be a finite number > 0 (a velocity well below "
            f"the motion's); got {name}={value!r}."
        )


def coulomb_viscous_friction(v, *, xp, Fc, Fv, eps=1e-4):
    """Coulomb and viscous friction: ``Fv v + Fc sign(v)``.

    Parameters
    ----------
    v : ndarray or torch.Tensor
        Velocity.
    xp : module
        The array namespace (``numpy`` or ``torch``).
    Fc : float
        Coulomb (dry) friction force.
    Fv : float
        Viscous coefficient (force per unit velocity).
    eps : float, default=1e-4
        Velocity over which the sign is smoothed (``tanh(v / eps)``), > 0.

    Returns
    -------
    force : ndarray or torch.Tensor
        The friction force, in the direction of ``v``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import coulomb_viscous_friction
    >>> coulomb_viscous_friction(np.array([-1.0, 0.0, 2.0]), xp=np, Fc=20.0, Fv=5.0)
    array([-25.,   0.,  30.])
    """
    _check_positive("eps", eps, "coulomb_viscous_friction")
    return Fv * v + Fc * xp.tanh(v / eps)


def asymmetric_friction(v, *, xp, Fc_pos, Fc_neg, Fv_pos, Fv_neg, eps=1e-4):
    """Coulomb and viscous friction with other coefficients in each direction.

    ``Fv_pos v + Fc_pos`` for ``v > 0`` and ``Fv_neg v - Fc_neg`` for ``v < 0``,
    blended smoothly around ``v = 0`` (a drive whose friction depends on the
    direction of motion, as the EMPS axis's does).

    Parameters
    ----------
    v : ndarray or torch.Tensor
        Velocity.
    xp : module
        The array namespace (``numpy`` or ``torch``).
    Fc_pos, Fc_neg : float
        Coulomb friction in the positive and the negative direction (both
        positive numbers).
    Fv_pos, Fv_neg : float
        Viscous coefficients in each direction.
    eps : float, default=1e-4
        Velocity over which the direction is blended, > 0.

    Returns
    -------
    force : ndarray or torch.Tensor
        The friction force, in the direction of ``v``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import asymmetric_friction
    >>> asymmetric_friction(
    ...     np.array([-1.0, 1.0]), xp=np, Fc_pos=20.0, Fc_neg=25.0,
    ...     Fv_pos=150.0, Fv_neg=220.0,
    ... )
    array([-245.,  170.])
    """
    _check_positive("eps", eps, "asymmetric_friction")
    positive = 0.5 * (1.0 + xp.tanh(v / eps))
    return positive * (Fv_pos * v + Fc_pos) + (1.0 - positive) * (Fv_neg * v - Fc_neg)


def stribeck_friction(v, *, xp, Fc, Fs, vs, Fv, eps=1e-4):
    """Stribeck friction: static friction falling to Coulomb's as the speed grows.

    ``Fv v + (Fc + (Fs - Fc) exp(-(v / vs)^2)) sign(v)``.

    Parameters
    ----------
    v : ndarray or torch.Tensor
        Velocity.
    xp : module
        The array namespace (``numpy`` or ``torch``).
    Fc : float
        Coulomb friction force (at speeds well above ``vs``).
    Fs : float
        Static (breakaway) friction force, at speeds well below ``vs``.
    vs : float
        Stribeck velocity (> 0): the speed over which ``Fs`` falls to ``Fc``.
    Fv : float
        Viscous coefficient.
    eps : float, default=1e-4
        Velocity over which the sign is smoothed, > 0.

    Returns
    -------
    force : ndarray or torch.Tensor
        The friction force, in the direction of ``v``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import stribeck_friction
    >>> f = stribeck_friction(
    ...     np.array([1e-3, 1.0]), xp=np, Fc=20.0, Fs=30.0, vs=0.01, Fv=0.0
    ... )
    >>> np.round(f, 2)
    array([29.9, 20. ])
    """
    _check_positive("eps", eps, "stribeck_friction")
    _check_positive("vs", vs, "stribeck_friction")
    level = Fc + (Fs - Fc) * xp.exp(-((v / vs) ** 2))
    return Fv * v + level * xp.tanh(v / eps)
