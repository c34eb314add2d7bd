"""Summarise `skhybrid run` outputs of several seeds as markdown tables.

Usage::

    python docs/make_reference_results.py RUN_DIR [RUN_DIR ...]

Each RUN_DIR is an ``--out`` folder of ``skhybrid run``. Prints, per system, the
paper's claims for every seed and the median-window RMSE in dB and the RMSE over
the oracle's, per model and test split (mean over seeds), for the last output.
"""

import json
import sys
from collections import defaultdict
from pathlib import Path


def main(paths):
    runs = [json.loads((Path(p) / "results.json").read_text()) for p in paths]
    by_system = defaultdict(list)
    for run in runs:
        for name, system in run["systems"].items():
            by_system[name].append((run["environment"], system))
    for entries in by_system.values():
        print(f"### {entries[0][1]['title']}\n")
        print("| seed | wall time | claim | holds | figures |")
        print("| --- | --- | --- | --- | --- |")
        for _, system in entries:
            seed = system["settings"]["seed"]
            for claim in system["claims"]:
                print(
                    f"| {seed} | {system['wall_time_s']:.0f} s | {claim['claim']} | "
                    f"{'yes' if claim['passed'] else '**no**'} | {claim['detail']} |"
                )
        rows = [r for _, s in entries for r in s["results"]]
        output = rows[0]["output"] if rows else ""
        outputs = sorted(
            {r["output"] for r in rows}, key=[r["output"] for r in rows].index
        )
        output = outputs[-1]
        splits = sorted({r["split"] for r in rows}, reverse=True)
        models = list(dict.fromkeys(r["model"] for r in rows))
        print(
            f"\n{output}: median over windows of RMSE in dB / RMSE over the oracle's "
            f"(mean over {len(entries)} seeds)\n"
        )
        print("| model | " + " | ".join(splits) + " |")
        print("| --- |" + " --- |" * len(splits))
        for model in models:
            cells = []
            for split in splits:
                sel = [
                    r
                    for r in rows
                    if r["model"] == model
                    and r["split"] == split
                    and r["output"] == output
                ]
                db = sum(r["median_window_rmse_db"] for r in sel) / len(sel)
                ratio = sum(r["rmse_over_oracle"] for r in sel) / len(sel)
                cells.append(f"{db:.1f} dB / {ratio:.2f}")
            print(f"| {model} | " + " | ".join(cells) + " |")
        noise = entries[0][1].get("noise")
        if noise is not None:
            split = "interpolation"
            print(
                f"\nWhiteness on the {split} set ({entries[0][1]['noise_type']} "
                "noise): residual std / injected noise and Ljung-Box Q at "
                f"{entries[0][1]['settings']['lags']} lags, mean over seeds\n"
            )
            print("| model | " + " | ".join(outputs) + " |")
            print("| --- |" + " --- |" * len(outputs))
            for model in models:
                cells = []
                for j, out in enumerate(outputs):
                    sel = [
                        r
                        for r in rows
                        if r["model"] == model
                        and r["split"] == split
                        and r["output"] == out
                    ]
                    q = sum(r["ljung_box_stat"] for r in sel) / len(sel)
                    if noise[j] > 0:
                        ratio = sum(r["residual_std"] for r in sel) / len(sel)
                        cells.append(f"{ratio / noise[j]:.3f} / {q:.0f}")
                    else:
                        cells.append(f"- / {q:.0f}")
                print(f"| {model} | " + " | ".join(cells) + " |")
        params = defaultdict(list)
        for _, system in entries:
            for model, ps in system["params"].items():
                for p, v in ps.items():
                    # A hybrid's frozen first stage repeats the frozen physics.
                    frozen_stage = "+" in model and v["std"] == 0
                    if isinstance(v["value"], float) and not frozen_stage:
                        params[(model, p)].append((v["value"], v["std"]))
        if params:
            print("\nFitted physical parameters (value ± standard error, per seed)\n")
            print("| model | parameter | values |")
            print("| --- | --- | --- |")
            for (model, p), vals in params.items():
                text = "; ".join(
                    f"{v:.4g} ± {s:.2g}" if s is not None else f"{v:.4g}"
                    for v, s in vals
                )
                print(f"| {model} | {p} | {text} |")
        print()


if __name__ == "__main__":
    main(sys.argv[1:])
