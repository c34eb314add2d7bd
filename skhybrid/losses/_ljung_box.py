"""The Ljung-Box statistic, for NumPy arrays and torch tensors from one implementation.

The lag sums ``sum_t x_t x_{t+k}`` are computed by blocked matrix products (long
series, up to 256 lags; the kernels live in :mod:`skhybrid.losses._lag_products`)
or by FFT (short series, more lags), and the torch version is differentiable: the
matrix-product paths have their own backward passes, so a Ljung-Box loss costs
about 3.6x an MSE at a million samples (``benchmarks/bench_ljung_box.py``,
``docs/losses.md``).
"""

import functools
from numbers import Integral

from skhybrid.losses._lag_products import (
    _lag_products,
    direct_lag_products,
    lag_products_function,
)
from skhybrid.utils._array_api import get_namespace, is_torch

__all__ = [
    "autocorrelation",
    "autocovariance_norm",
    "ljung_box",
    "weighted_autocorrelations",
]

# Small primes that FFT libraries (pocketfft, MKL) handle fast.
_FAST_RADICES = (2, 3, 5)


def _fast_length(n):
    """Smallest 5-smooth integer >= n: a length FFT libraries transform quickly."""
    best = 1 << (n - 1).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            p235 = p35
            while p235 < n:
                p235 *= 2
            best = min(best, p235)
            p35 *= 3
        p5 *= 5
    return best


def _check_series(residuals, lags, xp):
    dtype = residuals.dtype
    # A tensor always holds numbers; a NumPy array may hold strings or objects.
    if not is_torch(xp) and dtype.kind not in "biuf":
        raise TypeError(
            "residuals must hold real numbers (a float array); got "
            f"dtype {dtype}. Convert them with np.asarray(residuals, dtype=float)."
        )
    if residuals.ndim not in (1, 2):
        raise ValueError(
            "residuals must be 1-D (n_samples,) or 2-D (n_samples, n_outputs); "
            f"got an array with shape {tuple(residuals.shape)}."
        )
    if isinstance(lags, bool) or not isinstance(lags, Integral) or lags < 1:
        raise ValueError(f"lags must be a positive integer; got lags={lags!r}.")
    n = residuals.shape[0]
    if lags >= n:
        raise ValueError(
            f"lags must be smaller than the number of samples; got lags={lags} "
            f"with n_samples={n}."
        )


def _scaled_by_max(residuals, xp):
    """Each column divided by its largest magnitude, and the divisors.

    Sums of squares of the result neither under- nor overflow at any scale of the
    series (1e-200 or 1e200). The divisor is a constant (detached in torch), so
    gradients of scale-invariant quantities are exact. The maximum propagates NaN
    and infinity, so checking it checks the whole series in one pass; a column of
    zeros keeps the divisor 1.
    """
    scale = xp.max(xp.abs(residuals), axis=0, keepdims=True)
    if is_torch(xp):
        scale = scale.detach()
    if not bool(xp.all(xp.isfinite(scale))):
        raise ValueError(
            "residuals contain NaN or infinite values; the Ljung-Box statistic and "
            "the autocovariances are undefined for them (a model that produced "
            "them diverged, or the data hold missing values)."
        )
    scale = xp.where(scale > 0, scale, xp.ones_like(scale))
    return residuals / scale, scale


def _block_size(nlags):
    """FFT length of the blocked autocovariance: short enough to stay in cache."""
    return max(256, 1 << (32 * (nlags + 1) - 1).bit_length())


