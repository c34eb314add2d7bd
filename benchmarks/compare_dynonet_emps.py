"""dynoNet on the EMPS, as published and by skhybrid's protocol, over seeds.

Issue 24's EMPS target is dynoNet's 2.64 mm (Forgione & Piga 2021), quoted as
the free-run RMSE on the benchmark's test record (``DATA_EMPS_PULSES.mat``, the
estimation trajectory plus force pulses that no input measures). The script
that produced it, ``examples/EMPS/EMPS_test.py`` of github.com/forgi86/dynonet,
sets ``dataset_filename = 'DATA_EMPS_PULSES.mat'`` but loads ``'DATA_EMPS.mat'``
(the estimation record, the one it was trained on) at every commit that holds
it, and the paper's EMPS figure is the one that script saves. This script
reruns the published model on both records so that the two can be told apart:

- the model and training of ``EMPS_train.py``: ``G1`` (1 -> 10 channels, second
  order, one step of delay), a static ``tanh`` network ``F1`` (10 -> 5), ``G2``
  (5 -> 1, second order) and an integrator from velocity to position, trained
  on the whole estimation record (24,841 samples, one batch) by Adam at
  ``lr = 1e-4`` for 50,000 iterations on ``10 * mean((y - y_hat) ** 2)``;
  nothing is chosen, so there is no validation part;
- *as published*: the free-run RMSE over every sample of the estimation
  record, the figure ``EMPS_test.py`` prints;
- *skhybrid's protocol*: the free run of the test record, scored on its samples
  after the official ``n_init = 20`` (dynoNet's filters start at rest and its
  position at zero; the measured position is 7.7e-6 m at the first sample).

Run ``python benchmarks/compare_dynonet_emps.py --data ../shared/data`` (one
process per seed, ``--n-jobs`` at a time, about 17 minutes a seed on one core;
``--iterations`` shortens it). It needs dynoNet, which skhybrid does not
depend on: ``pip install --no-deps dynonet==0.1.2`` (on top of skhybrid's own
torch). Compare with ``skhybrid run emps``'s figure of record, whose sealed
selection never saw these numbers.
"""

import argparse
import sys
import time

import numpy as np
from joblib import Parallel, delayed

from skhybrid.datasets import load_emps

SETTINGS = {"iterations": 50_000, "lr": 1e-4}


def dynonet_model():
    """dynoNet's EMPS model of ``EMPS_train.py``: its blocks and its forward map."""
    from dynonet.lti import MimoLinearDynamicalOperator
    from dynonet.static import MimoStaticNonLinearity

    blocks = [
        MimoLinearDynamicalOperator(1, 10, n_b=2, n_a=2, n_k=1),
        MimoStaticNonLinearity(10, 5, activation="tanh"),
        MimoLinearDynamicalOperator(5, 1, n_b=2, n_a=2, n_k=0),
    ]
    return blocks


def simulate(blocks, u, dt):
    """Position of the model driven by ``u`` of shape (1, n, 1), from rest."""
    import torch

    velocity = u
    for block in blocks:
        velocity = block(velocity)
    return torch.cumsum(velocity, dim=1) * dt


def run_seed(data, seed, settings):
    """Train dynoNet at ``seed``; its RMSE [mm] on both records and its time."""
    import torch

    torch.manual_seed(seed)
    torch.set_num_threads(1)
    d = load_emps(data)
    train, test = d.splits["train"], d.splits["test"]

    def tensor(a):
        return torch.tensor(np.asarray(a, dtype=np.float32)[None])

    blocks = dynonet_model()
    params = [p for block in blocks for p in block.parameters()]
    optimizer = torch.optim.Adam(params, lr=settings["lr"])
    u, y = tensor(train.u), tensor(train.y)
    start = time.perf_counter()
    for _ in range(settings["iterations"]):
        optimizer.zero_grad()
        loss = torch.mean((y - simulate(blocks, u, d.dt)) ** 2) * 10
        loss.backward()
        optimizer.step()
    seconds = time.perf_counter() - start
    if not np.isfinite(loss.item()):
        raise RuntimeError(f"dynoNet diverged at seed {seed} (loss {loss.item()})")

    def rmse_mm(split, first):
        with torch.no_grad():
            y_sim = simulate(blocks, tensor(split.u), d.dt).numpy()[0]
        return 1e3 * float(np.sqrt(np.mean((y_sim[first:] - split.y[first:]) ** 2)))

    return {
        "seed": seed,
        "published": rmse_mm(train, 0),
        "test": rmse_mm(test, d.n_init),
        "seconds": seconds,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="folder holding emps/")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument(
        "--iterations", type=int, default=SETTINGS["iterations"], help="Adam steps"
    )
    args = parser.parse_args(argv)
    try:
        import dynonet  # noqa: F401
    except ImportError:
        sys.exit("dynoNet is not installed: pip install --no-deps dynonet==0.1.2")
    settings = {**SETTINGS, "iterations": args.iterations}
    rows = Parallel(n_jobs=args.n_jobs)(
        delayed(run_seed)(args.data, seed, settings) for seed in args.seeds
    )
    print(f"dynoNet's EMPS model {settings}, trained on the whole estimation record")
    print("seed  estimation record (as published)   test record (n_init 20)   fit [s]")
    for r in rows:
        print(
            f"{r['seed']:>4}  {r['published']:>8.2f} mm"
            f"{'':>25}{r['test']:>8.2f} mm{'':>9}{r['seconds']:.0f}"
        )
    published = np.array([r["published"] for r in rows])
    test = np.array([r["test"] for r in rows])
    spread = (lambda a: a.std(ddof=1)) if len(rows) > 1 else (lambda a: 0.0)
    print(
        "mean ± std over seeds: estimation record "
        f"{published.mean():.2f} ± {spread(published):.2f} mm, test record "
        f"{test.mean():.2f} ± {spread(test):.2f} mm"
    )


if __name__ == "__main__":
    main()
