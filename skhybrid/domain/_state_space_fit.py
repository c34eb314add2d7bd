"""Fit strategies of StateSpaceModel: the simulation-error fit and its starts.

``fit_simulation`` (the free-run error over whole records, with the Jacobians
simulated in one batch where the equations are vectorised), and the stages
before a fit: several ``starts`` and the ``continuation``. A mixin of
:class:`~skhybrid.domain.StateSpaceModel`.
"""

import copy
import warnings

import numpy as np

from skhybrid.domain._base import _central_differences, _ParameterSpec
from skhybrid.domain._continuation import continued_start
from skhybrid.domain._starts import short_fit_start
from skhybrid.domain._state_space_batch import SetRows, simulation_key
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.losses import objective_residuals
from skhybrid.simulation import check_trajectories
from skhybrid.utils._docstrings import RECORDS_OUTPUTS, fill_doc
from skhybrid.utils._lockstep import current_member
from skhybrid.utils._sklearn_compat import _fit_context
from skhybrid.utils._transaction import transactional

# Residual given to least_squares where a simulation became non-finite or ran
# off (beyond this many times the largest measured output, at least 1).
_DIVERGED_RESIDUAL = 1e6


def _penalised(r, Y):
    """``r`` with every diverged residual set to the penalty, and the penalty.

    A trial step into an unstable region makes the free run overflow: its
    residuals are inf or NaN, or finite but so large that their finite
    differences overflow, and least_squares then stops inside scipy with
    "array must not contain infs or NaNs". A bounded penalty there lets it
    reject the step and shrink its region instead.
    """
    bound = _DIVERGED_RESIDUAL * max(1.0, float(np.max(np.abs(Y), initial=0.0)))
    with np.errstate(invalid="ignore"):
        diverged = ~(np.abs(r) <= bound)
    return np.where(diverged, bound, r), bound


