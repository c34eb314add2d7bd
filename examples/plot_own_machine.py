"""
Model your own machine
======================

From measured records to a chosen, simulated and reported model, through the
public workflow: a :class:`~skhybrid.experiments.SystemSpec` describes the
machine once, :func:`~skhybrid.experiments.run_system` fits the default
candidate family, chooses by blocked cross-validation of the estimation
records, seals the selection and only then simulates the test record.

The machine here is simulated so that the truth is known: a mass on a
stiffening spring (``k x + k3 x^3``) with viscous and Coulomb-like friction,
driven by a force; only the position is measured, the velocity is latent. The
physics we write lacks the cubic term, as a user's physics lacks what they do
not know. Two estimation records of different lengths and one test record come
as pandas DataFrames with a time index. Run it with::

    python examples/plot_own_machine.py

It runs ``quick=True`` with two seeds (20 to 35 s on two cores): short fits
and fewer candidates, a smoke test of the workflow rather than a figure to
quote. Drop ``quick=True`` (and keep the default three seeds) for a real run.
"""

import hashlib
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments import SystemSpec, load_fitted, run_system

# %%
# The machine and its records
# ---------------------------
# ``m x'' = F - k x - k3 x^3 - c x' - fc tanh(x' / 0.01)`` with ``m = 1``,
# integrated finely and sampled every 50 ms; the force is held for 2 s at random
# levels; the position is measured with 5 mm of noise.
DT = 0.05
TRUTH = {"k": 4.0, "k3": 6.0, "c": 0.3, "fc": 0.4}


