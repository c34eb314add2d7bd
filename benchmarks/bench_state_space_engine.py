"""Time per epoch of the state-space hybrid on the shared engine against a hand loop.

``StateSpaceHybridRegressor`` trains through :func:`skhybrid.neural.engine.
train_module` (skorch: callbacks, history, schedule, early stopping, divergence
check). Until 0.3 it trained in a hand-written Adam loop. This script measures what
the engine costs: the same module, on the same packed sub-sequences (captured from
a ``fit_simulation``), trained for the same epochs by

1. the engine (skorch's net of the fitted model, trained on), and
2. a plain loop of the old kind: Adam, shuffled batches of ``batch_size``
   sub-sequences, one validation pass per epoch (timed the same way),

one epoch of each in turn (so that the load of the machine falls on both alike);
it prints the median epoch time of each and the median ratio of the interleaved
pairs (issue 22: at most 1.1x). The engine's epochs are ``partial_fit`` calls,
each with the callbacks' start and end of training, which a real epoch does not
pay: the ratio is an upper bound.

Data: 8 records of 300 samples of a damped oscillator with a cubic spring whose
physics lacks the cubic term; one state measured; horizon 30, a
sub-sequence every 5 samples.

Run: ``python benchmarks/bench_state_space_engine.py`` (about a minute on 2
cores).
"""

import argparse
import copy
import time

import numpy as np
import torch

import skhybrid.hybrid._state_space as state_space
from skhybrid.domain import StateSpaceModel
from skhybrid.hybrid import StateSpaceHybridRegressor


def oscillator(x, u, *, xp, omega, zeta):
    p, v = x[:, 0], x[:, 1]
    return xp.stack([v, -(omega**2) * p - 2 * zeta * omega * v + u[:, 0]], axis=1)


def truth(x, u, *, xp, omega, zeta):
    out = oscillator(x, u, xp=xp, omega=omega, zeta=zeta)
    return out - xp.stack([0 * x[:, 0], 3.0 * x[:, 0] ** 3], axis=1)


def physics(rhs, omega=2.0):
    return StateSpaceModel(
        rhs,
        {"omega": omega, "zeta": 0.1},
        state_names=["p", "v"],
        observed=["p"],
        dt=0.05,
        n_substeps=2,
        n_init=10,
        max_nfev=10,
    )


def records(n_records, n_times, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n_records, n_times, 1))
    sim = physics(truth, omega=2.2).fit_simulation(u, np.zeros((n_records, n_times, 1)))
    y = sim.simulate_from_state(u, np.zeros((n_records, 2)))
    return u, y + 0.01 * rng.normal(size=y.shape)


def capture(u, y, epochs, batch_size):
    """Fit by the engine; return the model and what it trained on."""
    seen = {}
    original = state_space.train_module

    def spy(est, make_module, X, y_, **kwargs):
        if kwargs.get("sequences"):
            seen["data"] = (X, y_, kwargs.get("valid"))
            seen["module"] = copy.deepcopy(make_module())
        return original(est, make_module, X, y_, **kwargs)

    state_space.train_module = spy
    try:
        model = StateSpaceHybridRegressor(
            physics(oscillator),
            n_init=10,
            horizon=30,
            hidden_layer_sizes=(32, 32),
            max_epochs=epochs,
            patience=None,
            batch_size=batch_size,
            stride=5,
            random_state=0,
        ).fit_simulation(u, y)
    finally:
        state_space.train_module = original
    return model, seen


class HandLoop:
    """The old kind of loop: Adam, shuffled equal batches, a validation pass."""

    def __init__(self, module, data, batch_size, lr):
        self.X, self.y, self.valid = data
        self.module = copy.deepcopy(module).train()
        for p in self.module.parameters():
            p.requires_grad_(True)
        self.optimizer = torch.optim.Adam(self.module.parameters(), lr=lr)
        self.batch = min(batch_size, len(self.X))
        self.rng = np.random.default_rng(0)

    def epoch(self):
        n, batch = len(self.X), self.batch
        perm = self.rng.permutation(n)
        for i in range(max(1, n // batch)):
            idx = torch.as_tensor(perm[i * batch : (i + 1) * batch])
            self.optimizer.zero_grad()
            loss = torch.mean((self.module(self.X[idx]) - self.y[idx]) ** 2)
            loss.backward()
            self.optimizer.step()
        if self.valid is not None:
            with torch.no_grad():
                float(torch.mean((self.module(self.valid[0]) - self.valid[1]) ** 2))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--epochs", type=int, default=8)
    parser.add_argument("--batch-size", type=int, default=32)
    args = parser.parse_args()
    u, y = records(8, 300)
    model, seen = capture(u, y, 2, args.batch_size)
    net = model.net_
    for p in net.module_.parameters():
        p.requires_grad_(True)
    # Go on training the engine's net one epoch at a time (its callbacks, history
    # and early stopping run as in fit; patience lifted so that it keeps going),
    # each epoch interleaved with one of the hand loop on a copy of the module.
    dict(net.callbacks_)["early_stopping"].patience = 10**9
    X, y_, _ = seen["data"]
    hand = HandLoop(seen["module"], seen["data"], args.batch_size, model.lr)
    engine_s, hand_s = [], []
    for epoch in range(args.epochs):
        start = time.perf_counter()
        net.partial_fit(X, y_, epochs=1)
        engine_s.append(time.perf_counter() - start)
        start = time.perf_counter()
        hand.epoch()
        hand_s.append(time.perf_counter() - start)
        print(
            f"epoch {epoch + 1}: engine {engine_s[-1] * 1e3:.0f} ms, hand loop "
            f"{hand_s[-1] * 1e3:.0f} ms ({len(X)} sub-sequences)"
        )
    ratios = np.array(engine_s) / np.array(hand_s)
    print(
        f"median epoch: engine {np.median(engine_s) * 1e3:.0f} ms, hand loop "
        f"{np.median(hand_s) * 1e3:.0f} ms; median ratio of interleaved epochs "
        f"{np.median(ratios):.3f} (range {ratios.min():.3f}-{ratios.max():.3f}; "
        "target <= 1.1)"
    )


if __name__ == "__main__":
    main()
