"""Measured systems: grey-box physics, the official protocol, and ``skhybrid run``."""

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from skhybrid.cli import main
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.experiments._greybox import (
    OutputErrorModel,
    emps_output,
    emps_step,
    simulate_batch,
    tanks_output,
    tanks_step,
)
from skhybrid.experiments._measured import (
    MEASURED_SYSTEMS,
    PUBLISHED,
    _rmse,
    _windows,
    run_measured,
)


def _emps_model(**kwargs):
    # About 20 % off the truth of the test below.
    return OutputErrorModel(
        emps_step,
        emps_output,
        {"M": 80.0, "Fv": 170.0, "Fc": 17.0, "offset": -2.0},
        bounds={"M": (1.0, 1e3), "Fv": (0.0, 1e4), "Fc": (0.0, 1e3)},
        x0=[0.0, 0.0],
        state_names=["position", "velocity"],
        x0_from_y=lambda y: np.array([y[0], 0.0]),
        **kwargs,
    )


def test_output_error_fit_recovers_the_emps_parameters():
    """Simulated axis: the simulation-error fit finds M, Fv, Fc and the offset."""
    rng = np.random.default_rng(0)
    n = 3000
    t = np.arange(n) * 1e-3
    u = np.sin(2 * np.pi * 1.5 * t) + 0.5 * np.sin(2 * np.pi * 15.1 * t + 1.0)
    u = u[:, None]
    u += 0.1 * rng.standard_normal(u.shape)
    truth = np.array([[95.0, 200.0, 20.0, -3.0]])
    y = simulate_batch(emps_step, emps_output, truth, [[0.0, 0.0]], u)[0]
    model = _emps_model(max_nfev=100).fit(u, y[:, None])
    fitted = np.array(list(model.params_.values()))
    assert_allclose(fitted, truth[0], rtol=2e-2, atol=0.05)
    assert model.rmse_ < 1e-5
    assert set(model.params_std_) == set(model.params_)
    # The latent velocity is estimated from the initialisation window alone.
    sim = model.simulate(u[1000:], y[1000:1020])
    assert sim.shape == (2000, 1)
    # An integrating plant: a 20-sample window leaves a small velocity error.
    assert _rmse(y[1000:], sim, 20) < 0.05 * np.ptp(y[1000:])


def test_tanks_overflow_caps_the_upper_level():
    p = np.array([[0.05, 0.05, 0.05, 0.5, 3.0, 0.5, 0.0, 0.0, 0.0]])
    u = np.full((200, 1), 10.0)
    x = np.array([[2.9, 1.0]])
    levels = []
    for t in range(len(u)):
        x = tanks_step(x, u[t, 0], p)
        levels.append(x[0, 0])
    assert max(levels) <= 3.0 + 1e-12
    # The lower tank's sensor clips at 10 V.
    assert tanks_output(np.array([[1.0, 50.0]]), p)[0] == 10.0


def test_diverging_physics_raises():
    model = _emps_model()
    # Negative damping: the velocity triples every step and overflows later on.
    model.params_ = {"M": 1.0, "Fv": -2000.0, "Fc": 0.0, "offset": 0.0}
    model.x0_ = np.zeros(2)
    with pytest.raises(SimulationDivergedError, match="step"):
        model.simulate(np.ones((5000, 1)), np.zeros(20) + 1e-3)


def test_windows_are_causal_and_edge_padded():
    a = np.arange(5.0)
    X = _windows([a, 10 * a], 3)
    assert X.shape == (5, 6)
    # Row t holds a(t-2), a(t-1), a(t), then the second column's window.
    assert_allclose(X[4], [2, 3, 4, 20, 30, 40])
    assert_allclose(X[0], [0, 0, 0, 0, 0, 0])


def test_published_figures_are_data_with_sources():
    assert set(PUBLISHED) == set(MEASURED_SYSTEMS)
    assert PUBLISHED["emps"]["test"]["state of the art (dynoNet)"][0] == 2.64
    assert PUBLISHED["cascaded-tanks"]["test"]["linear (LTI SS)"][0] == 0.588
    for splits in PUBLISHED.values():
        for table in splits.values():
            for value, source in table.values():
                assert value > 0 and source


def test_run_without_data_says_what_to_pass(capsys, tmp_path):
    assert main(["run", "emps", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "--data DIR" in err and "emps" in err


def test_unknown_system_is_refused(tmp_path):
    with pytest.raises(ValueError, match="name must be one of"):
        run_measured("tanks", tmp_path, tmp_path)


@pytest.mark.slow
def test_cascaded_tanks_quick_run(shared_data_dir, tmp_path):
    """The whole pipeline on real data, by the official protocol."""
    out = tmp_path / "tanks"
    code = main(
        [
            "run",
            "cascaded-tanks",
            "--quick",
            "--data",
            str(shared_data_dir),
            "--out",
            str(out),
            "--no-progress",
        ]
    )
    assert code == 0
    results = json.loads((out / "results.json").read_text())
    assert results["n_init"] == 50 and results["unit"] == "V"
    rmse = results["test_rmse"]["test"]
    # The grey-box physics simulates better than the published linear model.
    assert rmse["physics"] < 0.588
    assert set(rmse) >= {"physics", "linear ARX", "dense NARX", "physics + dense"}
    assert (out / "report.html").read_text().count("Champneys") >= 2
    assert (out / "cascaded-tanks.png").stat().st_size > 10_000
    # A second run into the same folder is refused without --overwrite.
    again = [
        "run",
        "cascaded-tanks",
        "--quick",
        "--data",
        str(shared_data_dir),
        "--out",
        str(out),
    ]
    assert main(again) == 2
