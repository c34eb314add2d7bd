"""Make the figures of docs/diagnostics.md from synthetic data.

Run from the repository root::

    python docs/make_figures_diagnostics.py

It writes docs/images/diagnostics_acf.png, diagnostics_rmse_box.png and
diagnostics_decomposition.png. The data are simulated (no model is trained), so
the script runs in a few seconds.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp
from scipy.signal import lfilter

from skhybrid.diagnostics import (
    DecompositionDisplay,
    ResidualACFDisplay,
    RMSEBoxDisplay,
)

OUT = Path(__file__).resolve().parent / "images"
DT = 0.05


def pendulum(theta0, n, *, g=9.81, length=1.0, damping=0.05, wobble=0.0):
    """Angle and speed of a damped pendulum; ``wobble`` adds a small second mode."""

    def rhs(t, s):
        th, om, ph, ph_dot = s
        acc = -g / length * np.sin(th) - damping * om + wobble * np.sin(ph)
        return [om, acc, ph_dot, -64.0 * np.sin(ph) - 0.2 * ph_dot]

    t = np.arange(n) * DT
    sol = solve_ivp(
        rhs, (0, t[-1]), [theta0, 0.0, 0.6, 0.0], t_eval=t, rtol=1e-9, atol=1e-9
    )
    return t, sol.y[:2].T


def acf_figure(rng):
    """The paper's Fig. 5: residual ACF of three models of a double pendulum."""
    n = 3000
    t = np.arange(n) * DT
    white = 0.05 * rng.standard_normal(n)
    residuals = {
        # The physics model misses the second pendulum: an oscillating residual.
        "physics (MSE)": 0.08 * np.sin(5.0 * t) + lfilter([1], [1, -0.6], white),
        # Boosted by an RNN: most of the oscillation is gone, some colour is left.
        "physics + RNN (MSE)": 0.01 * np.sin(5.0 * t) + lfilter([1], [1, -0.5], white),
        # Boosted by an RNN trained with the Ljung-Box loss: white residuals.
        "physics + RNN (LJB)": white,
    }
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6), sharey=True, layout="constrained")
    for ax, (name, r) in zip(axes, residuals.items(), strict=True):
        ResidualACFDisplay.from_predictions(
            r, np.zeros(n), lags=40, ax=ax, name=name, output_names=["angle"]
        )
    fig.savefig(OUT / "diagnostics_acf.png", dpi=110)
    plt.close(fig)


def rmse_box_figure(rng):
    """The paper's Fig. 3: RMSE in dB over 100-step windows, one box per model."""
    _, states = pendulum(2.0, 5000)
    y = np.column_stack([np.cos(states[:, 0]), np.sin(states[:, 0]), states[:, 1]])
    n = y.shape[0]
    # (error level, how much it wanders from window to window) per fake model
    models = {
        "physics": (0.030, 0.6),
        "linear": (0.080, 0.4),
        "dense": (0.012, 0.5),
        "RNN": (0.008, 0.5),
        "physics+linear": (0.020, 0.7),
        "physics+dense": (0.006, 0.4),
        "physics+RNN": (0.004, 0.3),
        "physics+RNN (LJB)": (0.005, 0.3),
    }
    predictions = {}
    for name, (level, wander) in models.items():
        # A slowly varying error scale: some stretches of the test period are harder.
        drift = np.exp(wander * lfilter([0.02], [1, -0.98], rng.standard_normal(n)) * 5)
        scale = level * np.array([1.0, 1.2, 8.0])  # the speed has larger errors
        predictions[name] = y + scale * drift[:, None] * rng.standard_normal(y.shape)
    disp = RMSEBoxDisplay.from_predictions(
        y, predictions, window=100, output_names=["cos θ", "sin θ", "θ̇"]
    )
    disp.figure_.suptitle("Pendulum, interpolative test set (synthetic errors)")
    disp.figure_.savefig(OUT / "diagnostics_rmse_box.png", dpi=110)
    plt.close(disp.figure_)


def decomposition_figure(rng):
    """A pendulum trajectory split into physics, neural correction and noise."""
    t, true = pendulum(1.2, 400, wobble=4.0)  # a second mode the physics lacks
    _, physics = pendulum(1.2, 400)
    measured = true + rng.normal(0.0, [0.01, 0.03], true.shape)
    # A fake neural stage: it learned most of what physics leaves, not all.
    neural = 0.9 * (true - physics) + 0.002 * rng.standard_normal(true.shape)
    disp = DecompositionDisplay.from_decomposition(
        {"physics": physics, "RNN": neural},
        measured,
        time=t,
        output_names=["angle θ [rad]", "speed θ̇ [rad/s]"],
        name="physics + RNN on a pendulum with an unmodelled second mode",
    )
    disp.figure_.savefig(OUT / "diagnostics_decomposition.png", dpi=110)
    plt.close(disp.figure_)


def main():
    OUT.mkdir(exist_ok=True)
    acf_figure(np.random.default_rng(0))
    rmse_box_figure(np.random.default_rng(1))
    decomposition_figure(np.random.default_rng(2))


if __name__ == "__main__":
    main()
