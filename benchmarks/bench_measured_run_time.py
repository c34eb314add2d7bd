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
``test-predictions.npz``), and the report. Then, for the first seed, each
model's search and refit time and a fold's time by candidate (the wall time of
its group where a search fits folds side by side), and the peak memory of this
process and of its workers. Run it at two commits (a clean clone of each, one
after the other on a quiet machine) to compare them.

Run: ``python benchmarks/bench_measured_run_time.py friction-damper --data
../shared/data``; ``--device cuda`` trains the run's networks on a GPU (run it
with and without on one machine to compare them). It runs at commits before
``--device`` existed when the option is left out.
"""

import argparse
import dataclasses
import json
import os
import resource
import tempfile
import time
from pathlib import Path

from joblib.externals.loky import get_reusable_executor

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
    parser.add_argument("--device", choices=["cpu", "cuda"], default=None)
    args = parser.parse_args(argv)

    spec = benchmark_spec(args.name, args.data)
    U, Y = spec.estimation_records()
    stand_ins = {
        f"estimation_{i}": (u, y) for i, (u, y) in enumerate(zip(U, Y, strict=True))
    }
    spec = dataclasses.replace(spec, tests=stand_ins)
    out = Path(args.out or tempfile.mkdtemp(prefix="skhybrid-time-")) / args.name
    start = time.time()
    device = {} if args.device is None else {"device": args.device}
    run_system(spec, out, n_jobs=args.n_jobs, progress=False, **device)
    end = time.time()
    models = out / "models"
    first = _last_written((models / f"{spec.name}-seed-0").glob("*.json"))
    sealed = (out / "selection.json").stat().st_mtime
    scored = _last_written(models.glob("*/test-predictions.npz"))
    print(
        f"{args.name}: {os.cpu_count()} cores, {args.n_jobs} jobs, "
        f"networks on {args.device or 'cpu'}, records "
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
    _print_models(models / f"{spec.name}-seed-0")
    # The workers' peak counts once they have ended.
    get_reusable_executor().shutdown(wait=True)
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    workers = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"  peak memory: this process {own:.0f} MiB, a worker {workers:.0f} MiB")


def _print_models(folder):
    """Each model's search and refit time at the first seed, from its record."""
    print("  first seed, by model:       search    refit   a fold, by candidate")
    for path in sorted(folder.glob("*.json"), key=lambda p: p.stat().st_mtime):
        fit = json.loads(path.read_text()).get("fit", {})
        timing = fit.get("timing") or {}
        refit = float(timing.get("refit_seconds", 0.0))
        search = float(fit.get("fit_time") or 0.0) - refit
        folds = ", ".join(
            f"{key} {seconds:.1f} s"
            for key, seconds in (timing.get("fold_seconds_by_candidate") or {}).items()
        )
        print(f"    {path.stem:24s} {search:8.1f} s {refit:7.1f} s   {folds}")


if __name__ == "__main__":
    main()
