"""WienerHammersteinModel: the split scan finds the structure, refinement the rest."""

import pickle
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import lfilter
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from skhybrid.domain import WienerHammersteinModel

# G1: one pole at 0.8 and a zero at -0.5; G2: a resonant pair and a delay.
A1, B1 = [1.0, -0.8], [0.4, 0.2]
A2, B2 = [1.0, -1.0, 0.5], [0.0, 0.5]


def _diode(x):
    """A one-sided saturation, far from any low-order polynomial."""
    return np.where(x > 0, np.tanh(2 * x), 0.3 * x)


def _record(n, seed, noise=0.0):
    rng = np.random.default_rng(seed)
    u = lfilter([1.0], [1.0, -0.3], rng.standard_normal(n))
    y = lfilter(B2, A2, _diode(lfilter(B1, A1, u)))
    return u[:, None], y + noise * rng.standard_normal(n)


def _rmse(model, u, y, n_init=30):
    sim = model.simulate(u, y[:n_init, None])[:, 0]
    return float(np.sqrt(np.mean((sim[n_init:] - y[n_init:]) ** 2)))


@pytest.fixture(scope="module")
def fitted():
    u, y = _record(4000, 0)
    return WienerHammersteinModel(order=3, n_knots=12, max_nfev=400).fit(u, y)


def test_finds_the_split_and_simulates_held_out_records(fitted):
    u, y = _record(3000, 1)
    # The linear approximation misses the diode by tens of percent of the
    # output; the block model simulates an unseen record to a few per mille.
    bla_error = _rmse_linear(fitted.bla_, u, y)
    assert _rmse(fitted, u, y) < 0.01 * np.std(y) < bla_error / 20
    # The right split: G1 holds the pole at 0.8 and G2 the resonant pair.
    assert_allclose(np.sort(np.abs(np.roots(fitted.a1_))), [0.8], atol=0.02)
    assert_allclose(np.abs(np.roots(fitted.a2_)), [np.sqrt(0.5)] * 2, atol=0.02)
    assert fitted.splits_[0]["rmse"] == fitted.rmse_
    assert [s["rmse"] for s in fitted.splits_] == sorted(
        s["rmse"] for s in fitted.splits_
    )
    # Every pole split at least was scanned (two pole groups, zeros beside).
    assert fitted.n_splits_ >= 4 and len(fitted.splits_) == fitted.n_starts


def _rmse_linear(bla, u, y, n_init=30):
    sim = bla.simulate(u, y[:n_init])[:, 0]
    return float(np.sqrt(np.mean((sim[n_init:] - y[n_init:]) ** 2)))


def test_the_refinement_improves_on_the_scanned_splits():
    u, y = _record(3000, 0)
    scan_only = WienerHammersteinModel(order=3, n_knots=12, max_nfev=0).fit(u, y)
    refined = WienerHammersteinModel(order=3, n_knots=12, max_nfev=300).fit(u, y)
    assert refined.rmse_ < scan_only.rmse_ / 3
    assert scan_only.splits_[0]["nfev"] == 0


def test_several_records_and_a_noisy_output():
    records = [_record(2000, seed, noise=0.01) for seed in (0, 1)]
    U, Y = (list(part) for part in zip(*records, strict=True))
    model = WienerHammersteinModel(order=3, n_knots=12, max_nfev=300).fit(U, Y)
    u, y_clean = _record(2000, 5)
    # Simulation error against the noise-free output: well below the noise.
    assert _rmse(model, u, y_clean) < 0.01


def test_simulate_keeps_the_measured_window_and_pickles(fitted):
    u, y = _record(500, 2)
    sim = fitted.simulate(u, y[:40, None])
    assert sim.shape == (500, 1)
    assert_allclose(sim[:40, 0], y[:40])
    again = pickle.loads(pickle.dumps(fitted))
    assert_allclose(again.simulate(u, y[:40, None]), sim)
    assert fitted.memory_ > 0 and fitted.transient_ > 0


