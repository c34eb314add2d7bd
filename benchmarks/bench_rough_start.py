"""A grey box of the right structure from rough starts, with and without ``starts``.

Issue 24's case: a nonlinear system with a latent state, its physics of exactly
the right structure, fitted by ``fit_simulation`` from a start within a factor
2.2 of the truth, stops with several parameters 2-3x off. Here the system is
the cascaded tanks' own physics (the built-in spec's ``tanks_physics``: a
latent upper tank with Torricelli outflow and overflow, a lower tank read by a
sensor with an offset) at known parameters. It is simulated over a slow
multisine of 1024 samples (4 s apart, as the benchmark's) with white output
noise of 0.02 V, and scored by the free run over a second, noise-free
multisine.

Each of ``--rough`` starts draws the seven free parameters (``k1``-``k4``,
``x1max``, ``kof``, ``y_offset``) log-uniformly within a factor 2.2 of the
truth. From each start it fits:

1. ``fit_simulation`` from the start alone;
2. the same with ``starts=random_starts(model, 8, factor=5)``: eight more
   starts around it, each fitted with 15 evaluations, the fit going on from the
   best.

The same fit started at the truth sets the bar: a fit "reaches the truth" when
its held-out RMSE is within 3x that one's (the latent tank's scale is free, so
the parameters themselves need not return to the truth's). It prints each
start's held-out RMSE and fit time, the count that reach the truth, and the
ratio of the fit times.

Run: ``python benchmarks/bench_rough_start.py`` (about 20 minutes on 2 cores,
``--n-jobs 2``).

Measured (2 cores): started at the truth, held-out 0.0009 V. Alone, 13 of 16
rough starts reach the truth; the others end at 0.0144 / 0.0395 / 0.123 V
(starts 5, 0, 6). With ``starts``, 14 of 16; those three end at 0.0764 /
0.0169 / 0.0010; median fit time 67 s against 47 (1.69x). With
``--only 0,5,6 --starts-nfev none`` (every start fitted to convergence, the
lowest cost kept): 0.1094 / 0.0169 / 0.0010, 6.7x the time. A lower cost on
the fitting record does not always simulate the held-out record better: see
``docs/state_space.md``, "A start in the wrong valley: several starts".
"""

import argparse
import time
import warnings

import numpy as np
from joblib import Parallel, delayed

from skhybrid.benchmarks.cascaded_tanks import physics as tanks_physics
from skhybrid.domain import random_starts

TRUTH = {
    "k1": 0.06,
    "k2": 0.05,
    "k3": 0.045,
    "k4": 0.12,
    "k5": 0.001,
    "k6": 0.001,
    "u0": 0.0,
    "x1max": 9.0,
    "kof": 0.4,
    "y_offset": 1.0,
    "zmax": 10.0,
}
FREE = ("k1", "k2", "k3", "k4", "x1max", "kof", "y_offset")
FIXED = ("dt", "n_sub", "k5", "k6", "u0", "zmax")
DT, N = 4.0, 1024


def multisine(rng, n=N, dt=DT, band=0.0144):
    """A random-phase multisine over ``[0, band]`` Hz, scaled to 0.5-6.5 V."""
    t = np.arange(n) * dt
    lines = np.arange(1, int(band * n * dt) + 1) / (n * dt)
    u = np.sum(
        np.cos(2 * np.pi * lines * t[:, None] + rng.uniform(0, 2 * np.pi, len(lines))),
        axis=1,
    )
    u = (u - u.min()) / np.ptp(u)
    return (0.5 + 6.0 * u)[:, None]


def model(params):
    m = tanks_physics(DT)
    return m.set_params(params={**m.params, **params}, fixed=FIXED)


def records(seed=0):
    rng = np.random.default_rng(seed)
    u_fit, u_held = multisine(rng), multisine(rng)
    truth = model(TRUTH).set_params(fixed=tuple(model(TRUTH).params))
    truth.fit_simulation(u_fit, np.zeros((N, 1)))
    y_fit = truth.simulate_from_state(u_fit, [3.0, 4.0])
    y_held = truth.simulate_from_state(u_held, [3.0, 4.0])
    return u_fit, y_fit + 0.02 * rng.standard_normal(y_fit.shape), u_held, y_held


def rough_start(k):
    rng = np.random.default_rng(100 + k)
    return {
        name: TRUTH[name] * float(np.exp(rng.uniform(-np.log(2.2), np.log(2.2))))
        for name in FREE
    }


def one(k, data, n_starts, factor, starts_nfev=15):
    u_fit, y_fit, u_held, y_held = data
    out = {}
    for label in ("truth",) if k < 0 else ("alone", "starts"):
        m = model(TRUTH if label == "truth" else rough_start(k))
        if label == "starts":
            m.set_params(
                starts=random_starts(m, n_starts, factor=factor, random_state=k),
                starts_nfev=starts_nfev,
            )
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m.fit_simulation(u_fit, y_fit)
        sim = m.simulate(u_held, y_held[: m.n_init])
        rmse = float(np.sqrt(np.mean((sim[m.n_init :] - y_held[m.n_init :]) ** 2)))
        out[label] = (rmse, time.perf_counter() - t0)
    return k, out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rough", type=int, default=16, help="rough starts")
    parser.add_argument("--n-starts", type=int, default=8)
    parser.add_argument("--factor", type=float, default=5.0)
    parser.add_argument(
        "--starts-nfev",
        type=lambda v: None if v == "none" else int(v),
        default=15,
        help="evaluations of each start's short fit; 'none': each to convergence",
    )
    parser.add_argument(
        "--only",
        type=lambda v: [int(k) for k in v.split(",")],
        default=None,
        help="comma-separated rough starts to run (default: all of --rough)",
    )
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args()
    ks = args.only if args.only is not None else list(range(args.rough))
    data = records()
    results = Parallel(n_jobs=args.n_jobs)(
        delayed(one)(k, data, args.n_starts, args.factor, args.starts_nfev)
        for k in [-1, *ks]
    )
    (_, baseline), *results = sorted(results)
    bar = 3 * baseline["truth"][0]
    print(f"started at the truth: held-out RMSE {baseline['truth'][0]:.4f} V")
    head = ("start", "alone: held-out RMSE", "s", "starts: held-out RMSE", "s")
    print("{:>5} {:>21} {:>5} {:>22} {:>5}".format(*head))
    for k, out in results:
        (ra, ta), (rs, ts) = out["alone"], out["starts"]
        print(f"{k:>5} {ra:>21.4f} {ta:>5.0f} {rs:>22.4f} {ts:>5.0f}")
    for label in ("alone", "starts"):
        rmse = np.array([out[label][0] for _, out in results])
        times = np.array([out[label][1] for _, out in results])
        print(
            f"{label}: {np.sum(rmse < bar)} of {len(rmse)} reach the truth "
            f"(held-out RMSE < {bar:.4f} V; worst {rmse.max():.3f}); fit time median "
            f"{np.median(times):.0f} s"
        )
    ratio = np.median([out["starts"][1] / out["alone"][1] for _, out in results])
    print(f"fit time with starts / alone (median over the starts): {ratio:.2f}")


if __name__ == "__main__":
    main()
