"""How long an initialisation window must last to start the DC motor's free run.

The true physics of :func:`skhybrid.datasets.make_dc_motor` (five states, with
backlash) in state-space form, only the load angle measured (noise 0.01 rad);
each record's initial state is estimated by least squares from its first
``n_init`` samples (:meth:`StateSpaceModel.estimate_initial_state`) and the model
runs free for 1000 samples. For sample periods of 1 ms and 5 ms and windows of
20 to 200 ms the script prints, over 8 windows (4 records, 2 starts each):

- the free-run RMSE of the load angle over the 1000 samples, in units of the
  noise (median and largest): the estimate from the window, and the true initial
  state (the floor: 1 is the noise alone);
- the free-run RMSE that the initial state's standard error alone predicts
  (median over the windows), ``sqrt(sigma^2 + mean_t g_t^T C g_t)``: ``C =
  sigma^2 (J^T J)^-1`` the covariance of the least-squares estimate, ``J`` the
  window outputs' Jacobian with respect to the initial state at the true state,
  ``g_t`` the sensitivity of the free-run output at ``t`` to the initial state.

Run: ``python benchmarks/bench_initial_state_window.py`` (about 20 minutes on
2 shared cores).
"""

import sys
from pathlib import Path

import numpy as np

from skhybrid.datasets import make_dc_motor
from skhybrid.domain import StateSpaceModel

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "domain"))
from test_state_space import motor_rhs  # the physics with backlash

HORIZON = 1000
STARTS = (50, 150)


def motor(data, dt):
    params = {
        k: v for k, v in data.true_params.items() if k not in ("dt", "max_voltage")
    }

    def guess(outputs, inputs):
        theta = outputs[:, :, 0]
        speed = np.polyfit(np.arange(theta.shape[1]), theta.T, 1)[0] / dt
        zero = np.zeros_like(speed)
        return np.stack([zero, 10 * theta[:, 0], 10 * speed, theta[:, 0], speed], 1)

    model = StateSpaceModel(
        motor_rhs,
        params,
        state_names=data.full_state_names,
        observed=["load_angle"],
        dt=dt,
        n_substeps=max(1, round(dt / 5e-4)),  # 0.5 ms RK4 sub-steps
        initial_state=guess,
        fixed=tuple(params),
    )
    return model.fit_simulation(data.inputs[0][:60], data.states[0][:60, :1])


def sensitivity(model, u, x0, n_times):
    """d y(t) / d x0 (n_times, 5) by central differences."""
    cols = []
    for j in range(len(x0)):
        h = 1e-6 * max(1.0, abs(x0[j]))
        up, down = x0.copy(), x0.copy()
        up[j] += h
        down[j] -= h
        diff = model.simulate_from_state(u[:n_times], up)[:, 0]
        diff = diff - model.simulate_from_state(u[:n_times], down)[:, 0]
        cols.append(diff / (2 * h))
    return np.stack(cols, axis=1)


def window_study(dt, window_ms, seed=1):
    length = max(STARTS) + HORIZON + 1
    data = make_dc_motor(
        n_samples=4 * (length - 1), episode_length=length, dt=dt, random_state=seed
    )
    model = motor(data, dt)
    sigma = float(data.noise[0])
    rows = []
    for ms in window_ms:
        n_init = round(ms * 1e-3 / dt)
        est, true, predicted = [], [], []
        for e in range(4):
            for start in STARTS:
                u = data.inputs[e][start : start + HORIZON]
                y = data.states[e][start : start + HORIZON, :1]
                x_true = data.full_states[e][start]
                x0 = model.estimate_initial_state(u[:n_init], y[:n_init])
                sim = model.simulate_from_state(u, np.ravel(x0))
                est.append(np.sqrt(np.mean((sim[n_init:] - y[n_init:]) ** 2)))
                sim = model.simulate_from_state(u, x_true)
                true.append(np.sqrt(np.mean((sim[n_init:] - y[n_init:]) ** 2)))
                G = sensitivity(model, u, x_true, HORIZON)
                J = G[:n_init]
                C = sigma**2 * np.linalg.pinv(J.T @ J, rcond=1e-12)
                var = np.einsum("ti,ij,tj->t", G[n_init:], C, G[n_init:])
                predicted.append(np.sqrt(sigma**2 + np.mean(np.maximum(var, 0))))
        rows.append(
            (
                dt * 1e3,
                ms,
                n_init,
                np.median(est) / sigma,
                np.max(est) / sigma,
                np.median(true) / sigma,
                np.median(predicted) / sigma,
            )
        )
        dt_ms, _, _, med, worst, floor, pred = rows[-1]
        print(
            f"dt {dt_ms:.0f} ms, window {ms:3d} ms ({n_init:3d} samples): RMSE/noise "
            f"from the window median {med:5.2f} max {worst:5.2f} | true state "
            f"{floor:.2f} | linearised prediction {pred:5.2f}",
            flush=True,
        )
    return rows


def main():
    for dt in (0.001, 0.005):
        window_study(dt, (20, 50, 100, 200))


if __name__ == "__main__":
    main()
