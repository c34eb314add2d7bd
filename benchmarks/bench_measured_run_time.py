"""Wall time of a built-in benchmark's run, phase by phase, without its test records.

Runs the benchmark's documented run (seeds 0, 1, 2; two jobs by default)
through :func:`skhybrid.experiments.run_system`, with one change: its test
records are replaced by its own estimation records, so that the run scores
something of the real records' lengths and no test record is read (running it
is not a look; ``benchmarks/LOG.md`` counts the looks). The figures it prints
are times only.

The phases are read from the run folder's files as each was written: the
first seed's search (its last model's record), the further seeds' refits (up
to ``selection.json``), the free runs of the stand-in test records (the last
``test-predictions.npz``), and the report. Run it at two commits (a clean
clone of each, one after the other on a quiet machine) to compare them.

Run: ``python benchmarks/bench_measured_run_time.py friction-damper --data
../shared/data``.
"""

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

from skhybrid.benchmarks import benchmark_spec
from skhybrid.experiments import run_system


def _last_written(paths):
    times = [p.stat().st_mtime for p in paths]
    return max(times) if times else float("nan")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name", help="a built-in measured benchmark")
    parser.add_argument("--data", required=True, help="folder of its files")
    parser.add_argument("--out", default=None, help="run folder (default: temporary)")
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args(argv)

    spec = benchmark_spec(args.name, args.data)
    U, Y = spec.estimation_records()
    stand_ins = {
        f"estimation_{i}": (u, y) for i, (u, y) in enumerate(zip(U, Y, strict=True))
    }
    spec = dataclasses.replace(spec, tests=stand_ins)
    out = Path(args.out or tempfile.mkdtemp(prefix="skhybrid-time-")) / args.name
    start = time.time()
    run_system(spec, out, n_jobs=args.n_jobs, progress=False)
    end = time.time()
    models = out / "models"
    first = _last_written((models / f"{spec.name}-seed-0").glob("*.json"))
    sealed = (out / "selection.json").stat().st_mtime
    scored = _last_written(models.glob("*/test-predictions.npz"))
    print(
        f"{args.name}: {os.cpu_count()} cores, {args.n_jobs} jobs, records "
        f"{[len(u) for u in U]} (also the stand-in tests)"
    )
    for label, a, b in [
        ("first seed's search", start, first),
        ("further seeds' refits and the seal", first, sealed),
        ("free runs of the stand-in tests", sealed, scored),
        ("report", scored, end),
        ("total", start, end),
    ]:
        print(f"  {label:38s} {b - a:8.1f} s")


if __name__ == "__main__":
    main()
