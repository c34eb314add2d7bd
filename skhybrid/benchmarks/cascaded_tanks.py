"""Cascaded tanks with overflow: two tanks, a pump, and the lower tank's level.

The records: the official estimation and test records of Schoukens & Noël's
benchmark (1024 samples each at 4 s), loaded by
:func:`skhybrid.datasets.load_cascaded_tanks` (or fetched once). The physics: two
tanks with Torricelli outflow that both overflow, the upper tank's level latent,
the pump's inflow affine in its voltage. The candidates depart from the default
family (see :data:`NOTES`), and the test records are also scored under the
original protocol of the published grey-box figures.

Run it with ``skhybrid run cascaded-tanks --data DIR``.
"""

import sys
from functools import partial

import numpy as np

from skhybrid.benchmarks._common import (
    fill_make_spec_docstring,
    measured_spec,
    pair,
    read_files,
    test_records,
)
from skhybrid.datasets import fetch_cascaded_tanks, load_cascaded_tanks
from skhybrid.domain import StateSpaceModel
from skhybrid.experiments import hybrid_settings

__all__ = ["make_spec", "physics", "tanks", "tanks_output"]

NAME = "cascaded-tanks"
TITLE = "Cascaded tanks with overflow (measured)"
UNIT = "V"
SCALE = 1.0
#: Published free-run test RMSE (V), ``{test: {label: (rmse, source)}}``.
#: Champneys et al. scored with the nonlinear-benchmarks loader of 2024, whose
#: initialisation window was 5 samples (versions 0.1.0 to 1.0.0); version 1.0.1
#: (2025-10-20) made it the 50 used here. CT-SUBNET's figure: its own protocol.
PUBLISHED = {
    "test": {
        "linear (LTI SS; n_init = 5)": (
            0.588,
            "Champneys et al. 2024, arXiv:2405.10779",
        ),
        "best baseline (GRU; n_init = 5)": (
            0.396,
            "Champneys et al. 2024, arXiv:2405.10779",
        ),
        "CT-SUBNET (its own protocol)": (0.306, "Beintema et al., ICLR 2023"),
    },
    # All 1024 samples, the initial state the estimation record's.
    "test_original_protocol": {
        "grey-box with overflow": (0.191, "Worden et al. 2018"),
        "state of the art (grey-box)": (0.18, "Rogers et al. 2017"),
    },
}

#: Why the spec departs from the default candidate family (the report prints it).
NOTES = (
    "Own candidates: whole-record physics fits only (one record of 1024 "
    "samples); one state-space hybrid, T = 200 on the uncut record with a "
    "sub-sequence every 4 samples (the family's T = 46 on four pieces trained "
    "worse than physics + dense on the validation tail)."
)


def tanks(
    x, u, *, xp, k1, k2, k3, k4, k5, k6, u0, x1max, kof, y_offset, zmax, dt, n_sub
):
    """Two tanks with Torricelli outflow, both overflowing (discrete).

    ``x1' = -k1 sqrt(x1) - k5 x1 + k4 (u - u0)`` (upper tank, latent; it
    overflows at ``x1max`` and a share ``kof`` of the overflow reaches the lower
    tank) and ``z' = k2 sqrt(x1) + k5 x1 - k3 sqrt(z - y_offset) - k6 (z -
    y_offset)``, ``z`` the lower tank's level in sensor volts (its level plus
    the sensor's offset ``y_offset``), which overflows at ``zmax``: the level
    saturates there and the water above it is lost (a saturating state, not
    only a clipped output). The pump's net inflow is affine in its voltage,
    zero at ``u0`` and negative below it. Explicit Euler with ``n_sub``
    sub-steps per sample of ``dt`` seconds.
    """
    x1, z = x[:, 0], x[:, 1]
    h = dt / n_sub
    inflow = k4 * (u[:, 0] - u0)
    for _ in range(int(n_sub)):
        s1 = _sqrt_positive(x1, xp)
        x2 = z - y_offset
        s2 = _sqrt_positive(x2, xp)
        x1_next = x1 + h * (-k1 * s1 - k5 * x1 + inflow)
        overflow = xp.maximum(x1_next - x1max, 0.0 * x1)
        z = z + h * (k2 * s1 + k5 * x1 - k3 * s2 - k6 * x2) + kof * overflow
        z = xp.minimum(z, zmax + 0.0 * z)
        x1 = x1_next - overflow
    return xp.stack([x1, z], axis=1)


