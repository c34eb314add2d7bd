"""Epoch counting across joblib workers for the progress bar."""

import numpy as np
from joblib import Parallel, delayed

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.experiments._progress import attach_epoch_logger
from skhybrid.hybrid import HybridBoostingRegressor
from skhybrid.neural import DenseRegressor


def test_epoch_logger_counts_epochs_of_nested_networks_in_workers(tmp_path, rng):
    X = rng.standard_normal((120, 3))
    y = X[:, :1] * 0.5 + np.sin(X[:, 1:2])
    path = tmp_path / "epochs.log"
    path.touch()
    models = [
        HybridBoostingRegressor(
            [
                ("linear", LinearStateSpaceModel()),
                ("dense", DenseRegressor((8,), max_epochs=e, random_state=0)),
            ],
            stage_input="window",
        )
        for e in (2, 3)
    ]
    for i, model in enumerate(models):
        attach_epoch_logger(model, path, f"model{i}")
    # A package method, not a test-module function: workers must import it.
    fitted = Parallel(n_jobs=2)(
        delayed(HybridBoostingRegressor.fit)(m, X, y) for m in models
    )
    epochs = [f.stages_[1][1].n_epochs_ for f in fitted]
    lines = path.read_text().splitlines()
    assert sorted(lines) == ["model0"] * epochs[0] + ["model1"] * epochs[1]
    assert epochs == [2, 3]


def test_epoch_budget_counts_every_network_once_or_twice():
    from skhybrid.experiments._progress import epoch_budget

    booster = HybridBoostingRegressor(
        [
            ("linear", LinearStateSpaceModel()),
            ("dense", DenseRegressor((8,), max_epochs=7)),
            (
                "lb",
                DenseRegressor(
                    (8,), max_epochs=5, objective="ljung_box", mse_pretraining=True
                ),
            ),
        ]
    )
    assert epoch_budget(booster) == 7 + 2 * 5
    assert epoch_budget(LinearStateSpaceModel()) == 0


class _Terminal:
    def __init__(self, tty):
        import io

        self.buffer = io.StringIO()
        self.tty = tty

    def isatty(self):
        return self.tty

    def write(self, text):
        return self.buffer.write(text)

    def flush(self):
        pass


def test_without_a_terminal_one_line_per_finished_model():
    from skhybrid.experiments._progress import ProgressBars

    stream = _Terminal(tty=False)
    bars = ProgressBars(3, "pendulum", n_done=1, n_epochs=50, stream=stream)
    bars.model_done("dense", 12.34, 40)
    bars.model_done("physics", 0.5, None)
    bars.close()
    assert stream.buffer.getvalue().splitlines() == [
        "pendulum: 2/3 models: dense (12.3 s, 40 epochs)",
        "pendulum: 3/3 models: physics (0.5 s)",
    ]


def test_on_a_terminal_both_bars_know_their_totals_from_the_start():
    from skhybrid.experiments._progress import ProgressBars

    stream = _Terminal(tty=True)
    bars = ProgressBars(4, "pendulum", n_epochs=120, stream=stream)
    assert bars.models.total == 4 and bars.epochs.total == 120
    first = stream.buffer.getvalue()
    assert "0/4" in first and "/120" in first
    assert "?model/s" not in first
    bars.model_done("dense", 1.0, 3)
    bars.close()
    out = stream.buffer.getvalue()
    assert out.endswith("\n")  # what follows is not printed over the bars
