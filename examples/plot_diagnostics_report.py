"""
Residual diagnostics: the report and its Displays
=================================================

Is a model done? Its residual should be white (nothing left to predict from its
own past) and independent of the inputs (nothing left to predict from them).
:func:`skhybrid.diagnostics.diagnose` runs both tests with a verdict at a stated
significance level; the Displays draw the paper's figures: the residual
autocorrelation (Fig. 5), RMSE over windows in dB (Fig. 3) and a trajectory
decomposed into its physics, network and noise parts.

The plant has an input delay of three steps that the linear physics cannot see:
the diagnostics find it, and a network stage that reads a window of four steps
removes it.
"""

import matplotlib.pyplot as plt
import numpy as np

from skhybrid.diagnostics import (
    DecompositionDisplay,
    ResidualACFDisplay,
    RMSEBoxDisplay,
    diagnose,
)
from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.preprocessing import make_windows

rng = np.random.default_rng(0)
n = 3000
u = rng.uniform(-1, 1, (n, 1))
x = np.zeros((n, 1))
for t in range(3, n - 1):
    x[t + 1] = 0.9 * x[t] + 0.5 * u[t] + 0.3 * u[t - 3] + 0.05 * rng.standard_normal()
X, y = make_windows(x, u, n_steps=4)
X_train, y_train, X_test, y_test = X[:2200], y[:2200], X[2200:], y[2200:]

# The linear physics reads the newest step of the window only: it misses the delay.
physics = LinearStateSpaceModel(n_steps=4).fit(X_train, y_train)
hybrid = HybridBoostingRegressor(
    [
        ("physics", LinearStateSpaceModel(n_steps=4)),
        ("dense", DenseRegressor((32,), max_epochs=60, random_state=0)),
    ],
    n_steps=4,
    noise_model="gaussian",
).fit(X_train, y_train)
for name, model in (("physics", physics), ("physics + dense", hybrid)):
    print(name)
    print(diagnose(model, X_test, y_test, inputs=X_test[:, -1:], lags=20))

# %%
# The paper's figures for both models.
fig, axes = plt.subplots(1, 2, figsize=(9, 3.2), sharey=True, layout="constrained")
for ax, (name, model) in zip(
    axes, (("physics", physics), ("hybrid", hybrid)), strict=True
):
    ResidualACFDisplay.from_estimator(model, X_test, y_test, lags=30, ax=ax, name=name)
RMSEBoxDisplay.from_estimator(
    {"physics": physics, "physics + dense": hybrid}, X_test, y_test, window=100
)
DecompositionDisplay.from_estimator(
    hybrid, X_test[:200], y_test[:200], time=np.arange(200)
)
plt.show()