def measure(n_samples, seed):
    """One record of the machine: a DataFrame with a time index."""
    rng = np.random.default_rng(seed)
    force = np.repeat(rng.uniform(-3, 3, n_samples // 40 + 1), 40)[:n_samples]
    position, velocity, h = 0.0, 0.0, DT / 10
    y = np.empty(n_samples)
    for t in range(n_samples):
        y[t] = position
        for _ in range(10):
            spring = TRUTH["k"] * position + TRUTH["k3"] * position**3
            friction = TRUTH["c"] * velocity + TRUTH["fc"] * np.tanh(velocity / 0.01)
            position, velocity = (
                position + h * velocity,
                velocity + h * (force[t] - spring - friction),
            )
    y += 0.005 * rng.standard_normal(n_samples)
    time = pd.to_timedelta(np.arange(n_samples) * DT, unit="s")
    return pd.DataFrame({"force": force, "position": y}, index=time)


records = [measure(800, seed=0), measure(500, seed=1)]  # lengths may differ
test = measure(600, seed=2)
print(records[1].head(3))

# %%
# The physics a user writes
# -------------------------
# A :class:`~skhybrid.domain.StateSpaceModel` with a latent velocity: the
# position is ``observed``, the velocity is estimated at the start of every free
# run from the first ``n_init`` measured samples. The equations are written
# against the array namespace ``xp`` (so the state-space hybrid trains through
# them in torch) and at module level (so the fitted models pickle). No cubic
# term: the candidates that correct the physics have something to learn.


def spring_damper(x, u, *, xp, k, c, fc):
    position, velocity = x[:, 0], x[:, 1]
    accel = u[:, 0] - k * position - c * velocity - fc * xp.tanh(velocity / 0.01)
    return xp.stack([velocity, accel], axis=1)


physics = StateSpaceModel(
    spring_damper,
    {"k": 2.0, "c": 1.0, "fc": 0.1},  # a rough start
    state_names=["position", "velocity"],
    observed=["position"],
    time="continuous",  # dt and n_init: the spec's (said once)
    vectorized=True,
)

# %%
# The spec and the run
# --------------------
# ``dt`` is read from the DataFrames' time index (it must be uniform); the
# columns are named by ``inputs`` and ``outputs``. ``n_init=10`` samples (0.5 s)
# start every free run, on the held-out blocks and on the test record alike.
spec = SystemSpec(
    "my-machine",
    records=records,
    physics=physics,
    n_init=10,
    inputs=["force"],
    outputs=["position"],
    tests={"test": test},
    unit="m",
)
out = Path(tempfile.mkdtemp()) / "my-machine"
summary = run_system(spec, out, seeds=(0, 1), quick=True)
print("run folder:", sorted(p.name for p in out.iterdir()))

# %%
# The selection, sealed before the test
# -------------------------------------
# At each seed every candidate is fitted on three of four blocks of each
# estimation record and simulated in free run over the held-out block, each
# block in turn; the lowest mean RMSE over the folds (the CV RMSE) is the model
# quoted. Every seed's choices are written to
# ``selection.json`` with their SHA-256 *before* the test record is read, so
# the test figure cannot have steered any choice, and anyone holding the folder
# can check that the figures come from the selection it records. The networks
# depend on the seed, so each seed is a full selection; the test RMSE is quoted
# as its mean and spread over seeds.
sealed = json.loads((out / "selection.json").read_text())
canonical = json.dumps(
    sealed["selection"], sort_keys=True, separators=(",", ":"), default=str
)
assert hashlib.sha256(canonical.encode()).hexdigest() == sealed["sha256"]
print("sealed selection sha256:", sealed["sha256"])
results = json.loads((out / "results.json").read_text())["systems"][spec.name]
assert results["selection_sha256"] == sealed["sha256"] == summary["selection_sha256"]

validation = pd.DataFrame(results["validation_rmse"])
validation.columns = [f"seed {s}" for s in validation.columns]
print("\nCV RMSE [m] (mean over the folds' held-out blocks, free run)")
print(validation.round(4).to_string())
for seed, model in results["chosen_model"].items():
    print(f"chosen at seed {seed}: {model}")
chosen = results["chosen_test_rmse"]["test"]
print(
    f"\ntest RMSE of the chosen model: {chosen['mean']:.4f} +/- {chosen['std']:.4f} m"
    f" (mean +/- std over seeds; {chosen['min']:.4f} to {chosen['max']:.4f})"
)

# %%
# The physical parameters
# -----------------------
# The physics is fitted by its free-run (simulation) error, the same at every
# seed. Its spring constant absorbs the missing cubic term (the spring is
# stiffer than ``k`` alone); the friction stays near the truth.
fitted = results["physics_params"]["0"]
print(f"physics fitted by simulation error (truth: k3 = {TRUTH['k3']}, not modelled)")
for name in ("k", "c", "fc"):
    print(f"  {name:>2} = {fitted[name]:.3f}   (truth {TRUTH[name]})")

# %%
# The chosen model's free run on the test record
# ----------------------------------------------
# Every fitted model lands in ``models/<name>-seed-<seed>/`` of the run folder.
# :func:`~skhybrid.experiments.load_fitted` loads seed 0's chosen model (and,
# by name, the physics alone); simulate each from the test record's first
# ``n_init`` measured samples, as the run scored it. The equations are written
# in this script (``__main__``): the run folder stores them by value with the
# models, so ``load_fitted(out)`` works as well in a new session that never
# defined ``spring_damper``.
name = results["chosen_model"]["0"]
model = load_fitted(out, seed=0)
physics_alone = load_fitted(out, seed=0, model="physics")
u, y = test[["force"]].to_numpy(), test[["position"]].to_numpy()
n_init = spec.n_init
runs = {
    name: model.simulate(u, y[:n_init]),
    "physics": physics_alone.simulate(u, y[:n_init]),
}
for label, run in runs.items():
    rmse = np.sqrt(np.mean((run[n_init:, 0] - y[n_init:, 0]) ** 2))
    print(f"{label:>16}: test RMSE {rmse:.4f} m")
    assert np.isclose(rmse, results["test_rmse"]["test"][label]["by_seed"][0])

t = test.index.total_seconds()
fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
top.plot(t, y, "k", lw=1, label="measured")
for label, run in runs.items():
    top.plot(t, run, lw=0.9, label=label)
    bottom.plot(t[n_init:], (run - y)[n_init:, 0], lw=0.8, label=label)
for ax in (top, bottom):
    ax.axvspan(0, n_init * DT, color="0.9")
top.set_ylabel("position [m]")
top.set_title("test record and free runs (seed 0; grey: the initialisation window)")
top.legend(fontsize=8)
bottom.set_ylabel("simulation error [m]")
bottom.set_xlabel("time [s]")
bottom.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %%
# The same run from the shell
# ---------------------------
# Put the records, the physics and ``spec = SystemSpec(...)`` in a module the
# command can import, ``my_machine.py`` say, and run::
#
#     skhybrid run --system my_machine:spec --out runs/my-machine --seeds 0 1 2
#
# The folder then holds the same ``selection.json``, ``results.csv``,
# ``results.json``, ``report.html`` (open it in a browser) and the figure; an
# interrupted run carries on where it stopped with ``--resume``. The built-in
# measured benchmarks are specs of this same form:
# ``skhybrid.benchmarks.benchmark_spec("silverbox", data_dir)``.
