"""Time free-run simulation of 64 trajectories at once against 64 separate calls.

``simulate`` advances every trajectory together: one ``predict`` call per time
step for all of them. The baseline simulates each trajectory on its own (64
calls, each with one ``predict`` per step). Both give the same paths (checked
to 1e-10); the ratio is the speed-up of batching. Target: at least 10x.

Run: ``python benchmarks/bench_simulate.py`` (about a minute on 2 cores).
Torch runs on one CPU thread (``--threads N`` to change it): on a busy 2-core
machine two intra-op threads made a 64-row forward pass of a (64, 64) network
25 times slower (53 ms against 2 ms), which hides the effect being measured.
"""

import argparse
import time

import numpy as np
import torch

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor, RNNRegressor
from skhybrid.preprocessing import WindowLayout

N_TRAJ, N_TIMES = 64, 200


def data(n_states, n_inputs, n_steps, seed=0):
    rng = np.random.default_rng(seed)
    U = rng.uniform(-2, 2, size=(N_TRAJ, N_TIMES, n_inputs))
    X = np.zeros((N_TRAJ, N_TIMES, n_states))
    A = 0.9 * np.linalg.qr(rng.normal(size=(n_states, n_states)))[0]
    for t in range(N_TIMES - 1):
        X[:, t + 1] = X[:, t] @ A.T + 0.1 * np.tanh(U[:, t]).sum(1, keepdims=True)
    rows = WindowLayout(n_states, n_inputs, n_steps).make_rows(list(X), list(U))
    return X, U, rows


def time_it(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    torch.set_num_threads(parser.parse_args().threads)
    cases = [
        ("LinearStateSpaceModel", LinearStateSpaceModel(), 1),
        ("DenseRegressor", DenseRegressor((64, 64), max_epochs=5, random_state=0), 1),
        ("RNNRegressor (n_steps=5)", RNNRegressor(n_steps=5, max_epochs=3), 5),
        (
            "physics+dense booster",
            HybridBoostingRegressor(
                [
                    ("physics", LinearStateSpaceModel()),
                    ("dense", DenseRegressor((32,), max_epochs=5, random_state=0)),
                ]
            ),
            1,
        ),
    ]
    print(
        f"{N_TRAJ} trajectories of {N_TIMES} steps, 2 states, 1 input; "
        f"torch threads: {torch.get_num_threads()}"
    )
    print(f"{'model':<28}{'batched [s]':>12}{'separate [s]':>14}{'ratio':>8}")
    ratios = []
    for name, est, n_steps in cases:
        X, U, (Xr, yr) = data(2, 1, n_steps)
        est.fit(Xr, yr)
        init = X[:, :n_steps]
        t_batch, batch = time_it(lambda est=est, init=init, U=U: est.simulate(U, init))
        t_sep, sep = time_it(
            lambda est=est, init=init, U=U: np.stack(
                [est.simulate(U[i], init[i]) for i in range(N_TRAJ)]
            ),
            repeat=1,
        )
        np.testing.assert_allclose(batch, sep, rtol=1e-10, atol=1e-10)
        ratios.append(t_sep / t_batch)
        print(f"{name:<28}{t_batch:>12.3f}{t_sep:>14.3f}{t_sep / t_batch:>7.1f}x")
    print(f"smallest speed-up: {min(ratios):.1f}x (target >= 10x)")


if __name__ == "__main__":
    main()
