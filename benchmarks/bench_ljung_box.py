"""Forward + backward time of the Ljung-Box loss in torch against a plain MSE.

Compares, on the same tensor and in one run:

- ``lb``: :func:`skhybrid.losses.ljung_box` (lag sums by blocked matrix products
  on views of the series, centred afterwards, with a hand-written backward pass;
  ``docs/losses.md``);
- ``fft``: the same statistic through the overlap-save FFT path (the
  implementation before 0.2, still used beyond 256 lags), differentiated by
  autograd;
- ``loop``: the textbook loop over lags, ``sum_t x_t x_{t+k}`` for k = 1..L;
- ``mse``: ``mean(x ** 2)``, the baseline every training loop pays anyway.

The calls are interleaved (mse, lb, fft, loop, mse, ...) and each ratio is the
median over rounds of the per-round ratio, so a load that comes and goes on a
shared machine affects numerator and denominator alike.

Usage::

    python benchmarks/bench_ljung_box.py [--lags 50] [--dtype float32] [--threads 2]

Target (issue 12): at n = 1e6 and 50 lags the statistic costs at most 5x the MSE.
"""

import argparse
import time

import torch

from skhybrid.losses import ljung_box
from skhybrid.losses._ljung_box import _autocovariance, _scaled_by_max
from skhybrid.utils import get_namespace


def loop_ljung_box(x, lags):
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


def lb(x, lags):
    return ljung_box(x, lags)


def fft(x, lags):
    """The statistic through the FFT path, as skhybrid 0.1 computed it."""
    xp = get_namespace(x)
    scaled, _ = _scaled_by_max(x, xp)
    centered = scaled - xp.mean(scaled, axis=0)
    acov = _autocovariance(centered, lags, xp)
    rho = acov[1:] / acov[0]
    n = x.shape[0]
    k = torch.arange(1, lags + 1, dtype=x.dtype)
    weights = n * (n + 2.0) / (n - k)
    return (weights.reshape(-1, *[1] * (x.ndim - 1)) * rho**2).sum()


def time_rounds(fns, x, lags, min_time=1.0, max_rounds=200):
    """Per-round wall times of forward + backward, the functions interleaved."""
    x = x.detach().requires_grad_(True)
    for fn in fns:  # warm-up
        fn(x, lags).backward()
    rounds = []
    start = time.perf_counter()
    while len(rounds) < 5 or (
        time.perf_counter() - start < min_time and len(rounds) < max_rounds
    ):
        times = []
        for fn in fns:
            x.grad = None
            t0 = time.perf_counter()
            fn(x, lags).backward()
            times.append(time.perf_counter() - t0)
        rounds.append(times)
    return rounds


def _median(values):
    values = sorted(values)
    return values[len(values) // 2]


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
        f"{'n':>9} {'mse':>8} {'lb':>8} {'fft':>8} {'loop':>8} "
        f"{'lb/mse':>7} {'fft/mse':>8} {'loop/mse':>10}"
    )
    print(header)
    print("-" * len(header))
    for n in (1_000, 100_000, 1_000_000):
        x = torch.randn(n, generator=gen, dtype=dtype)
        reference = loop_ljung_box(x.double(), args.lags)
        for fn in (lb, fft):
            if not torch.allclose(fn(x.double(), args.lags), reference, rtol=1e-9):
                raise AssertionError(f"{fn.__name__} and the loop differ at n={n}")
        fns = [mse, lb, fft] + ([loop_ljung_box] if n <= 100_000 else [])
        rounds = time_rounds(fns, x, args.lags)
        ms = [1e3 * _median(r[i] for r in rounds) for i in range(len(fns))]
        ratios = [_median(r[i] / r[0] for r in rounds) for i in range(len(fns))]
        if len(fns) < 4:  # the O(n L) loop is too slow to repeat at 1e6
            t0 = time.perf_counter()
            x1 = x.detach().requires_grad_(True)
            loop_ljung_box(x1, args.lags).backward()
            ms.append(1e3 * (time.perf_counter() - t0))
            ratios.append(ms[-1] / ms[0])
        print(
            f"{n:>9} {ms[0]:>8.3f} {ms[1]:>8.3f} {ms[2]:>8.3f} {ms[3]:>8.2f} "
            f"{ratios[1]:>7.2f} {ratios[2]:>8.2f} {ratios[3]:>10.1f}"
        )


if __name__ == "__main__":
    main()
