"""The Ljung-Box statistic against statsmodels, its gradient and its invariants."""

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from statsmodels.stats.diagnostic import acorr_ljungbox

from skhybrid.losses import (
    autocorrelation,
    ljung_box,
    objective_residuals,
    objective_value,
    weighted_autocorrelations,
)
from skhybrid.losses._ljung_box import _fast_length


def _statsmodels_q(x, lags):
    return acorr_ljungbox(x, lags=lags)["lb_stat"].iloc[-1]


def _ar1(rng, n, phi, n_outputs=None):
    shape = (n,) if n_outputs is None else (n, n_outputs)
    e = rng.standard_normal(shape)
    x = np.empty_like(e)
    x[0] = e[0]
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    return x


@pytest.mark.parametrize("lags", [1, 5, 20, 50])
@pytest.mark.parametrize("kind", ["white", "ar1"])
def test_equals_statsmodels_1d(rng, kind, lags):
    x = rng.standard_normal(1000) if kind == "white" else _ar1(rng, 1000, 0.7)
    expected = _statsmodels_q(x, lags)
    np.testing.assert_allclose(ljung_box(x, lags), expected, rtol=1e-9, atol=0)
    np.testing.assert_allclose(
        ljung_box(torch.from_numpy(x), lags).item(), expected, rtol=1e-9, atol=0
    )


def test_equals_statsmodels_multi_output(rng):
    x = np.column_stack(
        [rng.standard_normal(777), _ar1(rng, 777, 0.5), _ar1(rng, 777, -0.3)]
    )
    expected = np.array([_statsmodels_q(x[:, j], 15) for j in range(3)])
    per_output = ljung_box(x, 15, reduction="none")
    assert per_output.shape == (3,)
    np.testing.assert_allclose(per_output, expected, rtol=1e-9, atol=0)
    np.testing.assert_allclose(ljung_box(x, 15), expected.sum(), rtol=1e-9, atol=0)
    torch_per_output = ljung_box(torch.from_numpy(x), 15, reduction="none")
    np.testing.assert_allclose(torch_per_output.numpy(), expected, rtol=1e-9, atol=0)


def test_autocorrelation_matches_statsmodels_acf(rng):
    from statsmodels.tsa.stattools import acf

    x = _ar1(rng, 500, 0.8)
    np.testing.assert_allclose(autocorrelation(x, 30), acf(x, nlags=30), rtol=1e-9)


def test_weighted_autocorrelations_square_sum_to_statistic(rng):
    x = rng.standard_normal((300, 2))
    q = weighted_autocorrelations(x, lags=7)
    assert q.shape == (7, 2)
    np.testing.assert_allclose((q**2).sum(), ljung_box(x, 7), rtol=1e-12)


def test_gradcheck_float64(rng):
    x = torch.tensor(rng.standard_normal((40, 2)), requires_grad=True)
    assert torch.autograd.gradcheck(lambda t: ljung_box(t, lags=6), (x,))
    assert torch.autograd.gradcheck(
        lambda t: objective_value(t, "mse+ljung_box", lags=6, ljung_box_weight=2.0),
        (x,),
    )


def test_gradient_descent_whitens(rng):
    """Following the gradient lowers the statistic (the loss is usable)."""
    x = torch.tensor(_ar1(rng, 400, 0.8), requires_grad=True)
    before = ljung_box(x, 10).item()
    opt = torch.optim.SGD([x], lr=1.0)
    for _ in range(20):
        opt.zero_grad()
        ljung_box(x, 10).backward()
        opt.step()
    assert ljung_box(x, 10).item() < 0.5 * before


