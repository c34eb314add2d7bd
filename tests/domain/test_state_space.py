"""StateSpaceModel: integrators, latent initial states, identifiability, the API."""

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from skhybrid.datasets import make_dc_motor
from skhybrid.domain import StateSpaceModel, check_identifiability
from skhybrid.exceptions import IdentifiabilityWarning
from skhybrid.preprocessing import make_windows


def damped(x, u, *, xp, omega, zeta):
    """A damped oscillator driven by u: x'' = -2 zeta omega x' - omega^2 x + u."""
    return xp.stack(
        [x[:, 1], -2 * zeta * omega * x[:, 1] - omega**2 * x[:, 0] + u[:, 0]], axis=1
    )


def _known(rhs, params, **kwargs):
    """A model with every parameter held at ``params`` (fitted on nothing new)."""
    model = StateSpaceModel(rhs, params, fixed=tuple(params), **kwargs)
    n_in = 1
    return model.fit_simulation(np.zeros((30, n_in)), np.zeros((30, 1)))


def _reference(u, x0, dt, omega=2.0, zeta=0.1):
    """solve_ivp at tight tolerance, one sample at a time (input held)."""
    x, out = np.asarray(x0, dtype=float), [x0[0]]
    for t in range(len(u) - 1):

        def f(_, z, t=t):
            return [z[1], -2 * zeta * omega * z[1] - omega**2 * z[0] + u[t, 0]]

        x = solve_ivp(f, (0, dt), x, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        out.append(x[0])
    return np.array(out)[:, None]


@pytest.mark.parametrize("method", ["rk4", "solve_ivp"])
def test_continuous_time_matches_solve_ivp(method):
    rng = np.random.default_rng(0)
    dt = 0.05  # as a loader's data.dt
    u = np.repeat(rng.uniform(-1, 1, 10), 10)[:, None]
    x0 = [0.3, -0.2]
    model = _known(
        damped,
        {"omega": 2.0, "zeta": 0.1},
        state_names=["x", "v"],
        observed=["x"],
        dt=dt,
        method=method,
        n_substeps=50 if method == "rk4" else 1,
    )
    y = model.simulate_from_state(u, x0)
    np.testing.assert_allclose(y, _reference(u, x0, dt), atol=1e-9)


def test_convergence_order_euler_1_rk4_4():
    rng = np.random.default_rng(1)
    dt = 0.2
    u = np.repeat(rng.uniform(-1, 1, 5), 4)[:, None]
    x0 = [0.5, 0.0]
    reference = _reference(u, x0, dt)
    orders = {}
    for method, substeps in (("euler", [8, 16, 32, 64]), ("rk4", [2, 4, 8, 16])):
        errors = []
        for n in substeps:
            model = _known(
                damped,
                {"omega": 2.0, "zeta": 0.1},
                state_names=["x", "v"],
                observed=["x"],
                dt=dt,
                method=method,
                n_substeps=n,
            )
            y = model.simulate_from_state(u, x0)
            errors.append(np.max(np.abs(y - reference)))
        h = dt / np.array(substeps)
        orders[method] = np.polyfit(np.log(h), np.log(errors), 1)[0]
    assert 0.9 < orders["euler"] < 1.1, orders
    assert 3.7 < orders["rk4"] < 4.3, orders


def motor_rhs(
    x,
    u,
    *,
    xp,
    resistance,
    inductance,
    back_emf,
    torque_constant,
    motor_inertia,
    motor_friction,
    gear_ratio,
    load_inertia,
    load_friction,
    stiffness,
    damping,
    backlash,
):
    """The DC motor with gear backlash of make_dc_motor, in state-space form."""
    i, theta_m, w_m, theta_l, w_l = (x[:, j] for j in range(5))
    twist = theta_m / gear_ratio - theta_l
    zero = 0.0 * twist
    dead_zone = xp.where(
        twist > backlash,
        twist - backlash,
        xp.where(twist < -backlash, twist + backlash, zero),
    )
    engaged = xp.where(dead_zone != 0.0, 1.0 + zero, zero)
    tau = stiffness * dead_zone + engaged * damping * (w_m / gear_ratio - w_l)
    return xp.stack(
        [
            (u[:, 0] - resistance * i - back_emf * w_m) / inductance,
            w_m,
            (torque_constant * i - motor_friction * w_m - tau / gear_ratio)
            / motor_inertia,
            w_l,
            (tau - load_friction * w_l) / load_inertia,
        ],
        axis=1,
    )


def motor_guess(outputs, inputs):
    """Initial guess: the motor on the load's angle and speed, no current."""
    theta = outputs[:, :, 0]
    speed = np.polyfit(np.arange(theta.shape[1]), theta.T, 1)[0] / 0.005
    zero = np.zeros_like(speed)
    return np.stack([zero, 10 * theta[:, 0], 10 * speed, theta[:, 0], speed], axis=1)


def test_dc_motor_latent_states_simulate_within_noise():
    data = make_dc_motor(n_samples=1100, episode_length=1100, dt=0.005, random_state=1)
    params = {
        k: v for k, v in data.true_params.items() if k not in ("dt", "max_voltage")
    }
    model = StateSpaceModel(
        motor_rhs,
        params,
        state_names=data.full_state_names,
        observed=["load_angle"],
        dt=data.dt,
        n_substeps=10,
        initial_state=motor_guess,
        fixed=tuple(params),
    )
    u, y = data.inputs[0], data.states[0][:, :1]
    model.fit_simulation(u[:60], y[:60])  # all parameters known: sets up the model
    start, n_init = 50, 20
    U, Y = u[start : start + 1000], y[start : start + 1000]
    clean = data.full_states[0][start : start + 1000, 3:4]
    sim = model.simulate(U, Y[:n_init])
    np.testing.assert_array_equal(sim[:n_init], Y[:n_init])
    noise = data.noise[0]
    rmse = np.sqrt(np.mean((sim[n_init:] - Y[n_init:]) ** 2))
    rmse_clean = np.sqrt(np.mean((sim[n_init:] - clean[n_init:]) ** 2))
    print(
        f"DC motor load angle: RMSE/noise {rmse / noise:.3f} (vs clean "
        f"{rmse_clean / noise:.3f})"
    )
    assert rmse < 1.5 * noise


def product(x, u, *, xp, a, b):
    return a * b * u[:, :1]


def test_product_parameters_warn_naming_both():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(200, 1))
    states = np.r_[0.0, 6.0 * u[:-1, 0]][:, None]
    X, y = make_windows(states, u)
    model = StateSpaceModel(
        product,
        {"a": 1.0, "b": 2.0},
        state_names=["y"],
        observed=["y"],
        time="discrete",
    )
    with pytest.warns(IdentifiabilityWarning, match=r"a\*b") as record:
        model.fit(X, y[:, 0])
    message = str(record[0].message)
    assert "'a'" in message and "'b'" in message
    assert model.params_["a"] * model.params_["b"] == pytest.approx(6.0)


