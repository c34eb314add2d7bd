"""HybridEnsembleRegressor: the parallel hybrid (the paper's section 3.2)."""

from numbers import Integral, Real

import numpy as np
import torch
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils import Bunch
from sklearn.utils.validation import check_is_fitted
from torch import nn

from skhybrid.domain import DomainModel
from skhybrid.hybrid._parameters import BoundedParameters
from skhybrid.neural.engine import (
    check_device,
    check_time_ordered_rows,
    record_training,
    train_module,
    training_constraints,
    training_parameters_doc,
    validation_rows,
)
from skhybrid.preprocessing import WindowLayout
from skhybrid.simulation import SimulatorMixin
from skhybrid.utils._lockstep import FORWARD_MODE, physics_signature
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    HasMethods,
    Interval,
    _fit_context,
    validate_data,
)
from skhybrid.utils._transaction import TransactionalFitMixin

__all__ = ["HybridEnsembleRegressor"]


class HybridEnsembleRegressor(
    SimulatorMixin,
    TransactionalFitMixin,
    VersionedPickleMixin,
    RegressorMixin,
    BaseEstimator,
):
    """Parallel hybrid model: physics parameters and network weights trained jointly.

    The paper's ensemble composition: the prediction is
    ``f(X; theta) + s * NN((X - mean) / scale; W)``, and ``theta`` and ``W`` are
    trained together by Adam on one objective. The domain equations run through
    the torch namespace (they are written once for NumPy and torch, see
    :class:`~skhybrid.domain.DomainModel`), so gradients reach the physical
    parameters exactly.

    Training runs on the networks' skorch engine (the protocol of
    :class:`~skhybrid.neural.BaseNeuralRegressor`): physics and network are one
    :class:`torch.nn.Module` whose parameters are the network's weights and the
    physical parameters (as :class:`torch.nn.Parameter`), trained by one Adam.

    - The domain parameters start from a least-squares fit of a clone of
      ``domain`` (``warm_start_domain=True``) or from its initial values
      (:meth:`~skhybrid.domain.DomainModel.initialize`); the physics runs in
      torch through :meth:`~skhybrid.domain.DomainModel.torch_forward`.
    - Bounds are respected by construction: a parameter bounded on both sides is
      ``lower + (upper - lower) * sigmoid(z)``, on one side ``lower + a *
      softplus(z)`` (or ``upper - a * softplus(z)``), unbounded ``theta0 + a * z``,
      with ``a`` the parameter's starting scale, so Adam's steps are relative
      changes; ``z`` is the trained tensor. Parameters in the domain's ``fixed``
      are held.
    - The network is ``neural.make_module(n_features, n_outputs)`` (any
      :mod:`skhybrid.neural` estimator; its own training settings are not used),
      run in float64 on standardised rows; its output is scaled by ``s``, the
      standard deviation of the residual the starting domain model leaves, so it
      starts as a correction of that size.
    - The objective (:func:`skhybrid.losses.objective_value`) is evaluated on the
      residual divided by ``s``. As for the networks, the last
      ``validation_fraction`` of the rows (the most recent ones; never shuffled
      in) is held out: its loss drives the learning-rate schedule (multiplied by
      ``lr_factor`` after ``lr_patience`` epochs without improvement), early
      stopping after ``patience`` epochs without improvement, and the choice of
      the epoch whose state (network and physics) is kept. With
      ``validation_fraction=0``, or too few rows for a split, the training loss
      is monitored instead.
    - Mini-batches of an epoch are of equal size (to one row); a Ljung-Box
      objective trains on contiguous blocks of rows in time order and validates
      on the whole validation stretch.
    - A loss that becomes non-finite or blows up raises
      :class:`~skhybrid.exceptions.TrainingDivergedError`; a Ctrl-C ends training
      with a warning and keeps the best epoch so far. A failed refit leaves the
      previously fitted model as it was.

    Parameters
    ----------
    domain : DomainModel
        The physics model; its equations must run on torch (a
        :class:`~skhybrid.domain.ParametricModel` whose ``func`` takes ``xp``).
    neural : estimator with ``make_module(n_features, n_outputs)``
        Supplies the network architecture (for example a
        :class:`~skhybrid.neural.DenseRegressor`); its own training settings are
        not used.
    %(training_parameters)s
    horizon : int, default=1
        Steps of the training loss. 1 trains one step ahead. ``T > 1`` trains by
        simulation error, as the networks do: from every row that starts ``T``
        consecutive rows of one experiment (found in the data, see
        :meth:`skhybrid.preprocessing.WindowLayout.horizon_starts`, with the
        domain's ``n_steps``), physics plus network are rolled ``T`` steps in
        torch, feeding back their own predictions with the measured inputs, and
        the loss is the MSE over the horizon; gradients reach the physical
        parameters through every step. Needs time-ordered windows and
        ``objective="mse"``.
    weight_decay : float, default=0.0
        L2 penalty on the network weights (not on the physical parameters).
    warm_start_domain : bool, default=True
        Start the physical parameters from a least-squares fit of ``domain``.

    Attributes
    ----------
    params_ : dict
        Jointly trained value of each domain parameter (fixed ones included).
    params_std_ : dict
        Standard errors from the Gauss-Newton covariance ``s^2 (J^T J)^-1`` at the
        end of training, ``J`` the Jacobian of the residual with respect to the
        free physical parameters with the network held fixed (0 for fixed
        parameters). They describe the data's information on ``theta`` given the
        network, not the uncertainty of the network.
    params_cov_ : ndarray of shape (n_free, n_free)
        Covariance of the free parameters, in the order of ``free_params_``.
    params_init_ : dict
        Starting value of each parameter (the least-squares fit when
        ``warm_start_domain``).
    free_params_ : list of str
        Names of the trained physical parameters.
    domain_ : DomainModel
        The domain clone used for its equations (fitted by least squares when
        ``warm_start_domain``; its own ``params_`` are the starting values).
    module_ : torch.nn.Module
        The trained network (float64, eval mode).
    net_ : skorch.NeuralNetRegressor
        The trained skorch net; its ``module_`` holds the network (``net``) and
        the unconstrained physical parameters (``z``).
    history_ : skorch.History
        Per-epoch records: ``history_[:, "train_loss"]`` and, with a validation
        split, ``history_[:, "valid_loss"]`` (residuals divided by ``s``).
    loss_curve_ : list of float
        Training objective of each epoch (mean over its batches).
    validation_scores_ : list of float or None
        Validation objective of each epoch; None without a validation split.
    n_epochs_ : int
        Number of epochs run.
    best_epoch_ : int
        Epoch (1-based) whose state was kept: the lowest monitored loss.
    interrupted_ : bool
        Whether a Ctrl-C cut the training short (the best epoch so far was
        kept, and a ``UserWarning`` said so).
    n_features_in_ : int
        Number of columns of ``X``.
    n_outputs_ : int
        Number of outputs.

    See Also
    --------
    HybridBoostingRegressor : The sequential composition.

    Notes
    -----
    When physics and network can both explain a feature of the data, joint
    training may share it between them; the network's small starting scale and a
    ``weight_decay`` favour the physics. Compare ``params_`` with
    ``params_init_``.

    Examples
    --------
    >>> import numpy as np
    >>> from skhybrid.domain import ParametricModel
    >>> from skhybrid.hybrid import HybridEnsembleRegressor
    >>> from skhybrid.neural import DenseRegressor
    >>> def decay(X, *, k, xp=np):
    ...     return X[:, :1] * xp.exp(-k * 0.1)
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(0.5, 2.0, size=(300, 1))
    >>> y = X[:, 0] * np.exp(-0.3) + 0.05 * np.sin(4 * X[:, 0])
    >>> model = HybridEnsembleRegressor(
    ...     ParametricModel(decay, {"k": 1.0}, bounds={"k": (0.0, 10.0)}),
    ...     DenseRegressor(hidden_layer_sizes=(16,)),
    ...     max_epochs=100, random_state=0,
    ... ).fit(X, y)
    >>> sorted(model.params_)
    ['k']
    >>> 0.0 <= model.params_["k"] <= 10.0
    True
    >>> parts = model.decompose(X[:2])
    >>> parts.stage_names
    ['domain', 'neural']
    """

    _parameter_constraints = {
        "domain": [HasMethods(["fit", "predict_with"])],
        "neural": [HasMethods(["make_module"])],
        **training_constraints(),
        "horizon": [Interval(Integral, 1, None, closed="left")],
        "weight_decay": [Interval(Real, 0, None, closed="left")],
        "warm_start_domain": ["boolean"],
    }

    def __init__(
        self,
        domain,
        neural,
        *,
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
        ljung_box_segment_length=None,
        ljung_box_scaling="target",
        mse_pretraining=False,
        lr=0.01,
        max_epochs=200,
        batch_size=512,
        validation_fraction=0.2,
        target_scaling="per_output",
        patience=30,
        lr_patience=10,
        lr_factor=0.5,
        callbacks=None,
        random_state=None,
        device="cpu",
        verbose=0,
        horizon=1,
        weight_decay=0.0,
        warm_start_domain=True,
    ):
        self.domain = domain
        self.neural = neural
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
        self.horizon = horizon
        self.weight_decay = weight_decay
        self.warm_start_domain = warm_start_domain

    @property
    def fits_in_lockstep(self):
        """Whether a search fits this model's folds side by side: on a GPU.

        Where ``device="cuda"`` and ``neural``'s network can be batched (a
        :class:`~skhybrid.neural.DenseRegressor`'s, see
        :attr:`skhybrid.neural.DenseRegressor.fits_in_lockstep`), the folds'
        fits run in threads of one process, each warm-starting its own physics,
        and their joint modules (physics and network) train as one batched
        call.
        """
        # neural supplies the architecture only: its device is not used.
        return self.device == "cuda" and getattr(
            self.neural, "_module_in_lockstep", False
        )

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

    # -- set-up --------------------------------------------------------------------
    def _start_domain(self, X, y):
        """A clone of ``domain`` at the starting parameters (fitted or initial)."""
        if not isinstance(self.domain, DomainModel):
            raise TypeError(
                "domain must be a skhybrid.domain.DomainModel (its equations run on "
                f"torch); got {type(self.domain).__name__}."
            )
        dom = clone(self.domain)
        if self.warm_start_domain:
            dom.fit(X, y)
        else:
            dom.initialize(X, y)
        # Fail before training when the equations cannot run on torch.
        dom.torch_forward(
            torch.tensor(X[:2]), torch.as_tensor(dom.pack_params(dom.params_))
        )
        return dom

    # -- fit -----------------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Warm-start the physics, then train physics and network jointly.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of time steps (see :mod:`skhybrid.preprocessing`), in time
            order: the last ``validation_fraction`` of them monitor training, and
            a Ljung-Box objective trains on contiguous blocks.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next states.

        Returns
        -------
        self : HybridEnsembleRegressor
            The fitted model.
        """
        target = self.neural.get_params(deep=False).get("target", "state")
        if target != "state":
            raise ValueError(
                "HybridEnsembleRegressor trains the network's module jointly with "
                "the physics and adds their outputs; it needs a network with "
                f"target='state', got neural with target={target!r}."
            )
        X, y = validate_data(
            self,
            X,
            y,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
            ensure_min_samples=2,
        )
        check_device(self.device)
        n, n_features = X.shape
        self._y_1d = y.ndim == 1
        Y = y[:, None] if self._y_1d else y
        self.n_outputs_ = Y.shape[1]
        min_rows = check_time_ordered_rows(self, n)
        if self.horizon > 1 and self.objective != "mse":
            raise ValueError(
                f"horizon={self.horizon} trains on simulated sub-sequences with "
                f"objective='mse' only; got objective={self.objective!r}."
            )

        dom = self._start_domain(X, y)
        self.domain_ = dom
        self.params_init_ = dict(dom.params_)
        self.free_params_ = dom.free_params_
        theta0 = dom.pack_params(dom.params_)
        lower, upper = dom.free_bounds_

        self.x_mean_ = X.mean(axis=0)
        x_scale = X.std(axis=0)
        self.x_scale_ = np.where(
            x_scale > 1e-12 * (1 + np.abs(self.x_mean_)), x_scale, 1
        )
        r0 = Y - dom.predict_with(X, self.params_init_)
        s = r0.std(axis=0)
        fallback = Y.std(axis=0)
        fallback = np.where(fallback > 0, fallback, 1.0)
        self.y_scale_ = np.where(s > 1e-12 * fallback, s, fallback)

        if self.target_scaling == "shared":
            shared = np.sqrt(np.mean(self.y_scale_**2))
            self.y_scale_ = np.full_like(self.y_scale_, shared)

        n_valid = validation_rows(n, self.validation_fraction, min_rows)
        Xt = torch.tensor(X, device=self.device)
        Yt = torch.as_tensor(Y / self.y_scale_, device=self.device)
        layout = None
        if self.horizon > 1:
            layout, Xt, Yt, n_valid = self._horizon_data(dom, X, Y, Yt, n_valid)
        stop = Xt.shape[0] - n_valid
        valid = (Xt[stop:], Yt[stop:]) if n_valid else None

        def make_module():
            network = self.neural.make_module(n_features, self.n_outputs_)
            module = HybridModule(
                dom,
                network.double(),
                theta0,
                lower,
                upper,
                self.x_mean_,
                self.x_scale_,
                self.y_scale_,
            )
            return (
                module
                if layout is None
                else HybridRollout(module, layout, self.horizon)
            )

        net = train_module(
            self,
            make_module,
            Xt[:stop],
            Yt[:stop],
            valid=valid,
            optimizer_kwargs={
                "param_groups": [("net.*", {"weight_decay": self.weight_decay})]
            },
        )
        record_training(self, net)
        hybrid = net.module_ if layout is None else net.module_.hybrid
        self.loss_curve_ = [float(v) for v in net.history[:, "train_loss"]]
        self.validation_scores_ = (
            [float(v) for v in net.history[:, "valid_loss"]] if n_valid else None
        )
        self.module_ = hybrid.net
        with torch.no_grad():
            theta = hybrid.theta().cpu().numpy().copy()
        self.params_ = dom.unpack_params(theta)
        self._theta = theta
        self.params_std_, self.params_cov_ = self._standard_errors(X, Y, theta)
        return self

    def _horizon_data(self, dom, X, Y, Yt, n_valid):
        """Start windows with future inputs, and targets, for ``horizon`` steps."""
        layout = WindowLayout.from_shapes(X.shape[1], Y.shape[1], n_steps=dom.n_steps)
        h = self.horizon
        starts = layout.horizon_starts(X, Y, h)
        if len(starts) == 0:
            raise ValueError(
                f"horizon={h}: no {h} consecutive rows of X continue each other "
                f"(row i + 1 is row i shifted by one step with y[i] as its newest "
                f"state, in a layout of the domain's n_steps={dom.n_steps}); pass "
                "time-ordered windows (skhybrid.preprocessing.make_windows) or "
                "horizon=1."
            )
        future = starts[:, None] + np.arange(1, h)[None, :]
        newest = X[:, X.shape[1] - layout.step_width :][:, layout.n_states :]
        U = newest[future].reshape(len(starts), -1)
        Z = torch.tensor(np.hstack([X[starts], U]), device=self.device)
        targets = Yt[torch.as_tensor(starts[:, None] + np.arange(h)[None, :])]
        targets = targets.reshape(len(starts), -1)
        n_valid_starts = (
            int(np.sum(starts + h - 1 >= X.shape[0] - n_valid)) if n_valid else 0
        )
        if n_valid_starts < 2 or len(starts) - n_valid_starts < 2:
            n_valid_starts = 0
        return layout, Z, targets, n_valid_starts

    def _standard_errors(self, X, Y, theta):
        dom = self.domain_
        if theta.size == 0:
            return _std_dict(dom, theta, self.free_params_), np.zeros((0, 0))
        Xt = torch.tensor(X)
        target = torch.as_tensor(Y - self._network_part(X))

        def residual(t):
            return (target - dom.torch_forward(Xt, t)).reshape(-1)

        t = torch.as_tensor(theta)
        # Forward mode: one pass per parameter rather than one per residual.
        with FORWARD_MODE:
            J = torch.func.jacfwd(residual)(t).detach().numpy()
        r = residual(t).detach().numpy()
        dof = r.size - theta.size
        s2 = float(r @ r) / dof if dof > 0 else np.inf
        cov = np.linalg.pinv(J.T @ J) * s2
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
        return _std_dict(dom, std, self.free_params_), cov

    # -- predictions ---------------------------------------------------------------
    def _network_part(self, X):
        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_, device=self.device)
        training = self.module_.training
        self.module_.eval()
        try:
            with torch.no_grad():
                out = self.module_(Xs).cpu().numpy()
        finally:
            self.module_.train(training)
        return out * self.y_scale_

    def _shape(self, Y):
        return Y[:, 0] if self._y_1d else Y

    def decompose(self, X):
        """The physics part, the network part, and their sum.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of time steps.

        Returns
        -------
        parts : :class:`~sklearn.utils.Bunch`
            ``stage_names`` (``["domain", "neural"]``), ``domain`` and ``neural``
            (arrays shaped like :meth:`predict`'s output) and ``total``, their sum,
            which is what :meth:`predict` returns.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        domain = np.asarray(self.domain_.predict_with(X, self.params_), dtype=float)
        domain = np.broadcast_to(domain, (X.shape[0], self.n_outputs_))
        neural = self._network_part(X)
        return Bunch(
            stage_names=["domain", "neural"],
            domain=self._shape(np.array(domain)),
            neural=self._shape(neural),
            total=self._shape(domain + neural),
        )

    def predict(self, X):
        """Predict the physics part plus the network part.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of time steps.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Float64 predictions, 1-D when ``y`` was 1-D in ``fit``.
        """
        return self.decompose(X).total


class HybridModule(nn.Module):
    """Physics and network as one torch module, for the skorch engine.

    ``forward(X)`` returns ``f(X; theta) / s + net((X - x_mean) / x_scale)``:
    the prediction in units of ``s`` (the targets are divided by ``s`` for
    training). ``theta`` is the bounded image of the trained tensor ``z`` (see
    :meth:`theta`); fixed parameters stay in the domain model.

    Parameters
    ----------
    domain : DomainModel
        Fitted (or initialised) domain model; its
        :meth:`~skhybrid.domain.DomainModel.torch_forward` evaluates the physics.
    net : torch.nn.Module
        The network on standardised rows (float64).
    theta0 : ndarray of shape (n_free_values,)
        Starting free parameters.
    lower, upper : ndarray of shape (n_free_values,)
        Their bounds (infinite where a side is open).
    x_mean, x_scale : ndarray of shape (n_features,)
        Standardisation of the network's input.
    y_scale : ndarray of shape (n_outputs,)
        The scale ``s`` of the targets and the network's output.
    """

    def __init__(self, domain, net, theta0, lower, upper, x_mean, x_scale, y_scale):
        super().__init__()
        self.domain = domain
        self.net = net
        self.params = BoundedParameters(theta0, lower, upper)
        for name, value in (
            ("x_mean", x_mean),
            ("x_scale", x_scale),
            ("y_scale", y_scale),
        ):
            self.register_buffer(name, torch.as_tensor(value, dtype=torch.float64))

    def theta(self):
        """The free physical parameters, inside their bounds.

        Returns
        -------
        theta : torch.Tensor of shape (n_free_values,)
            Differentiable in the trained tensor ``params.z``.
        """
        return self.params()

    def forward(self, X):
        """Physics plus network, in units of ``y_scale``.

        Parameters
        ----------
        X : torch.Tensor of shape (n_samples, n_features)
            Unscaled rows (float64).

        Returns
        -------
        y : torch.Tensor of shape (n_samples, n_outputs)
            The prediction divided by ``y_scale``.
        """
        physics = self.domain.torch_forward(X, self.theta())
        return physics / self.y_scale + self.net((X - self.x_mean) / self.x_scale)

    def lockstep_signature(self):
        """What its forward pass reads besides its tensors, or None.

        The physics' equations, settings and fixed parameter values (the free
        ones are its tensors), and the network's signature; None (each member
        alone) where the network has none (see :mod:`skhybrid.neural._lockstep`).
        """
        net = getattr(self.net, "lockstep_signature", lambda: None)()
        if net is None:
            return None
        return repr((*physics_signature(self.domain), net))


class HybridRollout(nn.Module):
    """Simulates ``horizon`` steps through a :class:`HybridModule`, for training.

    The input row holds an unscaled start window followed by the raw inputs of
    the next ``horizon - 1`` steps; the output is every step's prediction in
    units of ``y_scale``, ``(n, horizon * n_outputs)``. The window moves in raw
    units: the prediction enters as the newest state, the next input beside it
    (:meth:`skhybrid.preprocessing.WindowLayout.shift`). Gradients flow through
    the whole horizon into the network and the physical parameters.

    Parameters
    ----------
    hybrid : HybridModule
        Physics plus network.
    layout : skhybrid.preprocessing.WindowLayout
        The rows' layout.
    horizon : int
        Steps simulated from each start.
    """

    def __init__(self, hybrid, layout, horizon):
        super().__init__()
        self.hybrid = hybrid
        self.layout = layout
        self.horizon = horizon

    def forward(self, Z):
        """Roll ``horizon`` steps from each start window.

        Parameters
        ----------
        Z : torch.Tensor of shape (n, n_features + (horizon - 1) * n_inputs)
            Start windows and future inputs, unscaled.

        Returns
        -------
        y : torch.Tensor of shape (n, horizon * n_outputs)
            Every step's prediction divided by ``y_scale``.
        """
        n_features = self.layout.n_features
        X = Z[:, :n_features]
        U = Z[:, n_features:].reshape(Z.shape[0], self.horizon - 1, -1)
        preds = []
        for k in range(self.horizon):
            pred = self.hybrid(X)
            preds.append(pred)
            if k < self.horizon - 1:
                state = pred * self.hybrid.y_scale
                X = self.layout.shift(X, state, U[:, k] if U.shape[2] else None)
        return torch.cat(preds, dim=1)

    def lockstep_signature(self):
        """The layout, horizon and hybrid's signature, or None (see
        :meth:`HybridModule.lockstep_signature`)."""
        hybrid = self.hybrid.lockstep_signature()
        return None if hybrid is None else (repr(self.layout), self.horizon, hybrid)


def _std_dict(domain, std, free):
    """Standard errors by name: 0 for fixed parameters."""
    values = domain.unpack_params(std)
    return {
        k: v if k in free else (0.0 if np.ndim(v) == 0 else np.zeros(np.shape(v)))
        for k, v in values.items()
    }


HybridEnsembleRegressor.__doc__ = HybridEnsembleRegressor.__doc__.replace(
    "    %(training_parameters)s", training_parameters_doc()
)
