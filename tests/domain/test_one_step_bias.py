"""One-step fits on windows of noisy measured outputs are biased; free-run fits not.

The documented warning of ParametricModel and HybridBoostingRegressor (their
Notes): errors-in-variables. A damped linear oscillator, its position measured
with noise; the one-step fit reads the velocity from two noisy positions, so its
regressors are noisy and the damping lands several standard errors from the
truth, with no warning. The simulation-error fit of the same equations
(StateSpaceModel.fit_simulation, the velocity latent) stays within them.
"""

import warnings

import numpy as np

from skhybrid.domain import ParametricModel, StateSpaceModel

DT = 0.1
TRUTH = {"k": 1.0, "c": 0.4}


def oscillator(x, u, *, xp, k, c):
    p, v = x[:, 0], x[:, 1]
    return xp.stack([p + DT * v, v + DT * (-k * p - c * v + u[:, 0])], axis=1)


def one_step(X, *, k, c, xp=np):
    """The same Euler equations on rows [y(t-1), u(t-1), y(t), u(t)] -> y(t+1)."""
    p_old, u_old, p = X[:, 0], X[:, 1], X[:, 2]
    v_old = (p - p_old) / DT
    v = v_old + DT * (-k * p_old - c * v_old + u_old)
    return (p + DT * v)[:, None]


def test_one_step_damping_is_biased_and_the_free_run_fit_is_not():
    rng = np.random.default_rng(0)
    n = 2000
    u = np.repeat(rng.uniform(-1, 1, n // 20 + 1), 20)[:n]
    x, position = np.zeros(2), np.empty(n)
    for t in range(n):
        position[t] = x[0]
        x = oscillator(x[None], u[t : t + 1, None], xp=np, **TRUTH)[0]
    y = position + 0.01 * rng.standard_normal(n)  # about 1 % of the motion

    X = np.column_stack([y[:-2], u[:-2], y[1:-1], u[1:-1]])
    one = ParametricModel(one_step, {"k": 0.5, "c": 1.0}, n_steps=2).fit(X, y[2:])
    free = StateSpaceModel(
        oscillator,
        {"k": 0.5, "c": 1.0},
        state_names=["position", "velocity"],
        observed=["position"],
        time="discrete",
        n_init=10,
        vectorized=True,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        free.fit_simulation(u[:, None], y[:, None])

    def errors(model):  # distance from the truth in standard errors
        return {
            p: abs(model.params_[p] - TRUTH[p]) / model.params_std_[p] for p in TRUTH
        }

    assert errors(one)["c"] > 4, (one.params_, one.params_std_)
    assert max(errors(free).values()) < 4, (free.params_, free.params_std_)
