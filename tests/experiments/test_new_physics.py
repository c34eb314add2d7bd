"""The new benchmarks' physics: the linear output-error model, several starts,
the coupled drives and the friction damper's equations."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import lfilter

from skhybrid.benchmarks.coupled_electric_drives import ced
from skhybrid.benchmarks.coupled_electric_drives import physics as ced_physics
from skhybrid.benchmarks.friction_damper import band_friction
from skhybrid.benchmarks.friction_damper import physics as friction_damper_physics
from skhybrid.domain import _LinearOutputError


def _oe_record(n, seed, noise=0.0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 1))
    b, a = [0.0, 0.5, 0.2], [1.0, -1.2, 0.5]
    y = lfilter(b, a, u[:, 0]) + 0.3
    return u, (y + noise * rng.standard_normal(n))[:, None]


def test_linear_output_error_recovers_a_known_filter_from_several_records():
    U, Y = zip(*[_oe_record(800, s) for s in (0, 1)], strict=True)
    model = _LinearOutputError(order=2).fit(list(U), list(Y))
    assert_allclose(model.a_, [1.0, -1.2, 0.5], atol=1e-6)
    assert_allclose(model.b_[0], [0.0, 0.5, 0.2], atol=1e-6)
    assert model.c_ == pytest.approx(0.3, abs=1e-6) and model.is_stable_
    # Its free run from a measured window continues the record exactly.
    u, y = _oe_record(500, 3)
    sim = model.simulate(u, y[:10])
    assert sim.shape == (500, 1)
    assert_allclose(sim[:10], y[:10])
    assert_allclose(sim[10:], y[10:], atol=1e-6)


def test_linear_output_error_refines_a_biased_arx_start():
    # Output noise biases the one-step (ARX) fit; the free-run error does not.
    u, y = _oe_record(4000, 0, noise=0.05)
    arx = _LinearOutputError(order=2, max_nfev=0).fit(u, y)
    oe = _LinearOutputError(order=2).fit(u, y)
    assert abs(oe.a_[2] - 0.5) < abs(arx.a_[2] - 0.5) / 3
    assert oe.rmse_ < arx.rmse_


def test_linear_output_error_refuses_what_it_cannot_do():
    u, y = _oe_record(300, 0)
    model = _LinearOutputError(order=4).fit(u, y)
    with pytest.raises(ValueError, match="at least order=4"):
        model.simulate(u, y[:2])
    with pytest.raises(ValueError, match="measured window only"):
        model.simulate(u, y[:10], return_std=True)
    bad = u.copy()
    bad[5] = np.nan
    with pytest.raises(ValueError, match="must be finite"):
        model.simulate(bad, y[:10])


def _ced_truth(dt=0.02, w=25.0):
    model = ced_physics(dt, w=w)
    truth = {"K": 0.9, "tau": 0.15, "w": w, "zeta": 0.2, "tau_f": 0.03}
    return model.set_params(params=truth)


def test_the_drives_sensor_sees_the_speed_without_its_sign():
    x = np.array([[0.0, -2.0, 0.0, 0.0]])
    step = ced(x, np.zeros((1, 1)), xp=np, K=1, tau=0.1, w=10, zeta=0.2, tau_f=0.5)
    # The filtered speed rises towards |p| = 2, not towards -2.
    assert step[0, 3] == pytest.approx(2.0 / 0.5)


def test_the_band_follows_the_actuator_only_beyond_the_gap():
    params = {"gap": 0.1, "sigma": 50.0, "Fc": 2.0}
    x = np.array([[0.0, 0.0]])
    for d in (0.05, 0.08):  # inside the gap: the band stays, no force builds up
        x = band_friction(x, np.array([[d]]), xp=np, **params)
        assert x[0, 0] == 0.0 and x[0, 1] == 0.0
    x = band_friction(x, np.array([[0.3]]), xp=np, **params)
    # Engaged: the band moved to 0.3 - gap, the force grew towards +Fc (Dahl).
    assert x[0, 0] == pytest.approx(0.2)
    assert x[0, 1] == pytest.approx(2.0 * (1 - np.exp(-50.0 * 0.2 / 2.0)))
    model = friction_damper_physics()
    assert model.n_init == 50 and set(model.params) >= {"gap", "sigma", "Fc"}
