"""A user's own machine through the public workflow: SystemSpec, run_system, CLI.

The machine is simulated: a damped oscillator with a cubic spring, driven by a
held random input, whose position alone is measured (the velocity is latent).
Its physics is incomplete (a linear spring). Two estimation records of different
lengths and a test record; the test record is a function that checks, when it is
called, that the sealed selection is already on disk.
"""

import hashlib
import json
import textwrap

import numpy as np
import pandas as pd
import pytest
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import Ridge

from skhybrid.cli import main
from skhybrid.experiments import RunSettings, SystemSpec, load_fitted, run_system
from skhybrid.experiments._settings import on_device
from skhybrid.experiments.free_run import _family as _measured_zoo
from skhybrid.experiments.free_run import _search as _measured_search

MACHINE = textwrap.dedent(
    '''
    import numpy as np
    from pathlib import Path

    from skhybrid.domain import StateSpaceModel
    from skhybrid.experiments import SystemSpec

    DT = 0.1
    #: (selection.json existed, when) at each read of the test records.
    TEST_READS = []


    def oscillator(x, u, *, xp, k, c, dt):
        p, v = x[:, 0], x[:, 1]
        return xp.stack([p + dt * v, v + dt * (-k * p - c * v + u[:, 0])], axis=1)


    def record(n, seed):
        """The machine: a cubic spring the physics lacks; position measured."""
        rng = np.random.default_rng(seed)
        u = np.repeat(rng.uniform(-1, 1, n // 25 + 1), 25)[:n]
        x, y = np.zeros(2), np.empty(n)
        for t in range(n):
            y[t] = x[0]
            p, v = x
            x = np.array([p + DT * v, v + DT * (-p - 0.4 * v - 0.8 * p**3 + u[t])])
        return u[:, None], (y + 0.002 * rng.standard_normal(n))[:, None]


    def physics():
        return StateSpaceModel(
            oscillator,
            {"k": 0.6, "c": 0.6, "dt": DT},
            state_names=["position", "velocity (latent)"],
            observed=["position"],
            time="discrete",
            n_init=10,
            fixed=("dt",),
        )


    def linear_physics(U, Y, dt):
        """No physics written down: the best linear approximation (N4SID)."""
        from skhybrid.domain import subspace_state_space

        longest = max(range(len(U)), key=lambda i: len(U[i]))
        return subspace_state_space(U[longest], Y[longest], order=2, n_init=10)


    def make_spec(out="out", **kwargs):
        def tests():
            TEST_READS.append((Path(out) / "selection.json").is_file())
            return {"test": record(400, 7)}

        options = dict(
            name="toy-machine",
            records=[record(600, 0), record(440, 1)],
            physics=physics(),
            n_init=10,
            dt=DT,
            tests=tests,
            unit="m",
            hybrids={
                "T=20": {
                    "horizon": 20,
                    "hidden_layer_sizes": (8,),
                    "max_epochs": 3,
                    "batch_size": 16,
                }
            },
        )
        options.update(kwargs)
        return SystemSpec(**options)


    spec = make_spec()
    '''
)


