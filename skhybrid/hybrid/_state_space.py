"""StateSpaceHybridRegressor: physics state equations plus a learned correction.

A SUBNET-style model (Beintema, Toth and Schoukens, 2021): an encoder network
estimates the state at the end of an initialisation window of measured outputs
and inputs, the physics' discretised state equations plus a network correction
advance the state, and the outputs are the physics' observed states. Encoder,
correction and physical parameters are trained jointly by the simulation error
over sub-sequences of ``horizon`` steps.
"""

import contextlib
from numbers import Integral, Real

import numpy as np
import torch
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted

from skhybrid.domain import StateSpaceModel
from skhybrid.hybrid._parameters import BoundedParameters
from skhybrid.hybrid._state_space_fallback import keep_physics_if_better
from skhybrid.hybrid._state_space_module import (
    ACTIVATIONS,
    EncoderModule,
    StateSpaceHybridModule,
    mlp,
)

# The model's parts live in their own modules (records, simulation);
# MIN_SUBSEQUENCES is re-exported here, where it was defined before the split.
from skhybrid.hybrid._state_space_records import (
    MIN_SUBSEQUENCES,
    _RecordsFitMixin,
)
from skhybrid.hybrid._state_space_simulation import _SimulationMixin
from skhybrid.neural.engine import (
    check_device,
    check_sequence_objective,
    record_training,
    seeded,
    train_module,
    training_constraints,
    training_parameters_doc,
)
from skhybrid.preprocessing import split_steps
from skhybrid.utils._lockstep import current_member
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    Interval,
    Options,
    StrOptions,
    _fit_context,
    validate_data,
)
from skhybrid.utils._transaction import TransactionalFitMixin

__all__ = ["MIN_SUBSEQUENCES", "StateSpaceHybridRegressor"]


def _state_indices(items, names, param):
    """Column indices of ``items`` (names or indices; None is all) in ``names``."""
    if items is None:
        return list(range(len(names)))
    chosen = []
    for item in items:
        if isinstance(item, str) and item in names:
            chosen.append(names.index(item))
        elif (
            isinstance(item, Integral)
            and not isinstance(item, bool)
            and 0 <= item < len(names)
        ):
            chosen.append(int(item))
        else:
            raise ValueError(
                f"{param} must hold names or indices of physics.state_names="
                f"{names!r}; got {item!r} in {param}={items!r}."
            )
    return chosen


def _safe_scale(values, axis=0):
    s = np.std(values, axis=axis)
    m = np.mean(values, axis=axis)
    return np.where(s > 1e-12 * (1 + np.abs(m)), s, 1.0)


#: How many graphs of one compiled function (the step, or the module) a
#: process keeps during a joint training: one for each architecture, batch
#: size and grad mode it met, as the fits of a search in one worker add them.
#: torch's default, 8, would send a worker's later fits back to eager.
RECOMPILE_LIMIT = 256


@contextlib.contextmanager
def _room_for_recompiles():
    """Within: :data:`RECOMPILE_LIMIT` graphs per compiled function."""
    import torch._dynamo

    with torch._dynamo.config.patch(recompile_limit=RECOMPILE_LIMIT):
        yield


#: The fewest batch steps (batches per epoch, times the horizon, times
#: ``max_epochs``) for which ``compile_rollout="auto"`` compiles the step.
COMPILE_MIN_STEPS = 50_000


