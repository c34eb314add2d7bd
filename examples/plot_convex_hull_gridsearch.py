"""
Choosing a model for extrapolation: ConvexHullSplit inside GridSearchCV
=======================================================================

An ordinary shuffled split tests a model inside the range of its training data.
:class:`~skhybrid.model_selection.ConvexHullSplit` builds test folds whose points
lie outside the convex hull of the training fold (``kind="extrapolation"``) or
inside it (``kind="interpolation"``), so a grid search can pick the model that
extrapolates. Here a polynomial degree is chosen for data from ``sin(x0) + x1``:
high degrees interpolate well and extrapolate badly.
"""

import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import Ridge
from sklearn.model_selection import GridSearchCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures

from skhybrid.model_selection import ConvexHullSplit

rng = np.random.default_rng(0)
X = rng.uniform(-2, 2, size=(600, 2))
y = np.sin(X[:, 0]) + X[:, 1] + 0.05 * rng.standard_normal(600)

model = make_pipeline(PolynomialFeatures(), Ridge(alpha=1e-3))
grid = {"polynomialfeatures__degree": [1, 2, 3, 4, 5, 6, 7]}
results = {}
for kind in ("interpolation", "extrapolation"):
    cv = ConvexHullSplit(n_splits=5, kind=kind, test_size=0.2, random_state=0)
    search = GridSearchCV(model, grid, cv=cv, scoring="neg_root_mean_squared_error")
    search.fit(X, y)
    results[kind] = -search.cv_results_["mean_test_score"]
    print(f"{kind:>13}: best degree {search.best_params_}")

# %%
# The interpolative score keeps improving with the degree; the extrapolative score
# turns up: the degree that extrapolates best is the smaller one.
fig, ax = plt.subplots(figsize=(6, 3.4), layout="constrained")
for kind, rmse in results.items():
    ax.plot(grid["polynomialfeatures__degree"], rmse, "o-", label=f"{kind} folds")
ax.set_yscale("log")
ax.set_xlabel("polynomial degree")
ax.set_ylabel("test RMSE")
ax.legend()
plt.show()
