"""deepSI's SUBNET on the coupled electric drives, by skhybrid's protocol, over seeds.

Issue 24 asks that skhybrid's coupled-drives figure be compared, over seeds,
with deepSI's SUBNET (Beintema et al. 2021) run on the same machine by the same
protocol. This script runs it so:

- each record's estimation part (its first 400 samples) is split as skhybrid
  splits it: the first 75 % (300 samples) fitted, the last 25 % the validation
  tail, which deepSI uses to keep its best iterate (skhybrid's selection uses
  the same tails);
- the settings were chosen on those tails alone (seed 0, 10,000 iterations,
  batches of 256): ``nx=4, na=nb=10, T=30`` simulated the tails at 0.209 / 0.163
  (pooled 0.187), against 0.247 / 0.152 (0.205) for ``nx=8, T=50``; ``na = nb =
  10`` is the protocol's initialisation window;
- the model so chosen is simulated on each test record from its first 10
  measured samples and scored on the rest (the official ``n_init = 10``).

Run ``python benchmarks/compare_subnet_coupled_drives.py --data ../shared/data``
(one process per seed, ``--n-jobs`` at a time; about 4 minutes a seed on one
core). It needs deepSI, which skhybrid does not depend on:
``pip install deepsi==0.4.4 nonlinear-benchmarks progressbar2`` (on top of
skhybrid's own torch). Compare with ``skhybrid run coupled-electric-drives``'s
figure of record, whose sealed selection never saw these numbers.
"""

import argparse
import sys
import time

import numpy as np
from joblib import Parallel, delayed

from skhybrid.datasets import load_coupled_electric_drives

N_FIT = 300  # the first 75 % of each 400-sample estimation record
SETTINGS = {"nx": 4, "na": 10, "nb": 10, "T": 30, "n_its": 10_000, "batch_size": 256}


def run_seed(data, seed, settings):
    """Fit SUBNET at ``seed``; its validation and test RMSE of each record."""
    import deepSI
    import torch
    from nonlinear_benchmarks import Input_output_data

    torch.manual_seed(seed)
    torch.set_num_threads(1)
    d = load_coupled_electric_drives(data)
    dt = d.dt
    n_init = d.n_init

    def io(u, y, init=None):
        return Input_output_data(
            u[:, 0], y[:, 0], sampling_time=dt, state_initialization_window_length=init
        )

    records = [(d.splits[f"train_{i}"], d.splits[f"test_{i}"]) for i in (1, 2)]
    train = [io(tr.u[:N_FIT], tr.y[:N_FIT]) for tr, _ in records]
    # deepSI keeps its best iterate on these tails (with their own init windows).
    val = [
        io(tr.u[N_FIT - n_init :], tr.y[N_FIT - n_init :], n_init) for tr, _ in records
    ]
    nu, ny, norm = deepSI.get_nu_ny_and_auto_norm(train)
    model = deepSI.SUBNET(
        nu, ny, norm, nx=settings["nx"], nb=settings["nb"], na=settings["na"]
    )
    start = time.perf_counter()
    fit = deepSI.fit(
        model,
        train,
        val,
        n_its=settings["n_its"],
        T=settings["T"],
        batch_size=settings["batch_size"],
        val_freq=100,
    )
    seconds = time.perf_counter() - start
    best = fit["best_model"]

    def rmse(split):
        sim = best.simulate(io(split.u, split.y))
        return float(np.sqrt(np.mean((sim.y[n_init:] - split.y[n_init:, 0]) ** 2)))

    val_rmse = [_tail(best, tr, io, n_init) for tr, _ in records]
    test_rmse = [rmse(te) for _, te in records]
    return {"seed": seed, "validation": val_rmse, "test": test_rmse, "seconds": seconds}


def _tail(model, split, io, n_init):
    """Free run over the validation tail from its first ``n_init`` samples."""
    u, y = split.u[N_FIT:], split.y[N_FIT:]
    sim = model.simulate(io(u, y))
    return float(np.sqrt(np.mean((sim.y[n_init:] - y[n_init:, 0]) ** 2)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data", required=True, help="folder holding coupled_electric_drives/"
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args(argv)
    try:
        import deepSI  # noqa: F401
    except ImportError:
        sys.exit(
            "deepSI is not installed: pip install deepsi==0.4.4 nonlinear-benchmarks "
            "progressbar2"
        )
    rows = Parallel(n_jobs=args.n_jobs)(
        delayed(run_seed)(args.data, seed, SETTINGS) for seed in args.seeds
    )
    print(
        f"deepSI SUBNET {SETTINGS}, fitted on the first {N_FIT} samples of each record"
    )
    print("seed  validation 1 / 2        test 1 / 2 [ticks/s]   fit [s]")
    for r in rows:
        v, t = r["validation"], r["test"]
        print(
            f"{r['seed']:>4}  {v[0]:.4f} / {v[1]:.4f}        "
            f"{t[0]:.4f} / {t[1]:.4f}       {r['seconds']:.0f}"
        )
    test = np.array([r["test"] for r in rows])
    print(
        "test, mean ± std over seeds: "
        f"{test[:, 0].mean():.4f} ± {test[:, 0].std(ddof=1):.4f} / "
        f"{test[:, 1].mean():.4f} ± {test[:, 1].std(ddof=1):.4f}"
    )


if __name__ == "__main__":
    main()