class StateSpaceHybridRegressor(
    _RecordsFitMixin,
    _SimulationMixin,
    TransactionalFitMixin,
    VersionedPickleMixin,
    RegressorMixin,
    BaseEstimator,
):
    """State-space hybrid with a learned initial-state encoder, trained by simulation.

    The model is the SUBNET structure (Beintema et al., 2021) with a physics
    prior:

    - state update ``x(t+1) = step(x(t), u(t); theta) + c * S * net_f([x(t),
      u(t)])``, ``step`` the discretised equations of a
      :class:`~skhybrid.domain.StateSpaceModel` (:meth:`StateSpaceModel.step`,
      evaluated in torch), ``S`` each state's typical change per sample and
      ``c = correction_scale``, or the same correction inside the continuous
      equations (``correction_form="rhs"``); the network's output layer starts
      at zero, so the model starts as the physics;
    - outputs ``y(t) = h(x(t))``, the physics' observed states;
    - an encoder network maps the initialisation window (the ``n_init``
      measured outputs and the ``n_init - 1`` inputs between them) to the
      state at the window's last sample.

    Training (:meth:`fit_simulation`) cuts sub-sequences of ``n_init +
    horizon`` samples from the records; the encoder gives the state at the end
    of each init window, the model simulates ``horizon`` steps and the loss is
    the mean squared error of the simulated outputs (standardised). The physical
    parameters start from ``physics.fit_simulation`` and are trained with the
    networks (``train_physics=True``, bounds kept by reparametrisation as in
    :class:`HybridEnsembleRegressor`) or held there. Before the joint training
    the encoder is fitted to the physics' least-squares state estimates of the
    training windows, so the joint training starts from the physics model.
    Training runs on the networks' engine (:mod:`skhybrid.neural.engine`, the
    protocol of :class:`~skhybrid.neural.BaseNeuralRegressor`): Adam on
    mini-batches of ``batch_size`` sub-sequences, the learning rate reduced on
    a plateau, early stopping on the free-run error over the last
    ``validation_fraction`` of every record, or on whole held-out records
    (``validation_split``), each simulated from its first ``n_init`` samples as
    :meth:`simulate` would, keeping the best epoch (the starting model
    included), and never a model worse there than the physics alone (see
    ``correction_helped_``); the divergence check, ``callbacks``, ``verbose``,
    ``device``,
    Ctrl-C (stops training, keeps the best weights, warns) and the objectives
    with a Ljung-Box term (computed within each simulated sub-sequence) work as
    for the networks. The model trains on ``device`` and simulates on the CPU.

    :meth:`fit` and :meth:`predict` follow scikit-learn's convention on windows
    of history (see :func:`~skhybrid.preprocessing.make_windows`): each row's
    ``n_steps`` steps are the init window and the target is the output one step
    later (``horizon=1`` there).

    Parameters
    ----------
    physics : StateSpaceModel
        The physics: its ``rhs`` must run on torch (written with ``xp``) and use
        ``method="rk4"`` or ``"euler"`` (or ``time="discrete"``).
    n_init : int, default=20
        Samples of the initialisation window read by the encoder in
        :meth:`fit_simulation` and :meth:`simulate`.
    horizon : int, default=20
        Simulated steps per training sub-sequence (``fit_simulation``). With
        ``n_augmented_states``, a horizon long enough for the latent state to
        show in the loss: on the missing-physics suite's second mode, 100 steps
        with two latent states came to 3.3 times the true structure's free-run
        error (seeds 0-2) where 20 steps kept the physics
        (``docs/state_space.md``, "The defaults, and what they cost").
    n_steps : int, default=1
        Time steps per row of ``X`` in :meth:`fit` and :meth:`predict` (the init
        window there).
    hidden_layer_sizes : tuple of int, default=(64, 64)
        Hidden layers of the state-correction network.
    encoder_hidden_layer_sizes : tuple of int, default=(32,)
        Hidden layers (tanh) of the encoder.
    activation : {"tanh", "relu", "elu", "silu"}, default="silu"
        Activation of the correction network's hidden layers. SiLU (and ELU,
        ReLU) go on linearly outside the states and inputs the network was
        trained on, where a missing term may keep growing; ``"tanh"`` levels
        off there, and may fit a bounded term (a sine, a saturation) sooner.
        SiLU came nearer the true structure on the missing-physics suite,
        inside the training amplitude and beyond it (``docs/state_space.md``,
        "The defaults, and what they cost").
    correction_scale : float, default=0.1
        Factor ``c`` of the correction network's output, in units of each
        state's typical change per sample.
    correction_form : {"step", "rhs"}, default="step"
        Where the correction enters. ``"step"``: added to the state after each
        sample, ``x(t+1) = step(x(t), u(t)) + c * S * net_f(x(t), u(t))``.
        ``"rhs"``: added to the continuous-time equations, ``dx/dt = f(x, u) +
        c * S / dt * net_f(x, u)``, and integrated with them by the physics'
        ``method`` and ``n_substeps`` (the network is evaluated at every stage);
        suited to a force the physics misses that acts within a sample (a
        backlash, a friction). With ``time="discrete"`` physics both are the
        same.
    correction_states : sequence of str or int, or None, default=None
        The states the correction network reads (names of
        ``physics.state_names`` or indices), besides the inputs; ``None`` reads
        all. Leave out states whose absolute level does not matter to the
        dynamics (an angle that drifts without bound), so that the network does
        not extrapolate.
    corrected_states : sequence of str or int, or None, default=None
        The states whose update the network corrects (names or indices);
        ``None`` corrects all. Correcting only where the physics is uncertain
        (the speeds of a mechanism, not the kinematics ``d angle/dt = speed``)
        keeps the rest exact.
    encoder_absolute : bool, default=True
        Whether the encoder reads the absolute level of the window's outputs.
        It always reads the outputs relative to the window's last sample and
        starts the observed states from their last measured values; ``False``
        makes the encoder invariant to a constant offset of the outputs (a
        drive's angle).
    warm_start_physics : bool, default=True
        Start the physical parameters from ``physics.fit_simulation`` (or
        ``physics.fit`` in :meth:`fit`); ``False`` starts them from
        ``physics.params`` (for example values found by an earlier fit).
    train_physics : bool, default=True
        Train the free physical parameters jointly; ``False`` holds them at the
        values ``physics.fit_simulation`` (or ``physics.fit``) found.
    n_augmented_states : int, default=0
        Latent states beside the physics' own, that only the networks know
        (SUBNET's black-box states, here added to a physics model): the encoder
        estimates them from the window, the correction network reads them and
        moves each by ``correction_scale`` times its output per sample, and
        they reach the outputs only through the correction of the physics'
        states. They start at zero, so the hybrid starts as its physics. They
        carry what the physics lacks a state for: a disturbance the inputs do
        not measure, a drift, an unmodelled mode. Where the physics has every
        state they can cost: on a first-order toy, two made the free runs worse
        than the physics', so none is the default.
    physics_lr : float or None, default=None
        Learning rate of the free physical parameters in the joint training;
        None trains them at ``lr``. The parameters start from a least-squares
        fit, and each moves in steps of about ``physics_lr`` times its own
        magnitude (Adam on a relative parametrisation), so a rate below the
        networks' keeps the physics from wandering while the networks learn.
    validation_split : {"tail", "records"}, default="tail"
        What :meth:`fit_simulation` holds out for early stopping. ``"tail"``:
        the last ``validation_fraction`` of every record. ``"records"``: the
        last ``round(validation_fraction * n_records)`` records (at least one)
        whole, each simulated in free run from its first ``n_init`` samples to
        its end, so that the model kept is the one that simulates longest
        without drifting (the tails may be far shorter than the free runs the
        model is meant for). Ignored by :meth:`fit`.
    stride : int or "auto", default="auto"
        Samples between the starts of consecutive training sub-sequences (1:
        every sub-sequence; larger values train faster on long records).
        ``"auto"``: ``max(1, horizon // 4)``, so that every sample lies in about
        four sub-sequences, or closer (down to 1) where the records hold fewer
        than ``500 * horizon // 4`` samples, so that an epoch holds about 500
        sub-sequences (short records train as deepSI's SUBNET does, on a
        sub-sequence at every sample).
    physics_initial_state : bool, default=False
        Whether the encoder corrects the physics' own estimate of the latent
        states (the least-squares fit of
        :meth:`StateSpaceModel.estimate_initial_state` over the window at the
        starting parameters, run to the window's last sample); the encoder's
        output layer starts at zero, so training starts from the physics model.
        ``False``: the encoder alone (SUBNET), first fitted to those estimates
        for ``encoder_epochs`` epochs, then free to leave them; on the
        missing-physics suite it came closer to the true structure on every
        machine but the hardening spring (``docs/state_space.md``, "The
        defaults, and what they cost"). Either way the observed states start
        from their last measured values (the physics' estimate of them is biased
        wherever the physics is wrong, and the encoder would first have to learn
        to undo that bias).
    encoder_epochs : int, default=50
        Epochs of the encoder's pre-training with
        ``physics_initial_state=False`` (0 to skip).
    compile_rollout : {"auto", "step", "whole"} or False, default="auto"
        Whether the joint training (its training and validation batches)
        runs through :func:`torch.compile`. The fitted model is the same
        eager module whatever the setting (it simulates and pickles alike),
        and so are its numbers, up to rounding.

        - ``"step"``: one sample's step (physics, integrator and correction)
          is compiled, the loop over the horizon stays in Python. It compiles
          in seconds, a few times per fit (once per batch size), and on the
          CPU an epoch of the missing-physics suite's hardening spring took
          0.39 times an eager one.
        - ``"whole"``: the whole rollout (encoder and every sample of the
          horizon) is one graph, the batch dimension dynamic; on
          ``device="cuda"`` with ``mode="reduce-overhead"`` (inductor's kernels
          replayed as CUDA graphs). On the CPU its compilation takes as long
          as thousands of eager epochs.
        - ``"auto"``: ``"step"`` where the joint training is long enough to
          pay for its compilation (at least 50,000 batch steps: batches per
          epoch, times ``horizon``, times ``max_epochs``), else eager.
        - ``False``: eager.

        Where the compilation fails (no C++ compiler, say) a warning says so
        and the training runs eagerly. See ``docs/state_space.md``,
        "Capturing the rollout".
    %(training_parameters)s

    Attributes
    ----------
    physics_ : StateSpaceModel
        The physics clone after its warm start (its ``params_`` are the
        starting values).
    params_ : dict
        Physical parameters after the joint training.
    params_init_ : dict
        Their starting values.
    encoder_ : torch.nn.Module
        The trained encoder (float64).
    correction_ : torch.nn.Module
        The trained state-correction network (float64).
    state_mean_ : ndarray of shape (n_states,)
        Mean of the physics' states over the training data.
    state_scale_ : ndarray of shape (n_states,)
        Scale of each state.
    step_scale_ : ndarray of shape (n_states,)
        Typical change of each state per sample (the unit of the correction).
    module_ : StateSpaceHybridModule
        Encoder, correction and physical parameters as one torch module (eval
        mode, on the CPU).
    net_ : skorch.NeuralNetRegressor
        The skorch net of the joint training (its ``module_`` is ``module_``).
    history_ : skorch.History
        Per-epoch records: ``history_[:, "train_loss"]`` and, with a validation
        part, ``history_[:, "valid_loss"]`` (simulation errors over the
        outputs' scale, squared and averaged).
    loss_curve_ : list of float
        Training loss of each epoch (``history_[:, "train_loss"]``).
    validation_scores_ : list of float
        Validation loss of each epoch (empty without a validation part).
    n_epochs_ : int
        Epochs run.
    best_epoch_ : int
        Epoch (1-based) whose weights were kept; 0 when no epoch beat the
        starting model (the physics with a zero correction).
    rollout_compiled_ : {"step", "whole"} or None
        What of the joint training ran through :func:`torch.compile` (see
        ``compile_rollout``; None where it ran eagerly, as it always does
        where folds trained side by side).
    correction_helped_ : bool
        Whether a trained epoch simulates the monitored pieces (the validation
        pieces, or the training sub-sequences without them) better than the
        physics itself. Where it is False the model is not worse than its
        physics there: it keeps its start or becomes its physics (below), and
        an :class:`~skhybrid.exceptions.UnhelpfulCorrectionWarning` says so.
    validation_loss_ : float
        Loss of the model kept on the monitored pieces.
    physics_validation_loss_ : float
        Loss of the physics alone on the same pieces (at the starting
        parameters, from its least-squares state over each window). Where it
        is no larger than the trained model's, the model becomes its physics:
        the same free runs as ``physics_.simulate``.
    interrupted_ : bool
        Whether a Ctrl-C cut the training short (the best epoch so far was
        kept, and a ``UserWarning`` said so).
    unused_records_ : list of int
        The records :meth:`fit_simulation` trained on none of (too short for
        a window and its horizon; a ``UserWarning`` named them); empty after
        :meth:`fit`.
    n_features_in_ : int
        Columns of a row of ``X`` (``n_steps`` steps).
    n_outputs_ : int
        Number of outputs.
    n_inputs_ : int
        Number of inputs.

    See Also
    --------
    HybridEnsembleRegressor : Joint training on windows, one step ahead.
    skhybrid.domain.StateSpaceModel : The physics alone.

    References
    ----------
    G. I. Beintema, R. Toth and M. Schoukens, "Nonlinear state-space
    identification using deep encoder networks", Proc. L4DC, 2021.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import StateSpaceModel
    >>> from skhybrid.hybrid import StateSpaceHybridRegressor
    >>> def decay(x, u, *, xp, a):
    ...     return a * x + u
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, (4, 100, 1))
    >>> y = np.zeros((4, 100, 1))
    >>> for t in range(99):
    ...     y[:, t + 1] = 0.8 * y[:, t] + u[:, t] + 0.1 * np.sin(3 * y[:, t])
    >>> physics = StateSpaceModel(
    ...     decay, {"a": 0.5}, state_names=["y"], observed=["y"], time="discrete",
    ... )
    >>> model = StateSpaceHybridRegressor(
    ...     physics, n_init=2, horizon=5, max_epochs=5, random_state=0,
    ... ).fit_simulation(u, y)
    >>> model.simulate(u[0], y[0, :2]).shape
    (100, 1)
    """

    @property
    def fits_in_lockstep(self):
        """Whether a search fits this model's folds side by side: on a GPU.

        There, in threads of one process, their networks' steps are computed
        as one batched call (:mod:`skhybrid.neural._lockstep`), which costs
        about one fold's where a rollout's small kernels are launch-bound
        (:class:`~skhybrid.model_selection.SimulationSearchCV`). On a CPU the
        batched call costs what the folds cost in turn (``docs/results.md``),
        so the folds are spread over the search's workers instead.
        """
        return self.device == "cuda"

    _parameter_constraints = {
        "physics": [StateSpaceModel],
        "n_init": [Interval(Integral, 1, None, closed="left")],
        "horizon": [Interval(Integral, 1, None, closed="left")],
        "n_steps": [Interval(Integral, 1, None, closed="left")],
        "hidden_layer_sizes": [tuple, list],
        "encoder_hidden_layer_sizes": [tuple, list],
        "activation": [StrOptions(set(ACTIVATIONS))],
        "correction_scale": [Interval(Real, 0, None, closed="left")],
        "correction_form": [StrOptions({"step", "rhs"})],
        "correction_states": [list, tuple, None],
        "corrected_states": [list, tuple, None],
        "encoder_absolute": ["boolean"],
        "warm_start_physics": ["boolean"],
        "train_physics": ["boolean"],
        "n_augmented_states": [Interval(Integral, 0, None, closed="left")],
        "physics_lr": [Interval(Real, 0, None, closed="left"), None],
        "validation_split": [StrOptions({"tail", "records"})],
        "stride": [Interval(Integral, 1, None, closed="left"), StrOptions({"auto"})],
        "physics_initial_state": ["boolean"],
        "encoder_epochs": [Interval(Integral, 0, None, closed="left")],
        "compile_rollout": [
            StrOptions({"auto", "step", "whole"}),
            Options(bool, {False}),
        ],
        **training_constraints(),
    }

    def __init__(
        self,
        physics,
        *,
        n_init=20,
        horizon=20,
        n_steps=1,
        hidden_layer_sizes=(64, 64),
        encoder_hidden_layer_sizes=(32,),
        activation="silu",
        correction_scale=0.1,
        correction_form="step",
        correction_states=None,
        corrected_states=None,
        encoder_absolute=True,
        warm_start_physics=True,
        train_physics=True,
        n_augmented_states=0,
        physics_lr=None,
        validation_split="tail",
        stride="auto",
        physics_initial_state=False,
        encoder_epochs=50,
        compile_rollout="auto",
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
        ljung_box_segment_length=None,
        ljung_box_scaling="target",
        mse_pretraining=False,
        lr=0.01,
        max_epochs=500,
        batch_size=64,
        validation_fraction=0.2,
        target_scaling="per_output",
        patience=100,
        lr_patience=30,
        lr_factor=0.5,
        callbacks=None,
        random_state=None,
        device="cpu",
        verbose=0,
    ):
        self.physics = physics
        self.n_init = n_init
        self.horizon = horizon
        self.n_steps = n_steps
        self.hidden_layer_sizes = hidden_layer_sizes
        self.encoder_hidden_layer_sizes = encoder_hidden_layer_sizes
        self.activation = activation
        self.correction_scale = correction_scale
        self.correction_form = correction_form
        self.correction_states = correction_states
        self.corrected_states = corrected_states
        self.encoder_absolute = encoder_absolute
        self.warm_start_physics = warm_start_physics
        self.train_physics = train_physics
        self.n_augmented_states = n_augmented_states
        self.physics_lr = physics_lr
        self.validation_split = validation_split
        self.stride = stride
        self.physics_initial_state = physics_initial_state
        self.encoder_epochs = encoder_epochs
        self.compile_rollout = compile_rollout
        self.objective = objective
        self.ljung_box_lags = ljung_box_lags
        self.ljung_box_weight = ljung_box_weight
        self.ljung_box_segment_length = ljung_box_segment_length
        self.ljung_box_scaling = ljung_box_scaling
        self.mse_pretraining = mse_pretraining
        self.lr = lr
        self.max_epochs = max_epochs
        self.batch_size = batch_size
        self.validation_fraction = validation_fraction
        self.target_scaling = target_scaling
        self.patience = patience
        self.lr_patience = lr_patience
        self.lr_factor = lr_factor
        self.callbacks = callbacks
        self.random_state = random_state
        self.device = device
        self.verbose = verbose

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.regressor_tags.poor_score = True
        try:
            physics_tags = self.physics.__sklearn_tags__()
            tags.target_tags.multi_output = physics_tags.target_tags.multi_output
        except AttributeError:  # pragma: no cover
            tags.target_tags.multi_output = False
        return tags

    # -- checks --------------------------------------------------------------------
    def _check_settings(self):
        for name in ("hidden_layer_sizes", "encoder_hidden_layer_sizes"):
            value = getattr(self, name)
            if not all(
                isinstance(v, Integral) and not isinstance(v, bool) and v >= 1
                for v in value
            ):
                raise ValueError(
                    f"{name} must hold positive ints; got {name}={value!r}."
                )
        check_device(self.device)
        physics = self.physics
        names = list(physics.state_names)
        self._corr_idx = _state_indices(
            self.correction_states, names, "correction_states"
        )
        corrected = _state_indices(self.corrected_states, names, "corrected_states")
        self._corr_mask = np.isin(np.arange(len(names)), corrected).astype(float)
        if physics.time == "continuous" and physics.method == "solve_ivp":
            raise ValueError(
                "physics must integrate in torch: method='rk4' or 'euler'; got "
                f"physics.method={physics.method!r}."
            )

    # -- set-up --------------------------------------------------------------------
    def _setup(self, physics, Y_win, U_win, states, steps, n_in_window):
        """Scales and the torch module at the starting model (NumPy inputs)."""
        params = physics.params_
        theta0 = physics.pack_params(params)
        lower, upper = physics.free_bounds_
        self.params_init_ = dict(params)
        self.state_mean_ = states.mean(axis=0)
        self.state_scale_ = _safe_scale(states)
        self.step_scale_ = _safe_scale(steps) if len(steps) > 1 else self.state_scale_
        observed = physics.observed_indices()
        flat_y = Y_win.reshape(-1, Y_win.shape[-1])
        self.y_mean_ = flat_y.mean(axis=0)
        self.y_scale_ = _safe_scale(flat_y)
        if self.target_scaling == "shared":
            shared = np.sqrt(np.mean(self.y_scale_**2))
            self.y_scale_ = np.full_like(self.y_scale_, shared)
        rel = Y_win[:, : n_in_window - 1] - Y_win[:, n_in_window - 1 : n_in_window]
        rel = rel.reshape(-1, Y_win.shape[-1])
        self.y_rel_scale_ = (
            np.sqrt(np.mean(rel**2, axis=0)) if len(rel) else np.ones(rel.shape[1])
        )
        self.y_rel_scale_ = np.where(self.y_rel_scale_ > 0, self.y_rel_scale_, 1.0)
        if U_win.shape[-1]:
            flat_u = U_win.reshape(-1, U_win.shape[-1])
            self.u_mean_, self.u_scale_ = flat_u.mean(axis=0), _safe_scale(flat_u)
        else:
            self.u_mean_ = self.u_scale_ = np.zeros(0)
        n_states = states.shape[1]
        n_enc = (n_in_window - 1) * (self.n_outputs_ + self.n_inputs_)
        n_enc += self.n_outputs_ if self.encoder_absolute else 0
        n_enc = max(n_enc, 1)
        scales = {
            "state_mean": self.state_mean_,
            "state_scale": self.state_scale_,
            "step_scale": self.step_scale_,
            "y_mean": self.y_mean_,
            "y_scale": self.y_scale_,
            "y_rel_scale": self.y_rel_scale_,
            "u_mean": self.u_mean_,
            "u_scale": self.u_scale_,
            "correction_scale": self.correction_scale
            * self.step_scale_
            * self._corr_mask,
        }
        with seeded(self._seeds[0]):
            n_aug = self.n_augmented_states
            encoder = mlp(n_enc, n_states + n_aug, self.encoder_hidden_layer_sizes)
            correction = mlp(
                len(self._corr_idx) + n_aug + self.n_inputs_,
                n_states + n_aug,
                self.hidden_layer_sizes,
                self.activation,
            )
        # The correction starts at zero (a random start would add a drift that
        # accumulates in free run), the encoder too where it corrects the
        # physics' estimate: training starts from the physics model.
        zeroed = [correction] + ([encoder] if self.physics_initial_state else [])
        for module in zeroed:
            last = [m for m in module if isinstance(m, torch.nn.Linear)][-1]
            with torch.no_grad():
                last.weight.zero_()
                last.bias.zero_()
        return StateSpaceHybridModule(
            physics,
            encoder,
            correction,
            BoundedParameters(theta0, lower, upper, trainable=self.train_physics),
            n_init=n_in_window,
            n_outputs=self.n_outputs_,
            n_inputs=self.n_inputs_,
            observed=observed,
            corr_idx=self._corr_idx,
            continuous_correction=(
                self.correction_form == "rhs" and physics.time == "continuous"
            ),
            encoder_absolute=self.encoder_absolute,
            has_prior=self.physics_initial_state,
            scales=scales,
            dt=physics.dt,
            n_augmented=self.n_augmented_states,
            augmented_scale=self.correction_scale,
        )

    # -- training ------------------------------------------------------------------
    def _train(self, module, windows_train, windows_valid, x_targets):
        """Joint training on sub-sequences ``(Y (n, k+T, p), U (n, k+T, m), prior)``.

        ``prior`` is the physics' state at the window's last sample ``(n,
        n_states)`` (or None without ``physics_initial_state``). Both phases run
        on the shared engine (:func:`skhybrid.neural.engine.train_module`).
        """
        device = self.device
        module = module.to(device)

        def packed(w):
            Y, U, P = (
                None if a is None else torch.as_tensor(a, device=device) for a in w
            )
            return module.pack(Y, U, P), Y

        Ztr, Ytr = packed(windows_train)
        k = self._k
        valid = None
        if windows_valid is not None and len(windows_valid[0]) > 0:
            Zva, Yva = packed(windows_valid)
            valid = (Zva, Yva[:, k:] / module.y_scale)
        # 1. Encoder pre-training on the physics' state estimates.
        if (
            not self.physics_initial_state
            and self.encoder_epochs
            and x_targets is not None
        ):
            target = torch.as_tensor(
                (x_targets - self.state_mean_) / self.state_scale_, device=device
            )
            train_module(
                self,
                lambda: EncoderModule(module),
                Ztr,
                target,
                seed=self._seeds[1],
                overrides={
                    "objective": "mse",
                    "mse_pretraining": False,
                    "lr": self.lr * 3,
                    "max_epochs": self.encoder_epochs,
                    "patience": None,
                    "callbacks": None,
                },
            )
        # 2. Joint training by the simulation error, from the start kept here:
        # the hybrid never ends worse than its physics (below).
        start = {n: v.detach().clone() for n, v in module.state_dict().items()}
        self.rollout_compiled_ = self._rollout_compilation(len(Ztr))
        if self.rollout_compiled_ == "step":
            module.compile_step(self._compile_kwargs("step"))
        try:
            # Not around eager trainings: fits side by side run in threads,
            # and a patch of torch's global configuration is not per thread.
            with (
                _room_for_recompiles()
                if self.rollout_compiled_
                else contextlib.nullcontext()
            ):
                net = self._train_jointly(
                    module, Ztr, Ytr[:, k:] / module.y_scale, valid
                )
        finally:
            module.compile_step(None)
        record_training(self, net)
        module = net.module_.to("cpu").eval()
        for p in module.parameters():
            p.requires_grad_(False)
        self.module_ = module
        self.encoder_, self.correction_ = module.encoder, module.correction
        self.loss_curve_ = [float(v) for v in net.history[:, "train_loss"]]
        self.validation_scores_ = (
            [float(v) for v in net.history[:, "valid_loss"]] if valid else []
        )
        monitored = windows_valid if valid is not None else windows_train
        keep_physics_if_better(self, net, start, monitored[:2])
        with torch.no_grad():
            theta = module.params().numpy().copy()
        self.params_ = self.physics_.unpack_params(theta)
        self._params_t = module.physical_params()

    def _train_jointly(self, module, Ztr, ytr, valid):
        """The joint training's net: simulation error over the horizon.

        Training starts from the module as built (the physics with a zero
        correction), which is kept where no epoch beats it.
        """
        return train_module(
            self,
            lambda: module,
            Ztr,
            ytr,
            valid=valid,
            sequences=True,
            start_as_candidate=True,
            # The validation tails run free far beyond the horizon: an epoch
            # unstable there is not kept, and training goes on.
            free_run_validation=valid is not None,
            seed=self._seeds[2],
            # The networks' group first: the history's ``event_lr`` is the
            # first group's rate.
            optimizer_kwargs=(
                None
                if self.physics_lr is None
                else {
                    "param_groups": [
                        ("encoder.*", {}),
                        ("correction.*", {}),
                        ("params.*", {"lr": self.physics_lr}),
                    ]
                }
            ),
            compile_kwargs=(
                self._compile_kwargs("whole")
                if self.rollout_compiled_ == "whole"
                else None
            ),
        )

    def _rollout_compilation(self, n_sequences):
        """What of the joint training runs through torch.compile, or None.

        ``"auto"`` compiles the step where the training may run at least
        :data:`COMPILE_MIN_STEPS` batch steps (batches per epoch, times the
        horizon, times ``max_epochs``): below that, the compilation would
        cost about as much as it saves.

        Parameters
        ----------
        n_sequences : int
            Training sub-sequences.
        """
        if current_member() is not None or self.compile_rollout is False:
            # Fits trained side by side run one batched call, eagerly.
            return None
        if self.compile_rollout != "auto":
            return self.compile_rollout
        n_batches = -(-n_sequences // self.batch_size)
        steps = n_batches * self.horizon * self.max_epochs
        return "step" if steps >= COMPILE_MIN_STEPS else None

    def _compile_kwargs(self, kind):
        """:func:`torch.compile`'s arguments for the joint training.

        The whole rollout on a GPU: ``mode="reduce-overhead"``, inductor's
        kernels replayed as CUDA graphs. The engine marks the batch dimension
        dynamic (the training batches differ in size by at most a row,
        validation is one batch of its own size), so a fit compiles one graph
        for training and one for validation. The step: inductor's default
        mode, static shapes (a graph for each batch size, each in seconds).
        """
        if kind == "whole" and self.device == "cuda":
            return {"mode": "reduce-overhead"}
        return {}

    def _states_along(self, physics, x0, U, n_times):
        """Physics states ``(n, n_times, n_states)`` from ``x0`` under ``U``."""
        x, out = np.asarray(x0, dtype=float), []
        with np.errstate(all="ignore"):
            for t in range(n_times):
                out.append(x)
                if t < n_times - 1:
                    x = physics.step(x, U[:, t])
        return np.stack(out, axis=1)

    def _prior(self, Y, U):
        """The physics' state at the last sample of windows ``Y``, ``U`` (or None).

        None where the model reads no physics' estimate: without
        ``physics_initial_state``, unless the model became its physics.
        """
        module = getattr(self, "module_", None)
        if not self.physics_initial_state and not getattr(
            module, "physics_only", False
        ):
            return None
        return self._window_prior(Y, U)

    def _window_prior(self, Y, U):
        """The physics' state at the last sample of windows ``Y``, ``U``."""
        k = Y.shape[1]
        states, good = self._window_targets(self.physics_, Y, U, k)
        return np.where(good[:, None], states[:, k - 1], self.state_mean_)

    def _window_targets(self, physics, Y, U, k):
        """Physics' state estimates at the last sample of each window."""
        x0 = physics.estimate_initial_state(U[:, :k], Y[:, :k])
        states = self._states_along(physics, x0, U, k)
        good = np.all(np.isfinite(states), axis=(1, 2))
        return states, good

    # -- windows -------------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Train on windows of history, one step ahead.

        Each row's ``n_steps`` steps are the encoder's window; the model
        advances its last state one step and the loss is the error of the
        predicted outputs.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_steps * (n_outputs + n_inputs))
            Windows of ``n_steps`` time steps, oldest first, each step
            ``[outputs..., inputs...]``.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Outputs at the step after each window.

        Returns
        -------
        self : object
            The fitted model.
        """
        self._check_settings()
        multi = self.__sklearn_tags__().target_tags.multi_output
        X, y = validate_data(
            self,
            X,
            y,
            multi_output=multi,
            y_numeric=True,
            dtype=np.float64,
            ensure_min_samples=2,
        )
        self._y_1d = y.ndim == 1
        Y = y[:, None] if self._y_1d else y
        n_outputs = Y.shape[1]
        if X.shape[1] % self.n_steps:
            raise ValueError(
                f"X has {X.shape[1]} columns, not a whole number of n_steps="
                f"{self.n_steps} steps."
            )
        width = X.shape[1] // self.n_steps
        if width < n_outputs:
            raise ValueError(
                f"a time step of X has {width} column(s), fewer than the "
                f"{n_outputs} output(s); each step is [outputs..., inputs...]."
            )
        n_features = X.shape[1]
        check_sequence_objective(self, 1)
        physics = clone(self.physics).set_params(n_steps=self.n_steps)
        self._start_physics(physics, "fit", X, y)
        Ys, Us = self._split(X, n_outputs)
        # Sequences of n_steps + 1 samples: the window, then the target.
        Yseq = np.concatenate([Ys, Y[:, None, :]], axis=1)
        Useq = np.concatenate([Us, np.zeros_like(Us[:, :1])], axis=1)
        n = len(X)
        n_valid = round(self.validation_fraction * n)
        valid = None
        if n_valid >= 1 and n - n_valid >= 1:
            valid = (Yseq[n - n_valid :], Useq[n - n_valid :])
            Yseq, Useq = Yseq[: n - n_valid], Useq[: n - n_valid]
        self._fit_windows(
            physics, Yseq, Useq, valid, self.n_steps, n_outputs, width - n_outputs
        )
        self.unused_records_ = []
        self.n_features_in_ = n_features
        return self

    def _split(self, X, n_outputs):
        steps = split_steps(X, self.n_steps)
        return steps[:, :, :n_outputs], steps[:, :, n_outputs:]

    def predict(self, X):
        """Predict the outputs one step after each window.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps, each ``[outputs..., inputs...]``.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predicted outputs, 1-D when ``y`` was 1-D in ``fit``.
        """
        import torch

        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        if not X.flags.writeable:
            # torch.as_tensor shares the array's memory, and a torch tensor cannot
            # be read-only: a read-only X (a memmap, a joblib worker's input)
            # would become a writable tensor over it (torch warns). Copy it.
            X = X.copy()
        k = self.n_steps
        if self._k != k:
            raise ValueError(
                f"predict reads windows of n_steps={k} steps, but the model was "
                f"trained with fit_simulation on init windows of n_init={self._k}; "
                "use simulate, or train with fit."
            )
        Ys, Us = self._split(X, self.n_outputs_)
        prior = self._prior(Ys, Us)
        with torch.no_grad():
            out = self.module_.rollout(
                torch.as_tensor(Ys),
                torch.as_tensor(Us[:, : k - 1]),
                torch.as_tensor(Us[:, k - 1 :]),
                None if prior is None else torch.as_tensor(prior),
                params=self._params_t,
            )[:, 0].numpy()
        return out[:, 0] if getattr(self, "_y_1d", False) else out


_SEQUENCE_DEFAULTS = {
    "max_epochs": (
        500,
        (
            "Epochs over sub-sequences taken every ``stride`` samples are short; "
            "early stopping (``patience``) ends most trainings well before. "
            "Chosen with ``batch_size`` on the validation records of "
            "``benchmarks/bench_state_space_defaults.py``."
        ),
    ),
    "batch_size": (
        64,
        (
            "A sample is a sub-sequence of ``n_init + horizon`` samples, not a "
            "row: fewer per batch than rows, more updates per epoch (on the "
            "missing-physics suite, 256 left an epoch of a few thousand samples "
            "four updates, and the training stopped short)."
        ),
    ),
    "patience": (
        100,
        (
            "On the missing-physics suite the correction went on improving "
            "after 30 and 60 epochs without progress "
            '(``docs/state_space.md``, "The defaults, and what they cost").'
        ),
    ),
    "lr_patience": (
        30,
        "Three times the networks' default, with ``patience``.",
    ),
}

StateSpaceHybridRegressor.__doc__ = StateSpaceHybridRegressor.__doc__.replace(
    "    %(training_parameters)s", training_parameters_doc(_SEQUENCE_DEFAULTS)
)