def test_identifiable_parameters_do_not_warn():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(300, 1))
    x = np.zeros((300, 2))
    for t in range(299):
        x[t + 1] = [0.9 * x[t, 0] + 0.1 * x[t, 1], 0.5 * x[t, 1] + u[t, 0]]
    X, y = make_windows(x, u)

    def linear(x, u, *, xp, a, c):
        return xp.stack([a * x[:, 0] + 0.1 * x[:, 1], c * x[:, 1] + u[:, 0]], axis=1)

    model = StateSpaceModel(
        linear,
        {"a": 0.5, "c": 0.1},
        state_names=["p", "q"],
        observed=["p", "q"],
        time="discrete",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        model.fit(X, y)
    assert model.params_["a"] == pytest.approx(0.9)
    assert model.params_["c"] == pytest.approx(0.5)


def test_check_identifiability_ratio():
    J = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert check_identifiability(J, ["a", "b"]) is None
    # y = a / b: relative changes of a and b cancel when they move together.
    J = np.array([[1.0, -1.0], [2.0, -2.0]])
    assert "a/b" in check_identifiability(J, ["a", "b"])


def test_latent_state_fit_by_simulation_error():
    rng = np.random.default_rng(3)
    u = np.repeat(rng.uniform(-1, 1, 20), 10)[:, None]
    truth = _known(
        damped,
        {"omega": 2.0, "zeta": 0.2},
        state_names=["x", "v"],
        observed=["x"],
        dt=0.1,
        n_substeps=4,
    )
    y = truth.simulate_from_state(u, [0.4, -0.3])
    y_noisy = y + 1e-3 * rng.normal(size=y.shape)
    model = StateSpaceModel(
        damped,
        {"omega": 1.8, "zeta": 0.3},
        state_names=["x", "v"],
        observed=["x"],
        dt=0.1,
        n_substeps=4,
        n_init=10,
    ).fit_simulation(u, y_noisy)
    assert model.params_["omega"] == pytest.approx(2.0, rel=1e-2)
    assert model.params_["zeta"] == pytest.approx(0.2, rel=5e-2)
    np.testing.assert_allclose(model.initial_states_[0], [0.4, -0.3], atol=2e-2)
    assert model.rmse_ < 2e-3
    # Windows: the latent speed is estimated from each window, then one step.
    X, target = make_windows(y, u, n_steps=5)
    windowed = StateSpaceModel(
        damped,
        model.params_,
        state_names=["x", "v"],
        observed=["x"],
        dt=0.1,
        n_substeps=4,
        n_steps=5,
        fixed=("omega", "zeta"),
    ).fit(X, target[:, 0])
    np.testing.assert_allclose(windowed.predict(X), target[:, 0], atol=1e-3)


def _oscillator_records(seed=4):
    rng = np.random.default_rng(seed)
    U = np.repeat(rng.uniform(-1, 1, (3, 15)), 10, axis=1)[..., None]
    truth = _known(
        damped,
        {"omega": 2.0, "zeta": 0.2},
        state_names=["x", "v"],
        observed=["x"],
        dt=0.1,
        n_substeps=2,
    )
    Y = truth.simulate_from_state(U, [[0.4, -0.3], [0.0, 0.5], [-0.2, 0.0]])
    return U, Y + 1e-3 * rng.normal(size=Y.shape)


def _oscillator(rhs=damped, **kwargs):
    return StateSpaceModel(
        rhs,
        {"omega": 1.7, "zeta": 0.3},
        state_names=["x", "v"],
        observed=["x"],
        dt=0.1,
        n_substeps=2,
        n_init=10,
        **kwargs,
    )


def test_vectorized_fit_is_the_same_in_one_batch_per_jacobian():
    """vectorized=True: the same fit, with one simulation per Jacobian."""
    U, Y = _oscillator_records()
    calls = {"n": 0}

    def counted(x, u, *, xp, omega, zeta):
        calls["n"] += 1
        return damped(x, u, xp=xp, omega=omega, zeta=zeta)

    fits = {}
    for vectorized in (False, True):
        calls["n"] = 0
        fits[vectorized] = _oscillator(counted, vectorized=vectorized)
        fits[vectorized].fit_simulation(U, Y)
        fits[vectorized].calls_ = calls["n"]
    for name in ("omega", "zeta"):
        assert fits[True].params_[name] == pytest.approx(
            fits[False].params_[name], rel=1e-6
        )
        assert fits[True].params_std_[name] == pytest.approx(
            fits[False].params_std_[name], rel=1e-3
        )
    assert fits[True].params_["omega"] == pytest.approx(2.0, rel=1e-2)
    assert fits[True].calls_ < fits[False].calls_


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"dt": -0.1}, r"'dt'.*-0\.1"),
        ({"dt": None}, r"dt=None"),
        ({"observed": ["z"]}, r"observed names 'z'"),
        ({"method": "midpoint"}, r"'method'.*midpoint"),
        ({"n_substeps": 0}, r"'n_substeps'.*0"),
        ({"bounds": {"omega": (3.0, 4.0)}}, r"'omega' is 2\.0"),
        ({"params": {"omega": np.nan, "zeta": 0.1}}, r"'omega'.*nan"),
        ({"initial_state": [0.0]}, r"initial_state=\[0\.0\]"),
    ],
)
def test_bad_input_raises_naming_parameter_and_value(kwargs, match):
    args = {
        "params": {"omega": 2.0, "zeta": 0.1},
        "state_names": ["x", "v"],
        "observed": ["x"],
        "dt": 0.1,
    }
    args.update(kwargs)
    model = StateSpaceModel(damped, **args)
    X, y = make_windows(np.zeros((20, 1)), np.zeros((20, 1)))
    # One observed state: a single-output fit takes y 1-D (a column warns
    # DataConversionWarning, as scikit-learn's single-output estimators do).
    with pytest.raises(ValueError, match=match):
        model.fit(X, y[:, 0])


