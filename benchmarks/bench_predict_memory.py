"""Peak memory of a network's ``predict`` on a million rows, against its arrays.

``predict`` standardises rows chunk by chunk, runs float64 copies of the weights
through ``torch.func.functional_call`` (the network itself is never copied) and
writes into one preallocated output. The target: the resident memory grows by at
most twice the input and output arrays during the call (it grew by 1.1 GiB for a
61 MiB input when every call deep-copied the network and standardised all rows
at once).

Run: ``python benchmarks/bench_predict_memory.py`` (about 10 s on 2 cores; it needs
psutil, which the ``tests`` extra installs with dask).
"""

import os
import threading
import time

import numpy as np
import psutil

from skhybrid.neural import DenseRegressor


def main(n_rows=1_000_000):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(2000, 8))
    model = DenseRegressor((64, 64), max_epochs=1, random_state=0).fit(X, X[:, :2])
    big = rng.normal(size=(n_rows, 8))
    proc = psutil.Process(os.getpid())
    base, peak, done = proc.memory_info().rss, [0], threading.Event()

    def watch():
        while not done.is_set():
            peak[0] = max(peak[0], proc.memory_info().rss)
            time.sleep(0.002)

    thread = threading.Thread(target=watch)
    thread.start()
    start = time.perf_counter()
    out = model.predict(big)
    seconds = time.perf_counter() - start
    done.set()
    thread.join()
    arrays = big.nbytes + out.nbytes
    growth = peak[0] - base
    print(
        f"{n_rows} rows: input {big.nbytes / 2**20:.0f} MiB, output "
        f"{out.nbytes / 2**20:.0f} MiB, predict {seconds:.1f} s"
    )
    print(
        f"peak memory growth {growth / 2**20:.0f} MiB = {growth / arrays:.2f}x "
        "the input and output arrays (target <= 2x)"
    )


if __name__ == "__main__":
    main()
