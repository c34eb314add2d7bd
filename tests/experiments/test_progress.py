"""Epoch counting across joblib workers for the progress bar."""

import numpy as np
from joblib import Parallel, delayed

from skhybrid.domain import LinearStateSpaceModel
from skhybrid.experiments.run._progress import FileSink, attach_epoch_logger
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
    assert epochs == [2, 3]
    events = FileSink(path).drain()
    # Each epoch: its number of the network's most, and its losses.
    assert sorted((e["name"], e["epoch"], e["max_epochs"]) for e in events) == [
        ("model0", 1, 2),
        ("model0", 2, 2),
        ("model1", 1, 3),
        ("model1", 2, 3),
        ("model1", 3, 3),
    ]
    assert all(np.isfinite(e["train_loss"]) for e in events)
    assert FileSink(path).count() == 5


def test_epoch_budget_counts_every_network_once_or_twice():
    from skhybrid.experiments.run._progress import epoch_budget

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
    from skhybrid.experiments.run._progress import ProgressBars

    stream = _Terminal(tty=False)
    bars = ProgressBars(3, "pendulum", n_done=1, n_epochs=50, stream=stream)
    bars.model_done("dense", 12.34, 40)
    bars.model_done("physics", 0.5, None)
    bars.close()
    assert stream.buffer.getvalue().splitlines() == [
        "pendulum: 3 models to fit, 1 already finished",
        "pendulum: 2/3 models: dense (12.3 s, 40 epochs)",
        "pendulum: 3/3 models: physics (0.5 s)",
    ]


def test_on_a_terminal_both_bars_know_their_totals_from_the_start():
    from skhybrid.experiments.run._progress import ProgressBars

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


# -- a physics fit's evaluations --------------------------------------------------


def _line_model():
    from skhybrid.domain import ParametricModel

    def line(X, *, a, b, xp=np):
        return a * X[:, :1] + b

    return ParametricModel(line, {"a": 0.0, "b": 0.0}, max_nfev=50)


def test_fit_progress_reports_every_evaluation_against_max_nfev():
    from skhybrid.domain import fit_progress

    X = np.linspace(0, 1, 30)[:, None]
    seen = []
    with fit_progress(lambda *event: seen.append(event)):
        _line_model().fit(X, 2 * X[:, 0] + 1)
    assert [n for n, _, _ in seen] == list(range(1, len(seen) + 1))
    # max_nfev=50 steps, each followed by a finite-difference Jacobian of the
    # two free parameters: at most 150 evaluations, and never more.
    assert {(limit, records) for _, limit, records in seen} == {(150, 1)}
    assert all(n <= limit for n, limit, _ in seen)
    # Outside the context nothing is reported.
    _line_model().fit(X, 2 * X[:, 0] + 1)
    assert len(seen) == len({n for n, _, _ in seen})


def test_fit_progress_counts_the_records_of_a_fit_on_whole_records():
    from skhybrid.domain import StateSpaceModel, fit_progress

    def decay(x, u, *, xp, a):
        return a * x + u

    rng = np.random.default_rng(0)
    U = [rng.standard_normal((60, 1)), rng.standard_normal((40, 1))]
    Y = []
    for u in U:
        y = np.zeros((len(u), 1))
        for t in range(1, len(u)):
            y[t] = 0.7 * y[t - 1] + u[t - 1]
        Y.append(y)
    model = StateSpaceModel(
        decay,
        {"a": 0.5},
        state_names=["y"],
        observed=["y"],
        time="discrete",
        n_init=2,
    )
    seen = []
    with fit_progress(lambda *event: seen.append(event)):
        model.fit_simulation(U, Y)
    assert seen and {records for _, _, records in seen} == {2}


def test_fit_progress_refuses_a_hook_that_is_not_callable():
    import pytest

    from skhybrid.domain import fit_progress

    with pytest.raises(TypeError, match="hook=3"), fit_progress(3):
        pass