def _autocovariance(centered, nlags, xp):
    """Sums ``sum_t x_t x_{t+k}`` for k = 0..nlags, along axis 0, by FFT (many lags).

    Long series are cut into blocks of ``B = M - nlags`` samples; each block is
    correlated with itself extended by the next ``nlags`` samples through FFTs of
    length ``M`` (overlap-save), and the blocks' sums are added. That costs
    O(n log M) with ``M`` a few times ``nlags`` (at most O(n log n)), and many short
    transforms run several times faster than one transform of the whole series.
    Short series take one zero-padded transform.
    """
    n = centered.shape[0]
    M = _block_size(nlags)
    if n < 4 * M:
        # Zero padding to n + nlags is enough: a circular lag k <= nlags then wraps
        # only onto padded zeros, so the circular and the linear correlation agree.
        nfft = _fast_length(n + nlags)
        spectrum = xp.fft.rfft(centered, n=nfft, axis=0)
        power = xp.real(spectrum) ** 2 + xp.imag(spectrum) ** 2
        return xp.fft.irfft(power, n=nfft, axis=0)[: nlags + 1, ...]
    B = M - nlags
    m = -(-n // B)  # blocks holding the series
    pad = (m + 1) * B - n  # one more block of zeros supplies the last extension
    padded = xp.concat([centered, xp.zeros_like(centered[:pad, ...])], axis=0)
    blocks = xp.reshape(padded, (m + 1, B, *centered.shape[1:]))
    head = blocks[:m, ...]
    extended = xp.concat([head, blocks[1:, :nlags, ...]], axis=1)
    spec_head = xp.fft.rfft(head, n=M, axis=1)
    spec_ext = xp.fft.rfft(extended, n=M, axis=1)
    cross = xp.fft.irfft(xp.conj(spec_head) * spec_ext, n=M, axis=1)
    return xp.sum(cross[:, : nlags + 1, ...], axis=0)


#: Series of at least this many samples, with at most this many lags, take the
#: blocked matrix products; shorter series (a training batch), where the fixed cost
#: of a few dozen small tensor operations dominates, and more lags take FFTs.
#: The crossover was measured with benchmarks/bench_ljung_box.py's functions at
#: 16k-32k samples (one thread, float32).
_MATMUL_MIN_SAMPLES = 16_384
_MATMUL_MAX_LAGS = 256


def _scaled_lag_products(residuals, nlags, xp, *, center):
    """Lag sums of each column divided by a scale (and demeaned).

    Returns ``(sums, scale)``: ``sums`` of shape ``(nlags + 1, ...)`` (the trailing
    shape of ``residuals``), ``scale`` of shape ``(1, ...)``, so that the lag sums
    of the original series are ``sums * scale ** 2``. The scale is the columns'
    largest magnitude, or their root mean square where torch's direct path
    (:func:`~skhybrid.losses._lag_products.direct_lag_products`) takes the
    series. Raises a ValueError on NaN or infinite values (see
    :func:`_scaled_by_max`).
    """
    n = residuals.shape[0]
    if nlags > _MATMUL_MAX_LAGS or n < _MATMUL_MIN_SAMPLES:
        scaled, scale = _scaled_by_max(residuals, xp)
        if center:
            scaled = scaled - xp.mean(scaled, axis=0)
        return _autocovariance(scaled, nlags, xp), scale
    tail = residuals.shape[1:]
    columns = xp.reshape(residuals, (n, -1))
    series = xp.matrix_transpose(columns)  # (p, n)
    if is_torch(xp):
        direct = direct_lag_products(series, nlags, center=center)
        if direct is not None:
            sums, scale = direct
            return _untransposed(sums, scale, nlags, tail, xp)
        # Two reductions, no temporary: abs() would write a copy of the series
        # (aminmax and vector_norm(inf) are several times slower on the CPU).
        detached = columns.detach()
        scale = xp.maximum(
            -detached.amin(dim=0, keepdim=True), detached.amax(dim=0, keepdim=True)
        )
    else:
        scale = xp.max(xp.abs(columns), axis=0, keepdims=True)
    if not bool(xp.all(xp.isfinite(scale))):
        _scaled_by_max(residuals, xp)  # raises the common error
    scale = xp.where(scale > 0, scale, xp.ones_like(scale))
    scale_t = xp.matrix_transpose(scale)  # (p, 1)
    if is_torch(xp):
        sums = lag_products_function().apply(series, nlags, scale_t, center)
    else:
        z = series / scale_t
        if center:
            z = z - xp.mean(z, axis=-1, keepdims=True)
        sums = _lag_products(z, nlags, xp)
    return _untransposed(sums, scale_t, nlags, tail, xp)


def _untransposed(sums, scale, nlags, tail, xp):
    """Sums (p, nlags + 1) and scales (p, 1) in the residuals' trailing shape."""
    sums = xp.reshape(xp.matrix_transpose(sums), (nlags + 1, *tail))
    return sums, xp.reshape(scale, (1, *tail))


def autocorrelation(residuals, nlags):
    """Sample autocorrelation of a series, per column.

    The estimator is statsmodels' default ``acf(x, adjusted=False)``: the series is
    demeaned and ``rho_k = sum_t x_t x_{t+k} / sum_t x_t^2``. A constant series
    (zero included) has zero autocorrelation at every lag (instead of 0 / 0): it is
    perfectly white. The result does not depend on the series' scale, and is
    computed without overflow or underflow at any finite scale. NaN or infinite
    values raise a ValueError.

    Parameters
    ----------
    residuals : ndarray or torch.Tensor of shape (n_samples,) or (n_samples, n_outputs)
        The series, in time order.
    nlags : int
        Largest lag; must be smaller than ``n_samples``.

    Returns
    -------
    rho : ndarray or torch.Tensor of shape (nlags + 1,) or (nlags + 1, n_outputs)
        Autocorrelation at lags 0 to ``nlags``, of the input's type and device.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import autocorrelation
    >>> rho = autocorrelation(np.array([1.0, -1.0, 1.0, -1.0]), nlags=2)
    >>> np.round(rho, 3)
    array([ 1.  , -0.75,  0.5 ])
    """
    xp = get_namespace(residuals)
    _check_series(residuals, nlags, xp)
    # The autocorrelation does not depend on the series' scale.
    acov, _ = _scaled_lag_products(residuals, nlags, xp, center=True)
    variance = acov[0:1, ...]
    # A constant series has variance 0 and zero covariances: report rho = 0 there
    # (and keep gradients finite) rather than 0 / 0.
    safe = xp.where(variance > 0, variance, xp.ones_like(variance))
    rho = acov / safe
    if is_torch(xp):
        rho = xp.concat([xp.ones_like(rho[0:1, ...]), rho[1:, ...]], axis=0)
    else:
        rho[0, ...] = 1.0
    return rho


def weighted_autocorrelations(residuals, lags=20):
    """Terms ``q_k = sqrt(n (n + 2) / (n - k)) * rho_k`` whose squares sum to Q.

    This is the Ljung-Box statistic written as a residual vector, the form that
    :func:`scipy.optimize.least_squares` minimises (its cost is half the sum of
    squares): ``ljung_box(x, lags) == (weighted_autocorrelations(x, lags) ** 2).sum()``.

    Parameters
    ----------
    residuals : ndarray or torch.Tensor of shape (n_samples,) or (n_samples, n_outputs)
        The series, in time order.
    lags : int, default=20
        Number of lags ``L``; must be smaller than ``n_samples``.

    Returns
    -------
    q : ndarray or torch.Tensor of shape (lags,) or (lags, n_outputs)
        The weighted autocorrelations at lags 1 to ``lags``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import ljung_box, weighted_autocorrelations
    >>> x = np.random.default_rng(0).standard_normal(200)
    >>> q = weighted_autocorrelations(x, lags=5)
    >>> bool(np.isclose((q ** 2).sum(), ljung_box(x, lags=5)))
    True
    """
    xp = get_namespace(residuals)
    rho = autocorrelation(residuals, lags)[1:, ...]
    n = residuals.shape[0]
    k = xp.arange(1, lags + 1, dtype=residuals.dtype)
    if is_torch(xp):
        k = k.to(residuals.device)
    weights = xp.sqrt(n * (n + 2.0) / (n - k))
    if residuals.ndim == 2:
        weights = weights[:, None]
    return weights * rho


def ljung_box(residuals, lags=20, *, reduction="sum"):
    """Ljung-Box statistic ``Q = n (n + 2) sum_{k=1..L} rho_k^2 / (n - k)`` (Eq. 7).

    One implementation serves NumPy arrays (least-squares fits, diagnostics) and
    torch tensors (training losses, differentiable). The lag sums are blocked
    matrix products for long series (FFTs for short ones and beyond 256 lags), so
    the cost grows linearly with the length of the series. The statistic is
    non-negative and invariant to shifting and scaling the series; under the
    hypothesis of white noise it follows approximately a chi-squared distribution
    with ``L`` degrees of freedom.

    Parameters
    ----------
    residuals : ndarray or torch.Tensor of shape (n_samples,) or (n_samples, n_outputs)
        Residual series in time order; columns are separate outputs.
    lags : int, default=20
        Number of lags ``L``; must be smaller than ``n_samples``. Choose it larger
        than the longest correlation you expect.
    reduction : {"sum", "none"}, default="sum"
        ``"sum"`` adds the statistics of the outputs into one value; ``"none"``
        returns one statistic per output (shape ``(n_outputs,)`` for 2-D input).

    Returns
    -------
    statistic : float, ndarray or torch.Tensor
        A 0-d array or tensor for ``reduction="sum"`` (a Python float is not returned,
        so gradients flow), per-output values for ``reduction="none"``.

    See Also
    --------
    skhybrid.diagnostics.ljung_box_test : The statistic with its p-value.

    References
    ----------
    G. M. Ljung and G. E. P. Box, "On a measure of lack of fit in time series
    models", Biometrika 65(2), 1978.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import ljung_box
    >>> rng = np.random.default_rng(0)
    >>> white = rng.standard_normal((1000, 2))
    >>> ljung_box(white, lags=10, reduction="none").shape
    (2,)
    >>> walk = np.cumsum(rng.standard_normal(1000))
    >>> bool(ljung_box(walk, lags=10) > ljung_box(white[:, 0], lags=10))
    True
    """
    if reduction not in ("sum", "none"):
        raise ValueError(
            f"reduction must be 'sum' or 'none'; got reduction={reduction!r}."
        )
    xp = get_namespace(residuals)
    per_output = _long_torch_statistic(residuals, lags, xp)
    if per_output is None:
        q = weighted_autocorrelations(residuals, lags)
        per_output = xp.sum(q**2, axis=0)
    if reduction == "none":
        return per_output
    return xp.sum(per_output)


@functools.lru_cache(maxsize=16)
def _statistic_weights(n, lags, dtype, device):
    """``n (n + 2) / (n - k)`` for k = 1..lags, shape (lags, 1): Q's weights."""
    import torch

    k = torch.arange(1, lags + 1, dtype=torch.float64)
    return (n * (n + 2.0) / (n - k)).to(dtype=dtype, device=device)[:, None]


def _long_torch_statistic(residuals, lags, xp):
    """Q per output of a long torch series, or None for other inputs.

    The same statistic as ``sum(weighted_autocorrelations(...) ** 2)`` from the
    same lag sums, in a few differentiable operations instead of some twenty: on
    a long series each costs more in dispatch than in arithmetic
    (``bench_ljung_box.py``).
    """
    n = residuals.shape[0]
    if not is_torch(xp) or lags > _MATMUL_MAX_LAGS or n < _MATMUL_MIN_SAMPLES:
        return None
    _check_series(residuals, lags, xp)
    acov, _ = _scaled_lag_products(residuals, lags, xp, center=True)
    variance = acov[0:1, ...]
    # A constant series has zero covariances: Q = 0 rather than 0 / 0.
    rho = acov[1:, ...] / xp.where(variance > 0, variance, xp.ones_like(variance))
    weights = _statistic_weights(n, lags, rho.dtype, str(rho.device))
    if residuals.ndim == 1:
        weights = weights[:, 0]
    return xp.sum(rho * rho * weights, axis=0)


def autocovariance_norm(residuals, lags=20, *, segments=1):
    """Ljung-Box-weighted norm of the autocovariances, in the residuals' units squared.

    ``T = sqrt(sum_{k=1..L} (n + 2) / (n - k) * gamma_k ** 2)`` per output, with
    ``gamma_k = (1/n) sum_t x_t x_{t+k}`` the (uncentred) autocovariance of the
    series. For a zero-mean series it equals ``gamma_0 * sqrt(Q / n)``: the
    Ljung-Box statistic ``Q`` carried back to the scale of the residual. Unlike
    ``Q`` it is not normalised by the residual's own variance, so it cannot be
    lowered by adding noise: for independent zero-mean white noise ``e`` the
    autocovariances of ``r + e`` have exactly the expectation of those of ``r``,
    and the norm is convex, so ``E[T(r + e)] >= T(r)`` (Jensen). (Demeaning would
    bias the noise's autocovariances by ``-var(e) / n`` and break that; uncentred,
    a constant offset counts as correlation at every lag, so the objective also
    pulls the residual's mean to zero.) It is in the units of a mean square, so it
    adds to one without a scale-dependent weight.

    Parameters
    ----------
    residuals : ndarray or torch.Tensor of shape (n_samples,) or (n_samples, n_outputs)
        The series, in time order.
    lags : int, default=20
        Number of lags ``L``; must be smaller than ``n_samples`` (than the length
        of a segment with ``segments > 1``).
    segments : int, default=1
        Number of equal, consecutive segments the rows hold, each a time-ordered
        series of its own (a training batch drawn from several places of the
        data). The lag products are summed within each segment only, never
        across a boundary, and pooled: ``gamma_k = (1/n) sum_segments sum_t
        x_t x_{t+k}``, weighted by ``(m + 2) / (m - k)`` for segments of ``m``
        rows. ``n_samples`` must be a multiple of ``segments``. The pooled
        autocovariances of ``x + e`` still have the expectation of those of
        ``x`` for independent white noise ``e``, so the norm still cannot be
        lowered by adding noise.

    Returns
    -------
    T : ndarray or torch.Tensor of shape () or (n_outputs,)
        The norm of each output (a 0-d array for 1-D input); differentiable in
        torch (a zero norm has a zero gradient).

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.losses import autocovariance_norm, ljung_box
    >>> x = np.random.default_rng(0).standard_normal(500)
    >>> x -= x.mean()
    >>> T = autocovariance_norm(x, lags=10)
    >>> bool(np.isclose(T, x.var() * np.sqrt(ljung_box(x, lags=10) / 500)))
    True
    >>> bool(np.isclose(autocovariance_norm(10 * x, lags=10), 100 * T))
    True
    """
    xp = get_namespace(residuals)
    if (
        isinstance(segments, bool)
        or not isinstance(segments, Integral)
        or segments < 1
        or residuals.shape[0] % segments
    ):
        raise ValueError(
            f"segments must be a positive divisor of the number of samples, "
            f"n_samples={residuals.shape[0]}; got segments={segments!r}."
        )
    if segments == 1:
        _check_series(residuals, lags, xp)
        sums, scale = _scaled_lag_products(residuals, lags, xp, center=False)
        n = m = residuals.shape[0]
    else:
        sums, scale, n, m = _segment_lag_products(residuals, lags, segments, xp)
    acov = sums[1:, ...] / n
    k = xp.arange(1, lags + 1, dtype=residuals.dtype)
    if is_torch(xp):
        k = k.to(residuals.device)
    weights = (m + 2.0) / (m - k)
    if residuals.ndim == 2:
        weights = weights[:, None]
    squared = xp.sum(weights * acov**2, axis=0)
    # sqrt has an infinite slope at 0: a tiny floor keeps the gradient finite
    # without changing the value measurably (relative 1e-12 of the variance).
    floor = 1e-24 * (sums[0, ...] / n) ** 2
    if is_torch(xp):
        floor = floor.detach()
    norm = xp.sqrt(squared + floor + 1e-300)
    return norm * xp.reshape(scale, norm.shape) ** 2


def _segment_lag_products(residuals, lags, segments, xp):
    """Lag sums pooled over ``segments`` consecutive segments of the rows.

    Returns ``(sums, scale, n, m)`` like :func:`_scaled_lag_products` (the lag sums
    of the original series are ``sums * scale ** 2``), with ``n`` the rows and ``m``
    the rows of a segment. Every column is first divided by its largest magnitude
    over all rows, so the per-segment sums neither under- nor overflow.
    """
    n = residuals.shape[0]
    m = n // segments
    if residuals.ndim not in (1, 2):
        _check_series(residuals, lags, xp)  # raises the common error
    if isinstance(lags, bool) or not isinstance(lags, Integral) or lags < 1:
        raise ValueError(f"lags must be a positive integer; got lags={lags!r}.")
    if lags >= m:
        raise ValueError(
            f"lags must be smaller than the rows of a segment; got lags={lags} "
            f"with n_samples={n} in segments={segments} of {m} rows."
        )
    scaled, scale = _scaled_by_max(residuals, xp)
    tail = tuple(residuals.shape[1:])
    # (segments, m, ...) -> (m, segments, ...): each segment a column of its own.
    stacked = xp.reshape(scaled, (segments, m, *tail))
    axes = (1, 0, *range(2, 2 + len(tail)))
    sums, inner = _scaled_lag_products(
        xp.permute_dims(stacked, axes), lags, xp, center=False
    )
    sums = xp.sum(sums * inner**2, axis=1)
    return sums, xp.reshape(scale, (1, *tail)), n, m
