"""A horizon curriculum for the state-space hybrid, on the missing-physics suite.

A study, not an API: the hybrid has no curriculum option. This script trains
:class:`~skhybrid.hybrid.StateSpaceHybridRegressor` at its defaults (stage 1,
``horizon=20``), then trains the kept networks and physical parameters again on
sub-sequences of ``--h2`` steps (stage 2: a sub-sequence every ``h2 // 4``
samples, ``--lr2``, at most ``--epochs2`` epochs, patience ``--patience2``, no
encoder pre-training), keeping stage 2's best epoch on the validation tails
with stage 1's weights as a candidate; so stage 2 never ends worse than stage
1 on validation. It reaches the second stage through the estimator's private
``_fit_simulation`` and ``_train``, which may change without notice.

It prints, per machine and seed, the validation loss after each stage and the
free-run RMSE over the true structure's on the two test records (as
``bench_missing_physics.py``), then the median and worst machine. The state-space
guide's study ("The defaults, and what they cost") quotes its figures.

Run: ``python benchmarks/study_horizon_curriculum.py --n-jobs 2`` (every
machine, seeds 0 1 2; ``--machines``, ``--seeds``, ``--set PARAM=VALUE`` for
stage 1's settings, as in ``bench_missing_physics.py``).
"""

import time
import warnings

import numpy as np
from _cli import suite_parser
from bench_missing_physics import free_run_rmse
from joblib import Parallel, delayed
from sklearn.base import clone

from skhybrid.datasets import make_missing_physics
from skhybrid.hybrid import StateSpaceHybridRegressor
from skhybrid.simulation import check_trajectories


class CurriculumHybrid(StateSpaceHybridRegressor):
    """The hybrid, trained again on ``h2`` steps after its own training."""

    def _fit_simulation(self, inputs, outputs):
        self._records = (inputs, outputs)
        return super()._fit_simulation(inputs, outputs)

    def _train(self, module, windows_train, windows_valid, x_targets):
        super()._train(module, windows_train, windows_valid, x_targets)
        self.stage1_validation_loss_ = self.validation_loss_
        if getattr(self.module_, "physics_only", False):
            return
        U_list, Y_list, _ = check_trajectories(*self._records, initial_name="outputs")
        k, T = self._k, self.h2
        L, stride = k + T, max(1, T // 4)
        Y, U = [], []
        for u, y in zip(U_list, Y_list, strict=True):
            n_valid = round(self.validation_fraction * len(y))
            cut = len(y) - n_valid if n_valid >= L else len(y)
            for s in range(0, cut - L + 1, stride):
                Y.append(y[s : s + L])
                U.append(u[s : s + L])
        for p in self.module_.parameters():
            p.requires_grad_(True)
        self.module_.train()
        kept = {
            name: getattr(self, name)
            for name in ("encoder_epochs", "horizon", "lr", "max_epochs", "patience")
        }
        self.set_params(
            encoder_epochs=0,
            horizon=T,
            lr=self.lr2,
            max_epochs=self.epochs2,
            patience=self.patience2,
        )
        try:
            super()._train(
                self.module_, (np.stack(Y), np.stack(U), None), windows_valid, None
            )
        finally:
            self.set_params(**kept)


def one_run(name, seed, stage2, settings):
    """Stage 1 and 2 on one machine at one seed, and the true structure."""
    data = make_missing_physics(name, n_records=3, n_samples=2000, random_state=seed)
    k = data.n_init
    hybrid = CurriculumHybrid(
        clone(data.physics), n_init=k, random_state=seed, **settings
    )
    for attr, value in stage2.items():
        setattr(hybrid, attr, value)
    true = clone(data.true_model)
    row = {"machine": name, "seed": seed}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        hybrid.fit_simulation(data.inputs, data.outputs)
        row["fit_s"] = time.perf_counter() - t0
        true.fit_simulation(data.inputs, data.outputs)
    row["stage1_val"] = hybrid.stage1_validation_loss_
    row["val"] = hybrid.validation_loss_
    for test, (u, y) in data.tests.items():
        row[test] = free_run_rmse(hybrid, u, y, k) / free_run_rmse(true, u, y, k)
    return row


def main():
    parser = suite_parser(__doc__.splitlines()[0])
    parser.add_argument("--h2", type=int, default=100)
    parser.add_argument("--lr2", type=float, default=0.002)
    parser.add_argument("--epochs2", type=int, default=150)
    parser.add_argument("--patience2", type=int, default=20)
    args = parser.parse_args()
    stage2 = {
        "h2": args.h2,
        "lr2": args.lr2,
        "epochs2": args.epochs2,
        "patience2": args.patience2,
    }
    rows = Parallel(n_jobs=args.n_jobs)(
        delayed(one_run)(m, s, stage2, dict(args.set))
        for m in args.machines
        for s in args.seeds
    )
    print(f"stage 2: {stage2}; hybrid / true structure, free-run RMSE")
    for r in rows:
        print(
            f"{r['machine']:<20} seed {r['seed']}: validation {r['stage1_val']:.3g} "
            f"-> {r['val']:.3g}, inside {r['inside']:.2f}, beyond {r['beyond']:.2f}, "
            f"fit {r['fit_s']:.0f} s"
        )
    for test in ("inside", "beyond"):
        by = [
            np.mean([r[test] for r in rows if r["machine"] == m]) for m in args.machines
        ]
        print(
            f"{test}: "
            + ", ".join(f"{m} {v:.2f}" for m, v in zip(args.machines, by, strict=True))
            + f"; median {np.median(by):.2f}, worst {np.max(by):.2f}"
        )


if __name__ == "__main__":
    main()