def test_a_physics_fit_shows_its_evaluations_of_max_nfev_and_its_segments(tmp_path):
    from skhybrid.domain import fit_progress
    from skhybrid.experiments.run._progress import ProgressBars, physics_hook

    stream = _Terminal(tty=True)
    bars = ProgressBars(2, "toy", n_epochs=None, stream=stream)
    X = np.linspace(0, 1, 30)[:, None]
    label = "physics, fold 2 of 4 (6 fit pieces), in segments of 100 samples"
    with fit_progress(physics_hook(bars.sink, label, unit="segment")):
        _line_model().fit(X, 2 * X[:, 0] + 1)
    bars._update()
    assert bars.physics.total == 150 and bars.physics.n >= 1
    assert f"{label}; 1 segment simulated" in str(bars.physics)
    # Epochs and physics events share the sink: neither counts as the other.
    assert bars.sink.count() == 0
    bars.close()


def test_without_a_terminal_a_long_physics_fit_logs_a_line():
    from skhybrid.experiments.run._progress import ProgressBars, physics_event

    stream = _Terminal(tty=False)
    now = [0.0]
    bars = ProgressBars(
        1, "toy", stream=stream, clock=lambda: now[0], poll_interval=None
    )
    label = "physics, fold 2 of 4 (6 fit pieces), each whole"
    bars.sink.emit(physics_event(label, 7, 400, 6, "fit piece"))
    now[0] = 15.0
    bars.update()
    bars.sink.emit("dense")  # an epoch
    bars.close()
    assert stream.buffer.getvalue().splitlines() == [
        "toy: 1 model to fit",
        (
            "toy: physics, fold 2 of 4 (6 fit pieces), each whole: physics fit, 7 "
            "residual evaluations of at most 400 (6 fit pieces simulated) (15 s "
            "into the run)"
        ),
    ]


def test_a_refit_at_a_further_seed_names_its_seed_and_the_search():
    from skhybrid.experiments.run._progress import ProgressBars

    stream = _Terminal(tty=False)
    bars = ProgressBars(2, "toy seed 1; toy seed 2", stream=stream)
    bars.model_done("physics", 0.0, None, seed=1, searched_at=0)
    bars.model_done("physics", 0.0, None, seed=2, searched_at=0)
    bars.close()
    assert stream.buffer.getvalue().splitlines()[1:] == [
        f"toy seed 1; toy seed 2: {i}/2 models: physics at seed {i} (refit of "
        "the choice made at seed 0) (0.0 s)"
        for i in (1, 2)
    ]


def _context(U):
    from skhybrid.experiments.free_run._family import MeasuredContext

    Y = [u.copy() for u in U]
    return MeasuredContext(None, U, Y, n_init=5, dt=1.0, quick=True, seed=0)


def test_a_fit_says_which_fold_it_fits_or_that_it_refits_the_whole_records():
    from skhybrid.experiments.free_run._family import fit_pieces_label
    from skhybrid.model_selection import RecordBlockSplit, take_pieces

    rng = np.random.default_rng(0)
    U = [rng.standard_normal((400, 1)) for _ in range(3)]
    ctx = _context(U)
    folds = list(RecordBlockSplit(4, n_init=5).split(U))
    labels = []
    for fit, _ in folds:
        # As a worker receives them: copies, not views of the context's records.
        pieces = [p.copy() for p in take_pieces(U, None, fit)[0]]
        labels.append(fit_pieces_label(ctx, pieces))
    # The first and last folds hold one piece of each record, the middle two.
    assert labels == [
        "fold 1 of 4 (3 fit pieces)",
        "fold 2 of 4 (6 fit pieces)",
        "fold 3 of 4 (6 fit pieces)",
        "fold 4 of 4 (3 fit pieces)",
    ]
    assert fit_pieces_label(ctx, [u.copy() for u in U]) == (
        "the whole records (3 records)"
    )
    assert fit_pieces_label(ctx, [U[0][:100]]) == "1 record"


def test_a_fit_stopped_at_max_nfev_never_shows_more_than_its_limit():
    import warnings

    from skhybrid.domain import ParametricModel, fit_progress

    def curve(X, *, a, b, c, xp=np):
        return a * xp.exp(b * X[:, :1]) + c

    X = np.linspace(0, 1, 40)[:, None]
    seen = []
    with warnings.catch_warnings(), fit_progress(lambda *event: seen.append(event)):
        warnings.simplefilter("ignore")  # it stops short, on purpose
        model = ParametricModel(curve, {"a": 1.0, "b": 1.0, "c": 0.0}, max_nfev=5)
        model.fit(X, 3 * np.exp(-2 * X[:, 0]) + 1)
    # scipy's five evaluations and a finite-difference Jacobian of three
    # parameters after each: more than 5 calls, at most 5 * (1 + 3).
    assert {limit for _, limit, _ in seen} == {20}
    assert 5 < max(n for n, _, _ in seen) <= 20


