"""Free-run simulation of a fitted StateSpaceHybridRegressor.

The initial state of each record from its measured window (the encoder, or
least squares through the trained model), then the free run. A mixin of
:class:`~skhybrid.hybrid.StateSpaceHybridRegressor`.
"""

import numpy as np
import torch
from sklearn.utils.validation import check_is_fitted

from skhybrid.exceptions import SimulationDivergedError
from skhybrid.simulation import (
    check_finite_runs,
    check_trajectories,
    fit_initial_states,
    pack_trajectories,
    stack_trajectories,
)
from skhybrid.utils._docstrings import (
    INITIAL_WINDOW_INPUTS,
    NO_NOISE_SIMULATE_OPTIONS,
    RECORD_INPUTS,
    SIMULATE_FROM_STATE_DOCS,
    fill_doc,
)
from skhybrid.utils._simulate_checks import check_initial_states, check_simulate_options
from skhybrid.utils._simulate_contract import SimulateContract


@fill_doc(
    initial_window_inputs=INITIAL_WINDOW_INPUTS,
    no_noise_simulate_options=NO_NOISE_SIMULATE_OPTIONS,
    record_inputs=RECORD_INPUTS,
    **SIMULATE_FROM_STATE_DOCS,
)
class _SimulationMixin(SimulateContract):
    """``simulate``, ``simulate_from_state`` and ``estimate_initial_state``."""

    # -- simulation ----------------------------------------------------------------
    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Simulate the fitted model in free run from measured initial windows.

        The encoder reads the last ``n_init`` samples of each initial window
        (``n_steps`` after :meth:`fit`), then the model runs free to the end of
        the inputs. Follows the contract of :func:`skhybrid.simulation.simulate`:
        the first ``len(initial)`` samples returned are the measured ones.

        Parameters
        ----------
        %(record_inputs)s
        initial : array-like of shape (n_init, n_outputs), (n_trajectories, \
n_init, n_outputs) or list of 2-D arrays
            Measured outputs of the first time steps (at least ``n_init``), all
            finite.
        init : {"measured", "least_squares"}, default="measured"
            ``"measured"``: the encoder reads the newest ``n_init`` measured
            samples and the simulation starts there. ``"least_squares"``: the
            state the encoder gives at the end of the *first* ``n_init``
            samples is refined so that the model's own free run through all of
            ``initial`` matches it in least squares
            (:func:`~skhybrid.simulation.fit_initial_states`, one problem per
            trajectory), and the simulation continues from that run; with
            ``initial`` well longer than ``n_init`` this averages the
            measurement noise out of the start.
        %(no_noise_simulate_options)s

        Returns
        -------
        outputs : ndarray or list of ndarray
            Simulated outputs in the container form of ``inputs``.
        """

        check_is_fitted(self)
        check_simulate_options(
            self,
            init,
            n_samples,
            return_std,
            remedy="it simulates the deterministic path only",
        )
        k = self._k
        U_list, Y_list, form = check_trajectories(
            inputs, initial, min_init=k, window_name=f"the encoder (n_init={k})"
        )
        if U_list[0].shape[1] != self.n_inputs_:
            raise ValueError(
                f"the model was fitted with {self.n_inputs_} input column(s); got "
                f"{U_list[0].shape[1]}."
            )
        if Y_list[0].shape[1] != self.n_outputs_:
            raise ValueError(
                f"the model was fitted with {self.n_outputs_} output column(s); got "
                f"{Y_list[0].shape[1]} in initial."
            )
        lengths = np.array([len(u) for u in U_list])
        starts = np.array([len(y) for y in Y_list])
        n_max = int(lengths.max())
        out = np.zeros((len(U_list), n_max, self.n_outputs_))
        pairs = sorted({(int(a), int(b)) for a, b in zip(starts, lengths, strict=True)})
        for s, n in pairs:
            idx = [i for i in range(len(U_list)) if (starts[i], lengths[i]) == (s, n)]
            for i in idx:
                out[i, :s] = Y_list[i]
            if n == s:
                continue
            U = np.stack([U_list[i][:n] for i in idx])
            Y = np.stack([Y_list[i] for i in idx])
            if init == "least_squares" and s > k:
                sim = self._least_squares_run(Y, U)[:, s - k :]
            else:
                Yw = Y[:, s - k : s]
                prior = self._prior(Yw, U[:, s - k : s])
                u = torch.as_tensor(U)
                with torch.no_grad():
                    sim = self.module_.rollout(
                        torch.as_tensor(Yw),
                        u[:, s - k : s - 1],
                        u[:, s - 1 : n - 1],
                        None if prior is None else torch.as_tensor(prior),
                        params=self._params_t,
                    ).numpy()
            finite = np.all(np.isfinite(sim), axis=2)
            if not np.all(finite):
                j, t = np.argwhere(~finite)[0]
                raise SimulationDivergedError(
                    f"the simulation diverged at time step {s + t}: trajectory "
                    f"{idx[j]} reached a non-finite output."
                )
            out[idx, s:n] = sim
        return pack_trajectories(out, lengths, form)

    def estimate_initial_state(self, inputs, outputs):
        """The physics' state at the first sample of records, at ``params_``.

        :meth:`StateSpaceModel.estimate_initial_state` of the physics at the
        jointly trained physical parameters (the encoder is not used): the
        start of :meth:`simulate_from_state`.

        Parameters
        ----------
        %(initial_window_inputs)s
        outputs : array-like of shape (n_init, n_outputs), (n_records, n_init, \
n_outputs) or list of 2-D arrays
            Measured outputs of the initialisation window.

        Returns
        -------
        states : ndarray of shape (n_records, n_states)
            The physics' state at the first sample of each record.
        """
        check_is_fitted(self)
        return self.physics_.estimate_initial_state(
            inputs, outputs, params=self.params_
        )

    def simulate_from_state(self, inputs, states):
        """Simulate the corrected model in free run from known physics states.

        For a record that starts where no measured window precedes it (a test
        record started from another record's initial state, say): the
        physics' states are given, the augmented states start at zero, and
        the corrected state update runs from the first sample.

        Parameters
        ----------
        %(states_records_inputs)s
        states : array-like of shape (n_states,) or (n_records, n_states)
            The physics' state at the first sample of each record (for example
            from :meth:`estimate_initial_state`).

        Returns
        -------
        %(simulated_from_states)s

        Raises
        ------
        SimulationDivergedError
            Where the run reaches a non-finite output.
        """

        check_is_fitted(self)
        U_list, _, form = check_trajectories(inputs, None)
        if U_list[0].shape[1] != self.n_inputs_:
            raise ValueError(
                f"the model was fitted with {self.n_inputs_} input column(s); got "
                f"{U_list[0].shape[1]}."
            )
        module = self.module_
        n_states = module.n_physics_states
        x0 = check_initial_states(
            states,
            len(U_list),
            n_states,
            self.physics_.state_names,
            whose="the physics' ",
        )
        U, lengths = stack_trajectories(U_list)
        x = torch.as_tensor(
            np.hstack([x0, np.zeros((len(x0), module.n_augmented))]),
            dtype=torch.float64,
        )
        u = torch.as_tensor(U, dtype=torch.float64)
        outs = []
        with torch.no_grad():
            for t in range(U.shape[1]):
                outs.append(module.observe(x, self._params_t))
                if t < U.shape[1] - 1:
                    x = module.advance(x, u[:, t], self._params_t)
        out = torch.stack(outs, dim=1).numpy()
        check_finite_runs(out, lengths)
        return pack_trajectories(out, lengths, form)

    def _least_squares_run(self, Y, U):
        """Outputs ``(n, T - k, p)`` after the first window, its end state fitted.

        The encoder's state at sample ``k - 1`` of each record starts a least
        squares fit of the free run through the measured ``Y (n, s, p)``; the
        run from the fitted state then goes on under ``U (n, T, m)``.
        """

        k, s = self._k, Y.shape[1]
        Yw = Y[:, :k]
        prior = self._prior(Yw, U[:, :k])
        u = torch.as_tensor(U)
        with torch.no_grad():
            x0 = self.module_.encode(
                torch.as_tensor(Yw),
                u[:, : k - 1],
                None if prior is None else torch.as_tensor(prior),
            ).numpy()

        def run(x, U_run):
            outs = []
            with torch.no_grad():
                x = torch.as_tensor(x)
                for t in range(U_run.shape[1]):
                    x = self.module_.advance(x, U_run[:, t], self._params_t)
                    outs.append(self.module_.observe(x, self._params_t))
            if not outs:
                return np.zeros((len(U_run), 0, self.n_outputs_))
            return torch.stack(outs, dim=1).numpy()

        def residuals(Z, index):
            with np.errstate(all="ignore"):
                first = self.physics_.observe(
                    Z[:, : len(self.state_mean_)], self.params_
                )
                rest = run(Z, u[index, k - 1 : s - 1])
                r = np.concatenate([first[:, None], rest], axis=1) - Y[index, k - 1 :]
            return r.reshape(len(index), -1)

        z, _ = fit_initial_states(residuals, x0)
        return run(z, u[:, k - 1 : U.shape[1] - 1])
