"""Does the state-space hybrid learn what the physics misses? The missing-physics suite.

On each machine of :func:`skhybrid.datasets.make_missing_physics` (a mass on a
spring whose true equations add a hardening spring, Stribeck friction, a
saturating actuator, a dead zone or a second mode to the linear physics a user
writes; position measured with 1 % noise, the velocity latent), three models
are fitted on the same estimation records:

1. the physics alone (``StateSpaceModel.fit_simulation``);
2. the state-space hybrid at its defaults
   (``StateSpaceHybridRegressor(physics, n_init=20, random_state=seed)``, which
   fits the physics itself first: its fit time includes the physics');
3. the true structure fitted by simulation error from its true constants
   (``true_model.fit_simulation``): the reference a hybrid should approach.

Each simulates the two test records from their first 20 measured samples:
``inside`` the training amplitude and ``beyond`` it (1.5 times). The table gives
each model's free-run RMSE, the hybrid's RMSE over the true structure's and
over the physics', and the fit times; a seed draws other records and another
network start. The targets of issue #52: inside the training amplitude, the
hybrid at most 2x the true structure on the median machine and 4x on the
worst, never above its physics; beyond, at most 5x on the median machine; the
hybrid's fit under 2 minutes on 2 cores.

Measured (``--n-jobs 2``, commit ``f7f3e13``, 2 cores, 5 min 37 s; the
results page has the table): the hybrid at its defaults, over the true
structure inside the training amplitude, 1.26x (saturating actuator) to 2.78x
(Stribeck friction) where the physics has every state, 10.5x on the second
mode (where it stays its physics), 2.40x on the median machine; beyond it
8.74x on the median machine; never above its physics inside; fits of 11-75 s.
The defaults' study, one ``--set`` per row, is in the state-space guide ("The
defaults, and what they cost").

Run: ``python benchmarks/bench_missing_physics.py`` (every machine, seeds 0 1
2); ``--machines hardening-spring dead-zone``, ``--seeds 0``, ``--n-samples``,
``--n-records``, ``--n-jobs`` (machines and seeds in parallel: the fit times
are then not those of 2 idle cores); ``--set PARAM=VALUE`` (repeatable) fits
the hybrid with a parameter other than its default, as the defaults' study in
the state-space guide did (the value is read as a Python literal:
``--set horizon=40 --set correction_form='"rhs"'``); ``--restarts N`` fits the
hybrid from N network starts (``random_state`` seed, seed + 1000, ...) and
keeps the one with the lowest validation loss, its fit time theirs together.
"""

import time
import warnings

import numpy as np
from _cli import suite_parser
from joblib import Parallel, delayed
from sklearn.base import clone

from skhybrid.datasets import make_missing_physics
from skhybrid.exceptions import SimulationDivergedError, TrainingDivergedError
from skhybrid.hybrid import StateSpaceHybridRegressor

TARGETS = {"inside_median": 2.0, "inside_worst": 4.0, "beyond_median": 5.0}
FIT_LIMIT_S = 120.0


def free_run_rmse(model, u, y, n_init):
    sim = model.simulate(u, y[:n_init])
    return float(np.sqrt(np.mean((sim[n_init:] - y[n_init:]) ** 2)))


def _best_start(hybrid, restarts, inputs, outputs):
    """Fit ``hybrid`` from ``restarts`` network starts; the lowest validation loss.

    Start ``r`` trains with ``random_state = seed + 1000 * r`` (start 0 is the
    hybrid as given); the one kept has the lowest ``validation_loss_`` (the free
    run on the held-out tails), so no test record chooses it.
    """
    fits = []
    for r in range(restarts):
        model = clone(hybrid).set_params(random_state=hybrid.random_state + 1000 * r)
        model.fit_simulation(inputs, outputs)
        fits.append(model)
    return min(fits, key=lambda m: m.validation_loss_)


def one_run(name, seed, n_records, n_samples, noise, settings=None, restarts=1):
    """Fit the three models on one machine at one seed; their scores and times."""
    data = make_missing_physics(
        name,
        n_records=n_records,
        n_samples=n_samples,
        noise=noise,
        random_state=seed,
    )
    k = data.n_init
    models = {
        "physics": clone(data.physics),
        "hybrid": StateSpaceHybridRegressor(
            clone(data.physics), n_init=k, random_state=seed, **(settings or {})
        ),
        "true": clone(data.true_model),
    }
    row = {"machine": name, "seed": seed, "noise_std": data.noise_std}
    for label, model in models.items():
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                if label == "hybrid" and restarts > 1:
                    model = models[label] = _best_start(
                        model, restarts, data.inputs, data.outputs
                    )
                else:
                    model.fit_simulation(data.inputs, data.outputs)
                diverged = False
            except TrainingDivergedError:  # scores NaN, and is reported
                diverged = True
        row[f"{label}_fit_s"] = time.perf_counter() - t0
        row[f"{label}_warnings"] = sorted(
            {type(w.message).__name__ for w in caught}
            | ({"TrainingDivergedError"} if diverged else set())
        )
        for test, (u, y) in data.tests.items():
            try:
                if diverged:
                    raise SimulationDivergedError
                row[f"{label}_{test}"] = free_run_rmse(model, u, y, k)
            except SimulationDivergedError:  # scores NaN, and is reported
                row[f"{label}_{test}"] = float("nan")
    hybrid = models["hybrid"]
    row["hybrid_epochs"] = getattr(hybrid, "n_epochs_", None)
    row["hybrid_best_epoch"] = getattr(hybrid, "best_epoch_", None)
    row["correction_helped"] = getattr(hybrid, "correction_helped_", None)
    return row


