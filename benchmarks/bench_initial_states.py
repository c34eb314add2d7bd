"""The one initial-state solver against scipy's least_squares, one call per window.

:func:`skhybrid.simulation.fit_initial_states` runs one Levenberg-Marquardt
iteration per trajectory with the model evaluations of all trajectories batched;
:func:`scipy.optimize.least_squares` (``method="lm"``, MINPACK) solves the same
problems one window at a time. A lightly damped oscillator with its speed latent,
64 windows of 20 samples: the script prints both times and the largest difference
of the estimates.

Run: ``python benchmarks/bench_initial_states.py`` (a few seconds).
"""

import time

import numpy as np
from scipy.optimize import least_squares

from skhybrid.domain import StateSpaceModel

N_WINDOWS, N_INIT = 64, 20


def oscillator(x, u, *, xp, a, b):
    return xp.stack([x[:, 1], -a * x[:, 0] - b * x[:, 1] + u[:, 0]], axis=1)


def main():
    rng = np.random.default_rng(0)
    U = rng.normal(size=(N_WINDOWS, 40, 1))
    model = StateSpaceModel(
        oscillator,
        {"a": 4.0, "b": 0.5},
        state_names=["position", "speed"],
        observed=["position"],
        dt=0.05,
        fixed=("a", "b"),
    ).fit_simulation(U[:, :30], np.zeros((N_WINDOWS, 30, 1)))
    x0 = rng.normal(size=(N_WINDOWS, 2))
    Y = np.stack([model.simulate_from_state(U[i], x0[i]) for i in range(N_WINDOWS)])
    Y = Y + 0.01 * rng.normal(size=Y.shape)
    Uw, Yw = U[:, :N_INIT], Y[:, :N_INIT]

    start = time.perf_counter()
    batched = model.estimate_initial_state(Uw, Yw)
    t_batched = time.perf_counter() - start

    def one(i):
        def residuals(z):
            return (model.simulate_from_state(Uw[i], z) - Yw[i]).ravel()

        guess = np.r_[Yw[i, 0, 0], 0.0]
        return least_squares(residuals, guess, method="lm", x_scale="jac").x

    start = time.perf_counter()
    separate = np.stack([one(i) for i in range(N_WINDOWS)])
    t_scipy = time.perf_counter() - start
    print(
        f"{N_WINDOWS} windows of {N_INIT} samples: fit_initial_states "
        f"{t_batched:.3f} s, scipy least_squares per window {t_scipy:.3f} s "
        f"({t_scipy / t_batched:.0f}x); largest difference of the estimates "
        f"{np.abs(separate - batched).max():.1e}"
    )


if __name__ == "__main__":
    main()
