"""
A measured benchmark: the EMPS axis, fitted and simulated
=========================================================

The EMPS is a prismatic axis of a machine tool (Janot, Gautier and Brunot, 2019):
its input is the motor's voltage reference, its output the measured position.
skhybrid ships no data: point ``SKHYBRID_DATA`` at the folder holding the
benchmark files (``load_emps`` reads ``DATA_EMPS.mat`` and
``DATA_EMPS_PULSES.mat`` in it or in its ``emps/`` subfolder).

The physics is a rigid body with viscous and Coulomb friction and an offset,
``M q'' = gtau u - Fv q' - Fc sign(q') - offset``, written as a two-step difference
equation on the measured positions (the velocity is not measured). Its physical
parameters are fitted one step ahead on the estimation record; the model is then
simulated in free run on the test record from its first measured samples, as the
benchmark's protocol scores it.
"""

import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from skhybrid.datasets import load_emps
from skhybrid.domain import ParametricModel
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import SimulationDisplay

# By default ../shared/data from where you run it (the repository's root: the
# folder beside the repository, where CI keeps it).
default = Path.cwd() / ".." / "shared" / "data"
folder = Path(os.environ.get("SKHYBRID_DATA", default))
try:
    data = load_emps(folder)
except FileNotFoundError as exc:
    data = None
    print(f"The EMPS files are not here ({exc}); set SKHYBRID_DATA to the data folder.")

# %%
# Fit the physics on the estimation record (positions in metres, SI units).
if data is not None:
    train, test = data.splits["train"], data.splits["test"]
    DT, GTAU = data.dt, data.controller["gtau"]

    def rigid_axis(X, *, M, Fv, Fc, offset, xp=np):
        """Next position from the rows [q(t-1), u(t-1), q(t), u(t)]."""
        q_old, q, u = X[:, 0], X[:, 2], X[:, 3]
        v = (q - q_old) / DT
        force = GTAU * u - Fv * v - Fc * xp.tanh(v / 1e-3) - offset
        return (2 * q - q_old + DT**2 * force / M)[:, None]

    layout = WindowLayout(1, 1, 2, state_names=["qm"], input_names=["vir"])
    X, y = layout.make_rows(train.y, train.u)
    start = {"M": 50.0, "Fv": 100.0, "Fc": 10.0, "offset": 0.0}
    physics = ParametricModel(rigid_axis, start, n_steps=2).fit(X, y)
    for name, value in physics.params_.items():
        print(f"{name:>6} = {value:9.3f} +/- {physics.params_std_[name]:.3f}")

# %%
# Simulate the test record in free run from its first ``n_init`` = 20 measured
# positions and score it in millimetres (the benchmark's units).
if data is not None:
    sim = physics.simulate(test.u, test.y[: data.n_init])
    error = sim[data.n_init :] - test.y[data.n_init :]
    print(f"free-run test RMSE: {1e3 * np.sqrt(np.mean(error**2)):.2f} mm")
    disp = SimulationDisplay.from_predictions(
        1e3 * test.y,
        1e3 * sim,
        n_init=data.n_init,
        time=test.t.ravel(),
        output_names=["position qm [mm]"],
        name="rigid-axis physics",
    )
    plt.show()
