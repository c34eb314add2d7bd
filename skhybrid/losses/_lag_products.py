"""Lag sums ``sum_t x_t x_{t+k}`` of long series by blocked matrix products.

The series is cut into blocks of a little more than the lag count; the lag sums
are read off the diagonals of two matrix products of the blocks, and their
gradient is three more (products with Toeplitz matrices of the incoming
gradient). This module holds those kernels and the torch autograd Functions
around them; :mod:`skhybrid.losses._ljung_box` decides when to use them.

Two torch paths:

- :func:`direct_lag_products` multiplies views of the series itself (no copy,
  no scaling pass) and centres the sums afterwards, exactly, from the series'
  sum and its first and last ``nlags`` samples. It declines (returns None) a
  series whose sums could lose precision that way: values so small or large
  that products under- or overflow, NaN or infinity, or a mean so large
  against the spread that centring afterwards would cancel digits.
- :func:`lag_products_function` copies the series into a padded buffer,
  divided by its largest magnitude and demeaned first: safe at any scale, one
  buffer and a few elementwise passes slower.
"""

import functools

#: Blocks hold a multiple of this many samples: rows of 8 float32 (32 bytes, one
#: AVX register) keep every row of a block aligned, and MKL's products of blocks
#: of 51 samples (50 lags) ran 1.3-1.9x slower than of 56 on 2 threads
#: (``bench_ljung_box.py``: 15.4 ms against 11.9 ms at 1e6 samples).
_MATMUL_ALIGN = 8


