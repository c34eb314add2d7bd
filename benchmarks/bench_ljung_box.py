"""Forward + backward time of the Ljung-Box loss in torch against a plain MSE.

Compares, on the same tensor and in one run:

- ``fft``: :func:`skhybrid.losses.ljung_box` (autocorrelation by FFT, O(n log n));
- ``direct``: the textbook loop over lags, ``sum_t x_t x_{t+k}`` for k = 1..L
  (O(n L));
- ``mse``: ``mean(x ** 2)``, the baseline every training loop pays anyway.

Usage::

    python benchmarks/bench_ljung_box.py [--lags 50] [--dtype float32] [--threads 2]

Target (issue 2): at n = 1e6 the FFT statistic costs at most 3x the MSE.
"""

import argparse
import time

import torch

from skhybrid.losses import ljung_box


def direct_ljung_box(x, lags):
    n = x.shape[0]
    xc = x - x.mean()
    denom = (xc * xc).sum()
    q = x.new_zeros(())
    for k in range(1, lags + 1):
        rho = (xc[:-k] * xc[k:]).sum() / denom
        q = q + rho**2 / (n - k)
    return n * (n + 2) * q


def mse(x, lags):
    return (x * x).mean()


def fft(x, lags):
    return ljung_box(x, lags)


def time_fwd_bwd(fn, x, lags, min_time=0.5, max_repeats=200):
    """Median wall time of forward + backward over repeated calls."""
    x = x.detach().requires_grad_(True)
    fn(x, lags).backward()  # warm-up
    times = []
    start = time.perf_counter()
    while len(times) < 3 or (
        time.perf_counter() - start < min_time and len(times) < max_repeats
    ):
        x.grad = None
        t0 = time.perf_counter()
        fn(x, lags).backward()
        times.append(time.perf_counter() - t0)
    times.sort()
    return times[len(times) // 2]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lags", type=int, default=50)
    parser.add_argument("--dtype", choices=["float32", "float64"], default="float32")
    parser.add_argument("--threads", type=int, default=torch.get_num_threads())
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    dtype = getattr(torch, args.dtype)
    gen = torch.Generator().manual_seed(0)

    print(
        f"torch {torch.__version__}, {args.dtype}, {args.threads} threads, "
        f"L = {args.lags}; forward + backward, median ms"
    )
    header = (
        f"{'n':>9} {'mse':>9} {'fft':>9} {'direct':>9} "
        f"{'fft/mse':>8} {'direct/mse':>10} {'direct/fft':>10}"
    )
    print(header)
    print("-" * len(header))
    for n in (1_000, 100_000, 1_000_000):
        x = torch.randn(n, generator=gen, dtype=dtype)
        check = torch.allclose(
            fft(x.double(), args.lags),
            direct_ljung_box(x.double(), args.lags),
            rtol=1e-6,
        )
        if not check:
            raise AssertionError(f"fft and direct statistics differ at n={n}")
        t_mse = time_fwd_bwd(mse, x, args.lags)
        t_fft = time_fwd_bwd(fft, x, args.lags)
        t_dir = time_fwd_bwd(direct_ljung_box, x, args.lags)
        print(
            f"{n:>9} {1e3 * t_mse:>9.3f} {1e3 * t_fft:>9.3f} {1e3 * t_dir:>9.3f} "
            f"{t_fft / t_mse:>8.2f} {t_dir / t_mse:>10.2f} {t_dir / t_fft:>10.2f}"
        )


if __name__ == "__main__":
    main()
