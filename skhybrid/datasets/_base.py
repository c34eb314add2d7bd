"""Helpers shared by the simulators: validation, episodes, noise and windows."""

import math
from numbers import Integral, Real

import numpy as np
from sklearn.utils import Bunch

from skhybrid.preprocessing import make_windows

__all__ = []


def _check_int(value, name, minimum):
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise ValueError(
            f"{name} must be an integer >= {minimum}; got {name}={value!r}."
        )
    return int(value)


def _check_real(value, name, *, low=None, low_closed=True):
    if isinstance(value, bool) or not isinstance(value, Real) or not np.isfinite(value):
        raise ValueError(f"{name} must be a finite real number; got {name}={value!r}.")
    if low is not None and (value < low or (not low_closed and value == low)):
        relation = ">=" if low_closed else ">"
        raise ValueError(f"{name} must be {relation} {low}; got {name}={value!r}.")
    return float(value)


def _check_range(value, name, *, integer=False, minimum=None):
    """A ``(low, high)`` pair with ``low <= high``."""
    try:
        low, high = value
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a pair (low, high); got {name}={value!r}."
        ) from None
    kind = Integral if integer else Real
    for v in (low, high):
        if isinstance(v, bool) or not isinstance(v, kind) or not np.isfinite(v):
            what = "integers" if integer else "finite real numbers"
            raise ValueError(
                f"{name} must be a pair (low, high) of {what}; got {name}={value!r}."
            )
    if low > high:
        raise ValueError(f"{name} must satisfy low <= high; got {name}={value!r}.")
    if minimum is not None and low < minimum:
        raise ValueError(f"{name} must have low >= {minimum}; got {name}={value!r}.")
    return (int(low), int(high)) if integer else (float(low), float(high))


def _check_noise(noise, n_states, state_names):
    """Noise standard deviation per observed state, shape ``(n_states,)``."""
    array = np.asarray(noise, dtype=float) if not isinstance(noise, str) else None
    if array is None or array.ndim > 1 or (array.ndim == 1 and array.size != n_states):
        raise ValueError(
            f"noise must be a non-negative float or an array-like of {n_states} "
            f"standard deviations (one per state {state_names}); got noise={noise!r}."
        )
    if not np.all(np.isfinite(array)) or np.any(array < 0):
        raise ValueError(f"noise must be non-negative and finite; got noise={noise!r}.")
    return np.broadcast_to(array, (n_states,)).copy()


NOISE_TYPES = ("measurement", "process")


def _check_noise_type(noise_type):
    """``"measurement"`` or ``"process"``."""
    if not isinstance(noise_type, str) or noise_type not in NOISE_TYPES:
        raise ValueError(
            f"noise_type must be one of {list(NOISE_TYPES)}; got "
            f"noise_type={noise_type!r}."
        )
    return noise_type


def _process_noise(rng, noise, n):
    """A disturbance of shape ``(n, len(noise))``, or None when ``noise`` is zero."""
    if not np.any(noise):
        return None
    return rng.standard_normal((n, noise.size)) * noise


def _episode_lengths(n_samples, episode_length, n_steps):
    """Time steps of each episode so that the windows number exactly ``n_samples``.

    Every episode has ``episode_length`` time steps, which give
    ``episode_length - n_steps`` windows, except the last, which is cut short.
    """
    if episode_length <= n_steps:
        raise ValueError(
            f"episode_length must exceed n_steps so that an episode holds at least "
            f"one window; got episode_length={episode_length} and n_steps={n_steps}."
        )
    per_episode = episode_length - n_steps
    n_episodes = math.ceil(n_samples / per_episode)
    lengths = [episode_length] * n_episodes
    lengths[-1] = n_samples - (n_episodes - 1) * per_episode + n_steps
    return lengths


def _feature_names(state_names, input_names, n_steps):
    """Column names of a window: ``name[t-k]`` oldest first, ``name[t]`` newest."""
    names = []
    for k in range(n_steps - 1, -1, -1):
        suffix = "[t]" if k == 0 else f"[t-{k}]"
        names.extend(f"{name}{suffix}" for name in [*state_names, *input_names])
    return names


def _window_bunch(
    states_clean,
    inputs,
    *,
    noise,
    n_steps,
    rng,
    state_names,
    input_names,
    noise_type="measurement",
    **extra,
):
    """Add measurement noise to per-episode states and cut them into windows.

    The noise is added to each episode's state sequence once, before windowing,
    so that a state is measured once: a row's newest state is the previous row's
    target within an episode. With ``noise_type="process"`` the states already
    carry the disturbance that entered the dynamics and are measured exactly:
    nothing is added, and the "clean" arrays are the measured ones.
    """
    if noise_type == "process":
        states = [s.copy() for s in states_clean]
    else:
        states = [
            s + rng.standard_normal(s.shape) * noise if np.any(noise) else s.copy()
            for s in states_clean
        ]
    X, y, groups = make_windows(states, inputs, n_steps=n_steps, return_groups=True)
    X_clean, y_clean = make_windows(states_clean, inputs, n_steps=n_steps)
    return Bunch(
        X=X,
        y=y,
        groups=groups,
        X_clean=X_clean,
        y_clean=y_clean,
        states=states,
        states_clean=list(states_clean),
        inputs=inputs,
        feature_names=_feature_names(state_names, input_names, n_steps),
        target_names=list(state_names),
        state_names=list(state_names),
        input_names=list(input_names),
        n_steps=n_steps,
        noise=noise,
        noise_type=noise_type,
        **extra,
    )


def _newest_rows(per_episode, n_steps):
    """Per-episode arrays of shape (n_times, ...) at each window's newest time step.

    Row order matches :func:`~skhybrid.preprocessing.make_windows`: episode by
    episode, windows ending at time steps ``n_steps - 1 .. n_times - 2``.
    """
    return np.concatenate([a[n_steps - 1 : a.shape[0] - 1] for a in per_episode])