def test_wrong_number_of_outputs_raises():
    model = StateSpaceModel(
        damped,
        {"omega": 2.0, "zeta": 0.1},
        state_names=["x", "v"],
        observed=["x"],
        dt=0.1,
    )
    with pytest.raises(ValueError, match="observed"):
        model.fit_simulation(np.zeros((30, 1)), np.zeros((30, 2)))


def scalar_only(x, u, *, xp, omega, zeta):
    """``damped``, written so that it takes scalar parameters only."""
    omega, zeta = float(omega), float(zeta)
    return damped(x, u, xp=xp, omega=omega, zeta=zeta)


def mixing_rows(x, u, *, xp, omega, zeta):
    """``damped`` plus a term that mixes the rows of a batch (zero for one set)."""
    out = damped(x, u, xp=xp, omega=omega, zeta=zeta)
    return out + 0.1 * (xp.mean(omega) - omega) * out


@pytest.mark.parametrize(
    "rhs, batched", [(damped, True), (scalar_only, False), (mixing_rows, False)]
)
def test_auto_batches_an_rhs_that_broadcasts_and_fits_the_same(rhs, batched):
    # vectorized="auto" (the default) batches the Jacobians' parameter sets
    # where the rhs broadcasts them, and gives the fit of the unbatched one.
    U, Y = _oscillator_records()
    auto = _oscillator(rhs).fit_simulation(U, Y)
    alone = _oscillator(rhs, vectorized=False).fit_simulation(U, Y)
    assert auto.batched_jacobian_ is batched
    assert alone.batched_jacobian_ is False
    for name in ("omega", "zeta"):
        assert auto.params_[name] == pytest.approx(alone.params_[name], rel=1e-5)
        assert auto.params_std_[name] == pytest.approx(
            alone.params_std_[name], rel=1e-3
        )


