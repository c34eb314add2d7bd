"""benchmarks/release_table.py: the release run's figures from the run folders."""

import json


def _spread(mean, std):
    return {"mean": mean, "std": std, "min": mean, "max": mean, "by_seed": [mean]}


def _folder(tmp_path):
    cv = {
        "physics": {"mean": 0.4, "std": 0.1, "by_fold": [0.3, 0.5], "folds": 2},
        "physics + dense": {
            "mean": 0.3,
            "std": 0.05,
            "by_fold": [0.25, 0.35],
            "folds": 2,
        },
    }
    system = {
        "unit": "V",
        "seeds": [0, 1],
        "searched_at_seed": 0,
        "chosen_model": {"0": "physics + dense", "1": "physics + dense"},
        "cv_rmse": {"0": cv, "1": cv},
        "chosen_test_rmse": {"test": _spread(0.33, 0.01)},
        "chosen_test_over_cv": {"test": _spread(1.1, 0.03)},
        "band_coverage": {"test": _spread(0.9, 0.0)},
        "test_rmse": {
            "test": {
                "physics": _spread(0.45, 0.0),
                "physics + dense": _spread(0.33, 0.01),
            }
        },
        "selection_sha256": "ab" * 32,
        "wall_time_s": 90.0,
        "stack_weights": {"physics": 0.25, "physics + dense": 0.75, "ARX": 0.0},
    }
    (tmp_path / "results.json").write_text(
        json.dumps({"systems": {"toy": system}}), encoding="utf-8"
    )
    return tmp_path


def test_release_table_prints_the_chosen_model_and_every_model(
    tmp_path, capsys, benchmark_script
):
    table = benchmark_script("release_table.py")
    table.main([str(_folder(tmp_path))])
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| `toy`"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == "physics + dense"
    assert cells[2] == "0.3 ± 0.05 (2 folds)"
    assert cells[3] == "0.33 ± 0.01"
    assert cells[5] == "90 %"
    assert cells[6] == "`abababababababab`"
    assert cells[7] == "1.5 min"
    assert "| physics + dense (chosen) | 0.3 ± 0.05 (2 folds) | 0.33 ± 0.01 |" in out
    assert "| physics | 0.4 ± 0.1 (2 folds) | 0.45 (the same at every seed) |" in out
    assert "The stack's weights: physics 0.250, physics + dense 0.750" in out
