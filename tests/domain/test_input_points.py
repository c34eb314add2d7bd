"""StateSpaceModel(input_points=k): the integrator reads the input between samples."""

import warnings

import numpy as np
import pytest
import torch
from numpy.testing import assert_allclose, assert_array_equal

from skhybrid.benchmarks.silverbox import _duffing_rhs, duffing, with_next_input
from skhybrid.domain import StateSpaceModel, band_limited_inputs

DT = 2**14 / 1e7
PARAMS = {"g": 1.9e5, "d": 41.0, "k1": 1.85e5, "k2": -6e3, "k3": 7e5, "c": -1e3}


def duffing_band_limited(x, u, *, xp, g, d, k1, k2, k3, c, dt):
    """One hand-written RK4 step reading the input at its start, middle, end."""
    p = (g, d, k1, k2, k3, c)
    y, v = x[:, 0], x[:, 1]
    a1, b1 = _duffing_rhs(y, v, u[:, 0], *p)
    a2, b2 = _duffing_rhs(y + 0.5 * dt * a1, v + 0.5 * dt * b1, u[:, 1], *p)
    a3, b3 = _duffing_rhs(y + 0.5 * dt * a2, v + 0.5 * dt * b2, u[:, 1], *p)
    a4, b4 = _duffing_rhs(y + dt * a3, v + dt * b3, u[:, 2], *p)
    return xp.stack(
        [
            y + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
            v + dt / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
        ],
        axis=1,
    )


def duffing_foh(x, u, *, xp, g, d, k1, k2, k3, c, dt):
    """One hand-written RK4 step with the input held linearly between samples."""
    p = (g, d, k1, k2, k3, c)
    y, v = x[:, 0], x[:, 1]
    u0, u1 = u[:, 0], u[:, 1]
    um = 0.5 * (u0 + u1)
    a1, b1 = _duffing_rhs(y, v, u0, *p)
    a2, b2 = _duffing_rhs(y + 0.5 * dt * a1, v + 0.5 * dt * b1, um, *p)
    a3, b3 = _duffing_rhs(y + 0.5 * dt * a2, v + 0.5 * dt * b2, um, *p)
    a4, b4 = _duffing_rhs(y + dt * a3, v + dt * b3, u1, *p)
    return xp.stack(
        [
            y + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
            v + dt / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
        ],
        axis=1,
    )


def _force(n=500):
    return 0.05 * np.sin(2 * np.pi * 0.13 * np.arange(n))[:, None]


def _model(**kwargs):
    return StateSpaceModel(
        duffing,
        PARAMS,
        state_names=["y", "v"],
        observed=["y"],
        dt=DT,
        fixed=tuple(PARAMS),
        **kwargs,
    )


def _run(model, inputs):
    model.fit_simulation(inputs, np.zeros((len(inputs), 1)))
    return model.simulate_from_state(inputs, [0.0, 0.0])


@pytest.mark.parametrize(
    "step, points, transform",
    [
        (duffing_band_limited, 3, band_limited_inputs),
        (duffing_foh, 2, with_next_input),
    ],
)
def test_points_give_the_hand_written_step(step, points, transform):
    """A continuous Duffing reading 3 (2) points a sample is a hand-written
    band-limited (first-order-hold) RK4 step, to the last
    bit."""
    u = _force()
    inputs = transform(u)
    written = StateSpaceModel(
        step,
        {**PARAMS, "dt": DT},
        state_names=["y", "v"],
        observed=["y"],
        time="discrete",
        fixed=(*PARAMS, "dt"),
    )
    model = _model(input_points=points)
    assert_array_equal(_run(model, inputs), _run(written, inputs))
    # The torch step, which the state-space hybrid trains through, too.
    x = torch.zeros(4, 2, dtype=torch.float64)
    v = torch.as_tensor(inputs[:4])
    values = {k: torch.tensor(p, dtype=torch.float64) for k, p in PARAMS.items()}
    assert torch.equal(
        model.step(x, v, values), written.step(x, v, {**values, "dt": DT})
    )


def test_stages_between_points_converge_on_the_adaptive_solver():
    """Finer RK4 steps over 5 points agree with solve_ivp reading the same
    points; the held input is another system altogether."""
    u = _force()
    runs = {
        (method, n_sub, k): _run(
            _model(method=method, n_substeps=n_sub, input_points=k),
            band_limited_inputs(u, n_points=k) if k > 1 else u,
        )
        for method, n_sub, k in [("rk4", 8, 5), ("solve_ivp", 1, 5), ("rk4", 8, 1)]
    }
    reference = runs[("solve_ivp", 1, 5)]
    assert np.abs(runs[("rk4", 8, 5)] - reference).max() < 1e-3 * np.ptp(reference)
    assert np.abs(runs[("rk4", 8, 1)] - reference).max() > 0.5 * np.ptp(reference)