@pytest.fixture
def machine(tmp_path, monkeypatch):
    (tmp_path / "toy_machine.py").write_text(MACHINE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    # joblib's workers are reused across tests: those started by an earlier
    # test lack this folder on their path and could not import the machine;
    # new ones are started with it, as a user's script starts them.
    from joblib.externals.loky import get_reusable_executor

    get_reusable_executor().shutdown(wait=True)
    import importlib

    import toy_machine

    importlib.reload(toy_machine)
    toy_machine.TEST_READS.clear()
    return toy_machine


def _canonical_hash(selection):
    text = json.dumps(selection, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def test_run_system_seals_then_scores_three_seeds(machine, tmp_path, monkeypatch):
    searches = []

    class CountedSearch(_measured_search.SimulationSearchCV):
        def fit(self, U, Y):
            searches.append(self.random_state)
            return super().fit(U, Y)

    monkeypatch.setattr(_measured_search, "SimulationSearchCV", CountedSearch)
    out = tmp_path / "run"
    spec = machine.make_spec(out=out)
    summary = run_system(spec, out, quick=True, n_jobs=1)

    # The test records were read once, after selection.json was written.
    assert machine.TEST_READS == [True]
    sealed = json.loads((out / "selection.json").read_text())
    assert sealed["sha256"] == _canonical_hash(sealed["selection"])
    assert summary["selection_sha256"] == sealed["sha256"]
    assert sealed["sha256"] in (out / "report.html").read_text()

    models = {
        "physics",
        "linear ARX",
        "dense NARX",
        "physics + linear",
        "physics + dense",
        "physics + dense ensemble",
        "state-space hybrid",
    }
    family = models | {"stacked"}
    assert summary["seeds"] == [0, 1, 2]
    # Every model is searched once, at the first seed; the other seeds refit
    # its choice with their own networks' seed. The stack searches nothing: it
    # averages the others' runs.
    assert searches == [0] * len(models)
    assert summary["searched_at_seed"] == 0
    for seed in ("1", "2"):
        for name, fit in summary["fits"][seed].items():
            first = summary["fits"]["0"][name]["selection"]
            assert fit["selection"]["searched_at_seed"] == 0
            assert fit["selection"]["chosen_candidate"] == first["chosen_candidate"]
            assert summary["cv_rmse"][seed][name] == summary["cv_rmse"]["0"][name]
    dense = summary["test_rmse"]["test"]["physics + dense"]["by_seed"]
    assert len(set(dense)) == 3  # a network refitted at each seed
    for seed, chosen in summary["chosen_model"].items():
        validation = summary["validation_rmse"][seed]
        assert set(validation) == family
        assert chosen == min(validation, key=validation.get)
        frozen = sealed["selection"]["seeds"][int(seed)]
        assert frozen["chosen_model"] == chosen
        assert frozen["validation_rmse"] == pytest.approx(validation)
    assert sealed["selection"]["system"]["record_lengths"] == [600, 440]

    chosen = summary["chosen_test_rmse"]["test"]
    assert len(chosen["by_seed"]) == 3 and np.all(np.isfinite(chosen["by_seed"]))
    assert chosen["mean"] == pytest.approx(np.mean(chosen["by_seed"]))
    assert chosen["std"] == pytest.approx(np.std(chosen["by_seed"], ddof=1))
    for seed, name in summary["chosen_model"].items():
        by_seed = summary["test_rmse"]["test"][name]["by_seed"]
        assert chosen["by_seed"][int(seed)] == pytest.approx(by_seed[int(seed)])
    # The physics (no network) is the same at every seed.
    physics = summary["test_rmse"]["test"]["physics"]
    assert physics["std"] == pytest.approx(0.0, abs=1e-12)
    assert summary["physics_params"]["0"]["k"] > 0

    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 1 + 3 * len(family)

    # The stochastic part of the chosen model, at every seed: residual tests on
    # the validation tails and the test record, the noise model fitted on the
    # validation residuals, and its band's coverage of the test record.
    for seed, part in summary["stochastic"].items():
        assert part["model"] == summary["chosen_model"][seed]
        assert part["noise"]["fitted"] and part["noise"]["std"] > 0
        assert 0 <= part["validation"]["ljung_box_pvalue"] <= 1
        assert 0 <= part["tests"]["test"]["coverage"] <= 1
    coverage = summary["band_coverage"]["test"]
    assert len(coverage["by_seed"]) == 3 and 0 <= coverage["mean"] <= 1

    # Every model's CV RMSE by fold at every seed, the mean the choice used, and
    # what the chosen model's test is against it.
    for seed, cv in summary["cv_rmse"].items():
        assert set(cv) == family
        for name, entry in cv.items():
            assert entry["mean"] == pytest.approx(np.mean(entry["by_fold"]))
            assert entry["mean"] == pytest.approx(
                summary["validation_rmse"][seed][name]
            )
        best = summary["chosen_model"][seed]
        assert best == min(cv, key=lambda m: cv[m]["mean"])
        ratio = summary["chosen_test_over_cv"]["test"]["by_seed"][int(seed)]
        test = summary["chosen_test_rmse"]["test"]["by_seed"][int(seed)]
        assert ratio == pytest.approx(test / cv[best]["mean"])
    assert {"physics", "linear ARX", "physics + linear"} <= set(
        summary["deterministic"]
    )

    # The stack: the first seed's weights (fitted on the models' out-of-fold
    # runs) average each seed's own refitted models; its test free run is that
    # average of theirs.
    weights = summary["fits"]["0"]["stacked"]["selection"]["weights"]
    assert set(weights) <= models and sum(weights.values()) == pytest.approx(1.0)
    assert summary["stack_weights"] == weights
    for seed in ("0", "1", "2"):
        assert summary["fits"][seed]["stacked"]["selection"]["weights"] == weights
        stored = np.load(
            out / "models" / f"toy-machine-seed-{seed}" / "test-predictions.npz"
        )
        average = sum(w * stored[f"test/{m}"] for m, w in weights.items())
        np.testing.assert_allclose(stored["test/stacked"], average, rtol=1e-10)
        # Averaged from its members' runs, the stack's own simulation exactly.
        stack = load_fitted(out, seed=int(seed), model="stacked")
        u, y = machine.record(400, 7)
        np.testing.assert_array_equal(
            stored["test/stacked"], np.ravel(stack.simulate(u, y[:10]))
        )

    # The report speaks of this machine and this run, not of benchmarks or seed 0.
    page = (out / "report.html").read_text()
    assert "<title>skhybrid: toy-machine</title>" in page
    assert "measured benchmarks" not in page
    assert "<td>0, 1, 2</td>" in page
    # Fitted parameters with their standard errors; the fixed sample period is a
    # setting, not a fitted parameter.
    assert "k = " in page and "&plusmn;" in page.split("Physics parameters")[1]
    assert "dt = " not in page.split("Physics parameters")[1]
    assert "The stochastic part of the chosen model" in page
    assert "(deterministic)" in page and "test / CV" in page
    assert "band coverage" in page
    # Each residual test read in words, the standard errors' assumption said.
    assert page.count("white at 5 %") >= 2 and "reading (at 5 %)" in page
    assert "conditional on the physics&#x27; structure" in page
    assert "The stack (<code>stacked</code>) averages" in page


def test_the_cli_runs_the_same_spec_by_module_and_object(machine, tmp_path, capsys):
    # The same spec from the shell (one seed here): the same figures as Python.
    argv = ["run", "--system", "toy_machine:spec", "--quick", "--seeds", "0"]
    assert main([*argv, "--no-progress", "--n-jobs", "1", "--out", "out"]) == 0
    printed = capsys.readouterr().out
    assert "sealed selection sha256" in printed and "test: " in printed
    # One seed gives no spread: the figure says so, never "+- 0".
    test_line = next(line for line in printed.splitlines() if "test: " in line)
    assert "+-" not in test_line
    assert "(one seed)" in test_line or "(deterministic)" in test_line
    assert machine.TEST_READS == [True]
    cli = json.loads((tmp_path / "out" / "results.json").read_text())["systems"]
    cli = cli["toy-machine"]

    summary = run_system(
        machine.make_spec(out="py"), "py", quick=True, seeds=[0], n_jobs=1
    )
    assert summary["selection_sha256"] == cli["selection_sha256"]
    for model, spread in summary["test_rmse"]["test"].items():
        assert cli["test_rmse"]["test"][model]["mean"] == pytest.approx(
            spread["mean"], rel=1e-9
        )


def test_cli_spec_errors_are_one_line(machine, tmp_path, capsys):
    cases = [
        (["--system", "toy_machine"], "MODULE:OBJECT"),
        (["--system", "no_such_module:spec"], "cannot import no_such_module"),
        (["--system", "toy_machine:nothing"], "has no nothing"),
        (["--system", "toy_machine:DT"], "not a skhybrid.experiments.SystemSpec"),
        (["pendulum", "--system", "toy_machine:spec"], "give one system"),
        (
            ["--system", "toy_machine:spec", "--seed", "1", "--seeds", "2"],
            "--seed S is the same option",
        ),
        (["pendulum", "--seeds", "1", "2"], "simulated and runs one seed"),
    ]
    for extra, words in cases:
        out = tmp_path / "never"
        assert main(["run", *extra, "--out", str(out)]) == 2, extra
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, (extra, err)
        # A refused run leaves no folder behind...
        assert not out.exists(), extra
    # ... and one that existed before is kept as it was.
    kept = tmp_path / "kept"
    kept.mkdir()
    assert main(["run", "--system", "toy_machine", "--out", str(kept)]) == 2
    assert kept.is_dir() and not any(kept.iterdir())
    assert machine.TEST_READS == []


def test_dataframes_with_a_time_index_give_the_sample_period(machine):
    (u1, y1), (u2, y2) = machine.record(300, 0), machine.record(200, 1)
    frames = [
        pd.DataFrame(
            {"force": u[:, 0], "position": y[:, 0]},
            index=pd.to_timedelta(np.arange(len(u)) * 0.1, unit="s"),
        )
        for u, y in ((u1, y1), (u2, y2))
    ]
    spec = machine.make_spec(
        records=frames, dt=None, inputs=["force"], outputs=["position"]
    )
    U, Y = spec.estimation_records()
    assert [len(u) for u in U] == [300, 200]
    np.testing.assert_array_equal(Y[1], y2)
    assert spec.sample_period() == pytest.approx(0.1)

    with pytest.raises(ValueError, match=r"dt=0\.2 disagrees"):
        machine.make_spec(
            records=frames, dt=0.2, inputs=["force"], outputs=["position"]
        ).estimation_records()
    with pytest.raises(ValueError, match=r"no column\(s\) \['speed'\]"):
        machine.make_spec(
            records=frames, inputs=["force"], outputs=["speed"]
        ).estimation_records()
    with pytest.raises(ValueError, match=r"inputs=\[...\] and outputs"):
        machine.make_spec(records=frames).estimation_records()
    uneven = frames[0].iloc[[0, 1, 3, 4, 5]]
    with pytest.raises(ValueError, match="not uniformly sampled"):
        machine.make_spec(
            records=[uneven], dt=None, inputs=["force"], outputs=["position"]
        ).estimation_records()


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"n_init": 0}, ValueError, "n_init must be an int >= 1; got n_init=0"),
        ({"n_init": 2.5}, TypeError, "n_init must be an int >= 1; got n_init=2.5"),
        ({"dt": -1.0}, ValueError, "dt must be a positive number; got dt=-1.0"),
        ({"name": ""}, ValueError, "name must be a non-empty str"),
        ({"physics": 3}, TypeError, "physics must be an estimator"),
        ({"segments": (0,)}, ValueError, "segments must be 'auto'"),
        ({"hybrids": "all"}, TypeError, "hybrids must be 'auto', None or a dict"),
        ({"tests": [1, 2]}, TypeError, "tests must be a dict"),
        ({"scale": 0}, ValueError, "scale must be positive; got scale=0"),
    ],
)
def test_a_bad_spec_names_the_parameter(machine, kwargs, error, words):
    with pytest.raises(error, match=words.replace("(", r"\(").replace("[", r"\[")):
        machine.make_spec(**kwargs)


