"""Wall time of a built-in benchmark's physics search, on its estimation records.

Runs the measured family's physics model (or ``--model``, another model of the
family, after the models it requires, whose time is not counted) as a run fits
it at seed 0: every candidate on the four folds of the estimation records (two
jobs by default), the choice refitted on the whole records. No test record is read;
the figures are times, the chosen candidate and each candidate's CV RMSE in
the benchmark's units (to check that a faster engine chooses as before), and
the peak memory of this process and its workers. Run it at two commits (a
clean clone of each, one after the other on a quiet machine) to compare them.
Before ``experiments/`` was laid out by what it does (``2b5f039``), run this
script as it was at ``d73f964`` (``git show
d73f964:benchmarks/bench_physics_search.py``), which runs unchanged at
``cb05695``.

Run: ``python benchmarks/bench_physics_search.py emps --data ../shared/data``;
``--model "state-space hybrid"`` times the hybrid's search.
"""

import argparse
import resource
import tempfile
import time
import warnings

from joblib.externals.loky import get_reusable_executor

from skhybrid.benchmarks import benchmark_spec
from skhybrid.experiments.free_run._family import MeasuredContext, zoo
from skhybrid.experiments.free_run._search import fit_model
from skhybrid.experiments.free_run._system import MeasuredSystem


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name", help="a built-in measured benchmark")
    parser.add_argument("--data", required=True, help="folder of its files")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--model", default="physics", help="a model of the family")
    args = parser.parse_args(argv)

    spec = benchmark_spec(args.name, args.data)
    U, Y = spec.estimation_records()
    system = MeasuredSystem(spec)
    ctx = MeasuredContext(
        system=system,
        U=list(U),
        Y=list(Y),
        n_init=spec.n_init,
        dt=spec.dt,
        quick=False,
        seed=0,
        cache=tempfile.mkdtemp(prefix="skhybrid-physics-"),
        n_jobs=args.n_jobs,
    )
    family, deps = zoo(system), {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in family[args.model].requires:
            fitted = fit_model(name, family[name], ctx, deps)[1]
            # What a run hands a model of what it requires (_runner._dependency).
            deps[name] = {
                "model": fitted["estimator"],
                "validation_fit": fitted.get("extras", {}).get("validation_fit"),
                "fit": fitted,
                "runs": fitted.get("validation_runs"),
            }
        start = time.perf_counter()
        _, out = fit_model(args.model, family[args.model], ctx, deps)
    seconds = time.perf_counter() - start
    selection = out["selection"]
    cv = ", ".join(
        f"{key} {value:.5g}"
        for key, value in selection["validation_rmse_by_candidate"].items()
    )
    print(
        f"{args.name}: {args.model} search and refit {seconds:.1f} s, "
        f"{args.n_jobs} jobs"
    )
    print(f"  chosen {selection['chosen_candidate']}; CV RMSE by candidate: {cv}")
    timing = out.get("timing") or {}
    if timing:
        folds = ", ".join(
            f"{k} {v:.1f} s" for k, v in timing["fold_seconds_by_candidate"].items()
        )
        print(f"  a fold by candidate: {folds}; refit {timing['refit_seconds']:.1f} s")
    get_reusable_executor().shutdown(wait=True)
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    workers = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"  peak memory: this process {own:.0f} MiB, a worker {workers:.0f} MiB")


if __name__ == "__main__":
    main()