# -- a log never quiet for 15 s; folds, epochs and the time left --------------------


class _Log(_Terminal):
    """A log file that notes the (fake) time of every line."""

    def __init__(self, clock):
        super().__init__(tty=False)
        self.clock = clock
        self.times = []

    def write(self, text):
        self.times += [self.clock()] * text.count("\n")
        return super().write(text)


def test_a_log_never_goes_15_s_without_a_line_and_names_folds_epochs_and_seeds():
    from skhybrid.experiments.run._progress import ProgressBars, Tagged

    now = [0.0]
    log = _Log(lambda: now[0])
    bars = ProgressBars(
        2, "machine seed 0", stream=log, clock=lambda: now[0], poll_interval=None
    )
    seed = Tagged(bars.sink, seed=0)
    fold = Tagged(
        seed,
        model="state-space hybrid",
        candidate="T=20",
        where="fold 1 of 4 (3 fit pieces)",
        fold=1,
    )
    # What the fits send, and when: a search of 2 candidates on 4 folds, 2 at
    # a time; a network's epochs, then 200 s without any news.
    script = {
        1.0: [
            (
                seed,
                {
                    "kind": "search",
                    "model": "state-space hybrid",
                    "n_candidates": 2,
                    "n_folds": 4,
                    "n_workers": 2,
                    "searched_at": None,
                },
            ),
            (fold, {"kind": "fit", "state": "start"}),
        ],
        **{
            2.0 + 4 * k: [
                (
                    fold,
                    {
                        "kind": "epoch",
                        "name": "state-space hybrid",
                        "epoch": k + 1,
                        "max_epochs": 500,
                        "train_loss": 0.5,
                        "valid_loss": 0.25 / (k + 1),
                    },
                )
            ]
            for k in range(10)
        },
        60.0: [(fold, {"kind": "fit", "state": "done", "seconds": 59.0})],
    }
    while now[0] < 300.0:
        for sink, event in script.get(now[0], []):
            sink.emit(event)
        bars.update()
        now[0] += 0.5
    bars.close()
    lines = log.buffer.getvalue().splitlines()
    times = [0.0, *log.times, now[0]]
    gaps = np.diff(times)
    assert gaps.max() <= 15.0, (gaps.max(), lines)
    assert (
        "machine seed 0: state-space hybrid at seed 0: searching 2 candidates on 4 "
        "folds (8 fits, 2 at a time), then a refit on the whole records"
    ) in lines
    epoch = [line for line in lines if "epoch " in line]
    assert epoch and epoch[0].startswith(
        "machine seed 0: state-space hybrid T=20, fold 1 of 4 (3 fit pieces), seed "
        "0: epoch "
    )
    assert any("epoch 4 of at most 500, valid loss 0.0625" in line for line in epoch)
    # The fold's end, and the time the search has left: 3 more folds of T=20
    # and 4 of the other candidate, 59 s each, 2 at a time (206.5 s), and the
    # refit on 4/3 of a fold's data (78.7 s).
    [done] = [line for line in lines if "fold fits)" in line]
    assert done == (
        "machine seed 0: state-space hybrid T=20, fold 1 of 4 (3 fit pieces), seed "
        "0: fitted in 59 s (1 of 8 fold fits); about 4 min 45 s left for this model"
    )
    # Quiet fits: the latest news, and how old it is.
    assert lines[-1].startswith(
        "machine seed 0: state-space hybrid T=20, fold 1 of 4 (3 fit pieces), seed "
        "0: fitted in 59 s ("
    )
    assert lines[-1].endswith("latest news 3 min 45 s ago)"), lines[-1]


