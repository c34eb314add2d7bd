"""The block-structured model on the Wiener-Hammerstein benchmark's estimation record.

Fits :class:`~skhybrid.domain.WienerHammersteinModel` and, as the baseline of the
same run, its best linear approximation on the first ``--fit`` samples of the
official estimation record, and prints each one's free-run RMSE (mV) on the
record's remaining samples (validation data: the test record is never read),
its fit time and the refined splits; the block model is simulated from rest and
from the initial states fitted to the first 50 samples
(``init="least_squares"``). ``--knots`` and ``--nfev`` try other settings.

Run: ``python benchmarks/bench_wiener_hammerstein_block.py --data ../shared/data``.
"""

import argparse
import time
import warnings

import numpy as np

from skhybrid.datasets import load_wiener_hammerstein
from skhybrid.domain import WienerHammersteinModel

N_INIT = 50


def _rmse_mv(model, u, y, **kwargs):
    sim = model.simulate(u, y[:N_INIT], **kwargs)[:, 0]
    return 1e3 * float(np.sqrt(np.mean((sim[N_INIT:] - y[N_INIT:]) ** 2)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="folder of the measured data")
    parser.add_argument("--fit", type=int, default=80000, help="samples fitted on")
    parser.add_argument("--knots", type=int, default=20)
    parser.add_argument("--nfev", type=int, default=200)
    args = parser.parse_args()
    train = load_wiener_hammerstein(args.data).splits["train"]
    u = np.asarray(train.u, dtype=float).reshape(len(train.u), -1)
    y = np.ravel(train.y)
    n = args.fit
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = WienerHammersteinModel(n_knots=args.knots, max_nfev=args.nfev)
        model.fit(u[:n], y[:n])
    seconds = time.perf_counter() - start
    block, linear = _rmse_mv(model, u[n:], y[n:]), _rmse_mv(model.bla_, u[n:], y[n:])
    print(f"fitted on {n} samples, validated on the {len(y) - n} after them")
    print(f"best linear approximation   {linear:8.3f} mV")
    print(f"Wiener-Hammerstein model    {block:8.3f} mV  ({linear / block:.0f}x lower)")
    fitted_start = _rmse_mv(model, u[n:], y[n:], init="least_squares")
    print(f"  started by least squares  {fitted_start:8.3f} mV  (init='least_squares')")
    print(f"fit time {seconds:.0f} s; {model.n_splits_} splits scanned; refined:")
    for split in model.splits_:
        print(
            f"  G1 poles {np.round(split['poles_1'], 3)}, zeros "
            f"{np.round(split['zeros_1'], 3)}: scan {1e3 * split['scan_rmse']:.3f} "
            f"-> {1e3 * split['rmse']:.4f} mV in {split['nfev']} evaluations"
        )
    for w in caught:
        print(f"warning: {w.message}")


if __name__ == "__main__":
    main()
