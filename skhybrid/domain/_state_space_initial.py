"""Initial-state estimation of StateSpaceModel: the state at a record's start.

The observed states start at their measured values, the latent ones (all of
them with an ``output`` function) are fitted by least squares through the
physics over an initialisation window, one problem per record, by
:func:`~skhybrid.simulation.fit_initial_states`. A mixin of
:class:`~skhybrid.domain.StateSpaceModel`.
"""

import numpy as np

from skhybrid.simulation import (
    check_trajectories,
    fit_initial_states,
)
from skhybrid.utils._array_api import is_torch
from skhybrid.utils._docstrings import INITIAL_WINDOW_INPUTS, fill_doc


@fill_doc(initial_window_inputs=INITIAL_WINDOW_INPUTS)
class _InitialStateMixin:
    """Initial states of records and windows, and the records' checks."""

    # -- initial states ------------------------------------------------------------
    def _call_guess(self, func, Y, U, n_states):
        guess = np.asarray(func(np.asarray(Y), np.asarray(U)), dtype=float)
        if guess.shape != (Y.shape[0], n_states) or not np.all(np.isfinite(guess)):
            name = getattr(func, "__name__", repr(func))
            raise ValueError(
                f"initial_state {name} returned shape {guess.shape} for "
                f"{Y.shape[0]} window(s); it must return finite guesses of shape "
                f"({Y.shape[0]}, {n_states})."
            )
        return guess

    def _start(self, Y0, guess, observed, xp=np):
        """States at the first sample: observed ones measured, the others guessed.

        ``guess`` is one state ``(n_states,)`` or one per record ``(n, n_states)``.
        """
        n = Y0.shape[0]
        guess = np.broadcast_to(guess, (n, len(self.state_names)))
        if observed is None:
            return np.array(guess)
        columns = []
        for j in range(len(self.state_names)):
            if j in observed:
                columns.append(Y0[:, observed.index(j)])
            else:
                column = guess[:, j]
                if is_torch(xp):
                    column = xp.asarray(column, dtype=Y0.dtype)
                columns.append(column)
        return xp.stack(columns, axis=1)

    def _estimate_x0(
        self, Y, U, params, structure, estimate_observed=None, per_row=None
    ):
        """Least-squares initial states ``(n, n_states)`` of windows ``Y``, ``U``.

        ``Y`` is ``(n, k, n_outputs)`` measured outputs and ``U`` ``(n, k,
        n_inputs)`` inputs over each window; NumPy only. The free initial states
        (the latent ones, all of them with an ``output`` function or where the
        observed ones are estimated too) are fitted by
        :func:`~skhybrid.simulation.fit_initial_states`, the package's one
        initial-state solver, separately for every window; the perturbed
        windows are simulated in one batch. ``estimate_observed`` overrides the
        parameter of that name. ``per_row`` names the parameters given one
        value per window (a batch of parameter sets); None: those of shape
        ``(n,)`` where ``vectorized=True``.
        """
        n_states, observed, guess = structure
        if callable(guess):
            guess = self._call_guess(guess, Y, U, n_states)
        x0 = np.array(self._start(Y[:, 0], guess, observed), dtype=float)
        if estimate_observed is None:
            estimate_observed = self.estimate_observed
        free = (
            list(range(n_states))
            if observed is None or estimate_observed
            else [j for j in range(n_states) if j not in observed]
        )
        k = Y.shape[1]
        if not free or (k < 2 and observed is not None):
            return x0
        n = Y.shape[0]
        target = Y.reshape(n, -1)
        # Parameters given one value per window (a batch of parameter sets)
        # follow their window into every batch of candidates.
        if per_row is None:
            per_row = {
                name
                for name, v in params.items()
                if self.vectorized is True and np.ndim(v) == 1 and np.shape(v)[0] == n
            }

        def residuals(Z, index):
            X0 = x0[index]
            X0[:, free] = Z
            rows = {
                name: v[index] if name in per_row else v for name, v in params.items()
            }
            out, _ = self._run(X0, U[index], rows, observed, np, k)
            return np.reshape(out, (len(index), -1)) - target[index]

        z, _ = fit_initial_states(residuals, x0[:, free])
        x0[:, free] = z
        return x0

    def estimate_initial_state(self, inputs, outputs, *, params=None):
        """Estimate the initial state of records from their first samples.

        The observed states start at their measured values (and are fitted too
        where ``estimate_observed=True``); the latent ones are fitted by least
        squares so that the simulated outputs over the given samples match the
        measured ones. One least-squares problem per record, solved by
        :func:`~skhybrid.simulation.fit_initial_states` with every record's
        simulations in one batch; a record's estimate never depends on the
        other records given with it.

        Parameters
        ----------
        %(initial_window_inputs)s
        outputs : array-like of shape (n_init, n_outputs), (n_records, n_init, \
n_outputs) or list of 2-D arrays
            Measured outputs of the initialisation window; ``n_init >= 1``
            samples, all finite.
        params : dict or None, default=None
            Parameter values by name to simulate with; ``None`` uses the fitted
            ``params_``. A state-space hybrid estimates its physics' states at
            the physics' current parameters this way.

        Returns
        -------
        states : ndarray of shape (n_records, n_states)
            The estimated state at the first sample of each record.

        Raises
        ------
        ValueError
            Where a record has no measured sample, or a non-finite input or
            output (naming the record and the time step).
        """
        structure = self._check_fitted_structure()
        U_list, Y_list, _ = check_trajectories(inputs, outputs, initial_name="outputs")
        self._check_records(U_list, Y_list, "outputs")
        return self._estimate_records(
            U_list, Y_list, self.params_ if params is None else params, structure
        )

    def _estimate_records(self, U_list, Y_list, params, structure, **kwargs):
        """Initial states of records of any lengths, each length one batch."""
        out = np.empty((len(U_list), structure[0]))
        for n_init, idx in _groups([len(y) for y in Y_list]):
            U = np.stack([U_list[i][:n_init] for i in idx])
            Y = np.stack([Y_list[i] for i in idx])
            out[idx] = self._estimate_x0(Y, U, params, structure, **kwargs)
        return out

    def _check_records(self, U_list, Y_list, y_name):
        if len(U_list) != len(Y_list):
            raise ValueError(
                f"inputs holds {len(U_list)} record(s) but {y_name} holds "
                f"{len(Y_list)}; give one {y_name} array per inputs array."
            )
        # check_trajectories has checked that every record has these widths.
        n_inputs, n_outputs = U_list[0].shape[1], Y_list[0].shape[1]
        for name, expected, got in (
            ("input", getattr(self, "n_inputs_", None), n_inputs),
            ("output", getattr(self, "n_outputs_", None), n_outputs),
        ):
            if expected is not None and expected != got:
                raise ValueError(
                    f"the model was fitted with {expected} {name} column(s); got {got}."
                )
        for i, (u, y) in enumerate(zip(U_list, Y_list, strict=True)):
            if len(y) > len(u):
                raise ValueError(
                    f"{y_name}[{i}] holds {len(y)} time steps but inputs[{i}] only "
                    f"{len(u)}; inputs cover the whole record."
                )
        return n_inputs, n_outputs


def _groups(sizes):
    """``(size, indices)`` of the records sharing each size."""
    sizes = np.asarray(sizes)
    return [(int(s), np.flatnonzero(sizes == s)) for s in np.unique(sizes)]