@fill_doc(records_outputs=RECORDS_OUTPUTS)
class _SimulationFitMixin:
    """The simulation-error fit of a StateSpaceModel and where a fit starts."""

    # -- simulation-error fit ------------------------------------------------------
    def fit_simulation(self, inputs, outputs):
        """Fit the free parameters on whole records by the free-run output error.

        Each record's initial state is estimated from its first ``n_init``
        samples (least squares through the physics at the current parameters),
        then the model runs free over the whole record; ``least_squares``
        minimises the simulated outputs' error over every sample. The fitted model
        also predicts windows of ``n_steps`` steps (``predict``) and simulates
        (``simulate``).

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), (n_records, n_times, \
n_inputs) or list of (n_times_i, n_inputs) arrays
            Inputs of each record; ``inputs[t]`` acts between samples ``t`` and
            ``t + 1``. Zero columns for an autonomous system.
        %(records_outputs)s

        Returns
        -------
        self : object
            The fitted model.
        """
        start = self._fit_start("fit_simulation", inputs, outputs)
        return self._fit_simulation(inputs, outputs, start=start)

    def _fit_start(self, method, *args):
        """Where ``method``'s fit starts: after the ``starts``, then the continuation.

        None where neither applies (the fit starts from ``params``).
        """
        self._validate_params()  # starts_nfev, before the short fits use it
        chosen = short_fit_start(self, method, *args)
        continued = continued_start(self, method, *args, base=chosen)
        return continued if continued is not None else chosen

    @transactional
    @_fit_context(prefer_skip_nested_validation=True)
    def _fit_simulation(self, inputs, outputs, start=None):
        structure = self._structure()
        U_list, Y_list, _ = check_trajectories(inputs, outputs, initial_name="outputs")
        for attr in ("n_inputs_", "n_outputs_", "feature_names_in_"):
            self.__dict__.pop(attr, None)
        n_inputs, n_outputs = self._check_records(U_list, Y_list, "outputs")
        for i, (u, y) in enumerate(zip(U_list, Y_list, strict=True)):
            if len(u) != len(y):
                raise ValueError(
                    f"inputs[{i}] holds {len(u)} time steps but outputs[{i}] "
                    f"{len(y)}; each record's inputs and outputs must be aligned."
                )
            if len(y) <= self._init_window:
                raise ValueError(
                    f"outputs[{i}] holds {len(y)} time steps, not more than "
                    f"n_init={self._init_window}: nothing is left to simulate."
                )
        if self.jac == "autograd":
            raise ValueError(
                "fit_simulation differentiates by finite differences; got "
                "jac='autograd'. Use jac='2-point' or '3-point'."
            )
        self._check_layout(n_outputs + n_inputs, n_outputs)
        self.n_outputs_, self.n_inputs_ = n_outputs, n_inputs
        self.n_features_in_ = self.n_steps * (n_outputs + n_inputs)
        self._y_1d = False

        lengths = np.array([len(u) for u in U_list])
        T = int(lengths.max())
        U = np.zeros((len(U_list), T, n_inputs))
        Y = np.zeros((len(U_list), T, n_outputs))
        for i, (u, y) in enumerate(zip(U_list, Y_list, strict=True)):
            U[i, : len(u)], Y[i, : len(y)] = u, y
        mask = np.arange(T)[None, :] < lengths[:, None]
        y_flat = Y[mask]
        init = self._initial_params(start=start)
        if self.vectorized is True and any(np.ndim(v) for v in init.values()):
            raise ValueError(
                "vectorized=True broadcasts one value of each parameter per row; "
                "every parameter must be a scalar, got array-valued "
                f"{sorted(k for k, v in init.items() if np.ndim(v))}."
            )
        spec = _ParameterSpec(init, self.fixed, self.resolved_bounds(init))
        self._spec = spec
        if self.objective != "mse" and self.ljung_box_lags >= y_flat.shape[0]:
            raise ValueError(
                f"ljung_box_lags={self.ljung_box_lags} must be smaller than the "
                f"number of samples, {y_flat.shape[0]}."
            )
        self._records = (U, Y, mask, structure)
        self._speculated = None
        try:
            self._batch = self._broadcasts(spec)
            self.batched_jacobian_ = self._batch
            theta, result = self._least_squares(U, y_flat, spec)
            self.result_ = result
            self.params_ = spec.to_dict(theta)
            self.params_std_, self.params_cov_ = self._standard_errors(
                U, y_flat, spec, theta
            )
            Y_sim, x0 = self._simulate_records(U, Y, self.params_, structure)
        finally:
            del self._records, self._batch, self._speculated
        self._check_fitted_run(Y_sim, Y, mask, lengths)
        self.initial_states_ = x0
        err = (Y_sim - Y)[mask]
        self.rmse_ = float(np.sqrt(np.mean(err**2)))
        self.noise_model_ = None
        if self.noise_model is not None:
            n_init = min(self._init_window, T)
            residuals = np.concatenate(
                [(Y[i] - Y_sim[i])[n_init : lengths[i]] for i in range(len(lengths))]
            )
            self.noise_model_ = copy.deepcopy(self.noise_model).fit(residuals)
        return self

    def _check_fitted_run(self, Y_sim, Y, mask, lengths):
        """Raise where the fitted parameters' free run diverges on a record.

        The penalty keeps least_squares going where a trial step diverges; a
        fit that ends there has no model to give (its rmse_ would be inf), so
        this is an error, named, rather than a warning.
        """
        with np.errstate(all="ignore"):
            _, bound = _penalised(np.zeros(0), Y[mask])
            run_off = ~(np.abs(Y_sim - Y) <= bound)
        for i, n in enumerate(lengths):
            bad = np.flatnonzero(np.any(run_off[i, :n], axis=1))
            if bad.size:
                params = {k: self.params_[k] for k in self._spec.free}
                raise SimulationDivergedError(
                    f"{type(self).__name__}.fit_simulation: the free run at the "
                    f"fitted parameters {params} diverges (overflows or runs off "
                    f"beyond {bound:.3g}) on record {i} from time step {bad[0]}, "
                    f"so least_squares found no stable model from params="
                    f"{self.params!r}. Start nearer a stable model (params, "
                    "starts), bound the parameters to their stable range "
                    "(bounds), or shorten the records."
                )

    def _simulate_records(self, U, Y, params, structure, per_row=()):
        n_init = min(self._init_window, Y.shape[1])
        x0 = self._estimate_x0(
            Y[:, :n_init], U[:, :n_init], params, structure, per_row=per_row
        )
        with np.errstate(all="ignore"):
            out, _ = self._run(x0, U, params, structure[1], np)
        return out, x0

    def _record_residuals(self, theta, spec):
        """The records' free-run residuals at ``theta``, penalised where diverged.

        Where the parameter sets are simulated in one batch, the steps of the
        Jacobian at ``theta`` are simulated with it: ``least_squares`` asks for
        the Jacobian at every step it accepts, and the batch costs little more
        than one run where a run is a loop over time steps. The Jacobian then
        reads them (:meth:`_batched_jacobian`) instead of simulating again.
        """
        theta = np.asarray(theta, dtype=float)
        U, Y, mask, structure = self._records
        cached = self._speculation(theta)
        if cached is not None:
            return cached[0].reshape(-1, Y.shape[2])
        if getattr(self, "_batch", False):
            sets, _ = _difference_sets(theta, spec, central=self.jac == "3-point")
            R = self._record_residuals_batch(sets, spec)
            self._speculated = (theta.copy(), R)
            return R[0].reshape(-1, Y.shape[2])
        params = spec.to_dict(theta)
        out, _ = self._simulate_records(U, Y, params, structure)
        with np.errstate(all="ignore"):
            r = (Y - out)[mask]
        return _penalised(r, Y[mask])[0]

    def _speculation(self, theta):
        """The batch simulated with ``theta`` (its residuals first), or None."""
        cached = getattr(self, "_speculated", None)
        if cached is not None and np.array_equal(cached[0], theta):
            return cached[1]
        return None

    def _residual_vector(self, X, y, spec, xp):
        if getattr(self, "_records", None) is None:
            return super()._residual_vector(X, y, spec, xp)

        def residuals(theta):
            return self._objective(
                self._record_residuals(np.asarray(theta, dtype=float), spec)
            )

        return residuals

    def _objective(self, r):
        """The objective's residual vector of the records' residuals ``r``."""
        return objective_residuals(
            r,
            self.objective,
            lags=self.ljung_box_lags,
            ljung_box_weight=self.ljung_box_weight,
        )

    def _raw_jacobian(self, X, y, spec, theta):
        if getattr(self, "_records", None) is None:
            J, base = super()._raw_jacobian(X, y, spec, theta)
        else:

            def raw(t):
                return np.reshape(self._record_residuals(t, spec), -1)

            base = raw(theta)
            if getattr(self, "_batch", False):
                J = _central_differences_batch(
                    lambda sets: self._record_residuals_batch(sets, spec),
                    theta,
                    spec,
                )
            else:
                J = _central_differences(raw, theta, spec, base.size)
        return J, base

    def _broadcasts(self, spec):
        """Whether parameter sets can be simulated in one batch, one set per row.

        ``vectorized=True`` says so and ``False`` says not; ``"auto"`` finds out
        by simulating the start of the first record at two parameter sets both
        ways, one batch with a value per row and each set on its own, and
        batching where both give the same outputs (an ``rhs`` of plain
        elementwise arithmetic does; one that raises on array-valued
        parameters, or mixes rows, does not).
        """
        if self.vectorized is not True and self.vectorized != "auto":
            return False
        if self.jac == "autograd" or spec.n_free == 0:
            return False
        if self.vectorized is True:
            return True
        if any(np.ndim(v) for v in spec.to_dict(spec.x0).values()):
            return False
        U, Y, mask, structure = self._records
        n = min(Y.shape[1], self._init_window + 10)
        probe = (U[:1, :n], Y[:1, :n], mask[:1, :n], structure)
        thetas = np.vstack([spec.x0, _nudged(spec.x0, spec)])
        records, self._records = self._records, probe
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                batch = self._simulate_sets(thetas, spec)
                self._batch = False
                alone = [self._record_residuals(t, spec).ravel() for t in thetas]
            return bool(
                np.all(np.isfinite(batch))
                and np.allclose(batch, np.vstack(alone), rtol=1e-9, atol=0.0)
            )
        except Exception:  # noqa: BLE001 - any failure means "not vectorized"
            return False
        finally:
            self._records = records

    def _record_residuals_batch(self, thetas, spec):
        """Residuals ``(n_sets, n_residuals)`` of parameter sets ``thetas``.

        A fit run in lockstep with others (:func:`run_in_lockstep`, the short
        fits of ``starts``) has its sets simulated in one batch with theirs.
        """
        member = current_member()
        if member is None:
            return self._simulate_sets(thetas, spec)
        lockstep, index = member
        return lockstep.evaluate(index, self._set_rows(thetas, spec))

    def _simulate_sets(self, thetas, spec):
        """Residuals ``(n_sets, n_residuals)`` of ``thetas``, in one simulation."""
        return self._set_rows(thetas, spec).simulate()

    def _set_rows(self, thetas, spec):
        """The parameter sets ``thetas`` as rows of one free run of the records."""
        U, Y, mask, structure = self._records
        n_sets, n_rec = len(thetas), U.shape[0]
        per_set = [spec.to_dict(t) for t in thetas]
        params = {
            name: (
                np.repeat([p[name] for p in per_set], n_rec)
                if name in spec.free
                else per_set[0][name]
            )
            for name in per_set[0]
        }
        # The records are laid out once per set in the run's own array; the run
        # reads the measured outputs of the initial-state window only, and the
        # rest is compared with the records' own.
        n_window = min(self._init_window, Y.shape[1])

        def finish(out):
            out = out.reshape(n_sets, n_rec, *Y.shape[1:])
            with np.errstate(all="ignore"):
                r = (Y[None] - out)[:, mask]
            return _penalised(r.reshape(n_sets, -1), Y[mask])[0]

        # The values every row shares (the fixed parameters) are part of the
        # key: rows of other fits join only where they agree (a continuation's
        # stages fix a parameter at other values).
        shared = sorted((k, repr(v)) for k, v in params.items() if np.ndim(v) == 0)
        key = (simulation_key(self), *shared)
        return SetRows(
            self._simulate_records,
            key,
            structure,
            U,
            Y[:, :n_window],
            params,
            finish,
            copies=n_sets,
        )

    def _batched_jacobian(self, spec):
        if getattr(self, "_records", None) is None:
            return None
        if not getattr(self, "_batch", False):
            return None
        central = self.jac == "3-point"

        def jac(theta):
            theta = np.asarray(theta, dtype=float)
            sets, combine = _difference_sets(theta, spec, central=central)
            R = self._speculation(theta)
            if R is None:
                R = self._record_residuals_batch(sets, spec)
            if self.objective == "mse":
                # objective="mse" divides the residuals by the root of their number.
                return combine(R) / np.sqrt(R.shape[1])
            n_outputs = self._records[1].shape[2]
            return combine(
                np.vstack([self._objective(r.reshape(-1, n_outputs)) for r in R])
            )

        return jac


