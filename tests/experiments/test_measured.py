"""Measured systems: grey-box physics, the official protocol, and ``skhybrid run``."""

import functools
import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sklearn.exceptions import ConvergenceWarning

from skhybrid.benchmarks import MEASURED, PUBLISHED
from skhybrid.benchmarks.cascaded_tanks import physics as tanks_physics
from skhybrid.benchmarks.cascaded_tanks import tanks, tanks_output
from skhybrid.benchmarks.emps import physics as emps_physics
from skhybrid.benchmarks.silverbox import INTERSAMPLE, with_next_input
from skhybrid.benchmarks.silverbox import physics as silverbox_physics
from skhybrid.cli import main
from skhybrid.exceptions import IdentifiabilityWarning, SimulationDivergedError
from skhybrid.experiments.free_run._family import _records, _rmse
from skhybrid.experiments.run._fitting import fit_segments
from skhybrid.experiments.run._run_system import run_measured
from skhybrid.hybrid._correction import _windows

TRUTH = {"M": 95.0, "Fv_pos": 167.0, "Fv_neg": 240.0, "Fc_pos": 20.0, "Fc_neg": 21.0}


def _emps_data(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    u = np.sin(2 * np.pi * 1.5 * t) + 0.5 * np.sin(2 * np.pi * 15.1 * t + 1.0)
    u = u[:, None] + 0.1 * rng.standard_normal((n, 1))
    truth = emps_physics(1e-3).set_params(
        params={**emps_physics(1e-3).params, **TRUTH},
        fixed=tuple(emps_physics(1e-3).params),
    )
    y = truth.fit_simulation(u, np.zeros((n, 1))).simulate_from_state(u, [0.0, 0.0])
    return u, y


def _emps_start(**kwargs):
    # About 20 % off the truth.
    model = emps_physics(1e-3, **kwargs)
    start = {
        "M": 80.0,
        "Fv_pos": 140.0,
        "Fv_neg": 200.0,
        "Fc_pos": 17.0,
        "Fc_neg": 17.0,
    }
    return model.set_params(params={**model.params, **start})


@pytest.mark.parametrize("vectorized", [False, True])
def test_simulation_error_fit_recovers_the_emps_parameters(vectorized):
    """Simulated axis: the output-error fit finds M and each direction's friction."""
    u, y = _emps_data()
    model = _emps_start(max_nfev=100).set_params(vectorized=vectorized)
    model.fit_simulation([u[:1500], u[1500:]], [y[:1500], y[1500:]])
    fitted = np.array([model.params_[k] for k in TRUTH])
    assert_allclose(fitted, list(TRUTH.values()), rtol=1e-4)
    assert model.rmse_ < 1e-8
    assert model.params_std_["gtau"] == 0.0 and model.params_std_["M"] < 1e-3
    # The latent velocity is estimated from the initialisation window alone.
    sim = model.simulate(u[1000:], y[1000:1020])
    assert sim.shape == (2000, 1)
    assert _rmse(y[1000:], sim, 20) < 1e-3 * np.ptp(y[1000:])


def test_vectorized_jacobian_matches_the_sequential_one():
    """One batched simulation gives the Jacobian of one simulation per parameter."""
    u, y = _emps_data(n=800)
    # Two evaluations each: enough to compare the Jacobians, not to converge.
    with pytest.warns(ConvergenceWarning, match="max_nfev=2"):
        fits = [
            _emps_start(max_nfev=2).set_params(vectorized=v).fit_simulation(u, y)
            for v in (False, True)
        ]
    assert_allclose(
        [fits[1].params_[k] for k in TRUTH],
        [fits[0].params_[k] for k in TRUTH],
        rtol=1e-6,
    )
    assert_allclose(
        [fits[1].params_std_[k] for k in TRUTH],
        [fits[0].params_std_[k] for k in TRUTH],
        rtol=1e-3,
    )


def test_vectorized_needs_scalar_parameters():
    model = _emps_start().set_params(vectorized=True)
    model.set_params(params={**model.params, "M": [95.0, 96.0]})
    u, y = _emps_data(n=200)
    with pytest.raises(ValueError, match="must be a scalar"):
        model.fit_simulation(u, y)


def test_tanks_overflow_caps_both_levels():
    p = {
        "k1": 0.05,
        "k2": 0.05,
        "k3": 0.05,
        "k4": 0.5,
        "k5": 0.0,
        "k6": 0.0,
        "u0": 0.0,
        "x1max": 3.0,
        "kof": 0.5,
        "y_offset": 0.0,
        "zmax": 9.5,
        "dt": 4.0,
        "n_sub": 4,
    }
    x = np.array([[2.9, 1.0]])
    levels = []
    for _ in range(200):
        x = tanks(x, np.full((1, 1), 10.0), xp=np, **p)
        levels.append(x[0])
    levels = np.array(levels)
    assert levels[:, 0].max() <= 3.0 + 1e-12
    # The lower tank fills up to its brim and overflows there: water is lost,
    # its level stays at zmax while the inflow lasts.
    assert levels[:, 1].max() == pytest.approx(9.5) and levels[-1, 1] == 9.5
    assert np.all(np.diff(levels[:, 1]) >= -1e-12)
    # The lower tank's sensor clips at 10 V.
    assert tanks_output(np.array([[1.0, 50.0]]), xp=np)[0, 0] == 10.0
    assert tanks_physics(4.0).n_init == 50


def test_tanks_pump_inflow_is_affine_and_levels_below_an_outlet_keep_gradients():
    torch = pytest.importorskip("torch")
    p = {k: v for k, v in tanks_physics(4.0).params.items()}
    p.update(k1=0.05, k2=0.05, k5=0.0, k6=0.0, u0=2.0, y_offset=3.0)
    # Below u0 the pump's net flow is negative: the upper tank drains faster
    # than its outlet alone would drain it.
    x = np.array([[4.0, 5.0], [4.0, 5.0]])
    u = np.array([[1.0], [2.0]])
    nxt = tanks(x, u, xp=np, **p)
    assert nxt[0, 0] < nxt[1, 0] < 4.0
    # A lower level below its outlet (z < y_offset) and an empty upper tank:
    # the square roots' gradients are finite (a NaN here made a hybrid's
    # training diverge).
    xt = torch.tensor([[0.0, 2.5]], dtype=torch.float64, requires_grad=True)
    params = {
        k: torch.tensor(float(v), dtype=torch.float64, requires_grad=True)
        for k, v in p.items()
        if k not in ("dt", "n_sub")
    }
    out = tanks(
        xt,
        torch.tensor([[1.0]], dtype=torch.float64),
        xp=torch,
        dt=4.0,
        n_sub=4,
        **params,
    )
    out.sum().backward()
    grads = [xt.grad] + [v.grad for v in params.values()]
    assert all(bool(torch.isfinite(g).all()) for g in grads)


@pytest.mark.parametrize("intersample", sorted(INTERSAMPLE))
def test_silverbox_duffing_is_found_one_step_ahead_then_by_segments(intersample):
    """The equation-error start and the segment fit recover a known Duffing."""
    dt = 2**14 / 1e7
    rng = np.random.default_rng(1)
    u = np.convolve(rng.standard_normal(3000), np.ones(4) / 4, mode="same")[:, None]
    u = 0.2 * u
    truth = {"g": 1.9e5, "d": 41.0, "k1": 1.85e5, "k2": -6.4e3, "k3": 7.5e5, "c": -1e3}
    make = functools.partial(silverbox_physics, intersample=intersample)
    exact = make(dt, u, np.zeros((3000, 1))).set_params(
        params=truth, fixed=tuple(truth)
    )
    v = INTERSAMPLE[intersample][1](u)
    y = exact.fit_simulation(v, np.zeros((3000, 1))).simulate_from_state(v, [0, 0])
    model = make(dt, u, y, max_nfev=30)
    start = model.params
    assert abs(start["k1"] / truth["k1"] - 1) < 0.2
    model = fit_segments(model, v, y, 500)
    assert_allclose([model.params_[k] for k in truth], list(truth.values()), rtol=1e-3)
    assert model.rmse_ < 1e-6 * np.ptp(y)


def test_silverbox_physics_reads_the_input_between_samples_as_told():
    """Fed the same samples, the two physics differ only between the samples."""
    dt = 2**14 / 1e7
    u = 0.05 * np.sin(2 * np.pi * 0.13 * np.arange(400))[:, None]
    y = np.zeros((400, 1))
    params = {"g": 1.9e5, "d": 41.0, "k1": 1.85e5, "k2": 0.0, "k3": 0.0, "c": 0.0}
    runs = {}
    for mode, (points, inputs) in INTERSAMPLE.items():
        model = silverbox_physics(dt, u, y, intersample=mode)
        assert model.input_points == points
        model.set_params(params=params, fixed=tuple(params))
        model.fit_simulation(inputs(u), y)
        runs[mode] = np.ravel(model.simulate_from_state(inputs(u), [0, 0]))
    # A sine of 0.13 cycles a sample is far from linear between samples: the
    # first-order hold feeds the circuit a smaller input than it saw.
    assert np.ptp(runs["band-limited"]) > 1.02 * np.ptp(runs["first-order hold"])
    with pytest.raises(ValueError, match="intersample must be one of"):
        silverbox_physics(dt, u, y, intersample="zero-order hold")


def test_segments_and_records():
    U, _ = _records([np.arange(10.0)], [np.arange(10.0)], 3)
    assert [len(a) for a in U] == [3, 3, 4]
    # Several records: pieces in proportion to length, none spans two records.
    U, _ = _records([np.arange(10.0), np.arange(5.0)], [np.arange(10.0)] * 2, 3)
    assert [len(a) for a in U] == [5, 5, 5] and U[2].tolist() == list(range(5))
    model = emps_physics(1e-3)
    with pytest.raises(ValueError, match="must exceed the model's n_init"):
        fit_segments(model, np.zeros((100, 1)), np.zeros((100, 1)), 20)
    assert with_next_input(np.array([[1.0], [2.0], [3.0]])).tolist() == [
        [1.0, 2.0],
        [2.0, 3.0],
        [3.0, 3.0],
    ]


def test_diverging_physics_raises():
    u, y = _emps_data(n=200)
    # One evaluation on 200 samples: a fitted model to break, not a fit.
    with pytest.warns(ConvergenceWarning), pytest.warns(IdentifiabilityWarning):
        model = _emps_start(max_nfev=1).fit_simulation(u, y)
    # Negative damping: the velocity grows every step and overflows later on.
    model.params_ = {
        **model.params_,
        "M": 1.0,
        "Fv_pos": -2000.0,
        "Fv_neg": -2000.0,
        "Fc_pos": 0.0,
        "Fc_neg": 0.0,
    }
    with pytest.raises(SimulationDivergedError, match="step"):
        model.simulate(np.ones((5000, 1)), np.zeros((20, 1)) + 1e-3)


def test_windows_are_causal_and_edge_padded():
    a = np.arange(5.0)
    X = _windows([a, 10 * a], 3)
    assert X.shape == (5, 6)
    # Row t holds a(t-2), a(t-1), a(t), then the second column's window.
    assert_allclose(X[4], [2, 3, 4, 20, 30, 40])
    assert_allclose(X[0], [0, 0, 0, 0, 0, 0])


def test_published_figures_are_data_with_sources():
    # Every benchmark has its published figures, but the friction damper: none
    # exists (its linear ARX is the linear reference).
    assert set(PUBLISHED) == set(MEASURED) - {"friction-damper"}
    assert PUBLISHED["wiener-hammerstein"]["test"]["linear (LTI SS)"][0] == 43.4
    assert (
        PUBLISHED["coupled-electric-drives"]["test_2"]["linear (LTI SS; n_init = 4)"][0]
        == 0.384
    )
    # dynoNet's 2.64 mm is a figure of the estimation record, listed apart.
    assert "dynoNet" not in str(PUBLISHED["emps"]["test"])
    other = PUBLISHED["emps"]["estimation record (another protocol)"]
    assert other["dynoNet"][0] == 2.64
    assert PUBLISHED["emps"]["test"]["state of the art (CT-SUBNET)"][0] == 4.61
    assert (
        PUBLISHED["cascaded-tanks"]["test"]["linear (LTI SS; n_init = 5)"][0] == 0.588
    )
    for splits in PUBLISHED.values():
        for table in splits.values():
            for value, source in table.values():
                assert value > 0 and source


def test_run_without_data_fetches_and_offline_says_what_to_do(
    capsys, tmp_path, monkeypatch
):
    import socket

    with socket.socket() as s:  # a port nothing listens on: no network
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    monkeypatch.setenv("SKHYBRID_DATA", str(tmp_path / "home"))
    monkeypatch.setenv("SKHYBRID_DATA_MIRROR", f"http://127.0.0.1:{port}")
    assert main(["run", "emps", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err  # one line
    assert "EMPS.zip" in err and str(tmp_path / "home" / "emps") in err
    assert "--data" in err
    # The fix comes first; the connection errors after it.
    fix, why = err.split("Why the download failed:")
    assert "Download EMPS.zip" in fix and "127.0.0.1" not in fix and "127.0.0.1" in why


def test_unknown_system_is_refused(tmp_path):
    with pytest.raises(ValueError, match="name must be one of"):
        run_measured("tanks", tmp_path, tmp_path)


@pytest.mark.slow
def test_silverbox_quick_run(shared_data_dir, tmp_path):
    """The Duffing physics beats the published linear model; hybrids are chosen
    on the validation tail only."""
    out = tmp_path / "silverbox"
    results = run_measured(
        "silverbox", shared_data_dir, out, quick=True, seeds=[0], n_jobs=1
    )
    rmse = results["test_rmse"]
    assert rmse["test_multisine"]["physics"]["mean"] < 6.96
    fits = results["fits"]["0"]
    assert "state-space hybrid" in fits
    validation = results["validation_rmse"]["0"]
    assert results["chosen_model"]["0"] == min(validation, key=validation.get)
    assert fits["physics"]["selection"]["segment"] == 512
    assert json.loads((out / "results.json").read_text())["systems"]["silverbox"]
    assert (out / "selection.json").is_file()


def test_a_figure_over_seeds_says_what_its_spread_is():
    from skhybrid.experiments.free_run._report import spread_text

    three = {"mean": 0.2, "std": 0.01, "by_seed": [0.19, 0.2, 0.21]}
    assert spread_text(three, unit="mV") == "0.2 ± 0.01 mV"
    assert spread_text(three, plus_minus="+-") == "0.2 +- 0.01"
    same = {"mean": 0.3, "std": 0.0, "by_seed": [0.3, 0.3, 0.3]}
    assert spread_text(same, deterministic=True) == "0.3 (deterministic)"
    assert spread_text(same) == "0.3 ± 0"  # three networks' seeds that agreed
    one = {"mean": 0.4, "std": 0.0, "by_seed": [0.4]}
    assert spread_text(one, unit="m") == "0.4 m (one seed)"
    failed = {"mean": 0.5, "std": 0.0, "by_seed": [0.5, None], "n_failed": 1}
    assert spread_text(failed) == "0.5 (one seed) (1 failed)"
    assert spread_text({"mean": None, "std": None, "by_seed": [None]}) == "failed"
