"""StateSpaceModel: a user's state equations with latent states and initial-state fits.

The model is ``dx/dt = f(x, u; p)`` (or ``x(t+1) = f(x, u; p)`` in discrete time)
with the output ``y = x[observed]`` or ``y = h(x; p)``. Unmeasured (latent) states
of the first sample of a record are estimated by least squares through the physics
over an initialisation window; the parameters are fitted either on windows of
history (one-step-ahead error, :meth:`StateSpaceModel.fit`) or on whole records by
the free-run simulation error (:meth:`StateSpaceModel.fit_simulation`).
"""

import copy
import inspect
from numbers import Integral, Real

import numpy as np
from scipy.integrate import solve_ivp
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from skhybrid.domain._base import DomainModel, _central_differences, _ParameterSpec
from skhybrid.domain._continuation import continued_start
from skhybrid.domain._starts import short_fit_start
from skhybrid.exceptions import SimulationDivergedError
from skhybrid.losses import objective_residuals
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import (
    check_finite_runs,
    check_trajectories,
    fit_initial_states,
    pack_trajectories,
    stack_trajectories,
)
from skhybrid.utils._array_api import get_namespace, is_torch
from skhybrid.utils._sklearn_compat import (
    HasMethods,
    Interval,
    StrOptions,
    _fit_context,
    validate_data,
)
from skhybrid.utils._transaction import transactional

__all__ = ["StateSpaceModel"]

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


