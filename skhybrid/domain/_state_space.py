"""StateSpaceModel: a user's state equations with latent states and initial-state fits.

The model is ``dx/dt = f(x, u; p)`` (or ``x(t+1) = f(x, u; p)`` in discrete time)
with the output ``y = x[observed]`` or ``y = h(x; p)``. Unmeasured (latent) states
of the first sample of a record are estimated by least squares through the physics
over an initialisation window; the parameters are fitted either on windows of
history (one-step-ahead error, :meth:`StateSpaceModel.fit`) or on whole records by
the free-run simulation error (:meth:`StateSpaceModel.fit_simulation`).
"""

from numbers import Integral, Real

import numpy as np
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from skhybrid.domain._base import DomainModel, _ParameterSpec

# The model's parts live in their own modules (fit strategies, initial
# states, integrators); their module-level helpers are re-exported here, where
# they were defined before the split.
from skhybrid.domain._state_space_fit import (  # noqa: F401 (re-exported)
    _DIVERGED_RESIDUAL,
    _central_differences_batch,
    _penalised,
    _SimulationFitMixin,
)
from skhybrid.domain._state_space_initial import (  # noqa: F401 (re-exported)
    _groups,
    _InitialStateMixin,
)
from skhybrid.domain._state_space_integrators import _IntegratorMixin
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import (
    check_finite_runs,
    check_trajectories,
    pack_trajectories,
    stack_trajectories,
)
from skhybrid.utils._array_api import get_namespace, is_torch
from skhybrid.utils._docstrings import RECORD_INPUTS, SIMULATE_FROM_STATE_DOCS, fill_doc
from skhybrid.utils._simulate_checks import check_initial_states, check_simulate_options
from skhybrid.utils._sklearn_compat import (
    HasMethods,
    Interval,
    StrOptions,
    _fit_context,
    validate_data,
)

__all__ = ["StateSpaceModel"]

#: Initialisation window of ``fit_simulation`` where ``n_init`` is None.
DEFAULT_N_INIT = 20


