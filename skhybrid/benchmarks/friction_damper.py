"""A band friction damper with backlash, ARTS-Lab dataset 2.

The records: the harmonic characterisation tests estimate and the two earthquake
displacement profiles test, loaded by
:func:`skhybrid.datasets.load_friction_damper` (or fetched once). There is no
official split or protocol: ``n_init = 50`` (49 ms) and no published figure,
so the linear ARX is the linear reference. The physics: a band brake's dry
friction (Dahl) behind a backlash, the default candidate family.

Run it with ``skhybrid run friction-damper --data DIR``.
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
from skhybrid.datasets import fetch_friction_damper, load_friction_damper
from skhybrid.domain import StateSpaceModel

__all__ = ["band_friction", "band_friction_output", "make_spec", "physics"]

NAME = "friction-damper"
TITLE = "Band friction damper with backlash, ARTS-Lab dataset 2 (measured)"
UNIT = "kip"
SCALE = 1.0

#: No published figure for this protocol.
PUBLISHED = {}

#: Why the spec departs from the default candidate family (the report prints it).
NOTES = (
    "The default family. No official split or protocol: the harmonic tests "
    "estimate, the earthquake profiles test, n_init = 50 (49 ms); no "
    "published figure, so the linear ARX is the linear reference."
)


def band_friction(x, u, *, xp, gap, sigma, Fc, **params):
    """A band brake's dry friction (Dahl) behind a backlash (discrete time).

    The data sheet's device (a banded rotary friction damper driven in
    displacement): the band engages the drum after a gap, so the friction's
    own displacement ``s`` follows the actuator's ``d = u[:, 0]`` only beyond
    ``+-gap`` (a backlash); the friction force ``z`` follows Dahl's model in
    ``s``, ``dz/ds = sigma (1 - sign(ds) z / Fc)``, integrated exactly over
    each step (no step-size limit).
    """
    s, z = x[:, 0], x[:, 1]
    d = u[:, 0]
    s_next = xp.minimum(xp.maximum(s, d - gap), d + gap)
    ds = s_next - s
    target = xp.sign(ds) * Fc
    z_next = target + (z - target) * xp.exp(-sigma * xp.abs(ds) / Fc)
    return xp.stack([s_next, z_next], axis=1)


def band_friction_output(x, *, xp, offset, **params):
    """The load cell: the friction force plus an offset.

    One value per row (a 1-D column), so that an ``offset`` given one value
    per row (the parameter sets of a batched Jacobian) adds row by row.
    """
    return x[:, 1] + offset


def _band_guess(outputs, inputs):
    """The band at the actuator's position, the force at its first measured value."""
    y0 = np.asarray(outputs)[:, 0, 0]
    d0 = np.asarray(inputs)[:, 0, 0]
    return np.column_stack([d0, y0])


def physics(*, max_nfev=40):
    """The friction damper's grey-box :class:`StateSpaceModel` (inches, kip).

    Parameters
    ----------
    max_nfev : int, default=40
        Most residual evaluations of the fit.

    Returns
    -------
    model : StateSpaceModel
        Unfitted; the band's displacement and the friction force are latent
        (the load cell reads the force plus an offset).
    """
    return StateSpaceModel(
        band_friction,
        {"gap": 0.05, "sigma": 50.0, "Fc": 2.0, "offset": 0.0},
        state_names=["band displacement (latent)", "friction force (latent)"],
        output=band_friction_output,
        time="discrete",
        initial_state=_band_guess,
        n_init=50,
        bounds={"gap": (0.0, 0.5), "sigma": (1.0, 1e4), "Fc": (0.01, 20.0)},
        max_nfev=max_nfev,
    )


def make_spec(data=None, *, quick=False):
    """The friction damper's :class:`~skhybrid.experiments.SystemSpec`.

    ``quick`` estimates on the three 1 Hz harmonic tests only.

    %(make_spec_parameters)s
    """
    fetch, load = fetch_friction_damper, load_friction_damper
    d = read_files(fetch, load, data)
    train = [k for k in d.splits if k.startswith("train_")]
    if quick:  # the three 7169-sample tests at 1 Hz
        train = [k for k in train if k.startswith("train_1Hz")]
    tests = {k[len("test_") :]: k for k in d.splits if k.startswith("test_")}
    return measured_spec(
        sys.modules[__name__],
        d,
        records=[pair(d.splits[k]) for k in train],
        tests=partial(test_records, fetch, load, data, tests),
        # The data sheet: dry friction of a band behind a backlash (Dahl).
        physics=physics(max_nfev=40),
    )


make_spec.__doc__ = fill_make_spec_docstring(make_spec.__doc__)
