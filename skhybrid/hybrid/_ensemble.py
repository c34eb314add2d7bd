"""HybridEnsembleRegressor: the parallel hybrid (the paper's section 3.2)."""

import copy
import math
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils import Bunch, check_random_state
from sklearn.utils.validation import check_is_fitted

from skhybrid.domain._base import DomainModel, _ParameterSpec
from skhybrid.exceptions import TrainingDivergedError
from skhybrid.losses import OBJECTIVES, needs_time_order, objective_value
from skhybrid.neural._callbacks import check_divergence
from skhybrid.simulation import SimulatorMixin
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    HasMethods,
    Interval,
    StrOptions,
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

    Training:

    - the domain parameters start from a least-squares fit of a clone of
      ``domain`` (``warm_start_domain=True``) or from its initial values;
    - bounds are respected by construction: a parameter bounded on both sides is
      ``lower + (upper - lower) * sigmoid(z)``, on one side ``lower + a *
      softplus(z)`` (or ``upper - a * softplus(z)``), unbounded ``theta0 + a * z``,
      with ``a`` the parameter's starting scale, so Adam's steps are relative
      changes; parameters in the domain's ``fixed`` are held;
    - the network is ``neural._make_module(n_features, n_outputs)`` (any
      :mod:`skhybrid.neural` estimator), run in float64 on standardised rows; its
      output is scaled by ``s``, the standard deviation of the residual the
      starting domain model leaves, so it starts as a correction of that size;
    - the objective (:func:`skhybrid.losses.objective_value`) is evaluated on the
      residual divided by ``s``; Adam with learning rate ``lr``, halved after 10
      epochs without improvement, stops after ``patience`` epochs without
      improvement of the training objective and keeps the best epoch's state.

    Parameters
    ----------
    domain : DomainModel
        The physics model; its equations must run on torch (a
        :class:`~skhybrid.domain.ParametricModel` whose ``func`` takes ``xp``).
    neural : estimator with ``_make_module(n_features, n_outputs)``
        Supplies the network architecture (for example a
        :class:`~skhybrid.neural.DenseRegressor`); its own training settings are
        not used.
    objective : {"mse", "ljung_box", "mse+ljung_box"}, default="mse"
        Joint training objective. A Ljung-Box term assumes the rows are in time
        order and trains on contiguous blocks of rows.
    ljung_box_lags : int, default=20
        Lags of the Ljung-Box term; smaller than the rows of a batch.
    ljung_box_weight : float, default=1.0
        Weight of the Ljung-Box term in ``"mse+ljung_box"``.
    lr : float, default=0.01
        Initial learning rate of Adam.
    max_epochs : int, default=300
        Most passes over the rows.
    batch_size : int or None, default=None
        Rows per mini-batch (contiguous blocks for a Ljung-Box objective, shuffled
        rows otherwise); ``None`` trains on all rows at once.
    weight_decay : float, default=0.0
        L2 penalty on the network weights (not on the physical parameters).
    patience : int, default=30
        Epochs without improvement of the training objective before stopping.
    warm_start_domain : bool, default=True
        Start the physical parameters from a least-squares fit of ``domain``.
    random_state : int, RandomState instance or None, default=None
        Seeds the initial weights and the batch order; the same seed gives
        identical predictions. The global torch random state is left untouched.

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
    loss_curve_ : list of float
        Training objective after each epoch.
    n_epochs_ : int
        Number of epochs run.
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
        "neural": [HasMethods(["_make_module"])],
        "objective": [StrOptions(set(OBJECTIVES))],
        "ljung_box_lags": [Interval(Integral, 1, None, closed="left")],
        "ljung_box_weight": [Interval(Real, 0, None, closed="left")],
        "lr": [Interval(Real, 0, None, closed="neither")],
        "max_epochs": [Interval(Integral, 1, None, closed="left")],
        "batch_size": [Interval(Integral, 2, None, closed="left"), None],
        "weight_decay": [Interval(Real, 0, None, closed="left")],
        "patience": [Interval(Integral, 1, None, closed="left")],
        "warm_start_domain": ["boolean"],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        domain,
        neural,
        *,
        objective="mse",
        ljung_box_lags=20,
        ljung_box_weight=1.0,
        lr=0.01,
        max_epochs=300,
        batch_size=None,
        weight_decay=0.0,
        patience=30,
        warm_start_domain=True,
        random_state=None,
    ):
        self.domain = domain
        self.neural = neural
        self.objective = objective
        self.ljung_box_lags = ljung_box_lags
        self.ljung_box_weight = ljung_box_weight
        self.lr = lr
        self.max_epochs = max_epochs
        self.batch_size = batch_size
        self.weight_decay = weight_decay
        self.patience = patience
        self.warm_start_domain = warm_start_domain
        self.random_state = random_state

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

    # -- set-up --------------------------------------------------------------------
    def _start_domain(self, X, y):
        """Domain clone, its parameter spec and the starting free vector."""
        if not isinstance(self.domain, DomainModel):
            raise TypeError(
                "domain must be a skhybrid.domain.DomainModel (its equations run on "
                f"torch); got {type(self.domain).__name__}."
            )
        dom = clone(self.domain)
        dom._check_autograd()
        if self.warm_start_domain:
            dom.fit(X, y)
            spec, params = dom._spec, dom.params_
        else:
            y2 = y if y.ndim == 2 else y[:, None]
            dom._y_1d = y.ndim == 1
            dom.n_outputs_ = y2.shape[1]
            dom.n_features_in_ = X.shape[1]
            dom._check_layout(X.shape[1] // dom.n_steps, dom.n_outputs_)
            init = dom._initial_params(X, y2)
            spec = _ParameterSpec(init, dom.fixed, dom._resolved_bounds(init))
            dom._spec = spec
            params = spec.to_dict(spec.x0)
        theta0 = (
            np.concatenate([np.ravel(params[k]) for k in spec.free]).astype(float)
            if spec.free
            else np.zeros(0)
        )
        return dom, spec, theta0

    # -- fit -----------------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y):
        """Warm-start the physics, then train physics and network jointly.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of time steps (see :mod:`skhybrid.preprocessing`), in time
            order for a Ljung-Box objective.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next states.

        Returns
        -------
        self : HybridEnsembleRegressor
            The fitted model.
        """
        import torch

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
        n, n_features = X.shape
        self._y_1d = y.ndim == 1
        Y = y[:, None] if self._y_1d else y
        self.n_outputs_ = Y.shape[1]
        time_ordered = needs_time_order(self.objective)
        batch = n if self.batch_size is None else min(self.batch_size, n)
        if time_ordered and self.ljung_box_lags >= batch:
            raise ValueError(
                f"ljung_box_lags={self.ljung_box_lags} must be smaller than the rows "
                f"of a batch ({batch}: batch_size={self.batch_size}, n_samples={n})."
            )

        dom, spec, theta0 = self._start_domain(X, y)
        self.domain_, self._spec = dom, spec
        self.params_init_ = spec.to_dict(theta0)
        self.free_params_ = list(spec.free)
        self._transform = _BoundTransform(theta0, spec.lower, spec.upper)

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

        rng = check_random_state(self.random_state)
        seed = int(rng.randint(np.iinfo(np.int32).max))
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            module = self.neural._make_module(n_features, self.n_outputs_)
        module = module.double()

        Xt = torch.tensor(X)
        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_)
        Yt = torch.tensor(Y)
        scale = torch.as_tensor(self.y_scale_)
        z = torch.nn.Parameter(torch.as_tensor(self._transform.z0.copy()))
        groups = [
            {"params": list(module.parameters()), "weight_decay": self.weight_decay}
        ]
        if z.numel():
            groups.append({"params": [z], "weight_decay": 0.0})
        optimizer = torch.optim.Adam(groups, lr=self.lr)
        scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(
            optimizer, factor=0.5, patience=10
        )

        def loss_on(idx):
            if isinstance(idx, np.ndarray):
                idx = torch.as_tensor(idx)
            theta = self._transform.to_theta(z, torch)
            params = spec.to_dict(theta, xp=_torch_namespace(Xt))
            y_dom = dom.predict_with(Xt[idx], params)
            y_nn = module(Xs[idx]) * scale
            r = (Yt[idx] - y_dom - y_nn) / scale
            return objective_value(
                r,
                self.objective,
                lags=self.ljung_box_lags,
                ljung_box_weight=self.ljung_box_weight,
            )

        self.loss_curve_ = []
        best, best_state, since_best = math.inf, None, 0
        module.train()
        for epoch in range(self.max_epochs):
            for idx in _batches(n, batch, time_ordered, rng):
                optimizer.zero_grad()
                loss = loss_on(idx)
                if not torch.isfinite(loss):
                    raise TrainingDivergedError(
                        f"HybridEnsembleRegressor: the training objective became "
                        f"{float(loss)} in epoch {epoch + 1}; lower the learning rate "
                        f"(got lr={self.lr}) or check the domain equations for "
                        "overflow at the starting parameters."
                    )
                loss.backward()
                optimizer.step()
            module.eval()
            with torch.no_grad():
                epoch_loss = float(loss_on(slice(None)))
            module.train()
            if not math.isfinite(epoch_loss):
                raise TrainingDivergedError(
                    f"HybridEnsembleRegressor: the training objective became "
                    f"{epoch_loss} after epoch {epoch + 1}; lower the learning rate "
                    f"(got lr={self.lr})."
                )
            check_divergence(
                epoch_loss,
                self.loss_curve_[0] if self.loss_curve_ else None,
                name="HybridEnsembleRegressor's training objective",
                epoch=epoch + 1,
                lr=self.lr,
            )
            self.loss_curve_.append(epoch_loss)
            scheduler.step(epoch_loss)
            if epoch_loss < best:
                best, since_best = epoch_loss, 0
                best_state = (z.detach().clone(), copy.deepcopy(module.state_dict()))
            else:
                since_best += 1
                if since_best >= self.patience:
                    break
        self.n_epochs_ = len(self.loss_curve_)
        if best_state is not None:
            with torch.no_grad():
                z.copy_(best_state[0])
            module.load_state_dict(best_state[1])
        module.eval()
        for p in module.parameters():
            p.requires_grad_(False)
        self.module_ = module

        theta = self._transform.to_theta(z.detach(), torch).numpy().copy()
        self.params_ = spec.to_dict(theta)
        self._theta = theta
        self.params_std_, self.params_cov_ = self._standard_errors(X, Y, theta)
        return self

    def _standard_errors(self, X, Y, theta):
        import torch

        spec = self._spec
        if spec.n_free == 0:
            return spec.to_dict(np.zeros(0), fixed_value=0.0), np.zeros((0, 0))
        Xt = torch.tensor(X)
        target = torch.as_tensor(Y - self._network_part(X))
        xp = _torch_namespace(Xt)

        def residual(t):
            params = spec.to_dict(t, xp=xp)
            return (target - self.domain_.predict_with(Xt, params)).reshape(-1)

        t = torch.as_tensor(theta)
        # Forward mode: one pass per parameter rather than one per residual.
        J = torch.func.jacfwd(residual)(t).detach().numpy()
        r = residual(t).detach().numpy()
        dof = r.size - spec.n_free
        s2 = float(r @ r) / dof if dof > 0 else np.inf
        cov = np.linalg.pinv(J.T @ J) * s2
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
        return spec.to_dict(std, fixed_value=0.0), cov

    # -- predictions ---------------------------------------------------------------
    def _network_part(self, X):
        import torch

        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_)
        with torch.no_grad():
            out = self.module_(Xs).numpy()
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