def _matmul_block(nlags):
    """Samples per block: ``nlags + 1`` (so that lags reach at most the next
    block), rounded up to a multiple of ``_MATMUL_ALIGN``, and at least 16
    (the gradient's products of blocks of 8 ran 2.6x slower than of 16 at 5
    lags and 1e6 samples)."""
    return max(16, -(-(nlags + 1) // _MATMUL_ALIGN) * _MATMUL_ALIGN)


def _blocks(x, nlags, xp):
    """NumPy series (p, n) zero-padded and cut into blocks: shape (p, m, B).

    Torch cuts its own blocks, in a scaled buffer or as views of the series.
    """
    p, n = x.shape
    B = _matmul_block(nlags)
    m = -(-n // B)
    if m * B > n:
        x = xp.concat([x, xp.zeros((p, m * B - n), dtype=x.dtype)], axis=-1)
    return xp.reshape(x, (p, m, B))


def _lag_products(x, nlags, xp):
    """Sums ``sum_t x_t x_{t+k}``, k = 0..nlags, of series ``x`` (p, n): (p, nlags+1).

    The series is cut into blocks of ``B >= nlags + 1`` samples (see
    :func:`_matmul_block`), the rows of ``H``
    (m, B). ``H^T H`` (B, B) holds in ``[s, s + k]`` the products at lag ``k``
    within a block, summed over blocks, and ``H[:-1]^T H[1:]`` in ``[s, s + k - B]``
    those that reach into the next block. Side by side they form a (B, 2B)
    matrix whose diagonals are the lag sums, read off by skewing its rows. Two
    GEMMs on views of the series (no copies), about ``4 n B`` flops.
    """
    return _lag_products_blocks(_blocks(x, nlags, xp), nlags, xp)


def _lag_products_blocks(H, nlags, xp):
    """:func:`_lag_products` of a series already cut into blocks (p, m, B)."""
    p, _, B = H.shape
    Ht = xp.matrix_transpose(H)
    pair = xp.concat(
        [xp.matmul(Ht, H), xp.matmul(Ht[:, :, :-1], H[:, 1:, :])],
        axis=-1,
    )  # (p, B, 2B)
    # Row s shifted left by s: append B zeros to the flat matrix and re-cut it
    # into rows of 2B + 1, so that column k of row s holds pair[s, s + k].
    flat = xp.reshape(pair, (p, 2 * B * B))
    flat = xp.concat([flat, xp.zeros_like(flat[:, :B])], axis=-1)
    skew = xp.reshape(flat, (p, B, 2 * B + 1))[..., : nlags + 1]
    return xp.sum(skew, axis=1)


def _torch_lag_sums(H, nlags):
    """:func:`_lag_products_blocks` for torch, blocks of any size (p, m, b).

    Lag ``k`` reaches ``r = ceil(nlags / b)`` blocks ahead, so each block is
    multiplied with itself and its next ``r`` blocks: ``r + 1`` products, written
    side by side into one buffer that already holds the zeros the skew needs
    (no concatenation copies them). Blocks shorter than the lags cost fewer
    flops (about ``2 n (b + nlags)`` against ``4 n b``): blocks of
    :data:`_FORWARD_BLOCK` samples ran 16-22 % faster than of ``nlags + 1`` at
    50 lags (``bench_ljung_box.py``'s machine, 1e6 samples).
    """
    p, m, b = H.shape
    r = -(-nlags // b)
    width = (r + 1) * b
    flat = H.new_empty(p, width * b + b)
    flat[:, width * b :].zero_()
    pair = flat[:, : width * b].view(p, b, width)
    Ht = H.transpose(1, 2)
    for j in range(r + 1):
        pair[:, :, j * b : (j + 1) * b].baddbmm_(Ht[:, :, : m - j], H[:, j:], beta=0)
    return flat.view(p, b, width + 1)[:, :, : nlags + 1].sum(1)


#: Samples per block of the direct path's forward products (any lag count).
_FORWARD_BLOCK = 16


def _kernel(grad):
    """Taps of the gradient's correlation kernel by absolute lag, then a zero.

    ``d/dx_t sum_k g_k sum_s x_s x_{s+k} = 2 g_0 x_t + sum_{k>=1} g_k (x_{t+k} +
    x_{t-k})``: the tap of lag ``d`` is ``g_|d|``, doubled at 0. ``grad``
    (p, nlags + 1) gives (p, nlags + 2); the index ``nlags + 1`` (a zero)
    stands for the lags beyond ``nlags``.
    """
    import torch

    kernel = torch.nn.functional.pad(grad, (0, 1))
    kernel[:, 0] *= 2
    return kernel


def _lag_products_grad(H, kernel, nlags, out=None):
    """Gradient of ``sum_k g_k * lag_products(x)_k`` with respect to ``x`` (torch).

    ``H`` are the blocks of ``x`` (see :func:`_blocks`), ``kernel`` the taps of
    ``g`` (:func:`_kernel`): the gradient of the products among the blocks.
    ``d/dx_t = 2 g_0 x_t + sum_{k>=1} g_k (x_{t+k} + x_{t-k})``: a correlation of
    the series with a symmetric kernel, per block three matrix products with
    Toeplitz matrices: the block itself, the next block and the previous one.
    Returns the gradient in blocks, shape (p, m, B), written into ``out`` if
    given.
    """
    import torch

    p, _, B = H.shape
    index = _toeplitz_index(nlags, str(H.device))
    toeplitz = kernel.index_select(1, index).view(p, 3, B, B)
    same, ahead, behind = toeplitz.unbind(1)
    out = torch.matmul(H, same, out=out)
    # Accumulate in place (beta = 1): a product into a temporary and an add
    # would write and read two more series-sized buffers (2.3x slower at 1e6).
    out[:, :-1].baddbmm_(H[:, 1:], ahead)
    out[:, 1:].baddbmm_(H[:, :-1], behind)
    return out


@functools.lru_cache(maxsize=16)
def _toeplitz_index(nlags, device):
    """Indices into the kernel of :func:`_lag_products_grad`'s Toeplitz matrices.

    Flattened from shape (3, B, B): for the block itself, the next and the
    previous block, ``[u, s]`` indexes the tap from input ``u`` to output ``s``
    (the absolute lag ``|u - s|``, with the blocks' offset), or the kernel's
    trailing zero beyond ``nlags``.
    """
    import torch

    B = _matmul_block(nlags)
    arange = torch.arange(B)
    lag = arange[:, None] - arange + B * torch.tensor([0, 1, -1])[:, None, None]
    index = torch.where(lag.abs() <= nlags, lag.abs(), nlags + 1)
    return index.flatten().to(device)


_SCALED_FUNCTION = None


def lag_products_function():
    """The torch autograd Function of the scaled (and centred) lag sums.

    Forward and backward are fused by hand: the series is scaled, centred and
    cut into blocks in the padded buffer without temporaries, and the
    blocks are kept for the backward pass, which is three GEMMs and one more
    fused pass. At a million samples the elementwise passes cost as much as the
    matrix products, so this halves the cost of the loss against autograd.
    """
    global _SCALED_FUNCTION
    if _SCALED_FUNCTION is None:
        import torch

        class LagProducts(torch.autograd.Function):
            @staticmethod
            def forward(ctx, x, nlags, scale, center):
                p, n = x.shape
                B = _matmul_block(nlags)
                m = -(-n // B)
                inv = 1.0 / scale  # (p, 1)
                shift = -x.mean(dim=-1, keepdim=True) * inv if center else None
                # Only the padding needs zeros; the series part is written next.
                buffer = x.new_empty(p, m * B)
                buffer[:, n:].zero_()
                # mul then add_ in place: two fast passes (addcmul with broadcast
                # operands is slower than both together on the CPU).
                torch.mul(x, inv, out=buffer[:, :n])
                if center:
                    buffer[:, :n].add_(shift)
                H = buffer.view(p, m, B)
                ctx.save_for_backward(H, inv)
                ctx.nlags, ctx.center, ctx.n = nlags, center, n
                return _torch_lag_sums(H, nlags)

            @staticmethod
            def backward(ctx, grad):
                H, inv = ctx.saved_tensors
                n = ctx.n
                gz = _lag_products_grad(H, _kernel(grad), ctx.nlags)
                gz = gz.view(H.shape[0], -1)[:, :n]
                grad_x = gz.mul_(inv)  # gz is a fresh buffer: scale it in place
                if ctx.center:
                    grad_x.sub_(grad_x.mean(dim=-1, keepdim=True))
                return grad_x, None, None, None

        _SCALED_FUNCTION = LagProducts
    return _SCALED_FUNCTION


@functools.lru_cache(maxsize=16)
def _window_index(nlags, length, device):
    """Indices into :func:`_kernel`'s taps for the window's gradient matrix.

    The window is the series' last full block (``B`` samples) and the tail after
    it, ``length`` samples. ``[u, t]`` (flattened) indexes the tap from input
    ``u`` to output ``t`` (lag ``|u - t|``) for the pairs within ``nlags`` of which
    at least one sample lies in the tail, the kernel's trailing zero for others.
    """
    import torch

    B = _matmul_block(nlags)
    arange = torch.arange(length)
    lag = arange[:, None] - arange
    keep = (lag.abs() <= nlags) & (torch.maximum(arange[:, None], arange) >= B)
    return torch.where(keep, lag.abs(), nlags + 1).flatten().to(device)


@functools.lru_cache(maxsize=16)
def _edges(n, nlags, dtype, device):
    """What the centring needs of the series' ends, for ``n`` samples.

    Returns ``(index, ones, lags)``: ``index`` the first and the last ``nlags``
    samples; ``ones`` (2 nlags, nlags + 1) such that ``x[index] @ ones`` is
    ``A_k``, the sum of the first ``k`` and the last ``k`` samples; ``lags``
    ``n + k`` for k = 0..nlags.
    """
    import torch

    k = torch.arange(nlags + 1)
    j = torch.arange(nlags)[:, None]
    ones = torch.cat([j < k, nlags - 1 - j < k]).to(dtype)
    index = torch.cat([torch.arange(nlags), torch.arange(n - nlags, n)])
    lags = (k + n).to(dtype)[None]
    return index.to(device), ones.to(device), lags.to(device)


def _tail_sums(x, nlags, start):
    """Lag sums of the pairs that reach into the tail ``x[:, start:]``: (p, nlags + 1).

    For each tail sample ``x_u`` and lag ``k``, the product ``x_{u-k} x_u``:
    the tail times a sliding window of the ``nlags`` samples before it.
    """
    import torch

    # Row j holds x[start + j - nlags + i] for i = 0..nlags: lag nlags - i.
    behind = x[:, start - nlags :].unfold(1, nlags + 1, 1)
    return torch.matmul(x[:, None, start:], behind)[:, 0].flip(1)


def _tail_grad(x, kernel, nlags, start):
    """Gradient of :func:`_tail_sums` over its window ``x[:, start - B:]``."""
    import torch

    B = _matmul_block(nlags)
    window = x[:, start - B :]
    w = window.shape[1]
    index = _window_index(nlags, w, str(x.device))
    matrix = kernel.index_select(1, index).view(len(x), w, w)
    return torch.matmul(window[:, None], matrix)[:, 0]


def _centring(x, sums, nlags):
    """Sums of the demeaned series from those of the series itself.

    ``sum_{t<n-k} (x_t - mu)(x_{t+k} - mu) = S_k - (n + k) mu^2 + mu A_k`` with
    ``A_k`` the sum of the first ``k`` and the last ``k`` samples. Returns the
    centred sums and what :func:`_centring_grad` needs: ``mu`` and
    ``(A_k - 2 (n + k) mu) / n``.
    """
    n = x.shape[1]
    index, ones, lags = _edges(n, nlags, x.dtype, str(x.device))
    mu = x.mean(dim=1, keepdim=True)
    A = x.index_select(1, index) @ ones
    shift = lags * mu
    centred = sums.addcmul_(mu, A - shift)
    return centred, mu, A.sub_(shift, alpha=2).div_(n)


def _centring_grad(grad_x, grad, mu, shares, nlags):
    """Add the centring's share to the gradient ``grad_x`` (p, n), in place.

    ``dC_k/dx_t = dS_k/dx_t + (A_k - 2 (n + k) mu) / n + mu ([t < k] + [t >= n - k])``;
    ``shares`` is the middle term (see :func:`_centring`).
    """
    import torch

    n = grad_x.shape[1]
    index, ones, _ = _edges(n, nlags, grad.dtype, str(grad.device))
    grad_x.add_(torch.linalg.vecdot(grad, shares)[:, None])
    return grad_x.index_add_(1, index, (grad @ ones.T).mul_(mu))


_DIRECT_FUNCTION = None


def _direct_function():
    """The torch autograd Function of :func:`direct_lag_products`."""
    global _DIRECT_FUNCTION
    if _DIRECT_FUNCTION is None:
        import torch

        class DirectLagProducts(torch.autograd.Function):
            @staticmethod
            def forward(ctx, x, nlags, center):
                p, n = x.shape
                b = _FORWARD_BLOCK
                m0 = n // b
                sums = _torch_lag_sums(x[:, : m0 * b].view(p, m0, b), nlags)
                if n > m0 * b:
                    sums += _tail_sums(x, nlags, m0 * b)
                raw0 = sums[:, :1].clone()
                mu = A = None
                if center:
                    sums, mu, A = _centring(x, sums, nlags)
                ctx.save_for_backward(x, mu, A)  # A: the centring's shares
                ctx.nlags, ctx.center = nlags, center
                ctx.mark_non_differentiable(raw0)
                return sums, raw0

            @staticmethod
            def backward(ctx, grad, _):
                x, mu, A = ctx.saved_tensors
                nlags = ctx.nlags
                p, n = x.shape
                B = _matmul_block(nlags)
                m0 = n // B
                kernel = _kernel(grad)
                grad_x = x.new_empty(p, n)
                H = x[:, : m0 * B].view(p, m0, B)
                out = grad_x[:, : m0 * B].view(p, m0, B)
                if p == 1:  # one contiguous batch: the products write in place
                    _lag_products_grad(H, kernel, nlags, out=out)
                else:
                    out.copy_(_lag_products_grad(H, kernel, nlags))
                if n > m0 * B:
                    window = _tail_grad(x, kernel, nlags, m0 * B)
                    grad_x[:, (m0 - 1) * B : m0 * B].add_(window[:, :B])
                    grad_x[:, m0 * B :] = window[:, B:]
                if ctx.center:
                    _centring_grad(grad_x, grad, mu, A, nlags)
                return grad_x, None, None

        _DIRECT_FUNCTION = DirectLagProducts
    return _DIRECT_FUNCTION


def direct_lag_products(series, nlags, *, center):
    """Lag sums of torch series (p, n) from views of the series, or None.

    Returns ``(sums, scale)`` as :func:`skhybrid.losses._ljung_box._scaled_lag_products`
    does, differentiable: ``sums`` (p, nlags + 1) of the series divided by
    ``scale`` (p, 1), demeaned if ``center``. The scale is the series' root mean
    square, or 1 with ``center`` (where only ratios of the sums are used and
    no division is needed). Returns None where the products of the unscaled
    series could lose precision, and the caller takes the scaled path: a NaN or
    infinity, a mean square below ``tiny / eps`` of the dtype (products would
    underflow), a sum of squares above ``max * eps`` (they could overflow), or,
    with ``center``, a mean larger than the standard deviation (the centring
    afterwards would cancel more than one bit of the sums).
    """
    import torch

    n = series.shape[1]
    if n < 2 * _matmul_block(nlags) or not series.dtype.is_floating_point:
        return None
    x = series.contiguous()
    sums, raw0 = _direct_function().apply(x, nlags, center)
    info = torch.finfo(x.dtype)
    low, high = n * info.tiny / info.eps, info.max * info.eps
    for raw, centred in torch.cat([raw0, sums.detach()[:, :1]], 1).tolist():
        # NaN fails every comparison, infinity the upper bound.
        if not (low <= raw <= high) or (center and not raw <= 2 * centred):
            return None
    if center:
        return sums, torch.ones_like(raw0)
    scale = raw0.div(n).sqrt_()
    return sums / (scale * scale), scale
