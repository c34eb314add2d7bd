"""Time convex hull membership: skhybrid's in_convex_hull against the baselines.

For each dimension d, 25,000 query points are classified against the convex hull
of 25,000 reference points, both drawn from the same standard normal (queries
are held-out data from the distribution of the training data, the use in
ConvexHullSplit). Methods:

- ``in_convex_hull`` (method="auto": facets up to d=5, Wolfe's nearest-point
  algorithm with certificates above);
- ``in_convex_hull(method="nearest_point")`` where auto picks the facets, so the
  two exact methods are compared on the same points;
- ``scipy.spatial.Delaunay(reference).find_simplex`` (construction included),
  run in a child process and abandoned after ``--delaunay-timeout`` seconds;
- one ``scipy.optimize.linprog`` (HiGHS) feasibility LP per query point. At
  0.1-1 s per point the full 25,000 would take hours, so it runs on the first
  ``--n-lp`` queries and its time is scaled up to 25,000 (marked "est.").

Agreement is the fraction of points on which a baseline gives the same answer
as ``in_convex_hull``; the script exits with status 1 if any disagree.

Run: ``python benchmarks/bench_convex_hull.py`` (about 10 minutes on 2 cores).
"""

import argparse
import multiprocessing as mp
import sys
import time

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import Delaunay

from skhybrid.model_selection import in_convex_hull


def make_data(d, n, seed=0):
    rng = np.random.default_rng(seed + d)
    return rng.standard_normal((n, d)), rng.standard_normal((n, d))


def linprog_inside(q, reference):
    """Baseline: is there w >= 0, sum(w) = 1, reference.T @ w = q?"""
    n = len(reference)
    A_eq = np.vstack([reference.T, np.ones(n)])
    res = linprog(
        np.zeros(n), A_eq=A_eq, b_eq=np.r_[q, 1.0], bounds=(0, None), method="highs"
    )
    return res.status == 0


def _delaunay_child(d, n, conn):
    queries, reference = make_data(d, n)
    start = time.perf_counter()
    inside = Delaunay(reference).find_simplex(queries) >= 0
    conn.send((time.perf_counter() - start, inside))


def run_delaunay(d, n, timeout):
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_delaunay_child, args=(d, n, child))
    proc.start()
    if parent.poll(timeout):
        seconds, inside = parent.recv()
        proc.join()
        return seconds, inside
    proc.terminate()
    proc.join()
    return None, None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dims", type=int, nargs="+", default=[2, 4, 8, 16])
    parser.add_argument("--n", type=int, default=25_000)
    parser.add_argument("--n-lp", type=int, default=100)
    parser.add_argument("--delaunay-timeout", type=float, default=120.0)
    parser.add_argument(
        "--delaunay-max-dim",
        type=int,
        default=8,
        help="skip Delaunay above this dimension (Qhull needs 760 s for the "
        "hull alone at d=8 with 25,000 points)",
    )
    args = parser.parse_args(argv)
    n = args.n
    rows, ok = [], True
    for d in args.dims:
        queries, reference = make_data(d, n)
        start = time.perf_counter()
        inside = in_convex_hull(queries, reference)
        t_auto = time.perf_counter() - start
        row = {"d": d, "inside": inside.mean(), "auto": t_auto}
        if d <= 5:
            start = time.perf_counter()
            np_inside = in_convex_hull(queries, reference, method="nearest_point")
            row["nearest_point"] = time.perf_counter() - start
            row["agree_np"] = np.mean(np_inside == inside)
        if d <= args.delaunay_max_dim:
            t_del, del_inside = run_delaunay(d, n, args.delaunay_timeout)
            row["delaunay"] = t_del
            if del_inside is not None:
                row["agree_delaunay"] = np.mean(del_inside == inside)
        else:
            row["delaunay"] = None
        k = min(args.n_lp, n)
        start = time.perf_counter()
        lp_inside = np.array([linprog_inside(q, reference) for q in queries[:k]])
        row["linprog"] = (time.perf_counter() - start) * n / k
        row["agree_lp"] = np.mean(lp_inside == inside[:k])
        rows.append(row)
        ok &= all(row[key] == 1.0 for key in row if key.startswith("agree"))
        print(f"done d={d}", file=sys.stderr, flush=True)

    def fmt(x, spec="8.2f"):
        return f"{'n/a':>8}" if x is None else format(x, spec)

    print(f"{n} query points vs {n} reference points, N(0, I) in d dimensions")
    print(
        "   d  inside%   auto[s]  nearest_pt[s]  delaunay[s]  linprog[s]  "
        "speedup   agree(np/del/lp)"
    )
    for r in rows:
        delaunay = r.get("delaunay")
        if r["d"] > args.delaunay_max_dim:
            del_txt = f"{'skipped':>11}"
        elif delaunay is None:
            del_txt = f"{'>' + format(args.delaunay_timeout, '.0f'):>11}"
        else:
            del_txt = f"{delaunay:11.2f}"
        agree = "/".join(
            "-" if key not in r else f"{r[key]:.4f}"
            for key in ("agree_np", "agree_delaunay", "agree_lp")
        )
        np_txt = fmt(r["nearest_point"], "13.2f") if "nearest_point" in r else "n/a"
        print(
            f"{r['d']:4d}  {100 * r['inside']:6.1f}  {r['auto']:8.2f}  "
            f"{np_txt:>13}"
            f"  {del_txt}  {r['linprog']:8.0f} est.  {r['linprog'] / r['auto']:7.0f}x"
            f"   {agree}"
        )
    print(
        f"linprog: one HiGHS LP per point, timed on {min(args.n_lp, n)} points and "
        f"scaled to {n} (est.); its agreement is on those points. Delaunay: "
        f"construction + find_simplex, abandoned after {args.delaunay_timeout:.0f} s, "
        f"skipped above d={args.delaunay_max_dim}. speedup = linprog / auto."
    )
    print("all methods agree" if ok else "DISAGREEMENT between methods", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
