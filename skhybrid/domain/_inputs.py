"""The input between samples: band-limited interpolation for a physics' integrator."""

import numbers

import numpy as np
from scipy.signal import resample_poly

from skhybrid.utils._validation import as_columns

__all__ = ["band_limited_inputs"]


def band_limited_inputs(inputs, n_points=3):
    """Each input at ``n_points`` equally spaced times from ``t`` to ``t + 1``.

    A continuous-time physics integrated over one sample needs its input
    between the samples. A zero- or first-order hold is right for an input
    that a digital-to-analogue converter holds; a band-limited excitation (a
    multisine, filtered noise) is smooth between its samples, and a hold then
    feeds the equations an input the system never saw. This helper
    interpolates a band-limited input by polyphase filtering
    (:func:`scipy.signal.resample_poly`, its ends padded along a line), keeps
    the samples themselves and returns, for every sample ``t``, the input at
    ``t, t + 1/(n_points - 1), ..., t + 1``, ready for a Runge-Kutta step
    (``n_points=3``: the step's start, midpoint and end). Between the samples
    the values carry the filter's passband ripple: a constant input comes back
    within 5e-4 of itself.

    The interpolation reads samples on both sides of ``t``: it needs the
    whole input record, which a simulation is given anyway. Hand its columns
    to a :class:`StateSpaceModel` with ``input_points=n_points``, whose
    integrator then reads each input at each stage's time (or to a
    ``time="discrete"`` step that reads them itself), directly or as a
    :class:`~skhybrid.experiments.SystemSpec`'s ``physics_inputs`` (with
    :func:`functools.partial` for another ``n_points``).

    Parameters
    ----------
    inputs : array-like of shape (n_times,) or (n_times, n_inputs)
        One record's inputs, sampled uniformly.
    n_points : int, default=3
        Times per sample, at least 2 (2: ``u(t)`` and ``u(t + 1)``, as a
        first-order hold reads them).

    Returns
    -------
    points : ndarray of shape (n_times, n_inputs * n_points)
        Input ``j`` at time ``t + i / (n_points - 1)`` in column
        ``j * n_points + i``. The last sample's later points continue the
        record past its end along the line the padding draws.

    Raises
    ------
    ValueError
        If ``n_points`` is below 2, ``inputs`` has fewer than 2 samples, more
        than two dimensions, or a value that is not finite.
    TypeError
        If ``n_points`` is not an integer.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import band_limited_inputs
    >>> t = np.arange(200)
    >>> u = np.sin(2 * np.pi * 0.05 * t)
    >>> points = band_limited_inputs(u)
    >>> points.shape
    (200, 3)
    >>> bool(np.allclose(points[:, 0], u))
    True
    >>> exact = np.sin(2 * np.pi * 0.05 * (t + 0.5))
    >>> bool(np.abs(points[20:-20, 1] - exact[20:-20]).max() < 1e-2)
    True
    """
    if isinstance(n_points, bool) or not isinstance(n_points, numbers.Integral):
        raise TypeError(
            f"n_points must be an integer; got {n_points!r} of type "
            f"{type(n_points).__name__}."
        )
    if n_points < 2:
        raise ValueError(f"n_points must be at least 2; got {n_points}.")
    u = as_columns(inputs, "inputs", columns="n_inputs")
    if len(u) < 2:
        raise ValueError(
            f"inputs must hold at least 2 samples to interpolate; got {len(u)}."
        )
    bad = np.argwhere(~np.isfinite(u))
    if len(bad):
        t, j = bad[0]
        raise ValueError(
            f"inputs must be finite; input {j} at time step {t} is {float(u[t, j])}."
        )
    n, up = len(u), n_points - 1
    # One more sample, continuing the last step along a line, gives the last
    # sample's later points.
    extended = np.vstack([u, 2.0 * u[-1:] - u[-2:-1]])
    fine = resample_poly(extended, up, 1, axis=0, padtype="line")
    columns = []
    for j in range(u.shape[1]):
        # The samples stay exactly what was measured; only the times between
        # them are interpolated.
        columns.append(u[:, j])
        columns.extend(fine[i : i + up * n : up, j] for i in range(1, up))
        columns.append(extended[1:, j])
    return np.column_stack(columns)