def test_a_measured_run_takes_no_noise_type(machine, tmp_path):
    # Its records hold their own noise: refused before the folder is touched.
    with pytest.raises(ValueError, match=r"leave it unset; got noise_type='process'"):
        run_system(machine.make_spec(), tmp_path / "run", noise_type="process")
    assert not (tmp_path / "run").exists()


def test_records_are_checked_before_anything_is_fitted(machine):
    u, y = machine.record(100, 0)
    y_bad = y.copy()
    y_bad[5] = np.nan
    with pytest.raises(ValueError, match=r"records\[1\] holds NaN"):
        machine.make_spec(records=[(u, y), (u, y_bad)]).estimation_records()
    with pytest.raises(ValueError, match="at least 8 \\* n_init = 80 samples"):
        machine.make_spec(records=[(u, y), (u[:50], y[:50])]).estimation_records()
    with pytest.raises(ValueError, match=r"records\[0\] must hold aligned"):
        machine.make_spec(records=[(u, y[:90])]).estimation_records()


def test_the_default_family_scales_with_the_records(machine):
    spec = machine.make_spec(hybrids="auto", segments="auto")
    assert spec.segment_candidates([4000]) == (None, 1000, 250)
    assert spec.segment_candidates([600]) == (None, 150)
    hybrids = spec.hybrid_candidates([4000])
    assert [h["horizon"] for h in hybrids.values()] == [50, 200]
    # A sub-sequence every half horizon on long records; on short ones closer,
    # so that an epoch holds about 500 of them.
    long = spec.hybrid_candidates([40000, 20000])
    assert [h["stride"] for h in long.values()] == [25, 100]
    assert [h["stride"] for h in hybrids.values()] == [8, 8]
    two = spec.hybrid_candidates([300, 300])
    assert [h["stride"] for h in two.values()] == [1, 1]
    # Two records, four pieces: each record is cut in two halves of 150 samples.
    assert [h["horizon"] for h in two.values()] == [50, 65]
    # Short records: the horizon stays below half a piece of the training records.
    assert [h["horizon"] for h in spec.hybrid_candidates([400]).values()] == [40]
    assert machine.make_spec(hybrids=None).hybrid_candidates([4000]) == {}