def test_constant_series_is_zero_not_nan():
    assert ljung_box(np.zeros(50), 5) == 0.0
    t = torch.zeros(50, requires_grad=True)
    value = ljung_box(t, 5)
    value.backward()
    assert value.item() == 0.0
    assert torch.isfinite(t.grad).all()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"lags": 0}, "lags must be a positive integer; got lags=0"),
        ({"lags": 2.5}, "lags=2.5"),
        ({"lags": 100}, "lags=100 with n_samples=50"),
        ({"reduction": "mean"}, "reduction='mean'"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ljung_box(np.ones(50), **{"lags": 5, **kwargs})


def test_bad_shape():
    with pytest.raises(ValueError, match=r"shape \(2, 3, 4\)"):
        ljung_box(np.ones((2, 3, 4)), 1)


def test_objective_residuals_square_sum_to_value(rng):
    r = rng.standard_normal((120, 3))
    for objective in ("mse", "ljung_box", "mse+ljung_box"):
        v = objective_residuals(r, objective, lags=9, ljung_box_weight=0.3)
        np.testing.assert_allclose(
            (v**2).sum(),
            objective_value(r, objective, lags=9, ljung_box_weight=0.3),
            rtol=1e-12,
        )
    with pytest.raises(ValueError, match="objective='l2'"):
        objective_value(r, "l2")


@pytest.mark.parametrize("n", [1, 2, 7, 97, 1000, 1025, 4097])
def test_fast_length_is_smooth_and_not_shorter(n):
    m = _fast_length(n)
    assert n <= m <= 2 * n
    for p in (2, 3, 5):
        while m % p == 0:
            m //= p
    assert m == 1


series = arrays(
    np.float64,
    st.integers(12, 200),
    elements=st.floats(-1e3, 1e3, allow_nan=False, width=64),
)


@settings(max_examples=60, deadline=None)
@given(x=series, scale=st.floats(1e-3, 1e3), shift=st.floats(-1e3, 1e3))
def test_properties_nonnegative_and_invariant(x, scale, shift):
    lags = min(10, x.shape[0] - 1)
    q = ljung_box(x, lags)
    assert q >= 0
    if np.ptp(x) > 1e-6 * max(1.0, np.abs(x).max()):
        np.testing.assert_allclose(ljung_box(x * scale, lags), q, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(ljung_box(x + shift, lags), q, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("n, lags", [(10_000, 50), (20_011, 7), (20_000, 120)])
def test_blocked_fft_path_matches_statsmodels(rng, n, lags):
    """Long series take the overlap-save path; it must agree just as well."""
    from skhybrid.losses._ljung_box import _block_size

    assert n >= 4 * _block_size(lags)
    x = np.column_stack([_ar1(rng, n, 0.6), rng.standard_normal(n)])
    expected = [_statsmodels_q(x[:, j], lags) for j in range(2)]
    np.testing.assert_allclose(
        ljung_box(x, lags, reduction="none"), expected, rtol=1e-9
    )
    torch_value = ljung_box(torch.from_numpy(x), lags, reduction="none").numpy()
    np.testing.assert_allclose(torch_value, expected, rtol=1e-9)


@pytest.mark.parametrize("n, lags", [(16_384, 50), (20_011, 1), (30_000, 256)])
def test_matrix_product_path_matches_statsmodels(rng, n, lags):
    """Long series take the blocked matrix products, on NumPy and torch."""
    from skhybrid.losses import _ljung_box

    assert n >= _ljung_box._MATMUL_MIN_SAMPLES and lags <= _ljung_box._MATMUL_MAX_LAGS
    x = np.column_stack([_ar1(rng, n, 0.6), rng.standard_normal(n)])
    expected = [_statsmodels_q(x[:, j], lags) for j in range(2)]
    np.testing.assert_allclose(
        ljung_box(x, lags, reduction="none"), expected, rtol=1e-9
    )
    for t in (torch.from_numpy(x), torch.from_numpy(x[:, 1])):
        value = ljung_box(t, lags, reduction="none").numpy()
        np.testing.assert_allclose(value, expected[-value.size :], rtol=1e-9)


@pytest.mark.parametrize("n, lags", [(7, 3), (64, 1), (130, 20), (200, 5)])
@pytest.mark.parametrize("function", ["ljung_box", "autocovariance_norm"])
@pytest.mark.parametrize("offset", [0.0, 0.5, 5.0])
def test_matrix_product_path_gradcheck(monkeypatch, rng, n, lags, function, offset):
    """The hand-written backward passes of the matrix-product paths are exact.

    gradcheck perturbs every sample, so it runs on short series with the path's
    length threshold lowered; the value must equal the FFT path's as well. The
    offsets take the direct path with its centring afterwards (0.5) and, for
    the centred statistic, the scaled path (5.0, a mean far above the spread);
    130 samples leave a tail after the last full block, 200 none.
    """
    from skhybrid import losses
    from skhybrid.losses import _ljung_box

    f = getattr(losses, function)
    x = torch.tensor(rng.standard_normal((n, 2)) + offset, requires_grad=True)
    fft_value = f(x, lags)
    monkeypatch.setattr(_ljung_box, "_MATMUL_MIN_SAMPLES", 1)
    np.testing.assert_allclose(
        f(x, lags).detach().numpy(), fft_value.detach().numpy(), rtol=1e-10
    )
    assert torch.autograd.gradcheck(lambda t: f(t, lags), (x,))
    assert torch.autograd.gradcheck(
        lambda t: f(t, lags), (x[:, 0].detach().requires_grad_(),)
    )


@pytest.mark.parametrize(
    "dtype, scales",
    [(torch.float64, (1e-200, 1e150, 1e300)), (torch.float32, (1e-30, 1e20))],
)
def test_matrix_product_path_any_scale(monkeypatch, rng, dtype, scales):
    """Outside the safe range the series is rescaled before the products."""
    from skhybrid.losses import _ljung_box

    monkeypatch.setattr(_ljung_box, "_MATMUL_MIN_SAMPLES", 1)
    x = rng.standard_normal((300, 2))
    q = ljung_box(x, lags=10)
    for scale in scales:
        t = torch.tensor(x * scale, dtype=dtype, requires_grad=True)
        value = ljung_box(t, lags=10)
        rtol = 1e-9 if dtype == torch.float64 else 1e-4
        np.testing.assert_allclose(value.item(), q, rtol=rtol)
        value.backward()
        assert torch.isfinite(t.grad).all()


def test_direct_path_takes_ordinary_series_and_declines_unsafe_ones(rng):
    """The products of the unscaled series are used only where they are exact.

    An ordinary residual (mean below its spread, moderate scale) takes the
    direct path; a mean far above the spread (centring afterwards would cancel
    digits), scales whose products under- or overflow, and NaN are declined,
    and the statistic still equals statsmodels' through the scaled path.
    """
    from skhybrid.losses._lag_products import direct_lag_products

    n, lags = 20_011, 20
    x = rng.standard_normal(n)
    expected = _statsmodels_q(x, lags)
    cases = {
        "ordinary": (x + 0.5, torch.float64, True),
        "large mean": (x + 3.0, torch.float64, False),
        "tiny": (x * 1e-20, torch.float32, False),
        "huge": (x * 1e15, torch.float32, False),
        "nan": (np.where(np.arange(n) == 7, np.nan, x), torch.float64, False),
    }
    for name, (values, dtype, direct) in cases.items():
        t = torch.tensor(values, dtype=dtype)[None]
        taken = direct_lag_products(t, lags, center=True) is not None
        assert taken == direct, name
        if name != "nan":
            rtol = 1e-9 if dtype == torch.float64 else 1e-3
            value = ljung_box(t[0], lags).item()
            np.testing.assert_allclose(value, expected, rtol=rtol, err_msg=name)
            # autocorrelation's own route to the same sums agrees.
            q = (weighted_autocorrelations(t[0], lags) ** 2).sum().item()
            np.testing.assert_allclose(q, expected, rtol=rtol, err_msg=name)
    # Uncentred sums have no cancellation to fear: a large mean is taken.
    t = torch.tensor(x + 3.0)[None]
    assert direct_lag_products(t, lags, center=False) is not None


def test_direct_path_float32_matches_float64(rng):
    """Centring afterwards keeps float32's precision where the path is taken."""
    n, lags = 100_003, 50
    x = _ar1(rng, n, 0.6, n_outputs=2) + np.array([0.0, 0.9]) * 2.5  # mean 0.9 sd
    q64 = ljung_box(torch.tensor(x), lags, reduction="none")
    t32 = torch.tensor(x, dtype=torch.float32, requires_grad=True)
    q32 = ljung_box(t32, lags, reduction="none")
    np.testing.assert_allclose(q32.detach().numpy(), q64.numpy(), rtol=1e-4)
    t64 = torch.tensor(x, requires_grad=True)
    ljung_box(t64, lags).backward()
    q32.sum().backward()
    scale = t64.grad.abs().max().item()
    np.testing.assert_allclose(t32.grad.numpy(), t64.grad.numpy(), atol=1e-4 * scale)


def test_blocked_fft_path_gradcheck(rng):
    x = torch.tensor(rng.standard_normal(1100), requires_grad=True)
    assert torch.autograd.gradcheck(lambda t: ljung_box(t, lags=3), (x,))


def test_non_finite_residuals_are_rejected_and_any_scale_works():
    import torch

    from skhybrid.losses import ljung_box

    x = np.random.default_rng(0).standard_normal((500, 2))
    q = ljung_box(x, lags=20)
    for scale in (1e-200, 1e200, 1e300):
        np.testing.assert_allclose(ljung_box(x * scale, lags=20), q, rtol=1e-9)
        t = torch.tensor(x * scale, requires_grad=True)
        ljung_box(t, lags=20).backward()
        assert torch.isfinite(t.grad).all()
    assert ljung_box(np.zeros((100, 2)), lags=20) == 0.0
    for bad in (np.nan, np.inf, -np.inf):
        y = x.copy()
        y[3, 1] = bad
        with pytest.raises(ValueError, match="NaN or infinite"):
            ljung_box(y, lags=20)
        with pytest.raises(ValueError, match="NaN or infinite"):
            ljung_box(torch.tensor(y), lags=20)


def _structured_residuals():
    rng = np.random.default_rng(7)
    n = 400
    ar = np.zeros(n)
    for t in range(1, n):
        ar[t] = 0.95 * ar[t - 1] + rng.standard_normal()
    t = np.arange(n)
    return {
        "ar(1) 0.95": ar,
        "oscillation": np.sin(0.3 * t) + 0.1 * rng.standard_normal(n),
        "white": rng.standard_normal(n),
        "two outputs": np.column_stack([ar, np.cos(0.05 * t)]),
    }


@pytest.mark.parametrize("segments", [1, 4])
@pytest.mark.parametrize("objective", ["mse", "ljung_box", "mse+ljung_box"])
@pytest.mark.parametrize("name", list(_structured_residuals()))
@pytest.mark.parametrize("noise", [0.1, 1.0, 5.0])
def test_adding_noise_never_lowers_the_objective(objective, name, noise, segments):
    # For any residual r and independent white noise e, E[J(r + e)] >= J(r): a
    # model cannot buy whiteness by making its predictions noisier. The
    # expectation is estimated over antithetic pairs (e, -e), which cancel the
    # cross terms' sampling noise; the test allows three standard errors of the
    # Monte Carlo mean, no more. It holds as well with the autocovariances
    # pooled over segments (a training batch drawn from several places), and
    # with a fixed scale per output.
    from skhybrid.losses import objective_value

    r = _structured_residuals()[name]
    rng = np.random.default_rng(0)
    kw = {"lags": 20, "segments": segments}
    if segments > 1 and r.ndim == 2:
        kw["ljung_box_scale"] = r.var(axis=0)
    base = float(objective_value(r, objective, **kw))
    scale = noise * r.std()
    pairs = []
    for _ in range(400):
        e = scale * rng.standard_normal(r.shape)
        pairs.append(
            0.5
            * (
                float(objective_value(r + e, objective, **kw))
                + float(objective_value(r - e, objective, **kw))
            )
        )
    mean, se = np.mean(pairs), np.std(pairs) / np.sqrt(len(pairs))
    assert mean >= base - 3 * se, (mean, base, se)


@pytest.mark.parametrize("objective", ["ljung_box", "mse+ljung_box"])
def test_noise_on_an_autocorrelated_residual_raises_the_objective(objective):
    # The counterexample: with an AR(1) residual (0.95) the earlier
    # objectives fell as independent noise was added; now they rise clearly.
    from skhybrid.losses import objective_value

    r = _structured_residuals()["ar(1) 0.95"]
    rng = np.random.default_rng(1)
    base = float(objective_value(r, objective, lags=20))
    for level in (0.5, 2.0, 8.0):
        noisy = [
            float(
                objective_value(
                    r + level * r.std() * rng.standard_normal(r.shape),
                    objective,
                    lags=20,
                )
            )
            for _ in range(50)
        ]
        assert np.mean(noisy) > base


def test_the_papers_q_objective_rewards_noise():
    # Kept as "ljung_box_q" to reproduce the paper; this is why it is not the
    # default Ljung-Box objective.
    from skhybrid.losses import objective_value

    r = _structured_residuals()["ar(1) 0.95"]
    rng = np.random.default_rng(0)
    base = float(objective_value(r, "ljung_box_q", lags=20))
    noisy = float(
        objective_value(
            r + 5 * r.std() * rng.standard_normal(r.shape), "ljung_box_q", lags=20
        )
    )
    assert noisy < 0.2 * base


@pytest.mark.parametrize("objective", ["ljung_box", "mse+ljung_box", "ljung_box_q"])
def test_objective_residuals_match_values(objective):
    from skhybrid.losses import objective_residuals, objective_value

    r = _structured_residuals()["two outputs"]
    v = objective_residuals(r, objective, lags=10, ljung_box_weight=0.7)
    value = objective_value(r, objective, lags=10, ljung_box_weight=0.7)
    np.testing.assert_allclose((v**2).sum(), value, rtol=1e-10)


def test_segments_pool_the_autocovariances_within_each_segment(rng):
    from skhybrid.losses import autocovariance_norm

    r = rng.standard_normal((600, 2))
    segments, m, lags = 4, 150, 12
    pooled = np.zeros((lags, 2))
    for part in r.reshape(segments, m, 2):
        for k in range(1, lags + 1):
            pooled[k - 1] += (part[:-k] * part[k:]).sum(axis=0)
    pooled /= 600
    weights = (m + 2.0) / (m - np.arange(1, lags + 1))
    expected = np.sqrt((weights[:, None] * pooled**2).sum(axis=0))
    np.testing.assert_allclose(
        autocovariance_norm(r, lags, segments=segments), expected, rtol=1e-10
    )
    np.testing.assert_allclose(
        autocovariance_norm(r[:, 1], lags, segments=segments), expected[1], rtol=1e-10
    )
    # one segment is the plain norm; a lag product never crosses a boundary
    np.testing.assert_allclose(
        autocovariance_norm(r, lags, segments=1), autocovariance_norm(r, lags)
    )
    shuffled = r.reshape(segments, m, 2)[[2, 0, 3, 1]].reshape(600, 2)
    np.testing.assert_allclose(
        autocovariance_norm(shuffled, lags, segments=segments), expected, rtol=1e-10
    )
    assert not np.allclose(autocovariance_norm(shuffled, lags), expected)
    t = torch.tensor(r, requires_grad=True)
    assert torch.autograd.gradcheck(
        lambda x: autocovariance_norm(x, 5, segments=3),
        (t[:90].detach().requires_grad_(),),
    )


def test_segments_and_scales_are_checked(rng):
    from skhybrid.losses import autocovariance_norm

    r = rng.standard_normal((100, 2))
    for bad in (0, 3, 2.0, True):
        with pytest.raises(ValueError, match=f"segments={bad!r}"):
            autocovariance_norm(r, 5, segments=bad)
    with pytest.raises(ValueError, match="lags=30 with n_samples=100 in segments=4"):
        autocovariance_norm(r, 30, segments=4)
    for bad in ([1.0], [1.0, 0.0], [1.0, -2.0]):
        with pytest.raises(ValueError, match="ljung_box_scale"):
            objective_value(r, "mse+ljung_box", lags=5, ljung_box_scale=bad)


def test_ljung_box_scale_divides_each_outputs_norm(rng):
    from skhybrid.losses import autocovariance_norm, mse

    r = rng.standard_normal((200, 2)) * [1.0, 10.0]
    T = autocovariance_norm(r, 5)
    scale = np.array([1.0, 100.0])
    value = objective_value(r, "mse+ljung_box", lags=5, ljung_box_scale=scale)
    np.testing.assert_allclose(value, mse(r) + np.mean(T / scale))
    v = objective_residuals(r, "mse+ljung_box", lags=5, ljung_box_scale=scale)
    np.testing.assert_allclose((v**2).sum(), value, rtol=1e-12)
    # a scale per output makes the term invariant to each output's size
    assert np.isclose(
        objective_value(
            r[:, :1] * [10.0], "ljung_box", lags=5, ljung_box_scale=[100.0]
        ),
        objective_value(r[:, :1], "ljung_box", lags=5),
    )


@pytest.mark.parametrize(
    "residuals", [np.array(["a", "b", "c"] * 10), np.array([1 + 1j] * 30)]
)
def test_ljung_box_names_residuals_that_are_not_real_numbers(residuals):
    # Strings raised numpy's internal UFuncTypeError, naming no parameter.
    with pytest.raises(TypeError, match=r"residuals must hold real numbers.*dtype"):
        ljung_box(residuals, lags=2)