def test_a_short_refinement_warns_and_clone_refits_the_same():
    u, y = _record(2000, 0)
    model = WienerHammersteinModel(order=3, n_knots=12, n_starts=1, max_nfev=3)
    with pytest.warns(ConvergenceWarning, match="max_nfev=3"):
        model.fit(u, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        twin = clone(model).fit(u, y)
    assert_allclose(twin.spline_coef_, model.spline_coef_)


def test_bad_input_is_named():
    u, y = _record(300, 0)
    model = WienerHammersteinModel(order=2, max_nfev=5)
    with pytest.raises(ValueError, match="n_knots"):
        WienerHammersteinModel(n_knots=1).fit(u, y)
    with pytest.raises(ValueError, match="at least 6 samples; got 4"):
        model.fit(u[:4], y[:4])
    with pytest.raises(ValueError, match="one output"):
        model.fit(u, np.column_stack([y, y]))
    with pytest.raises(ValueError, match="transient=300"):
        WienerHammersteinModel(order=2, transient=300).fit(u, y)
    # The order-14 BLA's least squares tries unstable filters whose squared
    # residuals overflow; it rejects those steps, and says nothing about them.
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match="more than 4096"):
            WienerHammersteinModel(order=14, max_nfev=0).fit(*_record(3000, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        model.fit(u, y)
    with pytest.raises(ValueError, match="need a noise model"):
        model.simulate(u, y[:10, None], return_std=True)
    with pytest.raises(ValueError, match="init must be one of"):
        model.simulate(u, y[:10, None], init="rest")
    with pytest.raises(ValueError, match="2 columns"):
        model.simulate(np.hstack([u, u]), y[:10, None])
    with pytest.raises(ValueError, match="one output"):
        model.simulate(u, np.column_stack([y[:10], y[:10]]))


def test_a_short_window_is_better_started_by_least_squares(fitted):
    # Ten measured samples, a third of the filters' memory: a start at rest
    # leaves a transient that the least-squares start removes.
    u, y = _record(600, 3)
    start = 200  # the record starts mid-motion
    u, y = u[start:], y[start:]
    errors = {}
    for init in ("measured", "least_squares"):
        sim = fitted.simulate(u, y[:10, None], init=init)[:, 0]
        errors[init] = np.sqrt(np.mean((sim[10:40] - y[10:40]) ** 2))
    assert fitted.memory_ > 20
    assert errors["least_squares"] < errors["measured"] / 2


def test_simulate_takes_every_container(fitted):
    records = [_record(300, seed) for seed in (4, 5)]
    U = np.stack([u for u, _ in records])
    Y0 = np.stack([y[:20, None] for _, y in records])
    batch = fitted.simulate(U, Y0)
    assert batch.shape == (2, 300, 1)
    as_list = fitted.simulate(list(U), list(Y0))
    assert_allclose(as_list[1], batch[1])
    assert_allclose(fitted.simulate(U[0], Y0[0]), batch[0])


def test_the_refinement_jacobian_is_the_finite_difference_one():
    # The forward-mode sensitivities (one pass of filters over the record)
    # match central differences of the free run in every coefficient, with
    # two inputs, a fixed G2 coefficient and samples beyond the spline's ends.
    from scipy.optimize._numdiff import approx_derivative

    from skhybrid.domain._block import _sensitivities

    rng = np.random.default_rng(0)
    u = rng.standard_normal((600, 2))
    a1, b1 = np.r_[1.0, -0.5, 0.2], 0.3 * rng.standard_normal((2, 3))
    a2, b2 = np.r_[1.0, -1.0, 0.5], np.r_[0.2, 1.0, 0.3]
    knots = np.r_[[-0.8] * 3, np.linspace(-0.8, 0.8, 8), [0.8] * 3]
    coef, free_b2 = rng.standard_normal(10), np.array([0, 2])

    def unpack(theta):
        b2_ = b2.copy()
        b2_[free_b2] = theta[10:12]
        return (
            np.r_[1.0, theta[:2]],
            theta[2:8].reshape(2, 3),
            np.r_[1.0, theta[8:10]],
            b2_,
            theta[12:],
        )

    theta = np.concatenate([a1[1:], b1.ravel(), a2[1:], b2[free_b2], coef])
    model = WienerHammersteinModel()
    y, J = _sensitivities(*unpack(theta), knots, u, free_b2)
    assert np.abs(model._first_filter(a1, b1, u)).max() > 0.8  # beyond the knots
    assert_allclose(y, model._run(*unpack(theta), knots, u))
    expected = approx_derivative(
        lambda t: model._run(*unpack(t), knots, u), theta, method="3-point"
    )
    assert_allclose(J, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