def test_a_physics_without_equations_gets_no_state_space_hybrid(machine):
    from skhybrid.domain import WienerHammersteinModel

    block = WienerHammersteinModel(order=2)
    # "auto" tries none: the hybrid trains through a StateSpaceModel's equations.
    assert (
        machine.make_spec(physics=block, hybrids="auto").hybrid_candidates([4000]) == {}
    )
    with pytest.raises(ValueError, match="hybrids needs a StateSpaceModel physics"):
        machine.make_spec(physics=block)  # the machine's explicit hybrid


def test_system_spec_is_public_and_documented():
    from skhybrid import benchmarks, experiments

    for name in ("SystemSpec", "run_system"):
        assert name in experiments.__all__
    assert "benchmark_spec" in benchmarks.__all__
    assert "n_init" in SystemSpec.__doc__ and "selection.json" in run_system.__doc__


def test_the_original_protocol_starts_from_the_estimation_records_state(
    machine, tmp_path
):
    spec = machine.make_spec(
        out=tmp_path / "run", hybrids=None, score_from_estimation_start=True
    )
    summary = run_system(spec, tmp_path / "run", quick=True, seeds=[0], n_jobs=1)
    scores = summary["test_rmse"]["test_original_protocol"]
    # Defined for the physics and its corrections; not for the black boxes.
    assert np.isfinite(scores["physics"]["mean"])
    assert np.isfinite(scores["physics + linear"]["mean"])
    assert scores["linear ARX"]["mean"] is None

    # The physics' free run from the state of the first estimation record's start,
    # scored over every sample.
    from skhybrid.experiments.free_run._scoring import _from_estimation_start

    (u0, y0), _ = machine.record(600, 0), None
    u, y = machine.record(400, 7)
    folder = tmp_path / "run" / "models" / "toy-machine-seed-0"
    import joblib

    physics = joblib.load(folder / "physics.joblib")
    x0 = physics.estimator.estimate_initial_state(u0[:10], y0[:10])
    expected = physics.estimator.simulate_from_state(u, x0)
    np.testing.assert_allclose(
        _from_estimation_start(physics, u, u0, y0, 10), np.ravel(expected)
    )
    rmse = np.sqrt(np.mean((np.ravel(expected) - y[:, 0]) ** 2))
    assert scores["physics"]["mean"] == pytest.approx(rmse)


def test_the_original_protocol_runs_the_state_space_hybrid_from_that_state(
    machine, tmp_path
):
    import joblib

    from skhybrid.experiments.free_run._scoring import _from_estimation_start

    spec = machine.make_spec(out=tmp_path / "run", score_from_estimation_start=True)
    summary = run_system(spec, tmp_path / "run", quick=True, seeds=[0], n_jobs=1)
    scores = summary["test_rmse"]["test_original_protocol"]
    assert np.isfinite(scores["state-space hybrid"]["mean"])
    # The corrected model's run from the physics' state at the estimation
    # record's start (the encoder has no window there).
    u0, y0 = machine.record(600, 0)
    u, y = machine.record(400, 7)
    folder = tmp_path / "run" / "models" / "toy-machine-seed-0"
    hybrid = joblib.load(folder / "state-space-hybrid.joblib")
    x0 = hybrid.estimator.estimate_initial_state(u0[:10], y0[:10])
    expected = np.ravel(hybrid.estimator.simulate_from_state(u, x0))
    np.testing.assert_allclose(_from_estimation_start(hybrid, u, u0, y0, 10), expected)
    rmse = np.sqrt(np.mean((expected - y[:, 0]) ** 2))
    assert scores["state-space hybrid"]["mean"] == pytest.approx(rmse)
    # The stack's: its members' runs from that state, averaged with its weights;
    # defined where every member with a weight is.
    stack = joblib.load(folder / "stacked.joblib")
    members = [
        w * _from_estimation_start(m, u, u0, y0, 10)
        for w, m in zip(stack.weights_, stack.estimators_, strict=True)
    ]
    np.testing.assert_allclose(
        _from_estimation_start(stack, u, u0, y0, 10), np.sum(members, axis=0)
    )
    defined = all(np.all(np.isfinite(run)) for run in members)
    assert (scores["stacked"]["mean"] is not None) == defined


