"""
Fit the pendulum's physics from noisy transitions
=================================================

The grey-box first step of every hybrid model: fit the physical parameters of a
domain model by least squares and read them with their standard errors.

We simulate one-step transitions of gymnasium's ``Pendulum-v1`` (mass 1 kg, length
1 m), add measurement noise, and fit :class:`skhybrid.domain.PendulumModel` from the
paper's deliberately wrong start (mass 5 kg, length 10 m). Run it with::

    python examples/plot_fit_pendulum.py
"""

import numpy as np

from skhybrid.domain import PendulumModel, pendulum_step

rng = np.random.default_rng(0)
n = 5_000
theta = rng.uniform(-np.pi, np.pi, n)
theta_dot = rng.uniform(-8.0, 8.0, n)
torque = rng.uniform(-1.0, 1.0, n)

# One row per transition: [cos(theta), sin(theta), theta_dot, torque] at time t.
X = np.column_stack([np.cos(theta), np.sin(theta), theta_dot, torque])
# Target: [cos(theta), sin(theta), theta_dot] at t + 1, measured with noise.
y = np.column_stack(pendulum_step(*X.T, mass=1.0, length=1.0, g=10.0, dt=0.05))
y += 0.01 * rng.standard_normal(y.shape)

wrong = PendulumModel(mass=5.0, length=10.0, fixed=("mass", "length")).fit(X, y)
refit = PendulumModel(mass=5.0, length=10.0).fit(X, y)

print("PendulumModel fitted from mass=5, length=10 on", n, "noisy transitions")
for name in ("mass", "length"):
    print(
        f"  {name:<6} = {refit.params_[name]:.4f} +/- {refit.params_std_[name]:.4f}"
        f"   (true 1.0, start {wrong.params_[name]:.1f})"
    )
for label, model in (("frozen wrong physics", wrong), ("refit physics", refit)):
    rmse = np.sqrt(np.mean((model.predict(X) - y) ** 2, axis=0))
    db = ", ".join(f"{v:6.1f}" for v in 20 * np.log10(rmse))
    print(f"  one-step RMSE of the {label:<20}: [{db}] dB (cos, sin, theta_dot)")

# %%
# The fitted parameters with their standard errors, and the one-step error of the
# wrong and the refitted physics on each state.
import matplotlib.pyplot as plt

fig, (ax_p, ax_e) = plt.subplots(1, 2, figsize=(9, 3.4), layout="constrained")
names = ["mass", "length"]
ax_p.errorbar(
    names,
    [refit.params_[k] for k in names],
    yerr=[3 * refit.params_std_[k] for k in names],
    fmt="o",
    capsize=6,
    label="fitted (3 std)",
)
ax_p.axhline(1.0, color="0.5", linestyle=":", label="true")
ax_p.set_title("Physical parameters")
ax_p.legend()
states = ["cos", "sin", "theta_dot"]
for offset, (label, model) in zip(
    (-0.2, 0.2), (("wrong", wrong), ("refit", refit)), strict=True
):
    rmse = np.sqrt(np.mean((model.predict(X) - y) ** 2, axis=0))
    ax_e.bar(np.arange(3) + offset, rmse, width=0.4, label=label)
ax_e.set_yscale("log")
ax_e.set_xticks(range(3), states)
ax_e.set_title("One-step RMSE")
ax_e.legend()
plt.show()
