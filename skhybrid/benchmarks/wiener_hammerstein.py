"""Wiener-Hammerstein: an electronic circuit, SYSID 2009 (Schoukens et al.).

The records: the official estimation and test records at 51.2 kHz, loaded by
:func:`skhybrid.datasets.load_wiener_hammerstein` (or fetched once). The physics
is the data sheet's structure: two linear filters around a static nonlinearity,
a :class:`~skhybrid.domain.WienerHammersteinModel`. The candidates depart from
the default family (see :data:`NOTES`).

Run it with ``skhybrid run wiener-hammerstein --data DIR``.
"""

import sys
from functools import partial

from skhybrid.benchmarks._common import (
    fill_make_spec_docstring,
    measured_spec,
    read_files,
    test_records,
)
from skhybrid.datasets import fetch_wiener_hammerstein, load_wiener_hammerstein
from skhybrid.domain import WienerHammersteinModel

__all__ = ["make_spec"]

NAME = "wiener-hammerstein"
TITLE = "Wiener-Hammerstein electronic circuit, SYSID 2009 (measured)"
UNIT = "mV"
SCALE = 1e3
#: No state-space hybrid: it trains through a StateSpaceModel's equations.
HYBRIDS = False

#: Published free-run test RMSE (mV), ``{test: {label: (rmse, source)}}``.
PUBLISHED = {
    "test": {
        "linear (LTI SS)": (43.4, "Champneys et al. 2024, arXiv:2405.10779"),
        "best recurrent baseline (GRU)": (3.97, "Champneys et al. 2024"),
        "structured WH": (0.28, "Schoukens, Pintelon & Rolain 2014"),
        "state of the art (DT-SUBNET)": (0.241, "Beintema et al. 2021"),
    }
}

#: Why the spec departs from the default candidate family (the report prints it).
NOTES = (
    "The physics is a WienerHammersteinModel: two linear filters around a "
    "spline nonlinearity, started from the best pole/zero splits of the best "
    "linear approximation (6th order) and refined by the free-run error. No "
    "multiple shooting and no state-space hybrid, which needs a "
    "StateSpaceModel physics."
)


def make_spec(data=None, *, quick=False):
    """The Wiener-Hammerstein benchmark's :class:`~skhybrid.experiments.SystemSpec`.

    ``quick`` estimates on the record's first 20,000 samples only.

    %(make_spec_parameters)s
    """
    fetch, load = fetch_wiener_hammerstein, load_wiener_hammerstein
    d = read_files(fetch, load, data)
    train = d.splits["train"]
    n = 20000 if quick else len(train.u)
    return measured_spec(
        sys.modules[__name__],
        d,
        records=[(train.u[:n], train.y[:n])],
        tests=partial(test_records, fetch, load, data, {"test": "test"}),
        # The data sheet: two linear filters around a static nonlinearity,
        # nominal order 6.
        physics=WienerHammersteinModel(order=6),
        segments=(None,),
    )


make_spec.__doc__ = fill_make_spec_docstring(make_spec.__doc__)
