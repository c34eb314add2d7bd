"""Make docs/images/convex_hull_split.png (run once: python docs/make_figures_...).

A pendulum-like cloud of (angle, angular velocity) states is split into training,
interpolative and extrapolative sets, as in Fig. 2 of the method paper.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from skhybrid.model_selection import (
    ConvexHullSplitDisplay,
    interpolation_extrapolation_split,
)

rng = np.random.default_rng(0)
t = rng.uniform(0, 2 * np.pi, 600)
amplitude = rng.uniform(0.1, 1.0, 600) ** 0.5
X = np.column_stack([amplitude * np.cos(t), 2 * amplitude * np.sin(t)])
X += 0.03 * rng.standard_normal(X.shape)
parts = interpolation_extrapolation_split(
    X,
    np.arange(len(X)),
    interpolation_size=0.15,
    extrapolation_size=0.2,
    random_state=0,
)
train, interp, extrap = parts[3:]
fig, ax = plt.subplots(figsize=(5, 4.5))
ConvexHullSplitDisplay.from_split(
    X,
    train,
    interp,
    extrap,
    feature_names=("angle [rad]", "angular velocity [rad/s]"),
    ax=ax,
)
ax.set_title("Interpolative and extrapolative test sets")
fig.tight_layout()
out = Path(__file__).resolve().parent / "images" / "convex_hull_split.png"
fig.savefig(out, dpi=110)
