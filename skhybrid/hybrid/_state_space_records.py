"""Training a StateSpaceHybridRegressor on whole records.

``fit_simulation`` cuts the records into sub-sequences of ``n_init + horizon``
samples (every ``stride``), holds out records or tails for early stopping,
warm-starts the physics and trains on the windows. A mixin of
:class:`~skhybrid.hybrid.StateSpaceHybridRegressor`.
"""

import warnings

import numpy as np
from sklearn.base import clone
from sklearn.utils import check_random_state

from skhybrid.neural.engine import check_sequence_objective
from skhybrid.simulation import check_trajectories
from skhybrid.utils._docstrings import RECORDS_OUTPUTS, fill_doc
from skhybrid.utils._sklearn_compat import _fit_context
from skhybrid.utils._transaction import transactional

#: Sub-sequences an epoch holds, at least (about), under ``stride="auto"``:
#: short records are cut with a stride below the usual one, down to 1.
MIN_SUBSEQUENCES = 500


@fill_doc(records_outputs=RECORDS_OUTPUTS)
class _RecordsFitMixin:
    """``fit_simulation``: the records cut into training windows."""

    # -- records -------------------------------------------------------------------
    def fit_simulation(self, inputs, outputs):
        """Train on whole records by the simulation error over ``horizon`` steps.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), (n_records, n_times, \
n_inputs) or list of (n_times_i, n_inputs) arrays
            Inputs of each record; ``inputs[t]`` acts between samples ``t`` and
            ``t + 1``.
        %(records_outputs)s

        Returns
        -------
        self : object
            The fitted model.
        """
        return self._fit_simulation(inputs, outputs)

    @transactional
    @_fit_context(prefer_skip_nested_validation=True)
    def _fit_simulation(self, inputs, outputs):
        self._check_settings()
        U_list, Y_list, _ = check_trajectories(inputs, outputs, initial_name="outputs")
        n_inputs, n_outputs = U_list[0].shape[1], Y_list[0].shape[1]
        k, T = self.n_init, self.horizon
        check_sequence_objective(self, T)
        for i, (u, y) in enumerate(zip(U_list, Y_list, strict=True)):
            if len(u) != len(y):
                raise ValueError(
                    f"inputs[{i}] holds {len(u)} time steps but outputs[{i}] "
                    f"{len(y)}; each record's inputs and outputs must be aligned."
                )
        stride = self.stride
        if stride == "auto":
            # Every quarter horizon, or closer where the records are short.
            n_samples = sum(len(y) for y in Y_list)
            stride = max(1, min(T // 4, n_samples // MIN_SUBSEQUENCES))
        physics = clone(self.physics).set_params(n_init=k)
        self._start_physics(physics, "fit_simulation", U_list, Y_list)

        L = k + T
        train, valid, unused = [], [], []
        held = self._held_out_records(len(Y_list))
        for i, (u, y) in enumerate(zip(U_list, Y_list, strict=True)):
            if i in held:
                # The whole record, simulated from its first n_init samples.
                if len(y) > k:
                    valid.append((y, u))
                else:
                    unused.append((i, len(y), f"n_init + 1 = {k + 1}"))
                continue
            if len(y) < L:
                unused.append((i, len(y), f"n_init + horizon = {k} + {T} = {L}"))
                continue
            n_valid = 0
            if self.validation_split == "tail":
                n_valid = round(self.validation_fraction * len(y))
            cut = len(y) - n_valid if n_valid >= L else len(y)
            for s in range(0, cut - L + 1, stride):
                train.append((y[s : s + L], u[s : s + L]))
            if cut < len(y):
                # The whole tail, simulated from its first n_init samples.
                valid.append((y[cut:], u[cut:]))
        self.unused_records_ = [i for i, _, _ in unused]
        if not train:
            raise ValueError(
                f"no record holds n_init + horizon = {k} + {T} = {L} samples in its "
                "training part; lower n_init or horizon (or validation_fraction). "
                f"Record lengths: {[len(y) for y in Y_list]}."
            )
        if unused:
            warnings.warn(
                f"{type(self).__name__}.fit_simulation uses none of "
                + ", ".join(
                    f"record {i} ({n} samples, fewer than {need})"
                    for i, n, need in unused
                )
                + "; lower n_init or horizon, or leave such records out.",
                UserWarning,
                stacklevel=5,  # the caller of fit_simulation
            )
        Ytr = np.stack([a for a, _ in train])
        Utr = np.stack([b for _, b in train])
        wv = None
        if valid:
            n_tail = min(len(a) for a, _ in valid)
            wv = (
                np.stack([a[:n_tail] for a, _ in valid]),
                np.stack([b[:n_tail] for _, b in valid]),
            )
        return self._fit_windows(physics, Ytr, Utr, wv, k, n_outputs, n_inputs)

    def _held_out_records(self, n_records):
        """Indices of the records held out whole for early stopping."""
        if self.validation_split != "records" or self.validation_fraction == 0:
            return set()
        n_held = max(1, round(self.validation_fraction * n_records))
        if n_held >= n_records:
            raise ValueError(
                f"validation_split='records' holds out {n_held} of the "
                f"{n_records} record(s) (validation_fraction="
                f"{self.validation_fraction}), leaving none to train on; give more "
                "records, lower validation_fraction or use validation_split='tail'."
            )
        return set(range(n_records - n_held, n_records))

    def _start_physics(self, physics, method, a, b):
        """Warm-start ``physics`` by ``method(a, b)``, or set it up at its params."""
        if self.warm_start_physics:
            getattr(physics, method)(a, b)
        elif method == "fit":
            physics.initialize(a, b)
        else:
            physics.initialize()

    def _fit_windows(self, physics, Ytr, Utr, valid, k, n_outputs, n_inputs):
        self.physics_ = physics
        self.n_outputs_, self.n_inputs_ = n_outputs, n_inputs
        self.n_features_in_ = self.n_steps * (n_outputs + n_inputs)
        self._k = k
        states, good = self._window_targets(physics, Ytr, Utr, Ytr.shape[1])
        flat = states[good].reshape(-1, states.shape[-1])
        steps = np.diff(states[good], axis=1).reshape(-1, states.shape[-1])
        if flat.size == 0:
            flat = np.zeros((1, states.shape[-1]))
        x_targets = states[:, k - 1]
        rng = check_random_state(self.random_state)
        self._seeds = [int(s) for s in rng.randint(np.iinfo(np.int32).max, size=3)]
        module = self._setup(physics, Ytr, Utr, flat, steps, k)
        if not np.all(good):
            x_targets = np.where(good[:, None], x_targets, self.state_mean_)
        prior = x_targets if self.physics_initial_state else None
        if valid is not None:
            valid_prior = (
                self._window_prior(valid[0][:, :k], valid[1][:, :k])
                if self.physics_initial_state
                else None
            )
            valid = (*valid, valid_prior)
        self._train(module, (Ytr, Utr, prior), valid, x_targets)
        return self
