"""The Ljung-Box-trained RNN residual stage against the MSE-trained one, fast.

Builds one system's data exactly as ``skhybrid run SYSTEM`` does (full settings
unless ``--quick``), fits the physics stage once, then trains only the recurrent
residual stage of the zoo's ``physics+rnn`` hybrids with each variant of the
objective and compares them with the MSE-trained stage:

- on the **validation slice**, the last 10 % of the training rows, which the
  stage never trains on (the booster holds them out); design choices are made on
  these figures only;
- on the interpolative **test** set, the figures the issue's criteria read.

Per output it prints the RMSE over the MSE stage's and the Ljung-Box statistic
``Q`` at the run's lags (and the test RMSE over the oracle's). Results are cached
as JSON per system, seed and variant, so the MSE stage is trained once::

    python benchmarks/bench_ljung_box_stage.py pendulum --variants mse lb
    python benchmarks/bench_ljung_box_stage.py dc-motor \\
        --variants mse "seg=128" "seg=128,scale=per_output"

A variant is ``mse`` (the zoo's MSE stage), ``lb`` (the same network with
``objective="mse+ljung_box"`` and the library's defaults: contiguous blocks of
``batch_size`` rows, weight 1, the zoo's Ljung-Box stage before issue 12 was
closed) or comma-separated changes to ``lb``: ``seg=M``
(``ljung_box_segment_length``), ``scale=per_output`` (``ljung_box_scaling``),
``w=W`` (``ljung_box_weight``), ``lr=LR``, ``pre=1``
(``mse_pretraining=True``). The zoo's Ljung-Box stage is now
``seg=32,w=0.1``.
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
import torch
from scipy.stats import chi2
from sklearn.base import clone

from skhybrid.experiments import RunSettings, model_zoo
from skhybrid.experiments._registry import SYSTEMS
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.losses import ljung_box

KEYS = {
    "seg": ("ljung_box_segment_length", int),
    "scale": ("ljung_box_scaling", str),
    "w": ("ljung_box_weight", float),
    "lr": ("lr", float),
    "pre": ("mse_pretraining", lambda v: bool(int(v))),
}


def variant_params(spec):
    """The stage's parameters for a variant spec (see the module docstring)."""
    if spec == "mse":
        return {"objective": "mse"}
    params = {"objective": "mse+ljung_box"}
    if spec == "lb":
        return params
    for item in spec.split(","):
        key, value = item.split("=")
        name, kind = KEYS[key]
        params[name] = kind(value)
    return params


def stage_data(booster, X, Y):
    """The second stage's input and target, given the fitted physics stage."""
    windows = booster._windows(X)
    ((_, physics),) = booster.stages_
    preds = [booster._stage_predict(physics, W) for W in windows]
    Z = booster._augment(windows, preds, len(windows) - 1)
    return Z, Y - preds[-1], preds[-1]


def scores(y, pred, lags):
    r = y - pred
    return {
        "rmse": np.sqrt(np.mean(r**2, axis=0)).tolist(),
        "q": np.asarray(ljung_box(r, lags, reduction="none")).tolist(),
        "std": np.std(r, axis=0).tolist(),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("system", choices=sorted(SYSTEMS))
    parser.add_argument("--variants", nargs="+", default=["mse", "lb"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--cache", default="/tmp/bench_lb_stage")
    parser.add_argument("--refit", action="store_true", help="ignore the cache")
    args = parser.parse_args()
    torch.set_num_threads(int(os.environ.get("OMP_NUM_THREADS", "1")))

    system = SYSTEMS[args.system]
    s = RunSettings(quick=args.quick, seed=args.seed)
    lags = system.sizes(s).lags
    tag = f"{args.system}_s{args.seed}{'_quick' if args.quick else ''}"
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)

    splits = system.make_splits(s)
    train, test = splits["train"], splits["interpolation"]
    zoo = model_zoo(system, s)
    template = zoo["physics+rnn (mse)"]
    booster = HybridBoostingRegressor(
        [template.stages[0]],
        n_steps=system.n_steps,
        ljung_box_lags=lags,
        random_state=s.seed,
    )
    start = time.perf_counter()
    booster.fit(train.X, train.y)
    print(f"physics fitted in {time.perf_counter() - start:.1f} s")
    fit_rows, val_rows = booster._split(train.X.shape[0])
    Z, target, _ = stage_data(booster, train.X, train.y)
    Zt, _, phys_test = stage_data(booster, test.X, test.y)
    names = list(train.target_names)
    oracle = scores(test.y, np.asarray(test.oracle), lags)

    results = {}
    for spec in args.variants:
        path = cache / f"{tag}_{spec.replace('=', '-').replace(',', '_')}.json"
        if path.exists() and not args.refit:
            results[spec] = json.loads(path.read_text())
            continue
        stage = clone(template.stages[1][1]).set_params(**variant_params(spec))
        start = time.perf_counter()
        stage.fit(Z[fit_rows], target[fit_rows])
        elapsed = time.perf_counter() - start
        pred_val = stage.predict(Z[val_rows])
        pred_test = phys_test + stage.predict(Zt)
        out = {
            "params": variant_params(spec),
            "fit_s": elapsed,
            "epochs": stage.n_epochs_,
            "best_epoch": stage.best_epoch_,
            "history": {
                key: [row.get(key) for row in stage.history_]
                for key in ("train_loss", "valid_loss", "event_lr")
            },
            "val": scores(target[val_rows], pred_val, lags),
            "test": scores(test.y, pred_test, lags),
        }
        path.write_text(json.dumps(out))
        results[spec] = out
        print(f"{spec}: {elapsed:.0f} s, {stage.n_epochs_} epochs", flush=True)

    ref = results.get("mse")
    print(f"\n{tag}: outputs {names}; oracle test RMSE {oracle['rmse']}")
    print(f"oracle test Q {[round(q) for q in oracle['q']]}")
    for spec, out in results.items():
        line = [f"{spec:28s} ep {out['epochs']:3d}/{out['best_epoch']:3d}"]
        for part in ("val", "test"):
            rm, q = np.array(out[part]["rmse"]), np.array(out[part]["q"])
            ratio = rm / np.array(ref[part]["rmse"]) if ref else rm
            line.append(
                f"{part}: RMSE/mse "
                + " ".join(f"{v:.3f}" for v in ratio)
                + " Q "
                + " ".join(f"{v:.0f}" for v in q)
            )
        orc = np.array(out["test"]["rmse"]) / np.array(oracle["rmse"])
        line.append("test/oracle " + " ".join(f"{v:.2f}" for v in orc))
        pvalue = chi2.sf(out["test"]["q"], lags)
        noise = np.array(out["test"]["std"]) / system.noise
        line.append(
            "test p "
            + " ".join(f"{v:.2g}" for v in pvalue)
            + " std/noise "
            + " ".join(f"{v:.3f}" for v in noise)
        )
        print(" | ".join(line))


if __name__ == "__main__":
    main()
