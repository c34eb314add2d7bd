"""The `skhybrid` command: arguments, and the quick pendulum run end to end."""

import csv
import json
import re

import pytest

from skhybrid.cli import main

MODELS = [
    "oracle",
    "physics (frozen)",
    "physics (refit)",
    "linear",
    "dense",
    "rnn",
    "cyclic",
    "physics+linear",
    "physics+dense",
    "physics+rnn (mse)",
    "physics+rnn (ljung-box)",
    "physics+cyclic",
    "ensemble",
]


def test_list(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("pendulum", "double-pendulum", "dc-motor"):
        assert re.search(rf"^{name}\s", out, re.MULTILINE)


def test_help_explains_run(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for word in ("--quick", "--out", "--n-jobs", "--seed", "pendulum", "all"):
        assert word in out


@pytest.mark.parametrize(
    "argv, reason",
    [
        ([], "the following arguments are required"),
        (["fly"], "invalid choice: 'fly'"),
        (["run", "pendle"], "invalid choice: 'pendle'"),
        (["run", "pendulum", "--n-jobs", "0"], "got '0'"),
        (
            ["run", "pendulum", "--seed", "-3"],
            "between 0 and 4294967295 (2**32 - 1), got '-3'",
        ),
        (
            ["run", "pendulum", "--seed", str(2**32)],
            f"between 0 and 4294967295 (2**32 - 1), got '{2**32}'",
        ),
        (["run", "pendulum", "--resume", "--overwrite"], "not allowed with"),
        (["run", "pendulum", "--out", ""], "expected a folder, got an empty path"),
        (["run", "pendulum", "--quik"], "unrecognized arguments: --quik"),
        (["run", "pendulum", "--noise-type", "sensor"], "invalid choice: 'sensor'"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(capsys, argv, reason):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert reason in err


@pytest.mark.parametrize(
    "argv, reason",
    [
        (["run", "pendulum", "--seeds", "1", "2"], "simulated and runs one seed"),
        (["run", "emps", "--seed", "1", "--seeds", "2"], "--seed S is the same"),
    ],
)
def test_one_seed_option(capsys, tmp_path, argv, reason):
    # --seeds is the one option; --seed S still works, as --seeds S.
    assert main([*argv, "--out", str(tmp_path / "r")]) == 2
    assert reason in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    import matplotlib
    import matplotlib.pyplot as plt

    out = tmp_path_factory.mktemp("quick")
    backend = matplotlib.get_backend()
    users_figure = plt.figure()  # a user's own plotting session
    status = main(
        [
            "run",
            "pendulum",
            "--quick",
            "--out",
            str(out),
            "--no-progress",
            "--n-jobs",
            "1",
        ]
    )
    assert status == 0
    # write_report draws with the Figure API: the user's session is left alone.
    assert matplotlib.get_backend() == backend
    assert plt.get_fignums() == [users_figure.number]
    plt.close(users_figure)
    return out


def test_quick_run_reports_the_chosen_models_stochastic_part(quick_run):
    # The model chosen on the validation split (new episodes no fit read) is
    # the refit physics, the true equations: under the simulator's white
    # measurement noise its band covers close to 95 % of each test split.
    system = json.loads((quick_run / "results.json").read_text())["systems"]["pendulum"]
    part = system["stochastic"]
    scores = part["validation_rmse_over_oracle"]
    assert part["model"] == min(scores, key=scores.get) == "physics (refit)"
    assert set(scores) == set(MODELS) - {"oracle"}
    for output, entry in part["outputs"].items():
        assert entry["noise"]["fitted"]
        assert entry["noise"]["std"] == pytest.approx(0.01, rel=0.6), output
        assert 0 <= entry["validation"]["ljung_box_pvalue"] <= 1
        for split in ("interpolation", "extrapolation"):
            assert entry["tests"][split]["coverage"] == pytest.approx(0.95, abs=0.03)
    report = (quick_run / "report.html").read_text()
    assert "The stochastic part of the chosen model" in report
    assert (quick_run / "pendulum_band.png").is_file()
    # The validation split is no test split: it has no rows of its own.
    rows = (quick_run / "results.csv").read_text()
    assert ",validation," not in rows


def test_quick_run_writes_results(quick_run):
    with (quick_run / "results.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert {r["model"] for r in rows} == set(MODELS)
    assert {r["split"] for r in rows} == {"interpolation", "extrapolation"}
    assert {r["output"] for r in rows} == {"cos_theta", "sin_theta", "theta_dot"}
    assert len(rows) == len(MODELS) * 2 * 3
    for r in rows:
        assert float(r["rmse"]) > 0
        assert 0 <= float(r["ljung_box_pvalue"]) <= 1
    oracle = [r for r in rows if r["model"] == "oracle"]
    assert all(float(r["rmse_over_oracle"]) == pytest.approx(1.0) for r in oracle)
    # The refit physics is the true model: it matches the oracle closely.
    refit = [r for r in rows if r["model"] == "physics (refit)"]
    assert all(float(r["rmse_over_oracle"]) < 1.05 for r in refit)

    report = json.loads((quick_run / "results.json").read_text())
    system = report["systems"]["pendulum"]
    assert system["settings"]["n_train"] == 3000
    assert system["params"]["physics (refit)"]["mass"]["value"] == pytest.approx(
        1.0, abs=0.05
    )
    assert system["params"]["physics (frozen)"]["mass"]["value"] == 5.0
    # Fixed parameters were not fitted: no standard error, shown as fixed.
    assert system["params"]["physics (frozen)"]["mass"]["fixed"] is True
    assert system["params"]["physics (frozen)"]["mass"]["std"] is None
    assert system["params"]["ensemble"]["length"]["fixed"] is False
    assert system["params"]["physics+dense"]["length"]["value"] == 10.0
    assert system["params"]["ensemble"]["length"]["std"] is not None
    assert len(system["claims"]) == 2
    # The claims are about the full run: on quick settings they are not judged.
    assert all(c["passed"] is None for c in system["claims"])
    assert all(
        c["detail"].startswith("not evaluated on quick settings")
        for c in system["claims"]
    )
    assert system["hull_outside_share"]["extrapolation"] > 0
    # The pendulum's default is the paper's measurement noise, and the report
    # says so beside a whiteness table that includes the oracle.
    assert system["noise_type"] == "measurement"
    assert system["noise"] == [0.01, 0.01, 0.01]
    html = (quick_run / "report.html").read_text()
    assert "measurement noise (standard deviation cos_theta 0.01" in html
    assert "<h3>Whiteness</h3>" in html
    assert "<td>oracle</td>" in html
    assert report["environment"]["wall_time_s"] > 0
    for name, fit in system["fits"].items():
        assert fit["fit_time"] >= 0, name


def test_quick_run_writes_figures_and_self_contained_html(quick_run):
    pngs = sorted(p.name for p in quick_run.glob("*.png"))
    assert "pendulum_rmse_interpolation.png" in pngs
    assert "pendulum_rmse_extrapolation.png" in pngs
    assert sum(name.startswith("pendulum_acf_") for name in pngs) == 3
    page = (quick_run / "report.html").read_text()
    assert page.count("src='data:image/png;base64,") == len(pngs)
    assert "Total wall time" in page and "Fitted physical parameters" in page
    assert "http" not in page  # nothing fetched from elsewhere


def test_report_renders_in_headless_chromium(quick_run, tmp_path, rendered_dom):
    probe = tmp_path / "probe.html"
    probe.write_text(
        (quick_run / "report.html")
        .read_text()
        .replace(
            "</body>",
            "<script>window.addEventListener('load', () => {"
            "const ok = [...document.images].filter("
            "i => i.complete && i.naturalWidth > 100).length;"
            "document.body.setAttribute('data-rendered', ok);});</script></body>",
        )
    )
    stdout, stderr = rendered_dom(probe)
    match = re.search(r'data-rendered="(\d+)"', stdout)
    assert match, stderr[-2000:]
    assert int(match.group(1)) == len(list(quick_run.glob("*.png")))


def test_missing_requirement_stops_before_training(monkeypatch, capsys, tmp_path):
    # A fresh environment without matplotlib once trained every model and then
    # died writing the report; the check must come before any training.
    import importlib.util

    from skhybrid import experiments

    real_find_spec = importlib.util.find_spec

    def find_spec(name, *args, **kwargs):
        return None if name == "matplotlib" else real_find_spec(name, *args, **kwargs)

    def no_training(*args, **kwargs):  # pragma: no cover - must not be reached
        raise AssertionError("training started before the requirement check")

    monkeypatch.setattr(importlib.util, "find_spec", find_spec)
    monkeypatch.setattr(experiments, "run_experiment", no_training)
    assert main(["run", "pendulum", "--quick", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    expected = (
        "skhybrid: error: `skhybrid run` needs matplotlib, which is not "
        "installed; install it with `pip install matplotlib`"
    )
    assert err == [expected]
    assert not (tmp_path / "r").exists()


def test_the_catalogue_names_every_built_in_system():
    from skhybrid import benchmarks
    from skhybrid.experiments import MEASURED_SYSTEMS, SYSTEMS

    assert list(benchmarks.SIMULATED) == list(SYSTEMS)
    assert list(benchmarks.MEASURED) == list(MEASURED_SYSTEMS)
    for name, module in benchmarks.MEASURED.items():
        system = MEASURED_SYSTEMS[name]
        assert (system.name, system.title, system.unit) == (
            module.NAME,
            module.TITLE,
            module.UNIT,
        )
        assert callable(module.make_spec) and module.NOTES


@pytest.mark.parametrize(
    "system, noise_type, expected",
    [
        ("double-pendulum", None, "process"),
        ("double-pendulum", "measurement", "measurement"),
        ("pendulum", None, "measurement"),
        ("dc-motor", "process", "process"),
    ],
)
def test_noise_type_reaches_the_simulated_splits(system, noise_type, expected):
    from skhybrid.experiments import RunSettings

    settings = RunSettings(quick=True, noise_type=noise_type)
    small = _small(system, n_train=300, n_test=200)
    splits = small.make_splits(settings)
    assert {data.noise_type for data in splits.values()} == {expected}
    assert small.noise_type(settings) == expected


def _small(system, **sizes):
    """A built-in one-step system whose quick run has ``sizes``."""
    from dataclasses import replace

    from skhybrid.experiments import SYSTEMS
    from skhybrid.experiments._registry import get_system

    spec = SYSTEMS[system].spec
    quick = replace(spec.protocol.quick_sizes, **sizes)
    return get_system(replace(spec, protocol=replace(spec.protocol, quick_sizes=quick)))


@pytest.mark.parametrize("system", ["pendulum", "double-pendulum", "dc-motor"])
def test_every_seed_numpy_takes_makes_the_splits(system):
    # The test and validation splits' seeds are offsets of the run's: at the
    # top of numpy's range they wrap around instead of overflowing it.
    from skhybrid.experiments import RunSettings

    small = _small(system, n_train=60, n_test=40)
    settings = RunSettings(quick=True, seed=2**32 - 1)
    splits = small.make_splits(settings)
    assert {name: len(data.X) for name, data in splits.items()} == {
        name: 60 if name == "train" else 40 for name in splits
    }
    assert len(small.validation_split(settings).X) == 40
    # An ordinary seed's splits are unchanged: seed + 1000 and seed + 2000.
    assert small.split_seed(RunSettings(quick=True, seed=3), 1000) == 1003
