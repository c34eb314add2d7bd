"""
Simulate the measured cascaded tanks with grey-box physics
==========================================================

A real benchmark by its official protocol: two water tanks in cascade, the
upper one overflowing, only the lower level measured (Schoukens et al. 2016).
We fit the tanks' physics (Torricelli outflow, overflow of the upper tank, the
sensor's clipping at 10 V; the upper level is a latent state) on the estimation
record by its free-run simulation error, estimate the test's initial state from
its first ``n_init = 50`` measured samples, simulate the rest in free run and
score the RMSE beside the published figures (Champneys et al. 2024).

The data are not shipped: set ``SKHYBRID_DATA`` to the folder holding
``cascaded_tanks/dataBenchmark.mat`` (default: ``../shared/data`` beside the
repository). Run it with::

    python examples/plot_measured_tanks.py

The full model zoo runs with ``skhybrid run cascaded-tanks --data DIR``.
"""

import os
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from sklearn.exceptions import ConvergenceWarning

from skhybrid.benchmarks import PUBLISHED, benchmark_spec
from skhybrid.datasets import load_cascaded_tanks

# By default ../shared/data from where you run it (the repository's root).
default = Path.cwd() / ".." / "shared" / "data"
data_dir = Path(os.environ.get("SKHYBRID_DATA", default))
try:
    data = load_cascaded_tanks(data_dir)
except FileNotFoundError as exc:
    print(f"skipped: the benchmark data is not there ({exc})")
    data = None
    fig, ax = plt.subplots(figsize=(6, 1.5))
    ax.text(0.5, 0.5, "set SKHYBRID_DATA to run this example", ha="center")
    ax.set_axis_off()

if data is not None:
    train, test = data.splits["train"], data.splits["test"]
    n_init = data.n_init
    # The benchmark's spec (the same form a user writes for their own machine)
    # holds its physics.
    spec = benchmark_spec("cascaded-tanks", data_dir)
    physics = spec.make_physics([train.u], [train.y], data.dt).set_params(max_nfev=40)
    # A StateSpaceModel with the upper tank's level latent, fitted by the free-run
    # (simulation) error on the estimation record only. 40 evaluations keep this
    # example quick: the fit stops before it converges, and says so.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        physics.fit_simulation(train.u, train.y)
    for warning in caught:
        print(warning.message)
    sim = physics.simulate(test.u, test.y[:n_init])  # free run from 50 samples
    rmse = np.sqrt(np.mean((sim[n_init:] - test.y[n_init:]) ** 2))
    print(f"free-run test RMSE of the grey-box physics: {rmse:.3f} V")
    for label, (value, source) in PUBLISHED["cascaded-tanks"]["test"].items():
        print(f"  published {label}: {value} V ({source})")

    t = np.arange(len(test.y)) * data.dt
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    top.plot(t, test.y, "k", lw=1, label="measured")
    top.plot(t, sim, label=f"grey-box physics ({rmse:.3f} V)")
    top.axvspan(0, n_init * data.dt, color="0.9", label="initialisation window")
    top.set_ylabel("lower tank level [V]")
    top.legend()
    err = (sim - test.y)[:, 0]
    err[:n_init] = np.nan
    bottom.plot(t, err)
    bottom.set_ylabel("simulation error [V]")
    bottom.set_xlabel("time [s]")
    fig.tight_layout()
    plt.show()