def test_a_resumed_run_refuses_records_that_changed(machine, tmp_path):
    out = tmp_path / "run"
    spec = machine.make_spec(out=out, hybrids=None)
    run_system(spec, out, quick=True, seeds=[0], n_jobs=1)
    # The same folder, the same settings, other records of the same lengths.
    changed = machine.make_spec(
        out=out, hybrids=None, records=[machine.record(600, 5), machine.record(440, 6)]
    )
    from skhybrid.experiments.run._store import RunFolderError

    with pytest.raises(RunFolderError, match="fitted on other records"):
        run_system(changed, out, quick=True, seeds=[0], resume=True, n_jobs=1)
    sealed = json.loads((out / "selection.json").read_text())["selection"]
    assert len(sealed["system"]["records_sha256"]) == 64
    # The free runs on the test records are kept beside the models.
    with np.load(out / "models" / "toy-machine-seed-0" / "test-predictions.npz") as f:
        assert "test/physics" in f.files and f["test/physics"].shape == (400,)
    # The seal and the run's identity name the code and the CPU kernels; the
    # identity names the spec, so another physics is not resumed either.
    code = sealed["provenance"]
    assert code["skhybrid"] and code["kernels"]["torch"]
    identity = json.loads((out / "run.json").read_text())["identity"]
    assert identity["commit"] == code["commit"]
    assert identity["kernels"] == code["kernels"] and len(identity["spec"]) == 64
    other = machine.make_spec(
        out=out, hybrids=None, physics=machine.physics().set_params(n_init=12)
    )
    with pytest.raises(RunFolderError, match="finished run") as info:
        run_system(other, out, quick=True, seeds=[0], resume=True, n_jobs=1)
    assert "--resume" not in str(info.value)  # not the same run: nothing to resume


def test_a_physics_that_cannot_be_stored_is_refused_before_any_fit(machine, tmp_path):
    import threading

    lock = threading.Lock()

    def rhs(x, u, *, xp, k, c, dt):  # a closure over a lock: no pickle stores it
        with lock:
            return x

    physics = machine.physics().set_params(rhs=rhs)
    with pytest.raises(TypeError, match=r"spec\.physics cannot be pickled"):
        run_system(
            machine.make_spec(physics=physics), tmp_path / "run", quick=True, n_jobs=1
        )
    assert not (tmp_path / "run").exists()


def test_load_fitted_gives_the_models_the_run_scored(machine, tmp_path):
    from skhybrid.experiments import load_fitted

    out = tmp_path / "run"
    summary = run_system(
        machine.make_spec(out=out), out, quick=True, seeds=[0, 1], n_jobs=1
    )
    u, y = machine.record(400, 7)
    for seed in (0, 1):
        chosen = load_fitted(out, seed=seed)
        pred = chosen.simulate(u, y[:10])
        rmse = np.sqrt(np.mean((np.ravel(pred)[10:] - y[10:, 0]) ** 2))
        assert rmse == pytest.approx(
            summary["chosen_test_rmse"]["test"]["by_seed"][seed]
        )
    physics = load_fitted(out, seed=1, model="physics")
    assert physics.params_["k"] == pytest.approx(summary["physics_params"]["1"]["k"])
    # The public estimator itself, not the run's private wrapper.
    from skhybrid.domain import StateSpaceModel

    assert type(physics) is StateSpaceModel
    # Every model of the family is a public estimator of skhybrid (the stack a
    # StackedSimulation of the others).
    import skhybrid.domain
    import skhybrid.hybrid
    import skhybrid.model_selection

    public = {
        getattr(module, name)
        for module in (skhybrid.domain, skhybrid.hybrid, skhybrid.model_selection)
        for name in module.__all__
    }
    for name in summary["test_rmse"]["test"]:
        model = load_fitted(out, seed=0, model=name)
        assert type(model) in public, (name, type(model))
        pred = model.simulate(u, y[:10])
        assert np.all(np.isfinite(np.ravel(pred)[10:])), name
    with pytest.raises(ValueError, match="seed must be one of the run's seeds"):
        load_fitted(out, seed=5)
    with pytest.raises(ValueError, match="model must be one of"):
        load_fitted(out, model="oracle")
    with pytest.raises(FileNotFoundError, match="no finished run"):
        load_fitted(tmp_path / "nowhere")


