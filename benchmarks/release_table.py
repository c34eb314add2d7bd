"""Print the release run's figures of the measured benchmarks as Markdown tables.

Reads each run folder's ``results.json`` (written by ``skhybrid run NAME --data
DIR --out RUNS/NAME``) and prints, per benchmark: the chosen model, its CV RMSE
(mean ± std over the folds), its test RMSE per test record (mean ± std over the
seeds), test / CV, the band's coverage, the family's other models (CV and test)
and the stack's weights, the seal and the wall time. **Running it reads test
scores**: it is part of a release run's one look, to be logged in
``benchmarks/LOG.md``.

Run: ``python benchmarks/release_table.py RUNS/cascaded-tanks RUNS/emps ...``.
"""

import argparse
import json
from pathlib import Path


def _spread(entry, digits=3):
    if entry is None or entry.get("mean") is None:
        return "failed"
    if entry.get("std", 0.0) == 0.0:
        return f"{entry['mean']:.{digits}g} (the same at every seed)"
    return f"{entry['mean']:.{digits}g} ± {entry['std']:.2g}"


def _cv(entry):
    return f"{entry['mean']:.3g} ± {entry['std']:.2g} ({entry['folds']} folds)"


def summary(folder):
    """The benchmark's entry of ``results.json`` in ``folder``."""
    data = json.loads((Path(folder) / "results.json").read_text())
    (name, system), *_ = data["systems"].items()
    return name, system


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", help="run folders")
    args = parser.parse_args(argv)
    head = (
        "| benchmark | chosen | CV RMSE | test RMSE | test / CV | band coverage "
        "| selection | wall time |\n| --- | --- | --- | --- | --- | --- | --- | --- |"
    )
    print(head)
    details = []
    for folder in args.folders:
        name, s = summary(folder)
        unit = s["unit"]
        chosen = sorted(set(s["chosen_model"].values()))
        seed = str(s.get("searched_at_seed", s["seeds"][0]))
        cv = s["cv_rmse"][seed]
        splits = list(s["chosen_test_rmse"])
        tests = " / ".join(_spread(s["chosen_test_rmse"][k]) for k in splits)
        ratio = " / ".join(_spread(s["chosen_test_over_cv"][k], 2) for k in splits)
        cover = " / ".join(
            "n/a"
            if s["band_coverage"][k]["mean"] is None
            else f"{100 * s['band_coverage'][k]['mean']:.0f} %"
            for k in splits
        )
        print(
            f"| `{name}` ({' / '.join(splits)}) [{unit}] | {', '.join(chosen)} "
            f"| {_cv(cv[chosen[0]])} | {tests} | {ratio} | {cover} "
            f"| `{s['selection_sha256'][:16]}` | {s['wall_time_s'] / 60:.1f} min |"
        )
        rows = [f"\n**{name}** [{unit}], every model:\n"]
        rows.append("| model | CV RMSE | " + " | ".join(splits) + " |")
        rows.append("| --- | --- | " + " | ".join("---" for _ in splits) + " |")
        for model in s["test_rmse"][splits[0]]:
            cells = [_spread(s["test_rmse"][k].get(model)) for k in splits]
            cv_text = _cv(cv[model]) if model in cv else "n/a"
            mark = " (chosen)" if model in chosen else ""
            rows.append(f"| {model}{mark} | {cv_text} | " + " | ".join(cells) + " |")
        weights = s.get("stack_weights") or {}
        if weights:
            rows.append(
                "\nThe stack's weights: "
                + ", ".join(f"{m} {w:.3f}" for m, w in weights.items() if w > 0)
            )
        details.append("\n".join(rows))
    print("\n".join(details))


if __name__ == "__main__":
    main()
