"""
The stochastic model: prediction bands and sample paths
=======================================================

What the physics and the networks leave is modelled as noise (the third term of
the paper's Eq. 1). With ``noise_model="ar"`` a hybrid fits an autoregressive model
to its final residual: ``predict(X, return_std=True)`` gives the one-step
standard deviation, ``sample`` draws outputs with coloured noise, and
``simulate(..., return_std=True)`` gives the band of free-run sample paths, which
widens with the horizon.
"""

import matplotlib.pyplot as plt
import numpy as np

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.preprocessing import WindowLayout

rng = np.random.default_rng(0)


def plant(n):
    u = rng.uniform(-1, 1, (n, 1))
    e = np.zeros(n)
    x = np.zeros((n, 1))
    for t in range(n - 1):
        e[t + 1] = 0.7 * e[t] + 0.05 * rng.standard_normal()  # coloured noise
        x[t + 1] = 0.9 * x[t] + 0.3 * u[t] + e[t + 1]
    return x, u


layout = WindowLayout(1, 1)
X, y = layout.make_rows(*plant(3000))
model = HybridBoostingRegressor(
    [("physics", LinearStateSpaceModel())], noise_model="ar"
).fit(X, y)
mean, std = model.predict(X[:5], return_std=True)
print("noise std:", np.round(std[:, 0], 4), "(stationary; the true one is 0.070)")
draws = model.sample(X[:200], random_state=0)

# %%
# Free run of a new experiment from one measured state: the mean simulation, a
# band of two standard deviations over 200 sample paths, and three of the paths.
states, inputs = plant(150)
paths = model.simulate(inputs, states[:1], n_samples=200, random_state=1)
mean, std = paths.mean(axis=0)[:, 0], paths.std(axis=0)[:, 0]
fig, ax = plt.subplots(figsize=(8, 3.4), layout="constrained")
ax.fill_between(
    np.arange(150), mean - 2 * std, mean + 2 * std, alpha=0.2, label="2 std over paths"
)
ax.plot(paths[:3, :, 0].T, linewidth=0.8, color="C1")
ax.plot(mean, color="C0", label="mean")
ax.plot(states[:, 0], ".", color="0.4", markersize=3, label="measured")
ax.set_xlabel("time step")
ax.legend(loc="upper right")
plt.show()