def test_several_starts_start_the_physics_from_the_best_short_fit(machine):
    U, Y = [machine.record(600, 0)[0]], [machine.record(600, 0)[1]]
    starts = [{"k": 0.05, "c": 3.0}, {"k": 1.5, "c": 0.4}]
    spec = machine.make_spec(physics_starts=starts, starts_nfev=3)
    physics = spec.make_physics(U, Y, machine.DT)
    # The spec's starts become the physics' own: the first replaces its
    # parameters, the others are its starts, fitted briefly by the model.
    base = machine.physics().params
    assert physics.params == {**base, **starts[0]}
    assert physics.starts == starts[1:] and physics.starts_nfev == 3
    assert not hasattr(physics, "params_")
    # Each start fitted with 3 evaluations: the far one ends worse, and the
    # physics' fit goes on from the better one.
    with pytest.warns(ConvergenceWarning, match="max_nfev=3"):
        short = [
            machine.physics()
            .set_params(params={**base, **st}, max_nfev=3)
            .fit_simulation(U, Y)
            for st in starts
        ]
    assert short[1].result_.cost < short[0].result_.cost
    # Kept short (5 evaluations), the final fit shows where it started.
    from_best = machine.physics().set_params(params=dict(short[1].params_), max_nfev=5)
    alone = machine.physics().set_params(params={**base, **starts[0]}, max_nfev=5)
    physics.set_params(max_nfev=5)
    for model in (from_best, alone, physics):
        with pytest.warns(ConvergenceWarning):
            model.fit_simulation(U, Y)
    assert physics.params_ == pytest.approx(from_best.params_)
    assert physics.rmse_ < alone.rmse_

    with pytest.raises(TypeError, match="physics_starts must be a non-empty list"):
        machine.make_spec(physics_starts={"k": 1.0})
    with pytest.raises(ValueError, match="starts_nfev must be an int >= 1"):
        machine.make_spec(physics_starts=starts, starts_nfev=0)
    with pytest.raises(ValueError, match="not both; the physics has starts="):
        machine.make_spec(
            physics=machine.physics().set_params(starts=[{"k": 1.0}]),
            physics_starts=starts,
        )
    # A callable's physics gets the starts on a copy; its own object is left as is.
    shared = machine.physics()
    made = machine.make_spec(
        physics=lambda U, Y, dt: shared, physics_starts=starts
    ).make_physics(U, Y, machine.DT)
    assert made.starts == starts[1:]
    assert shared.starts is None and shared.params == base
    # A callable's physics is seen when it is made.
    ridge = machine.make_spec(physics=lambda U, Y, dt: Ridge(), physics_starts=starts)
    with pytest.raises(TypeError, match="needs a physics that takes starts"):
        ridge.make_physics(U, Y, machine.DT)


def test_the_starts_run_in_every_fit_of_the_physics(machine, tmp_path):
    import joblib

    out = tmp_path / "run"
    starts = [{"k": 0.05, "c": 3.0}, {"k": 1.5, "c": 0.4}]
    spec = machine.make_spec(out=out, physics_starts=starts, hybrids=None)
    run_system(spec, out, quick=True, seeds=[0], n_jobs=1)
    refit = joblib.load(out / "models" / "toy-machine-seed-0" / "physics.joblib")
    # Each fold's fit and the refit on the whole records start from the spec's
    # starts alike (the first as params, the others as starts): no fit
    # continues from another, so every fold is judged as the refit is made.
    assert refit.estimator.starts == starts[1:]
    assert refit.estimator.params["k"] == starts[0]["k"]


def test_a_black_box_machine_runs_from_its_best_linear_approximation(machine, tmp_path):
    # physics(U, Y, dt) returning subspace_state_space's model: the whole family,
    # the state-space hybrid included, trains around the linear model.
    out = tmp_path / "run"
    spec = machine.make_spec(out=out, physics=machine.linear_physics)
    assert spec.has_hybrids()
    summary = run_system(spec, out, quick=True, seeds=[0], n_jobs=1)
    validation = summary["validation_rmse"]["0"]
    assert np.isfinite(validation["state-space hybrid"])
    assert np.isfinite(validation["physics"])
    assert set(summary["physics_params"]["0"]) >= {"a_0_0", "b_1_0", "c_0_1"}
    test = summary["test_rmse"]["test"]
    # The linear model misses the cubic spring; the networks around it help.
    assert np.isfinite(test["physics"]["mean"])
    best_other = min(v for k, v in validation.items() if k != "physics")
    assert best_other < validation["physics"]
    from skhybrid.experiments import load_fitted

    fitted = load_fitted(out, model="physics")
    u, y = machine.record(400, 7)
    assert np.all(np.isfinite(fitted.simulate(u, y[:10])))


def test_the_spec_hands_its_sample_period_to_a_physics_without_one(machine):
    from skhybrid.domain import StateSpaceModel

    def spring(x, u, *, xp, k, c):
        return xp.stack([x[:, 1], -k * x[:, 0] - c * x[:, 1] + u[:, 0]], axis=1)

    physics = StateSpaceModel(
        spring,
        {"k": 1.0, "c": 0.4},
        state_names=["position", "velocity (latent)"],
        observed=["position"],
        n_init=10,
    )
    spec = machine.make_spec(physics=physics, hybrids=None)
    U, Y = spec.estimation_records()
    made = spec.make_physics(U, Y, spec.sample_period())
    assert made.dt == machine.DT and physics.dt is None  # the user's object kept
    # A physics given its own dt keeps it.
    spec = machine.make_spec(physics=physics.set_params(dt=0.05), hybrids=None)
    assert spec.make_physics(U, Y, spec.sample_period()).dt == 0.05


def test_the_spec_hands_its_initialisation_window_to_a_physics_without_one(machine):
    from skhybrid.domain import StateSpaceModel

    def spring(x, u, *, xp, k, c):
        return xp.stack([x[:, 1], -k * x[:, 0] - c * x[:, 1] + u[:, 0]], axis=1)

    physics = StateSpaceModel(
        spring,
        {"k": 1.0, "c": 0.4},
        state_names=["position", "velocity (latent)"],
        observed=["position"],
    )
    assert physics.n_init is None  # said once, on the spec
    spec = machine.make_spec(physics=physics, hybrids=None, n_init=12)
    U, Y = spec.estimation_records()
    made = spec.make_physics(U, Y, spec.sample_period())
    assert made.n_init == 12 and physics.n_init is None  # the user's object kept
    # A physics given its own window keeps it.
    spec = machine.make_spec(physics=physics.set_params(n_init=7), hybrids=None)
    assert spec.make_physics(U, Y, spec.sample_period()).n_init == 7


