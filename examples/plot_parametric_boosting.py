"""
Your own physics, boosted by a network
======================================

Write the physics you know as a function of the row and named parameters, fit it
with :class:`skhybrid.domain.ParametricModel`, and let a
:class:`skhybrid.neural.DenseRegressor` learn what it misses from its residual
inside :class:`skhybrid.hybrid.HybridBoostingRegressor`.

The plant is a damped oscillator with a cubic stiffness the physics does not know:
``x'' = -k x - c x' - 0.5 x**3 + u``, sampled at 20 Hz.
"""

import matplotlib.pyplot as plt
import numpy as np

from skhybrid.domain import ParametricModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.preprocessing import WindowLayout

DT = 0.05


def plant(n, seed):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-2, 2, n // 20 + 1), 20)[:n, None]
    x = np.zeros((n, 2))
    for t in range(n - 1):
        pos, vel = x[t]
        acc = -4.0 * pos - 0.4 * vel - 0.5 * pos**3 + u[t, 0]
        x[t + 1] = [pos + DT * vel, vel + DT * acc]
    return x + 0.002 * rng.standard_normal(x.shape), u


def linear_oscillator(X, *, k, c, xp=np):
    """One Euler step of x'' = -k x - c x' + u; a row is [pos, vel, u]."""
    pos, vel, u = X[:, 0], X[:, 1], X[:, 2]
    return xp.stack([pos + DT * vel, vel + DT * (-k * pos - c * vel + u)], axis=1)


layout = WindowLayout(2, 1, state_names=["pos", "vel"], input_names=["u"])
X, y = layout.make_rows(*plant(6000, 0))
X_test, y_test = layout.make_rows(*plant(1500, 1))

physics = ParametricModel(linear_oscillator, {"k": 1.0, "c": 1.0})
hybrid = HybridBoostingRegressor(
    [
        ("physics", physics),
        (
            "dense",
            DenseRegressor(
                (32, 32), max_epochs=40, target_scaling="shared", random_state=0
            ),
        ),
    ]
).fit(X, y)

print("physics parameters:", hybrid.domain_params_, "+/-", hybrid.domain_params_std_)
parts = hybrid.decompose(X_test)
for name in ("physics", "total"):
    pred = parts[name]
    rmse = np.sqrt(np.mean((pred - y_test) ** 2, axis=0))
    print(f"{name:>8} one-step RMSE (pos, vel): {rmse.round(5)}")

# %%
# Free-run simulation of a held-out experiment: the physics alone drifts where
# the cubic stiffness matters; the hybrid follows the plant.
states, inputs = plant(400, 2)
physics_alone = ParametricModel(linear_oscillator, {"k": 1.0, "c": 1.0}).fit(X, y)
fig, ax = plt.subplots(figsize=(8, 3.2), layout="constrained")
ax.plot(states[:, 0], ".", color="0.5", markersize=3, label="measured")
ax.plot(physics_alone.simulate(inputs, states[:1])[:, 0], label="physics alone")
ax.plot(hybrid.simulate(inputs, states[:1])[:, 0], "--", label="physics + dense")
ax.set_xlabel("time step")
ax.set_ylabel("position")
ax.legend()
plt.show()
