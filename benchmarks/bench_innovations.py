"""Whiteness earned honestly: a stage reading earlier residuals models coloured noise.

The system (process noise, measured exactly)::

    x(t+1) = 0.8 x(t) + 0.5 u(t) + 0.3 sin(2 x(t)) + w(t)
    w(t)   = 0.8 w(t-1) + e(t),   e ~ N(0, 0.05^2)   (the innovation)

The physics stage knows ``0.8 x + 0.5 u`` (fitted by least squares); the
structured disturbance ``0.3 sin(2 x)`` and the coloured noise ``w`` are left. The
best one-step predictor adds ``0.3 sin(2 x(t)) + 0.8 w(t-1)``, where ``w(t-1)`` is
the physics' residual one step back minus the disturbance there: its residual is
the innovation ``e``, white, with standard deviation 0.05. A booster stage with
``stage_input="window+prediction+residuals"`` reads the physics' residuals on the
window's older steps, the innovations form of a prediction-error method.

Compared on held-out episodes, one seed per row (``--seeds``): the stage without
residual inputs (``"window+prediction"``) and with them, each trained on
``"mse"`` and as the zoo's Ljung-Box stage (``lb``: ``"mse+ljung_box"``, segments
of 32 rows, weight 0.1, ``mse_pretraining``); and the Ljung-Box stage of before
(contiguous blocks, weight 1, from scratch). Printed: the residual's standard
deviation over the innovation's, and the Ljung-Box statistic and p-value at 20
lags.

Run: ``python benchmarks/bench_innovations.py [--seeds 0 1 2]`` (about a minute per
seed on 2 cores).
"""

import argparse

import numpy as np

from skhybrid.diagnostics import ljung_box_test
from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor
from skhybrid.preprocessing import make_windows

INNOVATION_STD = 0.05
N_STEPS = 3


def simulate(n_episodes, length, rng):
    """States and inputs of episodes of the system above."""
    states, inputs = [], []
    for _ in range(n_episodes):
        u = np.repeat(rng.uniform(-1, 1, length // 5 + 1), 5)[:length]
        x, w = np.zeros(length), 0.0
        for t in range(length - 1):
            w = 0.8 * w + INNOVATION_STD * rng.standard_normal()
            x[t + 1] = 0.8 * x[t] + 0.5 * u[t] + 0.3 * np.sin(2 * x[t]) + w
        states.append(x[:, None])
        inputs.append(u[:, None])
    return states, inputs


def make_data(seed):
    rng = np.random.default_rng(seed)
    train = make_windows(*simulate(8, 1000, rng), n_steps=N_STEPS)
    test = make_windows(*simulate(4, 1000, rng), n_steps=N_STEPS)
    return train, test


#: The Ljung-Box stage's settings: those of the zoo's ``physics+rnn (ljung-box)``
#: stage (segments of 32 rows, weight 0.1, trained on the MSE first), taken as
#: they are, not tuned on this problem.
LJUNG_BOX = {
    "objective": "mse+ljung_box",
    "ljung_box_segment_length": 32,
    "ljung_box_weight": 0.1,
    "mse_pretraining": True,
}


def booster(stage_input, params, seed):
    return HybridBoostingRegressor(
        [
            ("physics", LinearStateSpaceModel(n_steps=N_STEPS)),
            (
                "nn",
                DenseRegressor(
                    (32, 32),
                    max_epochs=150,
                    batch_size=256,
                    random_state=seed,
                    **params,
                ),
            ),
        ],
        stage_input=stage_input,
        n_steps=N_STEPS,
        random_state=seed,
    )


VARIANTS = {
    "physics alone": None,
    "window+prediction, mse": ("window+prediction", {"objective": "mse"}),
    "window+prediction, lb": ("window+prediction", LJUNG_BOX),
    "+residuals, mse": ("window+prediction+residuals", {"objective": "mse"}),
    "+residuals, lb": ("window+prediction+residuals", LJUNG_BOX),
    "+residuals, lb w=1 (old)": (
        "window+prediction+residuals",
        {"objective": "mse+ljung_box"},
    ),
}


def run(seed):
    (X, y), (X_test, y_test) = make_data(seed)
    rows = {}
    for name, spec in VARIANTS.items():
        if spec is None:
            model = LinearStateSpaceModel(n_steps=N_STEPS).fit(X, y)
            pred = model.predict(X_test)
        else:
            model = booster(*spec, seed).fit(X, y)
            pred = model.predict(X_test)
        residual = (y_test - pred).ravel()
        test = ljung_box_test(residual, lags=20)
        rows[name] = (
            residual.std() / INNOVATION_STD,
            float(test.statistic[0]),
            float(test.pvalue[0]),
        )
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    args = parser.parse_args(argv)
    print(f"{'seed':<5}{'model':<28}{'std / innovation':>17}{'Q(20)':>9}{'p':>9}")
    for seed in args.seeds:
        for name, (ratio, q, p) in run(seed).items():
            print(f"{seed:<5}{name:<28}{ratio:>17.3f}{q:>9.1f}{p:>9.3f}")


if __name__ == "__main__":
    main()