def test_a_state_space_model_without_n_init_starts_from_20_samples_alone():
    from skhybrid.domain import StateSpaceModel

    def decay(x, u, *, xp, a):
        return a * x + u

    model = StateSpaceModel(
        decay, {"a": 0.5}, state_names=["x"], observed=["x"], time="discrete"
    )
    u = np.zeros((20, 1))
    with pytest.raises(ValueError, match="not more than n_init=20"):
        model.fit_simulation(u, np.ones((20, 1)))


#: The models of the family built on the physics (and the physics).
ON_PHYSICS = (
    "physics",
    "physics + linear",
    "physics + dense",
    "physics + dense ensemble",
    "state-space hybrid",
)


# About 15 s each on 2 cores. The searches' workers are where the fits were
# fitted again (issue 54): that case runs by default, the others with
# `pytest -m slow`.
@pytest.mark.parametrize(
    "n_jobs, resume",
    [
        pytest.param(1, False, marks=pytest.mark.slow),
        (2, False),
        pytest.param(2, True, marks=pytest.mark.slow),
    ],
    ids=["n_jobs=1", "n_jobs=2", "n_jobs=2, resumed"],
)
def test_the_physics_is_fitted_once_per_fold_for_the_whole_family(
    machine, tmp_path, monkeypatch, n_jobs, resume
):
    import sys

    from skhybrid.experiments._spec import records_digest
    from skhybrid.experiments.free_run import _family as _measured_zoo
    from skhybrid.experiments.free_run import _system as _measured_system
    from skhybrid.experiments.free_run._system import MeasuredSystem

    # The equations written in the user's script (``__main__``), as
    # docs/own_machine.md shows: the workers receive them by value.
    monkeypatch.setattr(machine.oscillator, "__module__", "__main__")
    monkeypatch.setattr(
        sys.modules["__main__"], "oscillator", machine.oscillator, raising=False
    )
    # Every fit of the physics, in this process or in a worker (the zoo's fit
    # function travels to the workers by value, with the log's path).
    log = tmp_path / "physics-fits.log"
    fit_physics = _measured_zoo._fit_physics

    def counting(segment, U, Y, ctx, deps, start):
        with open(log, "a") as f:
            f.write(f"{segment} {records_digest(U, Y)}\n")
        return fit_physics(segment, U, Y, ctx, deps, start)

    monkeypatch.setattr(_measured_zoo, "_fit_physics", counting)
    family = MeasuredSystem.model_zoo
    monkeypatch.setattr(
        MeasuredSystem,
        "model_zoo",
        lambda self, settings: {
            name: model
            for name, model in family(self, settings).items()
            if name in ON_PHYSICS
        },
    )
    out = tmp_path / "run"
    spec = machine.make_spec(out=out, segments=(None, 100))
    if resume:  # Ctrl-C once the physics and its linear correction are kept
        fit_model = _measured_system.fit_model

        def interrupted(name, *args, **kwargs):
            if name == "physics + dense":
                raise KeyboardInterrupt
            return fit_model(name, *args, **kwargs)

        monkeypatch.setattr(_measured_system, "fit_model", interrupted)
        with pytest.raises(KeyboardInterrupt):
            run_system(spec, out, quick=True, seeds=[0, 1], n_jobs=n_jobs)
        monkeypatch.setattr(_measured_system, "fit_model", fit_model)
    summary = run_system(
        spec, out, quick=True, seeds=[0, 1], n_jobs=n_jobs, resume=resume
    )
    assert set(summary["fits"]["1"]) == set(ON_PHYSICS)
    # Two seeds, and four models built on the physics, on any number of
    # workers and across a resume: still each segment candidate fitted once on
    # each fold's pieces, and the chosen one once on the whole records.
    fits = log.read_text().splitlines()
    n_folds = summary["fits"]["0"]["physics"]["selection"]["cv_folds"]
    assert len(fits) == len(set(fits)) == 1 * n_folds + 1  # quick: one segment
    assert summary["chosen_model"]["0"] == min(
        summary["validation_rmse"]["0"], key=summary["validation_rmse"]["0"].get
    )


def test_run_system_shows_progress_by_default(machine, tmp_path, capsys, monkeypatch):
    from skhybrid.experiments.run import _runner

    bars = []

    class Recorded(_runner.ProgressBars):
        def close(self):
            bars.append((self.n_epochs, self.sink.count()))
            super().close()

    monkeypatch.setattr(_runner, "ProgressBars", Recorded)
    out = tmp_path / "run"
    run_system(
        machine.make_spec(out=out, hybrids=None), out, quick=True, seeds=[0], n_jobs=1
    )
    err = capsys.readouterr().err
    # Not a terminal here: a line per finished model, as the command line shows.
    for model in ("physics", "linear ARX", "physics + dense ensemble"):
        assert model in err
    # The epoch bar's total is known from the start: 4 folds and a refit of
    # the dense NARX (15 epochs), of the two windows of physics + dense, and of
    # the ensemble's three networks; every epoch trained is within it.
    [(total, trained)] = bars
    assert total == (4 * 15 + 15) + (4 * 2 * 15 + 15) + (4 * 45 + 45)
    assert 0 < trained <= total