def _spread(values):
    values = np.asarray(values, dtype=float)
    return f"{np.mean(values):.4f} ± {np.std(values):.4f}"


def report(rows, machines):
    """Print the table by machine (mean ± std over seeds) and the targets."""
    seeds = sorted({r["seed"] for r in rows})
    print(
        f"\nmissing-physics suite, seeds {seeds}: free-run RMSE (m) on the test "
        "records, mean ± std over seeds"
    )
    header = (
        f"{'machine':<20} {'test':<7} {'physics':>17} {'hybrid':>17} "
        f"{'true structure':>17} {'hyb/true':>9} {'hyb/phys':>9}"
    )
    print(header)
    ratios = {"inside": {}, "beyond": {}}
    above_physics = []
    for name in machines:
        mine = [r for r in rows if r["machine"] == name]
        for test in ("inside", "beyond"):
            phys = [r[f"physics_{test}"] for r in mine]
            hyb = [r[f"hybrid_{test}"] for r in mine]
            true = [r[f"true_{test}"] for r in mine]
            over_true = np.mean(np.divide(hyb, true))
            over_phys = np.mean(np.divide(hyb, phys))
            ratios[test][name] = over_true
            if test == "inside":
                above_physics += [
                    (name, r["seed"])
                    for r in mine
                    if not r["hybrid_inside"] <= r["physics_inside"]
                ]
            print(
                f"{name:<20} {test:<7} {_spread(phys):>17} {_spread(hyb):>17} "
                f"{_spread(true):>17} {over_true:>9.2f} {over_phys:>9.2f}"
            )
    print(
        f"\n{'machine':<20} {'physics fit (s)':>16} {'hybrid fit (s)':>16} "
        f"{'true fit (s)':>13} {'epochs (best)':>16} {'helped':>8}"
    )
    for name in machines:
        mine = [r for r in rows if r["machine"] == name]
        epochs = ", ".join(
            f"{r['hybrid_epochs']} ({r['hybrid_best_epoch']})" for r in mine
        )
        helped = ", ".join(str(r["correction_helped"])[0] for r in mine)
        print(
            f"{name:<20} {np.mean([r['physics_fit_s'] for r in mine]):>16.1f} "
            f"{np.mean([r['hybrid_fit_s'] for r in mine]):>16.1f} "
            f"{np.mean([r['true_fit_s'] for r in mine]):>13.1f} {epochs:>16} "
            f"{helped:>8}"
        )
    inside = np.array(list(ratios["inside"].values()))
    beyond = np.array(list(ratios["beyond"].values()))
    slowest = max(r["hybrid_fit_s"] for r in rows)
    checks = [
        ("inside, median machine", np.median(inside), TARGETS["inside_median"]),
        ("inside, worst machine", np.max(inside), TARGETS["inside_worst"]),
        ("beyond, median machine", np.median(beyond), TARGETS["beyond_median"]),
    ]
    print("\ntargets (hybrid RMSE / true structure's, mean over seeds):")
    for label, value, limit in checks:
        verdict = "met" if value <= limit else "NOT met"
        print(f"  {label:<24} {value:6.2f}x  (target <= {limit:g}x): {verdict}")
    verdict = "met" if not above_physics else f"NOT met at {above_physics}"
    print(f"  inside, never above its physics: {verdict}")
    verdict = "met" if slowest <= FIT_LIMIT_S else "NOT met"
    print(f"  hybrid fit under {FIT_LIMIT_S:.0f} s: slowest {slowest:.0f} s: {verdict}")


def main():
    parser = suite_parser(__doc__.splitlines()[0])
    parser.add_argument("--n-records", type=int, default=3)
    parser.add_argument("--n-samples", type=int, default=2000)
    parser.add_argument("--noise", type=float, default=0.01)
    parser.add_argument(
        "--restarts",
        type=int,
        default=1,
        metavar="N",
        help="fit the hybrid from N network starts and keep the lowest "
        "validation loss (its fit time is theirs together)",
    )
    args = parser.parse_args()
    settings = dict(args.set)
    if settings:
        print(f"hybrid settings: {settings}", flush=True)
    if args.restarts < 1:
        parser.error(f"--restarts must be >= 1; got {args.restarts}")
    jobs = [(m, s) for m in args.machines for s in args.seeds]
    rows = Parallel(
        n_jobs=args.n_jobs, return_as="generator", verbose=10 if args.n_jobs != 1 else 0
    )(
        delayed(one_run)(
            m, s, args.n_records, args.n_samples, args.noise, settings, args.restarts
        )
        for m, s in jobs
    )
    done = []
    for r in rows:  # each machine and seed as it ends
        print(
            f"{r['machine']} seed {r['seed']}: "
            + ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                for k, v in r.items()
                if k not in ("machine", "seed")
            ),
            flush=True,
        )
        done.append(r)
    report(done, args.machines)


if __name__ == "__main__":
    main()
