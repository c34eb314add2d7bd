"""Training overhead of DenseRegressor (skorch) against a plain PyTorch loop.

Both train the same network (``DenseRegressor.make_module``, the paper's 10 x 256
perceptron by default) on the same standardised data, with Adam, the same learning
rate and the same batch size, for the same number of epochs, in the same process.
The wall time per epoch of ``DenseRegressor.fit`` (everything included: input
validation, standardisation, building the skorch net, callbacks, history) is
divided by that of the plain loop. Two settings:

- ``no validation``: ``validation_fraction=0`` against a loop over all rows;
- ``validation 20 %``: the default protocol (LR schedule, early stopping
  bookkeeping, best-weight copies) against a loop that also evaluates the last
  20 % of the rows after each epoch.

Runs are interleaved and repeated; the table reports the best of the repeats
(the usual estimate of a cost without interference from other processes) and,
for reference, the ratio of the medians. Target: a ratio (best of) of
at most 1.10 on CPU.

Usage::

    python benchmarks/bench_training_overhead.py [--n-samples 10000] [--epochs 5]
        [--repeats 5] [--threads 1] [--hidden 256 x 10]
"""

import argparse
import statistics
import sys
import time

import numpy as np
import torch

from skhybrid.neural import DenseRegressor


def plain_loop(est, X, y, epochs, validation_fraction, seed):
    """Train ``est``'s module the textbook way; return seconds per epoch."""
    start = time.perf_counter()
    Xs = (X - X.mean(axis=0)) / X.std(axis=0)
    ys = (y - y.mean()) / y.std()
    Xt = torch.as_tensor(Xs, dtype=torch.float32)
    yt = torch.as_tensor(ys[:, None], dtype=torch.float32)
    n_valid = int(len(X) * validation_fraction)
    stop = len(X) - n_valid
    X_train, y_train, X_valid, y_valid = Xt[:stop], yt[:stop], Xt[stop:], yt[stop:]
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        module = est.make_module(X.shape[1], 1)
        optimizer = torch.optim.Adam(module.parameters(), lr=est.lr)
        loss_fn = torch.nn.MSELoss()
        for _ in range(epochs):
            module.train()
            perm = torch.randperm(stop)
            total = 0.0
            for i in range(0, stop, est.batch_size):
                idx = perm[i : i + est.batch_size]
                optimizer.zero_grad()
                loss = loss_fn(module(X_train[idx]), y_train[idx])
                loss.backward()
                optimizer.step()
                total += loss.item() * len(idx)
            if n_valid:
                module.eval()
                with torch.no_grad():
                    for i in range(0, n_valid, est.batch_size):
                        sl = slice(i, i + est.batch_size)
                        loss_fn(module(X_valid[sl]), y_valid[sl]).item()
    return (time.perf_counter() - start) / epochs


def skorch_fit(est, X, y, epochs):
    start = time.perf_counter()
    est.fit(X, y)
    elapsed = time.perf_counter() - start
    assert est.n_epochs_ == epochs, est.n_epochs_
    return elapsed / epochs


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-samples", type=int, default=10000)
    parser.add_argument("--n-features", type=int, default=8)
    parser.add_argument("--epochs", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--batch-size", type=int, default=512)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument(
        "--hidden", type=int, nargs=2, default=(256, 10), metavar=("WIDTH", "LAYERS")
    )
    args = parser.parse_args(argv)
    if args.threads:
        torch.set_num_threads(args.threads)
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(args.n_samples, args.n_features))
    y = np.sin(3 * X[:, 0]) * X[:, 1] + 0.05 * rng.standard_normal(args.n_samples)
    width, layers = args.hidden

    rows = []
    for label, fraction in [("no validation", 0.0), ("validation 20 %", 0.2)]:
        est = DenseRegressor(
            (width,) * layers,
            batch_size=args.batch_size,
            max_epochs=args.epochs,
            validation_fraction=fraction,
            patience=None,
            random_state=0,
        )
        # warm up: first-call costs (torch's lazy imports, allocator) hit once
        skorch_fit(est.set_params(max_epochs=1), X[:2000], y[:2000], 1)
        est.set_params(max_epochs=args.epochs)
        plain_loop(est, X[:2000], y[:2000], 1, fraction, 0)
        t_skorch, t_plain = [], []
        for r in range(args.repeats):
            t_plain.append(plain_loop(est, X, y, args.epochs, fraction, r))
            t_skorch.append(
                skorch_fit(est.set_params(random_state=r), X, y, args.epochs)
            )
        rows.append(
            (
                label,
                min(t_plain),
                min(t_skorch),
                statistics.median(t_skorch) / statistics.median(t_plain),
            )
        )

    out = sys.stdout
    out.write(
        f"DenseRegressor {width}x{layers}, {args.n_samples} rows x "
        f"{args.n_features} features, batch_size={args.batch_size}, "
        f"{args.epochs} epochs, best of {args.repeats}, "
        f"torch threads={torch.get_num_threads()}\n"
    )
    out.write(
        f"{'setting':<18}{'plain s/epoch':>15}{'skorch s/epoch':>16}{'ratio':>8}"
        f"{'median ratio':>14}\n"
    )
    for label, plain, skorch, median_ratio in rows:
        out.write(
            f"{label:<18}{plain:>15.4f}{skorch:>16.4f}{skorch / plain:>8.3f}"
            f"{median_ratio:>14.3f}\n"
        )
    out.write("target: ratio <= 1.10\n")


if __name__ == "__main__":
    main()