def test_the_epoch_total_counts_folds_candidates_and_refits(machine):
    from skhybrid.experiments.free_run._system import MeasuredSystem, _context

    spec = machine.make_spec(
        hybrids={
            "T=20": {"horizon": 20, "max_epochs": 7},
            "T=40": {"horizon": 40, "max_epochs": 5},
        }
    )
    system = MeasuredSystem.from_spec(spec)
    result = system.new_result(RunSettings(), None)
    models = system.model_zoo(result.settings)
    ctx = _context(result)
    # Full settings: 60-epoch networks, three correction windows, both hybrids.
    per_model = {"dense NARX": [60], "physics + dense": [60, 60, 60]}
    per_model |= {"physics + dense ensemble": [180], "state-space hybrid": [7, 5]}
    expected = sum(4 * sum(e) + max(e) for e in per_model.values())
    assert _measured_zoo.epochs_at_most(models, ctx) == expected
    assert system.epochs_at_most(models, result) == expected
    # A model whose search was made at another seed only refits its choice.
    searched = {"dense NARX", "state-space hybrid"}
    assert _measured_zoo.epochs_at_most(models, ctx, searched) == expected - (
        4 * 60 + 4 * 12
    )
    # A model without networks adds nothing; one record too short for four
    # blocks of 8 initialisation windows folds fewer times.
    assert _measured_zoo.epochs_at_most({"physics": models["physics"]}, ctx) == 0
    short = _context(result)
    short = type(short)(**{**short.__dict__, "U": [ctx.U[0][:200]]})
    n_folds = _measured_zoo.RecordBlockSplit(4, n_init=10).get_n_splits(short.U)
    assert n_folds < 4
    only = {"dense NARX": models["dense NARX"]}
    assert _measured_zoo.epochs_at_most(only, short) == n_folds * 60 + 60


def test_device_puts_every_network_of_a_run_there(machine, tmp_path, monkeypatch):
    # No GPU here: the run asks for "cuda"; where its networks would be moved
    # is recorded, and they stay on the CPU.
    from skhybrid.experiments.run import _run_system

    placed = []

    def record(estimator, device):
        placed.append((type(estimator).__name__, device))
        return on_device(estimator, "cpu")

    monkeypatch.setattr(_run_system, "check_device", lambda device: None)
    monkeypatch.setattr(_measured_zoo, "on_device", record)
    out = tmp_path / "run"
    spec = machine.make_spec(out=out)
    run_system(spec, out, quick=True, seeds=[0], n_jobs=1, device="cuda")
    kinds = {kind for kind, _ in placed}
    assert {device for _, device in placed} == {"cuda"}
    assert {"NARXSimulator", "StateSpaceHybridRegressor"} <= kinds
    # Another device is another run: its identity says so.
    run = json.loads((out / "run.json").read_text())
    assert run["identity"]["settings"]["device"] == "cuda"


@pytest.mark.skipif(
    __import__("torch").cuda.is_available(), reason="this machine has CUDA"
)
def test_device_cuda_without_a_gpu_is_refused_before_the_folder(machine, tmp_path):
    out = tmp_path / "run"
    with pytest.raises(ValueError, match="device='cuda' but torch finds no CUDA"):
        run_system(machine.make_spec(out=out), out, quick=True, device="cuda")
    assert not out.exists()
    with pytest.raises(ValueError, match="device must be one of"):
        run_system(machine.make_spec(out=out), out, quick=True, device="tpu")


def test_on_device_reaches_the_networks_inside_a_model():
    from sklearn.ensemble import VotingRegressor

    from skhybrid.neural import DenseRegressor

    model = VotingRegressor([("a", DenseRegressor()), ("b", DenseRegressor())])
    assert on_device(model, "cuda") is model
    assert {m.device for _, m in model.estimators} == {"cuda"}
    settings = RunSettings(device="cuda")
    assert settings.to_dict()["device"] == "cuda"
    assert "device" not in RunSettings().to_dict()  # identities as before
    with pytest.raises(ValueError, match="device must be one of"):
        RunSettings(device="gpu")


@pytest.mark.gpu
def test_a_run_on_the_gpu_trains_its_networks_there(machine, tmp_path):
    import torch

    if not torch.cuda.is_available():
        pytest.skip("needs CUDA")
    out = tmp_path / "run"
    summary = run_system(
        machine.make_spec(out=out), out, quick=True, seeds=[0], device="cuda"
    )
    assert np.isfinite(summary["chosen_test_rmse"]["test"]["mean"])
    hybrid = load_fitted(out, model="state-space hybrid").estimator
    assert hybrid.device == "cuda"


def test_the_paper_zoo_at_a_device_has_every_network_there():
    from skhybrid.experiments import get_system, model_zoo

    zoo = model_zoo(get_system("pendulum"), RunSettings(quick=True, device="cuda"))
    devices = {
        name: {
            value
            for key, value in model.get_params(deep=True).items()
            if key == "device" or key.endswith("__device")
        }
        for name, model in zoo.items()
    }
    assert devices["dense"] == devices["physics+rnn (ljung-box)"] == {"cuda"}
    assert devices["ensemble"] == {"cuda"}
    assert all(found in (set(), {"cuda"}) for found in devices.values())


@pytest.mark.skipif(
    __import__("torch").cuda.is_available(), reason="this machine has CUDA"
)
def test_the_cli_refuses_device_cuda_without_a_gpu_in_one_line(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "pendulum", "--quick", "--device", "cuda", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    expected = (
        "skhybrid: error: --device cuda: device='cuda' but torch finds no CUDA "
        "device (torch.cuda.is_available() is False); use device='cpu'."
    )
    assert err == [expected]
    assert not out.exists()
