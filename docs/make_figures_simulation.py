"""Make the figure of docs/simulation.md: a hybrid simulated in free run.

Run from the repository root::

    python docs/make_figures_simulation.py

It fits the paper's deliberately wrong pendulum physics boosted by a small dense
network (with a Gaussian noise model) on simulated pendulum data, simulates a
held-out episode from its first measured state with 100 sample paths, and writes
docs/images/simulation_pendulum.png (about 20 s on 2 cores).
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from skhybrid.datasets import make_pendulum
from skhybrid.domain import PendulumModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.simulation import SimulationDisplay

OUT = Path(__file__).resolve().parent / "images"


def main():
    train = make_pendulum(n_samples=4000, random_state=0)
    test = make_pendulum(n_samples=400, random_state=1)
    model = HybridBoostingRegressor(
        [
            ("physics", PendulumModel(mass=5.0, length=10.0)),
            ("dense", DenseRegressor((64, 64), max_epochs=60, random_state=0)),
        ],
        noise_model="gaussian",
    ).fit(train.X, train.y)
    states, inputs = test.states[0][:100], test.inputs[0][:100]
    disp = SimulationDisplay.from_estimator(
        model,
        inputs,
        states,
        n_init=1,
        return_std=True,
        random_state=0,
        time=test.dt * np.arange(len(states)),
        output_names=test.state_names,
        name="physics+dense",
    )
    disp.figure_.suptitle("Free-run simulation of a held-out pendulum episode")
    disp.figure_.savefig(OUT / "simulation_pendulum.png", dpi=90)
    plt.close(disp.figure_)
    rmse = dict(zip(test.state_names, disp.rmse_.round(4).tolist(), strict=True))
    print("free-run RMSE per state:", rmse)


if __name__ == "__main__":
    main()