@fill_doc(record_inputs=RECORD_INPUTS, **SIMULATE_FROM_STATE_DOCS)
class StateSpaceModel(
    _SimulationFitMixin, _InitialStateMixin, _IntegratorMixin, DomainModel
):
    """A state-space physics model with latent states, fitted by least squares.

    Write the state equations once, ``rhs(x, u, *, xp, **params)``, against the
    array namespace ``xp``: ``x`` has shape ``(n, n_states)`` and ``u`` shape
    ``(n, n_inputs)`` (possibly zero columns), and ``rhs`` returns ``dx/dt`` of shape
    ``(n, n_states)`` for ``time="continuous"`` or the next state ``x(t+1)`` for
    ``time="discrete"``. Continuous-time equations are integrated over each sample
    period ``dt`` with the input held constant (zero-order hold), by ``n_substeps``
    Euler or classical Runge-Kutta steps, or by :func:`scipy.integrate.solve_ivp`;
    with ``input_points=k`` the inputs hold each input at ``k`` times of the
    period (:func:`~skhybrid.domain.band_limited_inputs`) and each stage reads
    the input at its own time.

    Only the ``observed`` states are measured; the others are latent. Wherever a
    record (a window of history, or the initialisation window of a simulation)
    starts, the observed states start at their measured values and the latent ones
    are estimated by least squares: the initial latent state whose simulated
    outputs over the window match the measured ones best (one least-squares
    problem per record, solved by :func:`~skhybrid.simulation.fit_initial_states`,
    the package's one initial-state solver).

    Two ways to fit the parameters:

    - ``fit(X, y)``: scikit-learn's convention. A row of ``X`` is a window of
      ``n_steps`` time steps, oldest first, each ``[outputs..., inputs...]`` (see
      :func:`~skhybrid.preprocessing.make_windows`), and ``y`` the outputs at the
      step after the window. The prediction of a row estimates the state at the
      window's first step from the window, then simulates to the next step.
      Choose ``n_steps`` large enough for the window to determine the latent
      states.
    - ``fit_simulation(inputs, outputs)``: on whole records, by the free-run
      (output) error; each record's initial state is estimated from its first
      ``n_init`` samples.

    After a fit, a nearly singular Jacobian of the residuals with respect to the
    free parameters (relative units) warns with
    :class:`~skhybrid.exceptions.IdentifiabilityWarning`, naming the parameters
    that only the data determine in combination.

    Parameters
    ----------
    rhs : callable
        ``rhs(x, u, *, xp, **params)``: the time derivative (continuous time) or
        the next state (discrete time), shape ``(n, n_states)``. Define it at
        module level so that the model pickles.
    params : dict of str to float
        Initial value of each parameter, by the name ``rhs`` (and ``output``)
        take it under.
    state_names : sequence of str
        Name of every state, in the column order of ``x``.
    observed : sequence of str or int, or None, default=None
        The measured states (names or column indices): the outputs are
        ``x[:, observed]``, in this order. Give exactly one of ``observed`` and
        ``output``.
    output : callable or None, default=None
        ``output(x, *, xp, **params)`` returning the outputs ``(n, n_outputs)``
        for a general measurement function; then every initial state is estimated
        by least squares, starting from ``initial_state``.
    time : {"continuous", "discrete"}, default="continuous"
        Whether ``rhs`` returns ``dx/dt`` or ``x(t+1)``.
    dt : float or None, default=None
        Sample period of the data, needed for ``time="continuous"``; pass the
        data set's ``data.dt`` (every loader of :mod:`skhybrid.datasets` returns
        it).
    method : {"rk4", "euler", "solve_ivp"}, default="rk4"
        Integrator of continuous-time equations: fixed-step classical Runge-Kutta
        or explicit Euler with ``n_substeps`` steps per sample, or
        :func:`scipy.integrate.solve_ivp` (NumPy only; ``solver_options``).
    n_substeps : int, default=1
        Integration steps per sample period (``"euler"`` and ``"rk4"``).
    input_points : int, default=1
        Values of each input that a sample of the inputs holds, at equally
        spaced times from the sample to the next (continuous time only). 1:
        the input is held over the period (zero-order hold). ``k >= 2``: the
        inputs are the columns of
        :func:`~skhybrid.domain.band_limited_inputs` ``(u, n_points=k)``
        (input ``j`` at time ``t + i / (k - 1)`` in column ``j * k + i``), and
        the integrator hands ``rhs`` each input at its stage's time,
        interpolated linearly between the points (exact where the stages fall
        on them: ``k = 2 n_substeps + 1`` for ``"rk4"``, ``n_substeps + 1`` for
        ``"euler"``). For an input that moves between its samples (a
        multisine, filtered noise), which a hold misrepresents.
    solver_options : dict or None, default=None
        Keyword arguments of :func:`scipy.integrate.solve_ivp`; ``None`` uses
        ``method="DOP853", rtol=1e-10, atol=1e-12``.
    initial_state : array-like of shape (n_states,), callable or None, \
default=None
        Starting guess of the estimated initial states: one state for every
        record (``None`` is zeros), or ``initial_state(outputs, inputs)`` returning
        guesses ``(n_records, n_states)`` from the windows' measured outputs
        ``(n_records, n_window, n_outputs)`` and inputs. Least squares through
        nonlinear physics (a backlash, friction) can stop in a local minimum far
        from a poor guess: a guess consistent with the measurements (a motor angle
        of ``gear_ratio`` times the load angle) helps.
    n_init : int or None, default=None
        Samples at the start of each record from which ``fit_simulation``
        estimates its initial state. None takes 20, or, where a
        :class:`~skhybrid.experiments.SystemSpec` fits the model, the spec's
        ``n_init`` (so a machine's initialisation window is said once).
    estimate_observed : bool, default=True
        Whether the initial values of the observed states are fitted too, starting
        from their measured values (robust to measurement noise), or held at the
        measured values (``False``). A window of one step always holds them at the
        measured values.
    identifiability_tol : float, default=1e-6
        Warn with ``IdentifiabilityWarning`` where the smallest singular value of
        the relative Jacobian is below this fraction of the largest.
    fixed : tuple of str, default=()
        Parameters held at their initial values during a fit.
    bounds : dict of str to (float, float) or None, default=None
        Bounds of named parameters.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        Least-squares objective (see :class:`DomainModel`).
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    jac : {"2-point", "3-point", "autograd"}, default="2-point"
        Jacobian of the residuals; ``"autograd"`` needs a model whose states are
        all observed (no initial-state estimation inside the residuals), the
        ``"rk4"`` or ``"euler"`` integrator and ``fit(X, y)``.
    loss : str, default="linear"
        Robust loss of ``least_squares``.
    f_scale : float, default=1.0
        Soft margin of robust losses.
    max_nfev : int or None, default=None
        Most residual evaluations.
    n_steps : int, default=1
        Time steps per row of ``X`` (the window of ``fit`` and ``predict``).
    vectorized : bool or "auto", default="auto"
        Whether ``rhs`` (and ``output``) broadcast parameter values given as
        arrays of shape ``(n,)``, one value per row of ``x`` (plain elementwise
        arithmetic does). Then ``fit_simulation`` simulates the perturbed
        parameter sets of its finite-difference Jacobians (``jac="2-point"``
        or ``"3-point"``, any ``objective``) in one batch, together with the
        residuals at the point they are taken at: one pass over the records
        per accepted step instead of one per parameter and one more for the
        residuals, which matters where a record is long and the model cheap
        (a pass is a loop over its time steps). ``"auto"`` finds out at the
        start of each fit by simulating the first record's first samples at
        two parameter sets, batched and one by one, and batches where they
        agree (``batched_jacobian_`` says which); ``False`` never batches.
        Needs scalar parameters.
    noise_model : object or None, default=None
        An unfitted noise model, :class:`~skhybrid.hybrid.GaussianNoise` or
        :class:`~skhybrid.hybrid.AutoRegressiveNoise` (or anything with
        ``fit(residuals)`` and ``sample(n_samples, random_state)``), copied and
        fitted by ``fit_simulation`` to the simulation residuals of every
        record after its ``n_init`` initialisation samples (the records one
        after the other, in time order). Then ``simulate`` gives sample paths
        (``n_samples``) and bands (``return_std=True``). ``fit(X, y)`` fits no
        noise model: its one-step residuals are not those of a free run.
    continuation : dict of str to sequence of float, or None, default=None
        Fits before the final one, through a sequence of values of fixed
        parameters: ``{"eps": [1e-2, 1e-3]}`` fits at ``eps = 1e-2``, then from
        those parameters at ``1e-3``, then from those at ``params["eps"]`` (the
        final fit). For a smoothing parameter (the width of a friction law's
        sign, a saturation's sharpness) whose value in use makes the
        least-squares surface rough: from a smoother surface each fit starts in
        the basin the previous one found, where a direct fit stops in one of
        many nearby local minima, which one depending on rounding (another BLAS
        kernel, another machine). Each named parameter must be in ``fixed``;
        every sequence has one value per stage. ``fit`` and ``fit_simulation``
        run the stages on the same data, each with ``max_nfev`` evaluations;
        only the final fit warns when it does not converge.
    starts : list of dict, or None, default=None
        Other starts of the fit, each a dict of free parameters' values that
        override ``params``: ``fit`` and ``fit_simulation`` first fit from
        ``params`` and from each start with ``starts_nfev`` evaluations, then
        fit from the parameters of the short fit with the lowest cost (then
        through ``continuation``, if given). For a physics whose fit can stop
        in a local minimum from a start only a factor of two or three off (a
        latent state's level, an outlet's height); draw starts with
        :func:`~skhybrid.domain.random_starts`. The short fits' warnings are
        not raised, and a short fit that fails (diverges, overflows) drops its
        start.
    starts_nfev : int or None, default=15
        Residual evaluations of each short fit of ``starts``. None fits from
        every start to convergence (``max_nfev`` each) and keeps the lowest
        cost: slower by about the number of starts, but the fit then never
        ends at a higher cost than from ``params`` alone, where a short fit's
        ranking can pick a start whose valley ends higher.

    Attributes
    ----------
    params_ : dict
        Fitted value of each parameter.
    params_std_ : dict
        Standard errors (0 for fixed parameters).
    params_cov_ : ndarray of shape (n_free, n_free)
        Covariance of the free parameters, in the order of ``free_params_``.
    result_ : OptimizeResult or None
        What ``least_squares`` returned.
    batched_jacobian_ : bool
        Whether ``fit_simulation`` simulated its Jacobians' parameter sets in
        one batch (see ``vectorized``). Set by ``fit_simulation`` only.
    n_features_in_ : int
        Number of columns of a row of ``X``.
    n_outputs_ : int
        Number of outputs.
    n_inputs_ : int
        Number of inputs.
    initial_states_ : ndarray of shape (n_records, n_states)
        Estimated initial state of each record (``fit_simulation`` only).
    rmse_ : float
        Free-run RMSE over the records (``fit_simulation`` only).
    noise_model_ : object or None
        The noise model fitted to the simulation residuals (``fit_simulation``
        with ``noise_model``), else None.
    feature_names_in_ : ndarray of shape (`n_features_in_`,)
        Names of the columns of ``X`` when ``fit`` got a DataFrame with string
        column names.

    See Also
    --------
    ParametricModel : A user's one-step function of the rows.
    LinearStateSpaceModel : An unstructured linear state-space model.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import StateSpaceModel
    >>> def oscillator(x, u, *, xp, omega):
    ...     return xp.stack([x[:, 1], -omega**2 * x[:, 0] + u[:, 0]], axis=1)
    >>> model = StateSpaceModel(
    ...     oscillator, {"omega": 2.8}, state_names=["position", "speed"],
    ...     observed=["position"], dt=0.05, n_substeps=2,
    ... )
    >>> u = np.sin(np.arange(200) * 0.05)[:, None]
    >>> truth = StateSpaceModel(
    ...     oscillator, {"omega": 3.0}, state_names=["position", "speed"],
    ...     observed=["position"], dt=0.05, n_substeps=2, fixed=("omega",),
    ... ).fit_simulation(u, np.zeros((200, 1)))
    >>> y = truth.simulate_from_state(u, [0.5, 0.0])
    >>> model = model.fit_simulation(u, y)
    >>> round(model.params_["omega"], 4)
    3.0
    """

    #: Fits of several records' sets run side by side gain from it: a search
    #: fits its folds in lockstep, their free runs simulated as one batch
    #: (:class:`~skhybrid.model_selection.SimulationSearchCV`).
    fits_in_lockstep = True

    _parameter_constraints = {
        **DomainModel._parameter_constraints,
        "rhs": [callable],
        "params": [dict],
        "state_names": [list, tuple],
        "observed": [list, tuple, None],
        "output": [callable, None],
        "time": [StrOptions({"continuous", "discrete"})],
        "dt": [Interval(Real, 0, None, closed="neither"), None],
        "method": [StrOptions({"rk4", "euler", "solve_ivp"})],
        "n_substeps": [Interval(Integral, 1, None, closed="left")],
        "input_points": [Interval(Integral, 1, None, closed="left")],
        "solver_options": [dict, None],
        "initial_state": ["array-like", callable, None],
        "n_init": [Interval(Integral, 1, None, closed="left"), None],
        "estimate_observed": ["boolean"],
        "identifiability_tol": [Interval(Real, 0, 1, closed="left")],
        "vectorized": ["boolean", StrOptions({"auto"})],
        "noise_model": [HasMethods(["fit", "sample"]), None],
        "continuation": [dict, None],
        "starts": [list, tuple, None],
        "starts_nfev": [Interval(Integral, 1, None, closed="left"), None],
    }

    def __init__(
        self,
        rhs,
        params,
        *,
        state_names,
        observed=None,
        output=None,
        time="continuous",
        dt=None,
        method="rk4",
        n_substeps=1,
        input_points=1,
        solver_options=None,
        initial_state=None,
        n_init=None,
        estimate_observed=True,
        identifiability_tol=1e-6,
        fixed=(),
        bounds=None,
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
        jac="2-point",
        loss="linear",
        f_scale=1.0,
        max_nfev=None,
        n_steps=1,
        vectorized="auto",
        noise_model=None,
        continuation=None,
        starts=None,
        starts_nfev=15,
    ):
        super().__init__(
            fixed=fixed,
            bounds=bounds,
            objective=objective,
            ljung_box_lags=ljung_box_lags,
            ljung_box_weight=ljung_box_weight,
            jac=jac,
            loss=loss,
            f_scale=f_scale,
            max_nfev=max_nfev,
            n_steps=n_steps,
        )
        self.rhs = rhs
        self.params = params
        self.state_names = state_names
        self.observed = observed
        self.output = output
        self.time = time
        self.dt = dt
        self.method = method
        self.n_substeps = n_substeps
        self.input_points = input_points
        self.solver_options = solver_options
        self.initial_state = initial_state
        self.n_init = n_init
        self.estimate_observed = estimate_observed
        self.identifiability_tol = identifiability_tol
        self.vectorized = vectorized
        self.noise_model = noise_model
        self.continuation = continuation
        self.starts = starts
        self.starts_nfev = starts_nfev

    @property
    def _init_window(self):
        """``n_init``, or its default where it is None."""
        return DEFAULT_N_INIT if self.n_init is None else int(self.n_init)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # A fixed functional form (the physics) cannot fit arbitrary data.
        tags.regressor_tags.poor_score = True
        observed = self.observed if self.observed is not None else ()
        tags.target_tags.multi_output = self.output is not None or len(observed) > 1
        return tags

    # -- structure -----------------------------------------------------------------
    def _structure(self):
        """Validated ``(n_states, observed indices, guess)``; ValueError otherwise."""
        names = list(self.state_names)
        if not names or not all(isinstance(n, str) for n in names):
            raise ValueError(
                "state_names must be a non-empty sequence of str; got "
                f"state_names={self.state_names!r}."
            )
        if len(set(names)) != len(names):
            raise ValueError(
                f"state_names={self.state_names!r} repeats a name; each state needs "
                "its own."
            )
        n_states = len(names)
        if (self.observed is None) == (self.output is None):
            raise ValueError(
                "give exactly one of observed (the measured states) and output (a "
                f"measurement function); got observed={self.observed!r} and "
                f"output={self.output!r}."
            )
        observed = None
        if self.observed is not None:
            observed = []
            for item in self.observed:
                if isinstance(item, str):
                    if item not in names:
                        raise ValueError(
                            f"observed names {item!r}, which is not in state_names="
                            f"{names!r}."
                        )
                    observed.append(names.index(item))
                elif isinstance(item, Integral) and not isinstance(item, bool):
                    if not 0 <= item < n_states:
                        raise ValueError(
                            f"observed holds index {item!r}, outside the "
                            f"{n_states} states of state_names={names!r}."
                        )
                    observed.append(int(item))
                else:
                    raise ValueError(  # noqa: TRY004 (a parameter value, not a type)
                        "observed must hold state names or column indices; got "
                        f"{item!r} in observed={self.observed!r}."
                    )
            if not observed or len(set(observed)) != len(observed):
                raise ValueError(
                    "observed must name at least one state, each once; got "
                    f"observed={self.observed!r}."
                )
        if self.time == "continuous" and self.dt is None:
            raise ValueError(
                "dt=None, but time='continuous' needs the sample period: pass "
                "dt=data.dt (every loader of skhybrid.datasets returns it)."
            )
        if self.time == "discrete" and self.input_points != 1:
            raise ValueError(
                f"input_points={self.input_points} is for time='continuous', whose "
                "integrator reads the input between samples; a time='discrete' rhs "
                "reads the columns of its inputs itself: leave input_points=1."
            )
        if self.initial_state is None:
            guess = np.zeros(n_states)
        elif callable(self.initial_state):
            guess = self.initial_state
        else:
            guess = np.asarray(self.initial_state, dtype=float).reshape(-1)
            if guess.shape != (n_states,) or not np.all(np.isfinite(guess)):
                raise ValueError(
                    f"initial_state must hold {n_states} finite values, one per "
                    f"state of {names!r}; got initial_state={self.initial_state!r}."
                )
        return n_states, observed, guess

    def _initial_params(self, X=None, y=None, *, start=None):
        """Checked initial values: ``start`` (a start chosen by earlier fits,
        handed on as a value) or ``params``."""
        if not self.params:
            raise ValueError(
                "params must name at least one parameter with its initial value; "
                f"got params={self.params!r}."
            )
        out = {}
        for name, value in (self.params if start is None else start).items():
            try:
                array = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(
                    f"initial value of parameter {name!r} must be a number; got "
                    f"{value!r}."
                ) from None
            if not np.all(np.isfinite(array)):
                raise ValueError(
                    f"initial value of parameter {name!r} must be finite; got "
                    f"{value!r}."
                )
            out[name] = array if array.ndim else float(array)
        return out

    def _n_outputs_of(self, observed):
        return None if observed is None else len(observed)

    def _check_layout(self, n_step_features, n_outputs):
        _, observed, _ = self._structure()
        expected = self._n_outputs_of(observed)
        if expected is not None and n_outputs != expected:
            raise ValueError(
                f"y has {n_outputs} output column(s) but observed={self.observed!r} "
                f"names {expected} measured state(s); give one column per observed "
                "state."
            )
        if n_step_features < n_outputs:
            raise ValueError(
                f"a time step of X has {n_step_features} column(s), fewer than the "
                f"{n_outputs} output(s); each step is [outputs..., inputs...]."
            )

    def _needs_estimation(self, observed):
        """Whether a window's initial state is fitted (not read off the window)."""
        if observed is None or self._n_latent(observed):
            return True
        return bool(self.estimate_observed) and self.n_steps > 1

    def _check_autograd(self):
        _, observed, _ = self._structure()
        if self._needs_estimation(observed) or self.method == "solve_ivp":
            raise ValueError(
                "jac='autograd' needs windows whose first step gives the state (every "
                "state observed, and n_steps=1 or estimate_observed=False) and method "
                f"'rk4' or 'euler'; got observed={self.observed!r} of state_names="
                f"{self.state_names!r}, n_steps={self.n_steps}, estimate_observed="
                f"{self.estimate_observed!r} and method={self.method!r}."
            )

    def _n_latent(self, observed):
        n_states = len(self.state_names)
        return n_states if observed is None else n_states - len(observed)

    def observed_indices(self):
        """Indices of the measured states in ``state_names``, or None.

        Returns
        -------
        indices : list of int or None
            The states ``observed`` names, in its order; None when the outputs
            come from an ``output`` function instead.

        Raises
        ------
        ValueError
            When ``state_names``, ``observed`` or ``output`` are invalid.
        """
        _, observed, _ = self._structure()
        return None if observed is None else list(observed)

    def initialize(self, X=None, y=None):
        """Set the parameters to their initial values, without fitting them.

        With windows ``X``, ``y`` this is :meth:`DomainModel.initialize
        <skhybrid.domain.DomainModel.initialize>`. Without data (the records
        of :meth:`fit_simulation` need none to set a state-space model's
        parameters up) the structure and the parameters are checked, and
        ``params_`` are the initial values (``params_std_`` and ``params_cov_``
        NaN, ``result_`` None): the model then steps, observes and packs its
        parameters, as a hybrid starting from ``params`` needs.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features) or None, default=None
            Windows of ``n_steps`` time steps, or None.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs) or None, \
default=None
            Next outputs (with ``X``).

        Returns
        -------
        self : object
            The model at its initial parameters.
        """
        if X is not None:
            return super().initialize(X, y)
        self._validate_params()
        _, observed, _ = self._structure()
        init = self._initial_params()
        spec = _ParameterSpec(init, self.fixed, self.resolved_bounds(init))
        self._spec = spec
        if observed is not None:
            self.n_outputs_ = len(observed)
        return self._at_initial_params(spec)

    def observe(self, x, params=None):
        """The outputs of states ``x``: ``x[:, observed]`` or ``output(x)``.

        Parameters
        ----------
        x : ndarray or torch.Tensor of shape (n, n_states)
            States.
        params : dict or None, default=None
            Parameter values by name (used by an ``output`` function); ``None``
            uses the fitted ``params_``.

        Returns
        -------
        y : ndarray or torch.Tensor of shape (n, n_outputs)
            Outputs of the states.
        """
        _, observed, _ = self._structure()
        xp = get_namespace(x)
        if not is_torch(xp):
            xp = np
        if params is None:
            params = self.params_ if observed is None else {}
        return self._output_fn(params, observed, xp)(x)

    def _check_fitted_structure(self):
        check_is_fitted(self)
        return self._structure()

    # -- windowed fit and predict --------------------------------------------------
    def _layout(self, n_features):
        """The windows' :class:`~skhybrid.preprocessing.WindowLayout`: outputs first."""
        return WindowLayout.from_shapes(
            n_features, self.n_outputs_, n_steps=self.n_steps
        )

    def _equations(self, X, params, xp):
        structure = self._structure()
        Y, U = self._layout(X.shape[1]).split(X)
        if self._needs_estimation(structure[1]) and not is_torch(xp):
            x0 = self._estimate_x0(np.asarray(Y), np.asarray(U), params, structure)
        else:
            guess = structure[2]
            if callable(guess):
                guess = self._call_guess(guess, Y, U, structure[0])
            x0 = self._start(Y[:, 0], guess, structure[1], xp)
        out, _ = self._run(x0, U, params, structure[1], xp, n_times=self.n_steps + 1)
        return out[:, -1]

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Fit the free parameters on windows of history (one-step-ahead error).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_steps * (n_outputs + n_inputs))
            Windows of ``n_steps`` time steps, oldest first, each step
            ``[outputs..., inputs...]`` (see
            :func:`~skhybrid.preprocessing.make_windows`).
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Outputs at the step after each window.

        Returns
        -------
        self : object
            The fitted model.
        """
        return self._fit_one_step(X, y, start=self._fit_start("fit", X, y))

    def _fit_one_step(self, X, y, start=None):
        self._structure()
        multi = self.__sklearn_tags__().target_tags.multi_output
        X, y = validate_data(
            self, X, y, multi_output=multi, y_numeric=True, dtype=np.float64
        )
        # DomainModel.fit validates again, on the array, which would drop the
        # names validate_data just read from a DataFrame.
        names = getattr(self, "feature_names_in_", None)
        # The body of DomainModel.fit, from the start handed in; this fit is
        # already transactional and its parameters validated.
        self._fit_least_squares(X, y, start=start)
        if names is not None:
            self.feature_names_in_ = names
        self.n_inputs_ = self._layout(X.shape[1]).n_inputs
        self.noise_model_ = None
        return self

    def predict(self, X):
        """Predict the outputs one step after each window.

        The state at each window's first step is estimated from the window (the
        observed states as measured, the latent ones by least squares), then
        simulated to the step after the window.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps, each ``[outputs..., inputs...]``.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted outputs, 1-D when ``y`` was 1-D in ``fit``.
        """
        return super().predict(X)

    # -- simulation ----------------------------------------------------------------
    def simulate_from_state(self, inputs, states):
        """Simulate the outputs from known initial states.

        Parameters
        ----------
        %(states_records_inputs)s
        states : array-like of shape (n_states,) or (n_records, n_states)
            State at the first sample of each record.

        Returns
        -------
        %(simulated_from_states)s
        """
        n_states, _, _ = self._check_fitted_structure()
        U_list, _, form = check_trajectories(inputs, None)
        x0 = check_initial_states(states, len(U_list), n_states, self.state_names)
        return self._free_run_records(U_list, x0, form)

    def _free_run_records(self, U_list, x0, form, initial=None, pack=True):
        _, observed, _ = self._structure()
        U, lengths = stack_trajectories(U_list)
        with np.errstate(all="ignore"):
            out, _ = self._run(x0, U, self.params_, observed, np)
        out = np.asarray(out, dtype=float)
        check_finite_runs(
            out,
            lengths,
            "The physics is unstable from this initial state (check the "
            "parameters and the inputs).",
        )
        if initial is not None:
            for i, y in enumerate(initial):
                out[i, : len(y)] = y
        return pack_trajectories(out, lengths, form) if pack else out

    def _simulate(self, inputs, initial, init, n_samples, random_state, return_std):
        """Simulate the fitted model in free run from measured initial windows.

        The state at the first sample of each record is estimated from its
        measured initial window (see :meth:`estimate_initial_state`), then the
        physics runs free to the end of the inputs. Follows the contract of
        :func:`skhybrid.simulation.simulate`: the first ``len(initial)`` samples
        returned are the measured ones.

        Parameters
        ----------
        %(record_inputs)s
        initial : array-like of shape (n_init, n_outputs), (n_trajectories, \
n_init, n_outputs) or list of 2-D arrays
            Measured outputs of the first ``n_init >= n_steps`` time steps, all
            finite.
        init : {"measured", "least_squares"}, default="measured"
            How the initial state is found; latent states are always fitted by
            least squares over the whole of ``initial``. ``"measured"``: the
            observed states start as the model was fitted to start them (at
            their measured values, fitted too where ``estimate_observed=True``).
            ``"least_squares"``: the observed states are fitted as well,
            whatever ``estimate_observed`` says, which averages their
            measurement noise out of the start.
        n_samples : int or None, default=None
            Number of sample paths: the deterministic simulation plus draws of
            the noise model fitted to the simulation residuals
            (``noise_model_``, see ``noise_model``), an output error that is not
            fed back into the states. Needs a noise model.
        random_state : int, RandomState instance or None, default=None
            Seed of the noise draws.
        return_std : bool, default=False
            Return the mean and the standard deviation over sample paths
            (``n_samples`` defaults to 100 then). Needs a noise model.

        Returns
        -------
        outputs : ndarray or list of ndarray
            Simulated outputs in the container form of ``inputs``; with
            ``n_samples`` a leading axis of sample paths, with
            ``return_std=True`` the tuple ``(mean, std)``.
        """
        structure = self._check_fitted_structure()
        noise = getattr(self, "noise_model_", None)
        stochastic = check_simulate_options(
            self,
            init,
            n_samples,
            return_std,
            noise_model=noise,
            remedy="pass noise_model (for example skhybrid.hybrid.GaussianNoise()) "
            "and fit with fit_simulation, which fits it to the simulation residuals",
        )
        U_list, Y_list, form = check_trajectories(
            inputs,
            initial,
            min_init=self.n_steps,
            window_name=f"the model's window (n_steps={self.n_steps})",
        )
        self._check_records(U_list, Y_list, "initial")
        x0 = self._estimate_records(
            U_list,
            Y_list,
            self.params_,
            structure,
            estimate_observed=True if init == "least_squares" else None,
        )
        out = self._free_run_records(U_list, x0, form, initial=Y_list, pack=False)
        lengths = np.array([len(u) for u in U_list])
        if not stochastic:
            return pack_trajectories(out, lengths, form)
        rng = check_random_state(random_state)
        n_paths = 100 if n_samples is None else int(n_samples)
        n_traj, n_max, n_out = out.shape
        draws = np.empty((n_paths, n_traj, n_max, n_out))
        for p in range(n_paths):
            for i in range(n_traj):
                draw = noise.sample(n_max, random_state=rng)
                draws[p, i] = np.reshape(draw, (n_max, n_out))
        paths = out[None] + draws
        for i, y in enumerate(Y_list):
            paths[:, i, : len(y)] = y
        if return_std:
            mean, std = paths.mean(axis=0), paths.std(axis=0)
            for i, y in enumerate(Y_list):
                # Exactly the measurements, not their mean's rounding.
                mean[i, : len(y)], std[i, : len(y)] = y, 0.0
            return (
                pack_trajectories(mean, lengths, form),
                pack_trajectories(std, lengths, form),
            )
        return pack_trajectories(paths, lengths, form)
