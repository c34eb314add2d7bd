"""
Boosting, joint ensemble and cyclic: the three compositions side by side
========================================================================

The paper composes physics and networks in three ways (section 3): boosting (the
network fits the physics' residual, :class:`~skhybrid.hybrid.HybridBoostingRegressor`),
a joint ensemble (physics parameters and network weights trained together,
:class:`~skhybrid.hybrid.HybridEnsembleRegressor`) and the cyclic method (a
boosting stage whose network also learns to reconstruct its input,
:class:`~skhybrid.neural.CyclicRegressor`). Here all three model the paper's
pendulum from its deliberately wrong physics (mass 5 kg, length 10 m), scored on an
interpolative test set (torques in the training range) and an extrapolative one
(twice the range).
"""

import matplotlib.pyplot as plt
import numpy as np

from skhybrid.datasets import make_pendulum
from skhybrid.domain import PendulumModel
from skhybrid.hybrid import HybridBoostingRegressor, HybridEnsembleRegressor
from skhybrid.neural import CyclicRegressor, DenseRegressor

train = make_pendulum(3000, torque_range=(-1.0, 1.0), random_state=0)
tests = {
    "interpolation": make_pendulum(1000, torque_range=(-1.0, 1.0), random_state=1),
    "extrapolation": make_pendulum(1000, torque_range=(-2.0, 2.0), random_state=2),
}
WRONG = ("mass", "length")  # the wrong physics stays wrong: the network must help
net = dict(max_epochs=40, target_scaling="shared", random_state=0)
models = {
    "boosting": HybridBoostingRegressor(
        [
            ("physics", PendulumModel(mass=5.0, length=10.0, fixed=WRONG)),
            ("dense", DenseRegressor((64, 64), **net)),
        ]
    ),
    "joint ensemble": HybridEnsembleRegressor(
        domain=PendulumModel(mass=5.0, length=10.0, fixed=WRONG),
        neural=DenseRegressor((64, 64)),
        max_epochs=40,
        random_state=0,
    ),
    "cyclic": HybridBoostingRegressor(
        [
            ("physics", PendulumModel(mass=5.0, length=10.0, fixed=WRONG)),
            ("cyclic", CyclicRegressor((64, 64), **net)),
        ]
    ),
}
scores = {}
for name, model in models.items():
    model.fit(train.X, train.y)
    scores[name] = []
    for data in tests.values():
        rmse = np.sqrt(np.mean((model.predict(data.X) - data.y) ** 2, axis=0))
        oracle = np.sqrt(np.mean((data.oracle - data.y) ** 2, axis=0))
        scores[name].append(float(np.mean(rmse / oracle)))
    print(f"{name:>15}: RMSE / oracle (interp, extrap) = {np.round(scores[name], 2)}")

# %%
# RMSE relative to the true model's (1 is as good as the true physics can be on
# noisy data), averaged over the three states.
fig, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
for i, (name, values) in enumerate(scores.items()):
    ax.bar(np.arange(2) + 0.27 * (i - 1), values, width=0.27, label=name)
ax.set_xticks(range(2), list(tests))
ax.axhline(1.0, color="0.4", linestyle=":")
ax.set_ylabel("RMSE / oracle RMSE")
ax.legend()
plt.show()