def _nudged(theta, spec):
    """``theta`` moved by a per mille of its size, inside the bounds."""
    size = np.maximum(np.abs(theta), 1e-3 * spec.scale)
    up = np.minimum(theta + 1e-3 * size, spec.upper)
    return np.where(up > theta, up, np.maximum(theta - 1e-3 * size, spec.lower))


def _difference_sets(theta, spec, central):
    """The parameter sets of a finite-difference Jacobian at ``theta``, and its rule.

    ``theta`` is the first set; forward differences (``central=False``, the
    step backwards where the upper bound is too close) add one set per
    parameter, central differences two, each step kept inside the bounds.
    ``combine(R)`` turns the sets' residuals ``R`` (one row per set) into the
    Jacobian ``(n_residuals, n_parameters)``; a parameter pinned between its
    bounds gets a zero column.
    """
    size = np.maximum(np.abs(theta), 1e-3 * spec.scale)
    eye = np.eye(theta.size)
    if not central:
        step = np.sqrt(np.finfo(float).eps) * size
        step = np.where(theta + step > spec.upper, -step, step)
        sets = np.vstack([theta, theta + np.diag(step)])

        def combine(R):
            return ((R[1:] - R[0]) / step[:, None]).T

        return sets, combine
    step = np.finfo(float).eps ** (1 / 3) * size
    hi = np.maximum(np.minimum(step, spec.upper - theta), 0.0)
    lo = np.maximum(np.minimum(step, theta - spec.lower), 0.0)
    sets = np.vstack([theta, theta + eye * hi[:, None], theta - eye * lo[:, None]])
    width = hi + lo

    def combine(R):
        n = theta.size
        J = (R[1 : n + 1] - R[n + 1 :]) / np.where(width > 0, width, 1.0)[:, None]
        J[width == 0] = 0.0
        return J.T

    return sets, combine


def _central_differences_batch(raw_batch, theta, spec):
    """:func:`_central_differences` with every step simulated in one batch."""
    sets, combine = _difference_sets(theta, spec, central=True)
    return combine(raw_batch(sets))