def test_the_search_clock_counts_each_candidates_folds_and_the_refit():
    from skhybrid.experiments.run._progress_lines import SearchClock

    clock = SearchClock(n_candidates=2, n_folds=4, n_workers=2)
    assert clock.remaining() is None  # nothing to go by yet
    clock.record({"fold": 1, "candidate": "T=20", "seconds": 10.0})
    # (3 folds of T=20 + 4 of the other) * 10 s on 2 workers, and a refit on
    # 4/3 of a fold's data.
    np.testing.assert_allclose(clock.remaining(), 70 / 2 + 10 * 4 / 3)
    clock.record({"fold": 1, "candidate": "T=40", "seconds": 30.0})
    np.testing.assert_allclose(clock.remaining(), (3 * 10 + 3 * 30) / 2 + 30 * 4 / 3)
    assert clock.progress() == "2 of 8 fold fits"
    clock.record({"fold": None, "candidate": "T=40", "seconds": 40.0})
    assert clock.remaining() == 0.0


def _first_order(x, u, *, xp, a, b):
    return a * x + b * u


def _record(n, seed):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10 + 1), 10)[:n]
    y, x = np.empty(n), 0.0
    for t in range(n):
        y[t] = x
        x = 0.8 * x + 0.5 * u[t] - 0.05 * x**3
    return u[:, None], (y + 0.001 * rng.standard_normal(n))[:, None]


class _WallLog(_Terminal):
    """Standard error of a run sent to a log: every line's wall time noted."""

    def __init__(self):
        super().__init__(tty=False)
        self.times = []

    def write(self, text):
        import time

        self.times += [time.monotonic()] * text.count("\n")
        return super().write(text)


def test_a_small_runs_log_names_folds_and_seeds_and_is_never_quiet(
    tmp_path, monkeypatch
):
    import sys
    import time

    from skhybrid.domain import StateSpaceModel
    from skhybrid.experiments import SystemSpec, run_system
    from skhybrid.experiments.run import _progress

    spec = SystemSpec(
        name="tiny",
        records=[_record(300, 0), _record(240, 1)],
        physics=StateSpaceModel(
            _first_order,
            {"a": 0.5, "b": 1.0},
            state_names=["y"],
            observed=["y"],
            time="discrete",
        ),
        n_init=5,
        dt=0.1,
        tests={"test": _record(200, 2)},
        hybrids=None,
    )
    # The log interval shortened from 15 s to 1 s: the run lasts seconds.
    monkeypatch.setattr(_progress, "LOG_INTERVAL", 1.0)
    log = _WallLog()
    monkeypatch.setattr(sys, "stderr", log)
    start = time.monotonic()
    run_system(spec, tmp_path / "run", quick=True, seeds=[0, 1], n_jobs=1)
    end = time.monotonic()
    lines = [line for line in log.buffer.getvalue().splitlines() if "tiny seed" in line]
    # Lines come every 0.5 to 1 s; the slack is for a loaded machine.
    gaps = np.diff([start, *log.times, end])
    assert gaps.max() < 3.0, (gaps.max(), lines)
    # Each fold of the searches, named with its seed; each refit at seed 1.
    assert any(
        "tiny seed 0: dense NARX n=" in line and ", fold 1 of 4 (" in line
        for line in lines
    )
    assert any(
        line.startswith("tiny seed 0: physics unsegmented, ")
        and "fold 4 of 4" in line
        and "left for this model" in line
        for line in lines
    )
    assert any(
        "seed 1: fitted in" in line and "the whole records (2 records)" in line
        for line in lines
    )
    assert (
        "tiny seed 1: physics at seed 1: refitting on the whole records the choice "
        "made at seed 0"
    ) in lines
    # A fold's pieces are never called whole records.
    assert not any(", fold " in line and "whole records," in line for line in lines)


def test_dask_events_are_read_once_and_their_epochs_counted():
    from skhybrid.experiments.run._progress import DaskEventSink, _encode

    sink = DaskEventSink("skhybrid-test")
    epoch = {"kind": "epoch", "name": "dense", "epoch": 1, "max_epochs": 5}
    fold = {"kind": "fit", "state": "done", "model": "dense", "seconds": 1.0}
    for event in (epoch, fold, epoch):
        sink._on_event((0.0, _encode(event)))  # as Dask hands them: (time, msg)
    assert sink.drain() == [epoch, fold, epoch]
    assert sink.drain() == []
    assert sink.count() == 2
    # Pickled into a worker, it keeps only its topic.
    import pickle

    assert pickle.loads(pickle.dumps(sink)).topic == "skhybrid-test"