class StateSpaceModel(DomainModel):
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
    n_init : int, default=20
        Samples at the start of each record from which ``fit_simulation``
        estimates its initial state.
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
    vectorized : bool, default=False
        Whether ``rhs`` (and ``output``) broadcast parameter values given as
        arrays of shape ``(n,)``, one value per row of ``x`` (plain elementwise
        arithmetic does). Then ``fit_simulation`` simulates the perturbed
        parameter sets of its finite-difference Jacobians in one batch
        (``jac="2-point"``, ``objective="mse"``): one pass over the records per
        Jacobian instead of one per parameter, which matters where a record is
        long and the model cheap. Needs scalar parameters.
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
        "n_init": [Interval(Integral, 1, None, closed="left")],
        "estimate_observed": ["boolean"],
        "identifiability_tol": [Interval(Real, 0, 1, closed="left")],
        "vectorized": ["boolean"],
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
        n_init=20,
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
        vectorized=False,
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

    def _initial_params(self, X=None, y=None):
        if not self.params:
            raise ValueError(
                "params must name at least one parameter with its initial value; "
                f"got params={self.params!r}."
            )
        out = {}
        start = self.__dict__.get("_chosen_start") or self.params
        for name, value in start.items():
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

    # -- the physics ---------------------------------------------------------------
    @staticmethod
    def _takes_xp(func):
        try:
            signature = inspect.signature(func)
        except (TypeError, ValueError):
            return True
        return "xp" in signature.parameters or any(
            p.kind is inspect.Parameter.VAR_KEYWORD
            for p in signature.parameters.values()
        )

    def _rhs_fn(self, params, xp):
        """``f(x, u)``: the user's ``rhs`` bound to ``params`` and ``xp``, checked."""
        rhs = self.rhs
        kwargs = dict(params, xp=xp) if self._takes_xp(rhs) else dict(params)

        def f(x, u):
            out = rhs(x, u, **kwargs)
            shape = tuple(int(d) for d in getattr(out, "shape", ()))
            if shape != tuple(x.shape):
                name = getattr(rhs, "__name__", repr(rhs))
                raise ValueError(
                    f"rhs {name} returned shape {shape} for a state of shape "
                    f"{tuple(x.shape)}; it must return one value per state and "
                    "sample, for example xp.stack([...], axis=1)."
                )
            return out

        return f

    def _output_fn(self, params, observed, xp):
        """``h(x)``: the observed states or the user's ``output``."""
        if observed is not None:
            return lambda x: x[:, observed]
        output = self.output
        kwargs = dict(params, xp=xp) if self._takes_xp(output) else dict(params)

        def h(x):
            out = output(x, **kwargs)
            return out[:, None] if out.ndim == 1 else out

        return h

    def _step(self, x, u, f):
        """State one sample period after ``x`` under the inputs ``u``.

        ``u`` is held over the period, or, with ``input_points > 1``, read at
        each stage's time (:meth:`_input_at`).
        """
        if self.time == "discrete":
            return f(x, u)
        dt = float(self.dt)
        at = self._input_at(u)
        if self.method == "solve_ivp":
            return self._step_ivp(x, at, f, dt)
        n = self.n_substeps
        h = dt / n
        for s in range(n):
            k1 = f(x, at(s / n))
            if self.method == "euler":
                x = x + h * k1
                continue
            middle = at((s + 0.5) / n)
            k2 = f(x + 0.5 * h * k1, middle)
            k3 = f(x + 0.5 * h * k2, middle)
            k4 = f(x + h * k3, at((s + 1) / n))
            x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return x

    def _input_at(self, u):
        """``at(tau)``: the inputs at the fraction ``tau`` of the sample period.

        With ``input_points=1`` the held ``u`` itself; otherwise each input's
        points (columns ``j * k + i``, :func:`band_limited_inputs`' layout)
        interpolated linearly at ``tau``.
        """
        k = int(self.input_points)
        if k == 1:
            return lambda tau: u
        width = u.shape[1]
        if width % k:
            raise ValueError(
                f"input_points={k} needs inputs of a multiple of {k} columns (each "
                f"input at {k} times a sample, as band_limited_inputs(u, "
                f"n_points={k}) makes them); got {width} column(s)."
            )

        def at(tau):
            position = tau * (k - 1)
            i = min(int(position), k - 2)
            w = position - i
            if w == 0.0:
                return u[:, i::k]
            return (1.0 - w) * u[:, i::k] + w * u[:, i + 1 :: k]

        return at

    def _step_ivp(self, x, at, f, dt):
        x = np.asarray(x, dtype=float)
        if not np.all(np.isfinite(x)):
            return np.full_like(x, np.nan)
        shape = x.shape
        options = {"method": "DOP853", "rtol": 1e-10, "atol": 1e-12}
        options.update(self.solver_options or {})

        def fun(t, z):
            return np.asarray(f(z.reshape(shape), at(t / dt)), dtype=float).ravel()

        sol = solve_ivp(fun, (0.0, dt), x.ravel(), **options)
        if not sol.success:
            return np.full_like(x, np.nan)
        return sol.y[:, -1].reshape(shape)

    def _run(self, x0, U, params, observed, xp, n_times=None):
        """Outputs ``(n, n_times, n_outputs)`` from states ``x0`` under ``U``.

        ``U`` is ``(n, T, n_inputs)``; the output at time ``t`` is read before the
        input ``U[:, t]`` acts. Also returns the final state (after ``n_times``
        samples, ``n_times <= T + 1``). NumPy runs use ``numpy`` itself as ``xp``.
        """
        if not is_torch(xp):
            xp = np
        f = self._rhs_fn(params, xp)
        h = self._output_fn(params, observed, xp)
        n_times = U.shape[1] if n_times is None else n_times
        x, outs = x0, []
        for t in range(n_times):
            outs.append(h(x))
            if t < U.shape[1]:
                x = self._step(x, U[:, t], f)
        return xp.stack(outs, axis=1), x

    def step(self, x, u, params=None, *, correction=None):
        """Advance states by one sample period, in NumPy or torch.

        Applies the discretised state equations (``time="discrete"``: ``rhs``
        itself; ``"continuous"``: ``n_substeps`` Euler or RK4 steps over ``dt``
        with ``u`` held) in the namespace of ``x``, so that with torch tensors
        (the states and the parameter values) gradients reach both; the
        state-space hybrid trains through it.

        Parameters
        ----------
        x : ndarray or torch.Tensor of shape (n, n_states)
            States at the current sample.
        u : ndarray or torch.Tensor of shape (n, n_inputs)
            Inputs held over the sample period.
        params : dict or None, default=None
            Parameter values (floats, arrays or 0-d tensors) by name; ``None``
            uses the fitted ``params_``.
        correction : callable or None, default=None
            ``correction(x, u) -> (n, n_states)``, a term added to the state
            equations: to ``dx/dt`` with ``time="continuous"`` (evaluated at
            every stage of the integrator, so it is integrated with the
            physics), to the next state with ``time="discrete"``. The seam a
            hybrid uses to put a learned force inside the physics
            (:class:`~skhybrid.hybrid.StateSpaceHybridRegressor` with
            ``correction_form="rhs"``).

        Returns
        -------
        x_next : ndarray or torch.Tensor of shape (n, n_states)
            States one sample period later.
        """
        xp = get_namespace(x)
        if is_torch(xp) and self.time == "continuous" and self.method == "solve_ivp":
            raise ValueError(
                "step on torch tensors needs method='rk4' or 'euler'; got "
                f"method={self.method!r}."
            )
        if not is_torch(xp):
            xp = np
        if params is None:
            check_is_fitted(self)
            params = self.params_
        f = self._rhs_fn(params, xp)
        if correction is not None:
            rhs = f
            # The correction reads the sample's inputs as given (every point of
            # them with input_points > 1), as the network was sized for them.
            points = self.input_points > 1

            def f(z, v):
                return rhs(z, v) + correction(z, u if points else v)

        return self._step(x, u, f)

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
        spec = _ParameterSpec(init, self.fixed, self._resolved_bounds(init))
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

    def _estimate_x0(self, Y, U, params, structure, estimate_observed=None):
        """Least-squares initial states ``(n, n_states)`` of windows ``Y``, ``U``.

        ``Y`` is ``(n, k, n_outputs)`` measured outputs and ``U`` ``(n, k,
        n_inputs)`` inputs over each window; NumPy only. The free initial states
        (the latent ones, all of them with an ``output`` function or where the
        observed ones are estimated too) are fitted by
        :func:`~skhybrid.simulation.fit_initial_states`, the package's one
        initial-state solver, separately for every window; the perturbed
        windows are simulated in one batch. ``estimate_observed`` overrides the
        parameter of that name.
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
        # Parameters given one value per window (vectorized=True) follow their
        # window into every batch of candidates.
        per_row = {
            name
            for name, v in params.items()
            if self.vectorized and np.ndim(v) == 1 and np.shape(v)[0] == n
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

    def _check_fitted_structure(self):
        check_is_fitted(self)
        return self._structure()

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
        inputs : array-like of shape (n_times, n_inputs), (n_records, n_times, \
n_inputs) or list of 2-D arrays
            Inputs over (at least) the initialisation window of each record.
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
        return self._fit_from(self._fit_start("fit", X, y), self._fit_one_step, X, y)

    def _fit_one_step(self, X, y):
        self._structure()
        multi = self.__sklearn_tags__().target_tags.multi_output
        X, y = validate_data(
            self, X, y, multi_output=multi, y_numeric=True, dtype=np.float64
        )
        # DomainModel.fit validates again, on the array, which would drop the
        # names validate_data just read from a DataFrame.
        names = getattr(self, "feature_names_in_", None)
        super().fit(X, y)
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
        outputs : array-like of shape (n_times, n_outputs), (n_records, n_times, \
n_outputs) or list of (n_times_i, n_outputs) arrays
            Measured outputs of each record, aligned with ``inputs``.

        Returns
        -------
        self : object
            The fitted model.
        """
        start = self._fit_start("fit_simulation", inputs, outputs)
        return self._fit_from(start, self._fit_simulation, inputs, outputs)

    def _fit_start(self, method, *args):
        """Where ``method``'s fit starts: after the ``starts``, then the continuation.

        None where neither applies (the fit starts from ``params``).
        """
        self._validate_params()  # starts_nfev, before the short fits use it
        chosen = short_fit_start(self, method, *args)
        continued = continued_start(self, method, *args, base=chosen)
        return continued if continued is not None else chosen

    def _fit_from(self, start, fit, *args):
        """``fit(*args)`` from ``start`` (after starts, continuation) or ``params``."""
        if start is None:
            return fit(*args)
        self._chosen_start = start
        try:
            return fit(*args)
        finally:
            self.__dict__.pop("_chosen_start", None)

    @transactional
    @_fit_context(prefer_skip_nested_validation=True)
    def _fit_simulation(self, inputs, outputs):
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
            if len(y) <= self.n_init:
                raise ValueError(
                    f"outputs[{i}] holds {len(y)} time steps, not more than "
                    f"n_init={self.n_init}: nothing is left to simulate."
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
        init = self._initial_params()
        if self.vectorized and any(np.ndim(v) for v in init.values()):
            raise ValueError(
                "vectorized=True broadcasts one value of each parameter per row; "
                "every parameter must be a scalar, got array-valued "
                f"{sorted(k for k, v in init.items() if np.ndim(v))}."
            )
        spec = _ParameterSpec(init, self.fixed, self._resolved_bounds(init))
        self._spec = spec
        if self.objective != "mse" and self.ljung_box_lags >= y_flat.shape[0]:
            raise ValueError(
                f"ljung_box_lags={self.ljung_box_lags} must be smaller than the "
                f"number of samples, {y_flat.shape[0]}."
            )
        self._records = (U, Y, mask, structure)
        try:
            theta, result = self._least_squares(U, y_flat, spec)
            self.result_ = result
            self.params_ = spec.to_dict(theta)
            self.params_std_, self.params_cov_ = self._standard_errors(
                U, y_flat, spec, theta
            )
            Y_sim, x0 = self._simulate_records(U, Y, self.params_, structure)
        finally:
            del self._records
        self._check_fitted_run(Y_sim, Y, mask, lengths)
        self.initial_states_ = x0
        err = (Y_sim - Y)[mask]
        self.rmse_ = float(np.sqrt(np.mean(err**2)))
        self.noise_model_ = None
        if self.noise_model is not None:
            n_init = min(self.n_init, T)
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

    def _simulate_records(self, U, Y, params, structure):
        n_init = min(self.n_init, Y.shape[1])
        x0 = self._estimate_x0(Y[:, :n_init], U[:, :n_init], params, structure)
        with np.errstate(all="ignore"):
            out, _ = self._run(x0, U, params, structure[1], np)
        return out, x0

    def _record_residuals(self, theta, spec):
        U, Y, mask, structure = self._records
        params = spec.to_dict(theta)
        out, _ = self._simulate_records(U, Y, params, structure)
        with np.errstate(all="ignore"):
            r = (Y - out)[mask]
        return _penalised(r, Y[mask])[0]

    def _residual_vector(self, X, y, spec, xp):
        if getattr(self, "_records", None) is None:
            return super()._residual_vector(X, y, spec, xp)

        def residuals(theta):
            return objective_residuals(
                self._record_residuals(np.asarray(theta, dtype=float), spec),
                self.objective,
                lags=self.ljung_box_lags,
                ljung_box_weight=self.ljung_box_weight,
            )

        return residuals

    def _raw_jacobian(self, X, y, spec, theta):
        if getattr(self, "_records", None) is None:
            J, base = super()._raw_jacobian(X, y, spec, theta)
        else:

            def raw(t):
                return np.reshape(self._record_residuals(t, spec), -1)

            base = raw(theta)
            if self._batched_records():
                J = _central_differences_batch(
                    lambda sets: self._record_residuals_batch(sets, spec),
                    theta,
                    spec,
                )
            else:
                J = _central_differences(raw, theta, spec, base.size)
        return J, base

    def _batched_records(self):
        """Whether the records' Jacobians are simulated in one batch."""
        return (
            self.vectorized
            and getattr(self, "_records", None) is not None
            and self.jac == "2-point"
        )

    def _record_residuals_batch(self, thetas, spec):
        """Residuals ``(n_sets, n_residuals)`` of parameter sets ``thetas``."""
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
        U_all, Y_all = np.tile(U, (n_sets, 1, 1)), np.tile(Y, (n_sets, 1, 1))
        out, _ = self._simulate_records(U_all, Y_all, params, structure)
        with np.errstate(all="ignore"):
            r = (Y_all - out).reshape(n_sets, n_rec, *Y.shape[1:])[:, mask]
        r = r.reshape(n_sets, -1)
        return _penalised(r, Y[mask])[0]

    def _batched_jacobian(self, spec):
        if not self._batched_records() or self.objective != "mse":
            return None

        def jac(theta):
            theta = np.asarray(theta, dtype=float)
            size = np.maximum(np.abs(theta), 1e-3 * spec.scale)
            step = np.sqrt(np.finfo(float).eps) * size
            # Step backwards where the upper bound is too close.
            step = np.where(theta + step > spec.upper, -step, step)
            sets = np.vstack([theta, theta + np.diag(step)])
            R = self._record_residuals_batch(sets, spec)
            J = ((R[1:] - R[0]) / step[:, None]).T
            # objective="mse" divides the residuals by the root of their number.
            return J / np.sqrt(R.shape[1])

        return jac

    # -- simulation ----------------------------------------------------------------
    def simulate_from_state(self, inputs, states):
        """Simulate the outputs from known initial states.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), (n_records, n_times, \
n_inputs) or list of 2-D arrays
            Inputs of each record.
        states : array-like of shape (n_states,) or (n_records, n_states)
            State at the first sample of each record.

        Returns
        -------
        outputs : ndarray or list of ndarray
            Simulated outputs ``(n_times, n_outputs)`` of each record, in the
            container form of ``inputs``; row 0 is the output of ``states``.
        """
        n_states, _, _ = self._check_fitted_structure()
        U_list, _, form = check_trajectories(inputs, None)
        x0 = np.atleast_2d(np.asarray(states, dtype=float))
        if x0.shape != (len(U_list), n_states):
            raise ValueError(
                f"states must have shape ({len(U_list)}, {n_states}) for "
                f"{len(U_list)} record(s) of state_names={list(self.state_names)!r}; "
                f"got shape {x0.shape}."
            )
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

    def simulate(
        self,
        inputs,
        initial,
        *,
        init="measured",
        n_samples=None,
        random_state=None,
        return_std=False,
    ):
        """Simulate the fitted model in free run from measured initial windows.

        The state at the first sample of each record is estimated from its
        measured initial window (see :meth:`estimate_initial_state`), then the
        physics runs free to the end of the inputs. Follows the contract of
        :func:`skhybrid.simulation.simulate`: the first ``len(initial)`` samples
        returned are the measured ones.

        Parameters
        ----------
        inputs : array-like of shape (n_times, n_inputs), (n_trajectories, \
n_times, n_inputs) or list of 2-D arrays
            Inputs over the whole experiment, initial window included.
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
        if not isinstance(init, str) or init not in ("measured", "least_squares"):
            raise ValueError(
                f"init must be one of ('measured', 'least_squares'); got init={init!r}."
            )
        stochastic = n_samples is not None or return_std
        if n_samples is not None:
            if isinstance(n_samples, bool) or not isinstance(
                n_samples, (int, np.integer)
            ):
                raise TypeError(f"n_samples must be an int or None; got {n_samples!r}.")
            if n_samples < 1:
                raise ValueError(f"n_samples must be >= 1; got n_samples={n_samples}.")
        noise = getattr(self, "noise_model_", None)
        if stochastic and noise is None:
            raise ValueError(
                f"n_samples={n_samples!r} and return_std={return_std!r} need a noise "
                f"model; this {type(self).__name__} has none. Pass noise_model (for "
                "example skhybrid.hybrid.GaussianNoise()) and fit with "
                "fit_simulation, which fits it to the simulation residuals."
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


def _central_differences_batch(raw_batch, theta, spec):
    """:func:`_central_differences` with every step simulated in one batch."""
    size = np.maximum(np.abs(theta), 1e-3 * spec.scale)
    step = np.finfo(float).eps ** (1 / 3) * size
    hi = np.maximum(np.minimum(step, spec.upper - theta), 0.0)
    lo = np.maximum(np.minimum(step, theta - spec.lower), 0.0)
    eye = np.eye(theta.size)
    sets = np.vstack([theta + eye * hi[:, None], theta - eye * lo[:, None]])
    R = raw_batch(sets)
    width = hi + lo
    J = (R[: theta.size] - R[theta.size :]) / np.where(width > 0, width, 1.0)[:, None]
    J[width == 0] = 0.0
    return J.T


def _groups(sizes):
    """``(size, indices)`` of the records sharing each size."""
    sizes = np.asarray(sizes)
    return [(int(s), np.flatnonzero(sizes == s)) for s in np.unique(sizes)]
