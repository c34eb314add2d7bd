"""Tests of the simulators in skhybrid.datasets."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.integrate import solve_ivp

from skhybrid.datasets import make_dc_motor, make_double_pendulum, make_pendulum
from skhybrid.datasets._dc_motor import _coefficients, _rhs
from skhybrid.domain import (
    ParametricModel,
    PendulumModel,
    dc_motor_step,
    single_pendulum_step,
)
from skhybrid.preprocessing import make_windows

# Small, fast configurations: (function, kwargs, n_states, n_inputs).
SIMULATORS = {
    "pendulum": (make_pendulum, dict(episode_length=60), 3, 1),
    "double_pendulum": (make_double_pendulum, dict(episode_length=100), 3, 0),
    "dc_motor": (make_dc_motor, dict(episode_length=80), 2, 1),
}


def _make(name, n_samples=230, **kwargs):
    func, defaults, _, _ = SIMULATORS[name]
    return func(n_samples, **{**defaults, **kwargs})


@pytest.fixture(scope="module")
def cache():
    return {}


def _cached(cache, name, **kwargs):
    key = (name, tuple(sorted(kwargs.items())))
    if key not in cache:
        cache[key] = _make(name, **kwargs)
    return cache[key]


@pytest.mark.parametrize("name", SIMULATORS)
@pytest.mark.parametrize("n_steps", [1, 3])
def test_shapes_and_names(name, n_steps, cache):
    _, _, n_states, n_inputs = SIMULATORS[name]
    data = _cached(cache, name, n_steps=n_steps, random_state=0)
    width = n_steps * (n_states + n_inputs)
    assert data.X.shape == (230, width)
    assert data.X_clean.shape == (230, width)
    for key in ("y", "y_clean", "oracle"):
        assert data[key].shape == (230, n_states), key
    assert data.groups.shape == (230,)
    assert len(data.feature_names) == width
    assert len(set(data.feature_names)) == width
    assert data.feature_names[-1].endswith("[t]")
    if n_steps > 1:
        assert data.feature_names[0].endswith(f"[t-{n_steps - 1}]")
    assert data.target_names == data.state_names
    assert len(data.target_names) == n_states
    assert len(data.input_names) == n_inputs
    assert isinstance(data.DESCR, str) and data.DESCR
    assert len(data.states) == len(data.states_clean) == data.groups.max() + 1
    assert data.dt > 0


@pytest.mark.parametrize("name", SIMULATORS)
def test_random_state_makes_it_repeatable(name, cache):
    first = _cached(cache, name, random_state=0)
    again = _make(name, random_state=0)
    other = _make(name, random_state=1)
    for key in ("X", "y", "y_clean", "oracle", "groups"):
        assert_array_equal(first[key], again[key])
    assert not np.allclose(first.y, other.y)


@pytest.mark.parametrize("name", SIMULATORS)
@pytest.mark.parametrize("n_steps", [1, 3])
def test_window_convention(name, n_steps, cache):
    _, _, n_states, n_inputs = SIMULATORS[name]
    data = _cached(cache, name, n_steps=n_steps, random_state=0)
    width = n_states + n_inputs
    same = data.groups[1:] == data.groups[:-1]
    assert same.sum() > 0 and (~same).sum() > 0  # several episodes
    # The newest state of a row is the previous row's target within an episode.
    newest = data.X[1:, (n_steps - 1) * width : (n_steps - 1) * width + n_states]
    assert_array_equal(newest[same], data.y[:-1][same])
    assert_array_equal(
        data.X_clean[1:, -width:][same][:, :n_states], data.y_clean[:-1][same]
    )
    # Rows shift by one step within an episode.
    assert_array_equal(data.X[1:, :-width][same], data.X[:-1, width:][same])
    # Episodes are contiguous blocks and the windows match the raw sequences.
    assert np.all(np.diff(data.groups) >= 0)
    X, y, groups = make_windows(
        data.states, data.inputs, n_steps=n_steps, return_groups=True
    )
    assert_array_equal(X, data.X)
    assert_array_equal(y, data.y)
    assert_array_equal(groups, data.groups)


@pytest.mark.parametrize("name", SIMULATORS)
def test_noise_level(name):
    _, _, n_states, _ = SIMULATORS[name]
    noise = np.linspace(0.01, 0.03, n_states)
    data = _make(name, n_samples=3000, noise=noise, random_state=0)
    std = (data.y - data.y_clean).std(axis=0)
    assert_allclose(std, noise, rtol=0.1)
    assert_allclose((data.y - data.y_clean).mean(axis=0), 0, atol=3 * noise.max() / 50)


@pytest.mark.parametrize("name", SIMULATORS)
def test_noise_free_oracle_is_the_clean_target(name):
    data = _make(name, noise=0.0, random_state=0)
    assert_array_equal(data.X, data.X_clean)
    assert_array_equal(data.y, data.y_clean)
    # The double pendulum's oracle is a separate solve_ivp run per row.
    atol = 1e-7 if name == "double_pendulum" else 1e-9
    assert_allclose(data.oracle, data.y_clean, rtol=0, atol=atol)


@pytest.mark.parametrize("name", SIMULATORS)
def test_oracle_beats_noise_free_persistence(name, cache):
    # The oracle sees noisy inputs: its error is at least the target noise, and
    # far below the error of predicting no change.
    data = _cached(cache, name, random_state=0)
    oracle_rmse = np.sqrt(((data.oracle - data.y) ** 2).mean(axis=0))
    assert np.all(oracle_rmse >= 0.8 * data.noise)
    n_states = data.y.shape[1]
    width = n_states + len(data.input_names)
    persistence = data.X[:, -width:][:, :n_states]
    persistence_rmse = np.sqrt(((persistence - data.y) ** 2).mean(axis=0))
    assert oracle_rmse.sum() < persistence_rmse.sum()


@pytest.mark.parametrize("name", SIMULATORS)
def test_process_noise_makes_the_true_residual_white(name):
    # Under process noise the states are measured exactly and the disturbance
    # enters the dynamics: the true equations' one-step residual is the injected
    # white noise. Under measurement noise, at the same seed, it is not white.
    from skhybrid.diagnostics import ljung_box_test

    noise = 0.02
    data = _make(
        name, n_samples=4000, noise=noise, noise_type="process", random_state=0
    )
    assert data.noise_type == "process"
    assert_array_equal(data.X, data.X_clean)
    residual = data.y - data.oracle
    # The double pendulum's disturbance enters theta and theta_dot only.
    disturbed = [0, 1] if name == "double_pendulum" else slice(None)
    assert_allclose(residual[:, disturbed].std(axis=0), noise, rtol=0.05)
    assert np.all(ljung_box_test(residual[:, disturbed], 20).pvalue > 0.01)
    measured = _make(name, n_samples=4000, noise=noise, random_state=0)
    assert measured.noise_type == "measurement"
    assert np.all(ljung_box_test(measured.y - measured.oracle, 20).pvalue[:1] < 1e-6)


def test_double_pendulum_process_noise_leaves_the_small_pendulum_undisturbed():
    data = make_double_pendulum(
        200, episode_length=100, noise=0.05, noise_type="process", random_state=0
    )
    assert_array_equal(data.noise, [0.05, 0.05, 0.0])
    # theta_ddot follows from the (disturbed) full state exactly.
    from skhybrid.datasets._double_pendulum import _observe

    for full, states in zip(data.full_states, data.states, strict=True):
        assert_allclose(_observe(full, data.true_params), states, atol=1e-12)


@pytest.mark.parametrize("n_samples", [1, 59, 61, 119])
@pytest.mark.parametrize("n_steps", [1, 2])
def test_exact_number_of_rows(n_samples, n_steps):
    data = make_pendulum(n_samples, n_steps=n_steps, episode_length=60, random_state=0)
    assert data.X.shape[0] == n_samples


@pytest.mark.parametrize(
    "func, kwargs, match",
    [
        (make_pendulum, dict(n_samples=0), "n_samples"),
        (make_pendulum, dict(n_samples=2.5), "n_samples"),
        (make_pendulum, dict(n_steps=0), "n_steps"),
        (make_pendulum, dict(torque_range=(1.0, -1.0)), "torque_range"),
        (make_pendulum, dict(torque_range=1.0), "torque_range"),
        (make_pendulum, dict(hold_steps=(0, 3)), "hold_steps"),
        (make_pendulum, dict(hold_steps=(1.5, 3)), "hold_steps"),
        (make_pendulum, dict(noise=-0.1), "noise"),
        (make_pendulum, dict(noise=[0.1, 0.2]), "noise"),
        (make_pendulum, dict(episode_length=3, n_steps=3), "episode_length"),
        (make_double_pendulum, dict(dt=0.0), "dt"),
        (make_double_pendulum, dict(masses=(1.0, -0.1)), "masses"),
        (make_double_pendulum, dict(lengths=1.0), "lengths"),
        (make_double_pendulum, dict(perturbation=-1.0), "perturbation"),
        (make_dc_motor, dict(excitation_hz=0.0), "excitation_hz"),
        (make_dc_motor, dict(motor_params={"ohms": 1.0}), "motor_params"),
        (make_dc_motor, dict(motor_params={"resistance": -1.0}), "resistance"),
        (make_pendulum, dict(noise_type="sensor"), "noise_type"),
        (make_double_pendulum, dict(noise_type=None), "noise_type"),
        (make_dc_motor, dict(noise_type="Process"), "noise_type"),
    ],
)
def test_bad_arguments_name_the_parameter(func, kwargs, match):
    with pytest.raises(ValueError, match=match):
        func(**{"n_samples": 10, **kwargs})


# -- pendulum -----------------------------------------------------------------------


def test_pendulum_matches_gymnasium():
    gym = pytest.importorskip("gymnasium")
    data = make_pendulum(
        300, (-2.5, 2.5), noise=0.0, episode_length=100, random_state=0
    )
    env = gym.make("Pendulum-v1")
    env.reset(seed=0)
    for states, torque in zip(data.states_clean, data.inputs, strict=True):
        for t in range(len(states) - 1):
            # gymnasium computes partly in float32: compare one step at a time.
            theta = np.arctan2(states[t, 1], states[t, 0])
            env.unwrapped.state = np.array([theta, states[t, 2]])
            obs, *_ = env.step(np.array([torque[t, 0]], dtype=np.float32))
            assert_allclose(obs, states[t + 1], rtol=0, atol=1e-6)
    env.close()


def test_pendulum_model_with_true_params_reproduces_the_data(cache):
    data = _cached(cache, "pendulum", n_steps=3, random_state=0)
    model = PendulumModel(**data.true_params, fixed=("mass", "length"), n_steps=3)
    model.fit(data.X, data.y)
    assert_allclose(model.predict(data.X_clean), data.y_clean, rtol=0, atol=1e-9)
    assert_allclose(model.predict(data.X), data.oracle, rtol=0, atol=1e-12)


def test_pendulum_torques_are_held_within_range():
    data = make_pendulum(
        2000,
        (-0.5, 1.5),
        hold_steps=(3, 5),
        noise=0.0,
        episode_length=400,
        random_state=0,
    )
    for torque in data.inputs:
        u = torque[:, 0]
        assert u.min() >= -0.5 and u.max() <= 1.5
        change = np.flatnonzero(np.diff(u)) + 1
        runs = np.diff(np.concatenate([[0], change, [len(u)]]))
        # Inner runs are whole holds; the last is cut at the episode's end.
        assert runs[:-1].min() >= 3 and runs.max() <= 5
    starts = np.array([s[0] for s in data.states_clean])
    assert_allclose(starts[:, 0] ** 2 + starts[:, 1] ** 2, 1.0)
    assert np.all(np.abs(starts[:, 2]) <= 1.0)


# -- double pendulum ----------------------------------------------------------------


def _energy(full, m1, m2, l1, l2, g, **_):
    th1, w1, th2, w2 = full.T
    kinetic = 0.5 * m1 * (l1 * w1) ** 2 + 0.5 * m2 * (
        (l1 * w1) ** 2 + (l2 * w2) ** 2 + 2 * l1 * l2 * w1 * w2 * np.cos(th1 - th2)
    )
    potential = -(m1 + m2) * g * l1 * np.cos(th1) - m2 * g * l2 * np.cos(th2)
    return kinetic + potential


def test_double_pendulum_conserves_energy(cache):
    data = _cached(cache, "double_pendulum", random_state=0)
    params = data.true_params
    # The reference scale of the energy: the large pendulum's swing.
    scale = (params["m1"] + params["m2"]) * params["g"] * params["l1"]
    for full in data.full_states:
        assert_allclose(full[0, [1, 3]], 0.0)  # released at rest
        assert np.all(np.abs(full[0, [0, 2]] - np.pi / 2) <= 0.05)
        energy = _energy(full, **params)
        assert np.ptp(energy) / scale < 1e-8
        # The small pendulum really moves relative to the large one.
        assert np.ptp(full[:, 2] - full[:, 0]) > 0.1


def test_double_pendulum_observes_the_large_pendulum(cache):
    data = _cached(cache, "double_pendulum", random_state=0)
    for full, states in zip(data.full_states, data.states_clean, strict=True):
        assert_array_equal(states[:, :2], full[:, :2])
        # theta_ddot agrees with a central difference of theta_dot.
        central = (states[2:, 1] - states[:-2, 1]) / (2 * data.dt)
        scale = np.abs(states[:, 2]).max()
        assert np.abs(central - states[1:-1, 2]).max() < 1e-2 * scale


def test_single_pendulum_step_matches_an_ode_solver():
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(-1.5, 1.5, 20), rng.uniform(-3, 3, 20)])
    X = np.column_stack([X, np.zeros(20)])
    pred = single_pendulum_step(X, length=0.8, damping=0.3, dt=0.01)
    k = 9.81 / 0.8
    for row, out in zip(X, pred, strict=True):
        sol = solve_ivp(
            lambda t, z: [z[1], -k * np.sin(z[0]) - 0.3 * z[1]],
            (0, 0.01),
            row[:2],
            rtol=1e-12,
            atol=1e-12,
        )
        # RK4's truncation error at dt=0.01 is about 1e-9.
        assert_allclose(out[:2], sol.y[:, -1], rtol=0, atol=1e-8)
        assert_allclose(out[2], -k * np.sin(out[0]) - 0.3 * out[1], atol=1e-12)


def test_single_pendulum_step_runs_on_torch():
    torch = pytest.importorskip("torch")
    from skhybrid.utils import get_namespace

    rng = np.random.default_rng(0)
    X = rng.standard_normal((10, 6))
    expected = single_pendulum_step(X, length=1.2, damping=0.1)
    Xt = torch.as_tensor(X)
    length = torch.tensor(1.2, dtype=torch.float64, requires_grad=True)
    out = single_pendulum_step(Xt, length=length, damping=0.1, xp=get_namespace(Xt))
    assert_allclose(out.detach().numpy(), expected, rtol=1e-12)
    out.sum().backward()
    assert length.grad is not None


def test_single_pendulum_fit_leaves_the_small_pendulum(cache):
    data = _cached(cache, "double_pendulum", random_state=0)
    model = ParametricModel(single_pendulum_step, {"length": 2.0, "damping": 0.0})
    model.fit(data.X, data.y)
    # A sensible effective length: near the large pendulum's.
    assert 0.8 < model.params_["length"] < 1.0 + data.true_params["l2"]
    residual_rmse = np.sqrt(((model.predict(data.X) - data.y) ** 2).mean(axis=0))
    oracle_rmse = np.sqrt(((data.oracle - data.y) ** 2).mean(axis=0))
    # The unmodelled small pendulum dominates the acceleration residual.
    assert residual_rmse[2] > 5 * oracle_rmse[2]


# -- DC motor -----------------------------------------------------------------------


def test_dc_motor_backlash_dead_zone():
    data = make_dc_motor(
        4 * 499, noise=0.0, episode_length=500, excitation_hz=20.0, random_state=0
    )
    p = data.true_params
    b, n = p["backlash"], p["gear_ratio"]
    reversals = engaged_after_delay = 0
    for full, voltage in zip(data.full_states, data.inputs, strict=True):
        twist = full[:, 1] / n - full[:, 3]
        # From rest in the middle of the gap the load stays exactly still while
        # the motor turns, until the gap closes.
        free = np.flatnonzero(np.abs(twist) > b)[0]
        assert free >= 2
        assert np.all(full[:free, 3] == 0.0) and np.all(full[:free, 4] == 0.0)
        assert np.abs(full[free - 1, 1]) > 0.0
        # After a polarity reversal the motor crosses the gap: a stretch with no
        # transmitted torque.
        v = voltage[:, 0]
        for r in np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1])) + 1:
            if r + 40 > len(v):
                continue
            reversals += 1
            engaged_after_delay += bool(np.any(np.abs(twist[r : r + 40]) <= b))
    assert reversals >= 5
    assert engaged_after_delay == reversals
    # Inside the gap the load coasts: its acceleration is its own friction only.
    full = data.full_states[0]
    inside = np.flatnonzero(np.abs(full[:-1, 1] / n - full[:-1, 3]) < 0.5 * b)
    inside = inside[np.abs(full[inside + 1, 1] / n - full[inside + 1, 3]) < 0.5 * b]
    decay = np.exp(-p["load_friction"] / p["load_inertia"] * data.dt)
    assert_allclose(full[inside + 1, 4], decay * full[inside, 4], rtol=1e-6, atol=1e-9)


def test_dc_motor_integrator_matches_solve_ivp():
    data = make_dc_motor(
        150, noise=0.0, episode_length=151, excitation_hz=50.0, random_state=0
    )
    p = data.true_params
    voltage = data.inputs[0][:, 0]
    coefficients = _coefficients(p)
    z = np.zeros(5)
    reference = [z]
    for v in voltage[:-1]:
        sol = solve_ivp(
            lambda t, x, v=v: _rhs(x, v, coefficients),
            (0.0, data.dt),
            z,
            rtol=1e-10,
            atol=1e-12,
        )
        z = sol.y[:, -1]
        reference.append(z)
    reference = np.array(reference)
    full = data.full_states[0]
    scale = np.abs(reference).max(axis=0)
    # First order at the contact switches: well inside 0.5 % of each range.
    assert np.all(np.abs(full - reference).max(axis=0) <= 5e-3 * scale)
    assert_array_equal(data.states_clean[0], full[:, 3:5])


def test_dc_motor_excitation_rate():
    slow = make_dc_motor(400, noise=0.0, episode_length=401, random_state=0)
    fast = make_dc_motor(
        400, noise=0.0, episode_length=401, excitation_hz=100.0, random_state=0
    )
    for data, hold in ((slow, 100), (fast, 10)):
        v = data.inputs[0][:, 0]
        change = np.flatnonzero(np.diff(v)) + 1
        assert np.all(change % hold == 0)
        assert np.abs(v).max() <= data.true_params["max_voltage"]
        assert np.any(v > 0) and np.any(v < 0)


def test_dc_motor_step_is_the_exact_first_order_solution():
    rng = np.random.default_rng(0)
    X = np.column_stack(
        [rng.uniform(-5, 5, 10), rng.uniform(-50, 50, 10), rng.uniform(-12, 12, 10)]
    )
    gain, tc, dt = 4.0, 0.02, 0.003
    pred = dc_motor_step(X, gain=gain, time_constant=tc, dt=dt)
    for row, out in zip(X, pred, strict=True):
        sol = solve_ivp(
            lambda t, z, v=row[2]: [z[1], (gain * v - z[1]) / tc],
            (0, dt),
            row[:2],
            rtol=1e-12,
            atol=1e-12,
        )
        assert_allclose(out, sol.y[:, -1], rtol=1e-8, atol=1e-10)


def test_dc_motor_step_runs_on_torch():
    torch = pytest.importorskip("torch")
    from skhybrid.utils import get_namespace

    X = np.random.default_rng(0).standard_normal((10, 3))
    expected = dc_motor_step(X, gain=3.0, time_constant=0.05)
    Xt = torch.as_tensor(X)
    gain = torch.tensor(3.0, dtype=torch.float64, requires_grad=True)
    out = dc_motor_step(Xt, gain=gain, time_constant=0.05, xp=get_namespace(Xt))
    assert_allclose(out.detach().numpy(), expected, rtol=1e-12)


def test_dc_motor_rigid_params_are_physical():
    data = make_dc_motor(10, episode_length=20, random_state=0)
    p, rigid = data.true_params, data.rigid_params
    # Steady state of the rigid drive: torque balance at constant speed.
    w = rigid["gain"] * 1.0  # load speed at 1 V
    i = (1.0 - p["back_emf"] * p["gear_ratio"] * w) / p["resistance"]
    motor_torque = p["torque_constant"] * i - p["motor_friction"] * p["gear_ratio"] * w
    assert_allclose(motor_torque * p["gear_ratio"], p["load_friction"] * w)
    assert rigid["time_constant"] > 0 and rigid["dt"] == data.dt
