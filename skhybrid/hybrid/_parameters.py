"""Physical parameters as a torch module, kept inside their bounds by construction."""

import math

import numpy as np
import torch
from torch import nn

__all__ = ["BoundedParameters"]


class BoundedParameters(nn.Module):
    """Free physical parameters trained by gradient steps, within their bounds.

    The trained tensor is an unconstrained ``z``; calling the module returns the
    parameters ``theta``:

    - bounded on both sides: ``lower + (upper - lower) * sigmoid(z)`` (a start
      nearer a bound than ``1e-12`` of the span starts that far from it);
    - on one side: ``lower + a * softplus(z)`` (or ``upper - a * softplus(z)``),
      ``a`` the starting gap to the bound over ``log 2``, so ``z = 0`` is the
      start (however small the gap; a start on the bound moves ``1e-8`` off);
    - unbounded: ``theta0 + a * z`` with ``a = |theta0|`` (1 where it is 0), so
      Adam's steps are relative changes.

    Parameters
    ----------
    theta0 : array-like of shape (n_free_values,)
        Starting values (the layout of
        :meth:`~skhybrid.domain.DomainModel.pack_params`).
    lower, upper : array-like of shape (n_free_values,)
        Bounds, infinite where a side is open.
    trainable : bool, default=True
        Whether ``z`` takes gradients; ``False`` holds the parameters.
    """

    def __init__(self, theta0, lower, upper, *, trainable=True):
        super().__init__()
        theta0 = np.asarray(theta0, dtype=float)
        lower = np.asarray(lower, dtype=float)
        upper = np.asarray(upper, dtype=float)
        lo_ok, hi_ok = np.isfinite(lower), np.isfinite(upper)
        both = lo_ok & hi_ok
        lo_only, hi_only = lo_ok & ~hi_ok, hi_ok & ~lo_ok
        lower = np.where(lo_ok, lower, 0.0)
        upper = np.where(hi_ok, upper, 0.0)
        span = np.where(both, upper - lower, 1.0)
        frac = np.clip((theta0 - lower) / span, 1e-12, 1 - 1e-12)
        gap = np.where(lo_only, theta0 - lower, np.where(hi_only, upper - theta0, 0))
        a_side = np.where(gap > 0, gap, 1e-8) / math.log(2.0)
        a_free = np.where(np.abs(theta0) > 0, np.abs(theta0), 1.0)
        z0 = np.where(both, np.log(frac / (1 - frac)), 0.0)
        self.z = nn.Parameter(
            torch.as_tensor(z0, dtype=torch.float64), requires_grad=bool(trainable)
        )
        for name, value in (
            ("lower", lower),
            ("upper", upper),
            ("theta0", theta0),
            ("a_side", a_side),
            ("a_free", a_free),
        ):
            self.register_buffer(name, torch.as_tensor(value, dtype=torch.float64))
        for name, value in (("both", both), ("lo_only", lo_only), ("hi_only", hi_only)):
            self.register_buffer(name, torch.as_tensor(value))

    def forward(self):
        """The free parameters, inside their bounds.

        Returns
        -------
        theta : torch.Tensor of shape (n_free_values,)
            Differentiable in ``z``.
        """
        z = self.z
        both = self.lower + (self.upper - self.lower) * torch.sigmoid(z)
        soft = nn.functional.softplus(z) * self.a_side
        free = self.theta0 + self.a_free * z
        return torch.where(
            self.both,
            both,
            torch.where(
                self.lo_only,
                self.lower + soft,
                torch.where(self.hi_only, self.upper - soft, free),
            ),
        )