def _sqrt_positive(v, xp):
    """``sqrt(max(v, 0))`` whose gradient is finite (zero) where ``v <= 0``.

    The square root's derivative is infinite at zero, and the chain rule
    through ``maximum`` multiplies it by zero, which autograd evaluates as NaN:
    a level at or below its outlet made a state-space hybrid's training
    diverge. The 1e-12 moves the value by at most 1e-6 V.
    """
    return xp.sqrt(xp.maximum(v, 0.0 * v) + 1e-12)


def tanks_output(x, *, xp, **params):
    """The lower tank's sensor, which saturates at 10 V."""
    return xp.minimum(x[:, 1:2], 10.0 + 0.0 * x[:, 1:2])


def _tanks_guess(outputs, inputs):
    """Upper tank mid-range, lower tank at its first measured value."""
    y0 = np.asarray(outputs)[:, 0, 0]
    return np.column_stack([np.full_like(y0, 5.0), y0])


def physics(dt, *, max_nfev=400):
    """The cascaded tanks' grey-box :class:`StateSpaceModel` (level units: volts).

    Parameters
    ----------
    dt : float
        Sample period (s), ``data.dt``.
    max_nfev : int, default=400
        Most residual evaluations of the fit (it converges in 107-120 on the
        estimation record's first 75 %, depending on the BLAS kernel, to the
        same minimum; stopped short, a fit ends where the kernel's rounding
        leads it).

    Returns
    -------
    model : StateSpaceModel
        Unfitted; ``fixed`` holds ``dt`` and the sub-steps.
    """
    return StateSpaceModel(
        tanks,
        {
            "k1": 0.05,
            "k2": 0.05,
            "k3": 0.05,
            "k4": 0.03,
            "k5": 0.001,
            "k6": 0.001,
            "u0": 0.0,
            "x1max": 6.0,
            "kof": 0.3,
            "y_offset": 0.5,
            "zmax": 10.0,
            "dt": float(dt),
            "n_sub": 4.0,
        },
        state_names=["upper level (latent)", "lower level"],
        output=tanks_output,
        time="discrete",
        initial_state=_tanks_guess,
        n_init=50,
        fixed=("dt", "n_sub"),
        bounds={
            "k1": (1e-4, 1),
            "k2": (1e-4, 1),
            "k3": (1e-4, 1),
            "k4": (1e-4, 1),
            "k5": (0.0, 1.0),
            "k6": (0.0, 1.0),
            "u0": (-5.0, 5.0),
            "x1max": (1.0, 100.0),
            "kof": (0.0, 1.0),
            "y_offset": (-3.0, 6.0),
            "zmax": (8.0, 12.0),
        },
        max_nfev=max_nfev,
        vectorized=True,
    )


def make_spec(data=None, *, quick=False):
    """The cascaded tanks' :class:`~skhybrid.experiments.SystemSpec`.

    ``quick`` changes nothing: the records are short already.

    %(make_spec_parameters)s
    """
    d = read_files(fetch_cascaded_tanks, load_cascaded_tanks, data)
    tests = {"test": "test"}
    return measured_spec(
        sys.modules[__name__],
        d,
        records=[pair(d.splits["train"])],
        tests=partial(
            test_records, fetch_cascaded_tanks, load_cascaded_tanks, data, tests
        ),
        # Level units are volts of the lower sensor; the upper tank is latent.
        # Run to convergence: the pump's inflow is affine in its voltage (u0
        # free), chosen on the validation tail.
        physics=physics(d.dt),
        segments=(None,),
        hybrids={"T=200, (64, 64)": hybrid_settings(200, (64, 64), stride=4)},
        hybrid_records=1,
        # The original protocol too: all 1024 samples, from the state of the
        # estimation record's start (the published grey-box figures' protocol).
        score_from_estimation_start=True,
    )


make_spec.__doc__ = fill_make_spec_docstring(make_spec.__doc__)