class _BoundTransform:
    """Map an unconstrained vector ``z`` to parameters inside their bounds."""

    def __init__(self, theta0, lower, upper):
        theta0 = np.asarray(theta0, dtype=float)
        lo_ok, hi_ok = np.isfinite(lower), np.isfinite(upper)
        self.lower = np.where(lo_ok, lower, 0.0)
        self.upper = np.where(hi_ok, upper, 0.0)
        self.both = lo_ok & hi_ok
        self.lo_only = lo_ok & ~hi_ok
        self.hi_only = hi_ok & ~lo_ok
        self.free = ~lo_ok & ~hi_ok
        self.theta0 = theta0
        span = np.where(self.both, self.upper - self.lower, 1.0)
        frac = np.clip((theta0 - self.lower) / span, 1e-6, 1 - 1e-6)
        gap = np.where(
            self.lo_only,
            theta0 - self.lower,
            np.where(self.hi_only, self.upper - theta0, 0),
        )
        # One-sided: theta = bound +/- a * softplus(z) with a = gap / log(2), z0 = 0.
        self.a_side = np.maximum(gap, 1e-8) / math.log(2.0)
        # Unbounded: theta = theta0 + a * z, a = |theta0| (1 where theta0 is 0).
        self.a_free = np.where(np.abs(theta0) > 0, np.abs(theta0), 1.0)
        self.z0 = np.where(self.both, np.log(frac / (1 - frac)), 0.0)

    def to_theta(self, z, torch):
        f = lambda a: torch.as_tensor(a, dtype=z.dtype)  # noqa: E731
        both = f(self.lower) + (f(self.upper) - f(self.lower)) * torch.sigmoid(z)
        soft = torch.nn.functional.softplus(z) * f(self.a_side)
        lo = f(self.lower) + soft
        hi = f(self.upper) - soft
        free = f(self.theta0) + f(self.a_free) * z
        return torch.where(
            f(self.both).bool(),
            both,
            torch.where(
                f(self.lo_only).bool(),
                lo,
                torch.where(f(self.hi_only).bool(), hi, free),
            ),
        )


def _torch_namespace(tensor):
    from skhybrid.utils._array_api import get_namespace

    return get_namespace(tensor)


def _batches(n, batch, contiguous, rng):
    """Row indices of each mini-batch of one epoch."""
    if batch >= n:
        return [slice(None)]
    if contiguous:
        n_blocks = max(1, n // batch)
        edges = np.linspace(0, n, n_blocks + 1).astype(int)
        order = rng.permutation(n_blocks)
        return [slice(int(edges[i]), int(edges[i + 1])) for i in order]
    # Rows spread evenly over ceil(n / batch) batches (sizes differ by at most
    # one), as the networks' BatchIterator does: no tiny remainder batch whose one
    # noisy step per epoch could decide the result.
    perm = rng.permutation(n)
    n_batches = max(1, min(-(-n // batch), n // 2))  # batch norm needs 2 rows
    edges = [(i * n) // n_batches for i in range(n_batches + 1)]
    return [perm[edges[i] : edges[i + 1]] for i in range(n_batches)]