def test_auto_refuses_an_rhs_whose_batch_differs_from_its_sets_alone():
    # An output that broadcasts a per-row offset across the rows ((n, 1) +
    # (n,) is (n, n)) gives other outputs in a batch than one set at a time:
    # the probe sees it and the fit simulates each set on its own.
    def crossed(x, *, xp, omega, zeta):
        return x[:, 0:1] + 0.0 * omega + 0.0 * xp.reshape(xp.asarray(zeta), (1, -1))

    U, Y = _oscillator_records()
    model = StateSpaceModel(
        damped,
        {"omega": 1.7, "zeta": 0.3},
        state_names=["x", "v"],
        output=crossed,
        dt=0.1,
        n_substeps=2,
        n_init=10,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit_simulation(U, Y)
    assert model.batched_jacobian_ is False


@pytest.mark.parametrize("jac", ["2-point", "3-point"])
@pytest.mark.parametrize("objective", ["mse", "mse+ljung_box"])
def test_the_jacobian_steps_are_simulated_with_the_residuals(jac, objective):
    # Every residual evaluation simulates the Jacobian's steps at its point in
    # the same batch, so a Jacobian costs no simulation of its own: the
    # simulations are the evaluations (and the probe and standard errors),
    # not evaluations plus Jacobians; the fit is the unbatched one's.
    U, Y = _oscillator_records()
    calls = {"n": 0}
    simulate = StateSpaceModel._simulate_sets

    def counted(self, thetas, spec):
        calls["n"] += 1
        return simulate(self, thetas, spec)

    kwargs = {"jac": jac, "objective": objective, "ljung_box_lags": 5}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(StateSpaceModel, "_simulate_sets", counted)
        batched = _oscillator(**kwargs).fit_simulation(U, Y)
    alone = _oscillator(vectorized=False, **kwargs).fit_simulation(U, Y)
    result = batched.result_
    assert result.njev > 1
    # One batch per evaluation (+1: the start's scale), the probe and the
    # standard errors' central differences.
    assert calls["n"] <= result.nfev + 3
    for name in ("omega", "zeta"):
        assert batched.params_[name] == pytest.approx(alone.params_[name], rel=1e-5)