def test_a_fit_reading_between_samples_finds_the_damping():
    """A smooth force sampled coarsely: held, the fit bends the damping; read
    between the samples (input_points=3), it finds it."""

    def oscillator(x, u, *, xp, omega, zeta):
        accel = -2 * zeta * omega * x[:, 1] - omega**2 * x[:, 0] + u[:, 0]
        return xp.stack([x[:, 1], accel], axis=1)

    dt, fine = 0.1, 50
    t = np.arange(200 * fine) * dt / fine
    smooth = [np.sin(1.1 * t + p) + np.sin(12.6 * t + 2 * p) for p in (0.0, 1.0)]
    names = dict(state_names=["position", "speed"], observed=["position"])
    exact = StateSpaceModel(
        oscillator,
        {"omega": 2.0, "zeta": 0.2},
        dt=dt / fine,
        fixed=("omega", "zeta"),
        **names,
    ).fit_simulation(smooth[0][:, None], np.zeros((len(t), 1)))
    sampled = [s[::fine, None] for s in smooth]
    measured = [exact.simulate_from_state(s[:, None], [0, 0])[::fine] for s in smooth]
    start = {"omega": 1.7, "zeta": 0.3}
    held = StateSpaceModel(oscillator, start, dt=dt, n_init=10, **names)
    held.fit_simulation(sampled, measured)
    between = StateSpaceModel(
        oscillator, start, dt=dt, n_init=10, input_points=3, **names
    ).fit_simulation([band_limited_inputs(s) for s in sampled], measured)
    assert abs(held.params_["zeta"] / 0.2 - 1) > 0.1
    assert_allclose(
        [between.params_[k] for k in ("omega", "zeta")], [2.0, 0.2], rtol=0.01
    )
    assert between.rmse_ < held.rmse_ / 10


def test_a_correction_reads_every_point():
    """A hybrid's correction (correction_form='rhs') was sized for the inputs
    as given: it gets every point, the equations the point of their stage."""
    seen = []

    def correction(x, v):
        seen.append(v.shape[1])
        return 0.0 * x

    model = _model(input_points=3)
    model.fit_simulation(band_limited_inputs(_force(60)), np.zeros((60, 1)))
    model.step(np.zeros((2, 2)), np.ones((2, 3)), correction=correction)
    assert seen == [3, 3, 3, 3]


def test_bad_input_points_are_named():
    u = _force(60)
    with pytest.raises(
        ValueError, match=r"input_points=3 needs inputs of a multiple of 3"
    ):
        _model(input_points=3).fit_simulation(
            np.column_stack([u, u]), np.zeros((60, 1))
        )
    with pytest.raises(ValueError, match="input_points=3 is for time='continuous'"):
        StateSpaceModel(
            duffing,
            PARAMS,
            state_names=["y", "v"],
            observed=["y"],
            time="discrete",
            input_points=3,
        ).fit_simulation(band_limited_inputs(u), np.zeros((60, 1)))
    with pytest.raises(ValueError, match="input_points"):
        _model(input_points=0).fit_simulation(u, np.zeros((60, 1)))


@pytest.mark.parametrize("correction_form", ["step", "rhs"])
def test_the_state_space_hybrid_trains_through_a_physics_reading_points(
    correction_form,
):
    from skhybrid.hybrid import StateSpaceHybridRegressor

    def oscillator(x, u, *, xp, omega, zeta):
        accel = -2 * zeta * omega * x[:, 1] - omega**2 * x[:, 0] + u[:, 0]
        return xp.stack([x[:, 1], accel], axis=1)

    t = 0.1 * np.arange(120)
    inputs = [band_limited_inputs(np.sin(1.3 * t + p)) for p in (0.0, 1.0, 2.0)]
    physics = StateSpaceModel(
        oscillator,
        {"omega": 2.0, "zeta": 0.2},
        state_names=["q", "v"],
        observed=["q"],
        dt=0.1,
        input_points=3,
        n_init=10,
        fixed=("omega", "zeta"),
    )
    outputs = [
        physics.fit_simulation(u, np.zeros((120, 1))).simulate_from_state(u, [0, 0])
        for u in inputs
    ]
    hybrid = StateSpaceHybridRegressor(
        physics,
        n_init=10,
        horizon=20,
        max_epochs=2,
        hidden_layer_sizes=(8,),
        correction_form=correction_form,
        random_state=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hybrid.fit_simulation(inputs[:2], outputs[:2])
    simulated = hybrid.simulate(inputs[2], outputs[2][:10])
    assert simulated.shape == (120, 1) and np.all(np.isfinite(simulated))
