"""HybridBoostingRegressor: the sequential hybrid (the paper's section 3.1)."""

from numbers import Integral, Real

import numpy as np
from sklearn.base import RegressorMixin, clone
from sklearn.utils import Bunch, check_random_state, get_tags
from sklearn.utils.validation import check_is_fitted

from skhybrid.hybrid._noise import NOISE_MODELS, make_noise_model
from skhybrid.hybrid._stage_whiteness import (
    StageWhiteness,
    _warn_if_not_white,
    _whiteness,
)
from skhybrid.preprocessing import (
    WindowLayout,
    infer_n_steps,
    split_steps,
    step_width,
)
from skhybrid.simulation import SimulatorMixin
from skhybrid.utils._lockstep import parts_fit_in_lockstep
from skhybrid.utils._pickle import VersionedPickleMixin
from skhybrid.utils._sklearn_compat import (
    Interval,
    StrOptions,
    _BaseComposition,
    _fit_context,
    validate_data,
    visual_block,
)
from skhybrid.utils._transaction import TransactionalFitMixin

__all__ = ["HybridBoostingRegressor", "StageWhiteness"]

STAGE_INPUTS = ("window", "window+prediction", "window+prediction+residuals")
_RESERVED_NAMES = ("stage_names", "total")
#: A stage must lower the validation RMSE by more than this share of it to count
#: as helpful: a stage that predicts next to nothing (a ridge of huge alpha) moves
#: the RMSE only by rounding, up or down with the library versions.
_ROUNDING = 1e-9


class HybridBoostingRegressor(
    SimulatorMixin,
    TransactionalFitMixin,
    VersionedPickleMixin,
    RegressorMixin,
    _BaseComposition,
):
    """Sequential hybrid model: each stage is fitted to what the earlier stages left.

    The paper's boosting composition ``Y = f(X; theta) + NN(X; W) + N(phi)``: a
    domain (physics) stage first, then one or more neural stages, each a clone of
    its estimator fitted to the residual ``y - (stage_0 + ... + stage_{t-1})`` with
    that estimator's own objective (``"mse"``, ``"ljung_box"``, ...), and finally an
    optional noise model fitted to the final residual. The prediction is the sum of
    the stages' predictions; :meth:`decompose` returns the parts.

    **Stage input.** The first stage sees the rows ``X`` as given. A later stage
    sees, per ``stage_input``:

    - ``"window"``: ``X`` alone;
    - ``"window+prediction"``: ``X`` plus the earlier stages' prediction;
    - ``"window+prediction+residuals"``: also the earlier stages' residuals on the
      older steps of the window (the paper's ``r(t)`` input).

    The extra columns are appended *per time step*, so a row of a later stage is
    still ``n_steps`` equally wide steps, oldest first, and an
    :class:`~skhybrid.neural.RNNRegressor` with the same ``n_steps`` reshapes it
    cleanly. Step ``p`` of the augmented row is
    ``[step_p of X (w columns), pred_p (s columns), res_p (s columns)]`` with ``s``
    the number of outputs (the state width) and ``res_p`` present only for
    ``"window+prediction+residuals"`` with ``n_steps > 1``:

    - ``pred_p`` is the earlier stages' prediction of the state after step ``p``,
      made on the sub-window ending at step ``p``. For the newest step this is their
      prediction for the row itself;
    - ``res_p`` is the known state of step ``p + 1`` (the first ``s`` columns of
      step ``p + 1`` of the row) minus ``pred_p``; it is 0 for the newest step,
      whose next state is the unknown target.

    A sub-window ending at an older step ``p`` lacks ``n_steps - 1 - p`` steps
    before the row; they are filled with copies of the oldest step, and their own
    prediction and residual slots are 0. Stages that read only the newest step
    (the built-in domain models) therefore predict older steps exactly; a stage
    that reads the whole window sees the padded copies. Everything is computed from
    the row itself, so predictions never depend on the order of the rows. With
    ``n_steps=1`` there are no older steps and the residual slots are left out.

    **Validation and unhelpful stages.** The last ``validation_fraction`` of the
    rows (the end of the time-ordered training data) is held out: stages are fitted
    on the rows before it, and ``stage_scores_`` holds the validation RMSE after
    each stage. A neural stage on top of an already correct physics model can make
    things worse; with ``drop_unhelpful_stages=True`` a stage whose validation RMSE
    is not lower than before it is dropped (lower by more than a relative 1e-9,
    so that a stage that adds only rounding is dropped; the first stage is
    always kept), and
    later stages are fitted without it. Off by default, so that the stages you ask
    for are the stages you get; read ``stage_scores_`` either way.

    **Noise model.** ``noise_model`` fits the ``N(phi)`` term on the final residual
    of all training rows in the order given (validation slice included):
    ``"gaussian"`` (mean and covariance across outputs) or ``"ar"`` (one
    autoregressive process per output, order chosen by BIC, statsmodels). It gives
    :meth:`predict` a ``return_std`` and enables :meth:`sample`.

    **Free-run simulation.** :meth:`simulate` runs the booster as a whole: at each
    time step the window holds the simulated history, and every stage reads the
    input built from it exactly as above. The residual slots are therefore
    defined over the horizon as follows. Inside the measured initial window they
    are the true residuals (a measured state minus the earlier stages'
    prediction of it). Beyond it the true state is unknown and the window holds
    simulated states, so ``res_p`` is the *simulated* state of step ``p + 1``
    minus the earlier stages' prediction: the later stages' own contribution
    (exactly so for stages that read only the newest step), with no measurement
    noise in it, which is the residual's conditional mean under the model; in
    sample paths (``n_samples``) it also holds the noise model's draw fed back
    at that step. No extra convention is needed: the same rows a one-step
    prediction reads are built from the simulated history.

    **Cyclic method.** A :class:`~skhybrid.neural.CyclicRegressor` stage (an
    encoder trained with a decoder that reconstructs its input) makes this the
    paper's cyclic composition; :meth:`inverse_predict` exposes its decoder as an
    inverse model.

    Parameters
    ----------
    stages : list of (str, estimator) tuples
        The stages in order, like a Pipeline's steps. Parameters of a stage are
        reached as ``<name>__<parameter>`` (``set_params(rnn__hidden_size=32)``,
        ``GridSearchCV`` over ``rnn__objective``). A name must not contain ``__``
        nor be ``"stage_names"`` or ``"total"``.
    stage_input : {"window", "window+prediction", "window+prediction+residuals"}, \
            default="window+prediction+residuals"
        Input of the stages after the first (see above).
    n_steps : int, default=1
        Time steps per row of ``X``. A stage with its own ``n_steps`` parameter
        must use the same value; ``fit`` raises otherwise and says which value to
        change (the one the rows of ``X`` do not follow).
    validation_fraction : float or None, default=0.1
        Fraction of the rows, taken from the end, held out to score the stages.
        ``None`` fits on every row and scores on the training rows.
    drop_unhelpful_stages : bool, default=False
        Drop a stage whose validation RMSE is not lower than the RMSE before it
        (by more than a relative ``1e-9``: rounding is no gain).
    noise_model : {"gaussian", "ar"} or None, default=None
        Stochastic model of the final residual.
    noise_max_lag : int, default=10
        Largest lag the ``"ar"`` noise model considers.
    ljung_box_lags : int, default=20
        Lag of the Ljung-Box test in ``residual_whiteness_`` (at most
        ``n_samples - 1``).
    random_state : int, RandomState instance or None, default=None
        Seeds the stages whose ``random_state`` is ``None`` (one seed per stage),
        so the whole fit is repeatable; stages with their own ``random_state``
        keep it. Also the default seed of :meth:`sample`.

    Attributes
    ----------
    stages_ : list of (str, estimator) tuples
        The fitted stages that were kept, in order. ``booster[i]`` and
        ``booster[name]`` give a fitted stage itself, as a Pipeline's steps.
    named_stages_ : :class:`~sklearn.utils.Bunch`
        The fitted, kept stages by name (``booster.named_stages_.physics``).
    dropped_stages_ : list of str
        Names of the stages dropped by ``drop_unhelpful_stages``.
    interrupted_ : bool
        Whether a Ctrl-C cut a stage's training short (that stage kept its best
        epoch so far and warned; the later stages were fitted as usual).
    stage_scores_ : ndarray of shape (n_stages,)
        Validation RMSE (over all outputs) after each stage of ``stages``, dropped
        ones included (the score they reached when tried).
    baseline_score_ : float
        Validation RMSE of predicting zero, the reference of the first stage.
    residual_whiteness_ : StageWhiteness
        Ljung-Box statistic and p-value of the training residual after each kept
        stage, per output.
    noise_model_ : GaussianNoise, AutoRegressiveNoise or None
        The fitted noise model.
    n_features_in_ : int
        Number of columns of ``X``.
    n_outputs_ : int
        Number of outputs.

    See Also
    --------
    HybridEnsembleRegressor : The parallel composition, trained jointly.
    skhybrid.domain.DomainModel : Physics stages.

    Notes
    -----
    Stages with a Ljung-Box objective assume the training rows are in time order
    (one episode, or episodes one after the other); so do ``validation_fraction``,
    ``residual_whiteness_`` and the ``"ar"`` noise model.

    **When a one-step fit is biased.** Every stage is fitted one step ahead.
    Where the rows' inputs hold *noisy measured outputs* (past positions, say),
    the physics stage's one-step fit is biased (errors-in-variables: a damping
    fitted several standard errors from the truth, with no warning; see
    :class:`~skhybrid.domain.ParametricModel`), and a network boosted on those
    one-step residuals learns from noisy past outputs that a free run does not
    have: it can lower the one-step error and make the free-run simulation
    worse. For a model to be simulated, fit the physics by simulation error
    (:meth:`~skhybrid.domain.StateSpaceModel.fit_simulation`, multiple shooting
    over segments) and compare candidates by their free runs, as
    :func:`~skhybrid.experiments.run_system` does for a
    :class:`~skhybrid.experiments.SystemSpec`.

    Examples
    --------
    A linear physics stage, then a small network on what it leaves:

    >>> import numpy as np
    >>> from skhybrid.domain import LinearStateSpaceModel
    >>> from skhybrid.hybrid import HybridBoostingRegressor
    >>> from skhybrid.neural import CyclicRegressor, DenseRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(400, 2))          # [x(t), u(t)]
    >>> y = 0.9 * X[:, 0] + 0.5 * X[:, 1] + 0.3 * np.sin(3 * X[:, 0])
    >>> booster = HybridBoostingRegressor(
    ...     [("physics", LinearStateSpaceModel()),
    ...      ("nn", DenseRegressor(hidden_layer_sizes=(16,), max_epochs=40,
    ...                            random_state=0))],
    ...     noise_model="gaussian",
    ... ).fit(X, y)
    >>> parts = booster.decompose(X[:3])
    >>> parts.stage_names
    ['physics', 'nn']
    >>> bool(np.allclose(parts.physics + parts.nn, booster.predict(X[:3])))
    True
    >>> bool(booster.stage_scores_[1] < booster.stage_scores_[0])
    True
    >>> mean, std = booster.predict(X[:3], return_std=True)
    >>> std.shape
    (3,)

    The cyclic composition: a :class:`~skhybrid.neural.CyclicRegressor` stage,
    whose decoder :meth:`inverse_predict` exposes as an inverse model:

    >>> cyclic = HybridBoostingRegressor(
    ...     [("physics", LinearStateSpaceModel()),
    ...      ("cyclic", CyclicRegressor(hidden_layer_sizes=(16,), max_epochs=20,
    ...                                 random_state=0))],
    ...     stage_input="window",
    ... ).fit(X, y)
    >>> part = cyclic.decompose(X[:3]).cyclic
    >>> cyclic.inverse_predict(part).shape       # reconstructed windows
    (3, 2)
    """

    _parameter_constraints = {
        "stages": [list],
        "stage_input": [StrOptions(set(STAGE_INPUTS))],
        "n_steps": [Interval(Integral, 1, None, closed="left")],
        "validation_fraction": [Interval(Real, 0, 1, closed="neither"), None],
        "drop_unhelpful_stages": ["boolean"],
        "noise_model": [StrOptions(set(NOISE_MODELS)), None],
        "noise_max_lag": [Interval(Integral, 1, None, closed="left")],
        "ljung_box_lags": [Interval(Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        stages,
        *,
        stage_input="window+prediction+residuals",
        n_steps=1,
        validation_fraction=0.1,
        drop_unhelpful_stages=False,
        noise_model=None,
        noise_max_lag=10,
        ljung_box_lags=20,
        random_state=None,
    ):
        self.stages = stages
        self.stage_input = stage_input
        self.n_steps = n_steps
        self.validation_fraction = validation_fraction
        self.drop_unhelpful_stages = drop_unhelpful_stages
        self.noise_model = noise_model
        self.noise_max_lag = noise_max_lag
        self.ljung_box_lags = ljung_box_lags
        self.random_state = random_state

    # -- parameters of the stages --------------------------------------------------
    def get_params(self, deep=True):
        """Get the parameters of the booster and, with ``deep``, of its stages.

        Parameters
        ----------
        deep : bool, default=True
            Also return ``<stage>__<parameter>`` entries.

        Returns
        -------
        params : dict
            Parameter names mapped to their values.
        """
        return self._get_params("stages", deep=deep)

    def set_params(self, **params):
        """Set parameters of the booster or of its stages (``<stage>__<param>``).

        Parameters
        ----------
        **params : dict
            Booster parameters, whole stages by name, or stage parameters.

        Returns
        -------
        self : HybridBoostingRegressor
            This estimator.
        """
        self._set_params("stages", **params)
        return self

    @property
    def named_stages(self):
        """The (unfitted) stages as a :class:`~sklearn.utils.Bunch` by name."""
        return Bunch(**dict(self.stages))

    @property
    def named_stages_(self):
        """The fitted, kept stages as a :class:`~sklearn.utils.Bunch` by name.

        ``booster.named_stages_.physics`` (or ``["physics"]``) is the fitted
        estimator itself; ``stages_`` holds the same as ``(name, estimator)``
        pairs, and ``booster[0]`` or ``booster["physics"]`` also give it.
        """
        check_is_fitted(self)
        return Bunch(**dict(self.stages_))

    def __getitem__(self, key):
        """A fitted stage by position or name, like indexing a Pipeline.

        Parameters
        ----------
        key : int or str
            Position among the kept stages (``stages_``; negative counts from the
            end) or a stage name.

        Returns
        -------
        estimator : estimator
            The fitted stage.
        """
        check_is_fitted(self)
        if isinstance(key, str):
            fitted = dict(self.stages_)
            if key not in fitted:
                dropped = (
                    " (dropped by drop_unhelpful_stages)"
                    if key in getattr(self, "dropped_stages_", ())
                    else ""
                )
                raise KeyError(
                    f"no fitted stage named {key!r}{dropped}; the fitted stages "
                    f"are {list(fitted)}."
                )
            return fitted[key]
        if isinstance(key, Integral) and not isinstance(key, bool):
            n = len(self.stages_)
            if not -n <= key < n:
                raise IndexError(
                    f"stage index {key} is out of range: the booster has {n} "
                    f"fitted stages {[name for name, _ in self.stages_]}."
                )
            return self.stages_[key][1]
        raise TypeError(
            f"index a booster by a stage's position (int) or name (str); got "
            f"{type(key).__name__} {key!r}."
        )

    def _sk_visual_block_(self):
        # One box per stage, in series, each under its stage's name: the way
        # StackingRegressor shows its final_estimator (a one-estimator parallel
        # block carries the label; the name before ":" prefixes the parameters,
        # as set_params reaches them). A fitted booster shows its fitted stages
        # and labels the ones drop_unhelpful_stages dropped.
        fitted = dict(getattr(self, "stages_", ()))
        dropped = set(getattr(self, "dropped_stages_", ()))
        blocks = []
        try:
            for name, template in self.stages:
                est = fitted.get(name, template)
                label = f"{name}: dropped" if name in dropped else str(name)
                blocks.append(
                    visual_block(
                        "parallel",
                        [est],
                        names=[label],
                        name_details=[str(est)],
                        dash_wrapped=False,
                    )
                )
        except (TypeError, ValueError):  # not (name, estimator) pairs: one box
            return visual_block(
                "single", self, names=type(self).__name__, name_details=str(self)
            )
        return visual_block("serial", blocks, dash_wrapped=False)

    @property
    def fits_in_lockstep(self):
        """Whether a search fits this model's folds side by side.

        Where a stage is a network on a GPU and every stage that says whether
        it fits in lockstep says yes (see
        :attr:`skhybrid.neural.DenseRegressor.fits_in_lockstep`), the folds'
        fits run in threads of one process, their networks trained as one
        batched call; a physics fitted by least squares fits in each fold's
        thread as it would alone. Without a network on a GPU (a physics and a
        linear stage) the folds are spread over the search's workers.
        """
        try:
            estimators = [estimator for _, estimator in self.stages]
        except (TypeError, ValueError):  # not (name, estimator) pairs: fit says
            return False
        return parts_fit_in_lockstep(estimators)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.regressor_tags.poor_score = False
        try:
            stage_tags = [get_tags(est) for _, est in self.stages]
        except (TypeError, ValueError, AttributeError):
            return tags
        tags.target_tags.multi_output = all(
            t.target_tags.multi_output for t in stage_tags
        )
        tags.regressor_tags.poor_score = any(
            t.regressor_tags is not None and t.regressor_tags.poor_score
            for t in stage_tags
        )
        return tags

    # -- validation ----------------------------------------------------------------
    def _check_stages(self):
        if not self.stages:
            raise ValueError(
                f"stages must hold at least one (name, estimator) pair; got "
                f"stages={self.stages!r}."
            )
        try:
            names, estimators = zip(*self.stages, strict=True)
        except (TypeError, ValueError):
            raise TypeError(
                "stages must be a list of (name, estimator) pairs; got "
                f"stages={self.stages!r}."
            ) from None
        for name in names:
            if not isinstance(name, str):
                raise TypeError(f"stage names must be strings; got {name!r} in stages.")
            if name in _RESERVED_NAMES:
                raise ValueError(
                    f"stage name {name!r} is reserved (decompose returns "
                    f"{list(_RESERVED_NAMES)}); rename the stage."
                )
        self._validate_names(names)
        self._check_estimators_are_instances(estimators)
        for name, est in self.stages:
            if not (hasattr(est, "fit") and hasattr(est, "predict")):
                raise TypeError(
                    f"stage {name!r} must be an estimator with fit and predict; got "
                    f"{est!r}."
                )

    def _check_stage_n_steps(self, X, Y):
        """Every stage reads windows of the booster's ``n_steps``; else say the fix.

        The right value to change is the wrong one, so the message is led by the
        data: rows cut from sequences by :func:`~skhybrid.preprocessing.make_windows`
        continue each other (row ``i + 1`` is row ``i`` shifted one step) only
        under their true window length
        (:func:`~skhybrid.preprocessing.infer_n_steps`). Where the rows do not
        tell (shuffled), a booster left at its default ``n_steps=1`` under a
        stage set to another length is the likelier slip.
        """
        inferred = infer_n_steps(X, Y)
        windowed = [
            name for name, est in self.stages if "n_steps" in est.get_params(deep=False)
        ]
        for name, est in self.stages:
            stage_steps = est.get_params(deep=False).get("n_steps", self.n_steps)
            if stage_steps == self.n_steps:
                continue
            head = (
                f"stage {name!r} has n_steps={stage_steps} but the booster has "
                f"n_steps={self.n_steps}; every stage must read windows of the "
                f"same length."
            )
            fix_booster = (
                f"set n_steps={stage_steps} on the booster "
                f"(HybridBoostingRegressor(..., n_steps={stage_steps}))"
            )
            fix_stage = f"set {name}__n_steps={self.n_steps}"
            rows = f"The rows of X ({X.shape[1]} columns) continue each other as"
            if inferred == stage_steps:
                raise ValueError(
                    f"{head} {rows} windows of {stage_steps} steps, not "
                    f"{self.n_steps}: {fix_booster}."
                )
            if inferred == self.n_steps:
                raise ValueError(
                    f"{head} {rows} windows of {self.n_steps} steps, not "
                    f"{stage_steps}: {fix_stage}."
                )
            first, second = (
                (fix_booster, fix_stage)
                if self.n_steps == 1
                else (fix_stage, fix_booster)
            )
            raise ValueError(
                f"{head} Set n_steps to the window length of X's rows: {first}, or "
                f"{second}."
            )
        if inferred is not None and inferred != self.n_steps:
            # Every stage agrees with the booster, but the rows do not: a booster
            # and stages left at n_steps=1 on windows of 2 steps fit without
            # complaint and fail only at simulate.
            stages = "".join(f", {name}__n_steps={inferred}" for name in windowed)
            raise ValueError(
                f"the booster has n_steps={self.n_steps}, but the rows of X "
                f"({X.shape[1]} columns) continue each other as windows of "
                f"{inferred} steps: set n_steps={inferred} on the booster"
                + (f" and on its windowed stages ({stages[2:]})." if stages else ".")
            )

    def _split(self, n):
        if self.validation_fraction is None:
            if n < 1:
                raise ValueError(f"got n_samples={n}; need at least 1 sample.")
            return np.arange(n), np.arange(n)
        n_val = int(np.ceil(self.validation_fraction * n))
        n_train = n - n_val
        if n_train < 1:
            raise ValueError(
                f"validation_fraction={self.validation_fraction} leaves no training "
                f"rows with n_samples={n}; pass more rows or validation_fraction="
                "None."
            )
        return np.arange(n_train), np.arange(n_train, n)

    # -- stage inputs --------------------------------------------------------------
    def _windows(self, X):
        """Windows ending at each step of the row, oldest first (see class doc)."""
        if self.stage_input == "window" or self.n_steps == 1:
            return [X]
        steps = split_steps(X, self.n_steps)
        n = self.n_steps
        out = []
        for k in range(n):
            idx = np.concatenate([np.zeros(n - 1 - k, dtype=int), np.arange(k + 1)])
            out.append(steps[:, idx, :].reshape(X.shape[0], -1))
        return out

    def _augment(self, windows, preds, k):
        """Stage input built from window ``k`` and the earlier predictions."""
        W = windows[k]
        if self.stage_input == "window":
            return W
        n, s = self.n_steps, self.n_outputs_
        with_res = self.stage_input == "window+prediction+residuals" and n > 1
        steps = split_steps(W, n)
        rows, w = W.shape[0], steps.shape[2]
        width = w + s + (s if with_res else 0)
        out = np.zeros((rows, n, width))
        out[:, :, :w] = steps
        if with_res:
            # The measured state of each step, read through the window layout
            # (the first n_outputs columns of a step, checked in fit).
            states, _ = self._layout(W.shape[1]).split(W)
        pad = n - 1 - k
        for p in range(pad, n):
            m = p - pad  # source step of position p: the window ending there is W_m
            out[:, p, w : w + s] = preds[m]
            if with_res and p < n - 1:
                out[:, p, w + s :] = states[:, p + 1] - preds[m]
        return out.reshape(rows, n * width)

    def _layout(self, n_features):
        """The rows' :class:`~skhybrid.preprocessing.WindowLayout`: states = outputs.

        Only the residual inputs need it (they read each step's measured state);
        the other stage inputs accept any equal-width steps.
        """
        return WindowLayout.from_shapes(
            n_features, self.n_outputs_, n_steps=self.n_steps
        )

    def _stage_predict(self, est, Z):
        pred = np.asarray(est.predict(Z), dtype=np.float64)
        return pred.reshape(Z.shape[0], self.n_outputs_)

    def _run_stages(self, X):
        """Yield ``(name, stage_input, part)`` for every kept stage on raw rows."""
        windows = self._windows(X)
        preds = [np.zeros((X.shape[0], self.n_outputs_)) for _ in windows]
        for (name, est), augmented in zip(self.stages_, self._augmented_, strict=True):
            inputs = [
                self._augment(windows, preds, k) if augmented else windows[k]
                for k in range(len(windows))
            ]
            parts = [self._stage_predict(est, Z) for Z in inputs]
            yield name, inputs[-1], parts[-1]
            preds = [p + q for p, q in zip(preds, parts, strict=True)]

    # -- fit -----------------------------------------------------------------------
    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y):
        """Fit the stages one after the other, then the noise model.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps, in time order when a stage, the
            validation slice or the noise model needs it.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Next states.

        Returns
        -------
        self : HybridBoostingRegressor
            The fitted booster.
        """
        self._check_stages()
        X, y = validate_data(
            self, X, y, multi_output=True, y_numeric=True, dtype=np.float64
        )
        self._y_1d = y.ndim == 1
        Y = y[:, None] if self._y_1d else y
        self._check_stage_n_steps(X, Y)
        self.n_outputs_ = Y.shape[1]
        w = step_width(X.shape[1], self.n_steps)
        if self.stage_input == "window+prediction+residuals" and self.n_steps > 1:
            try:
                self._layout(X.shape[1])
            except ValueError as exc:
                raise ValueError(
                    f"stage_input={self.stage_input!r} reads the state of each step "
                    f"from its first {self.n_outputs_} columns (one per output), but "
                    f"a step of X has {w} columns (n_steps={self.n_steps}): {exc}"
                ) from None
        train, val = self._split(X.shape[0])
        rng = check_random_state(self.random_state)

        windows = self._windows(X)
        preds = [np.zeros_like(Y) for _ in windows]
        self.stages_, self._augmented_, self.dropped_stages_ = [], [], []
        scores = []
        self.baseline_score_ = previous = _rmse(Y[val])
        whiteness_rows, residual = [], Y
        interrupted = False
        for name, template in self.stages:
            est = clone(template)
            _seed_stage(est, rng, self.random_state is not None)
            augmented = bool(self.stages_) and self.stage_input != "window"
            inputs = [
                self._augment(windows, preds, k) if augmented else windows[k]
                for k in range(len(windows))
            ]
            target = Y - preds[-1]
            est.fit(
                inputs[-1][train], target[train][:, 0] if self._y_1d else target[train]
            )
            interrupted |= bool(getattr(est, "interrupted_", False))
            parts = [self._stage_predict(est, Z) for Z in inputs]
            new_pred = preds[-1] + parts[-1]
            score = _rmse(Y[val] - new_pred[val])
            scores.append(score)
            helpful = score < previous * (1.0 - _ROUNDING)
            if self.drop_unhelpful_stages and self.stages_ and not helpful:
                self.dropped_stages_.append(name)
                continue
            previous = score
            self.stages_.append((name, est))
            self._augmented_.append(augmented)
            preds = [p + q for p, q in zip(preds, parts, strict=True)]
            residual = Y - preds[-1]
            whiteness_rows.append(residual)
        self.stage_scores_ = np.asarray(scores)
        self.interrupted_ = interrupted
        self.residual_whiteness_ = _whiteness(
            [n for n, _ in self.stages_], whiteness_rows, self.ljung_box_lags
        )
        self.noise_model_ = make_noise_model(
            self.noise_model, max_lag=self.noise_max_lag
        )
        if self.noise_model_ is not None:
            self.noise_model_.fit(residual)
            if self.noise_model == "gaussian":
                _warn_if_not_white(self.residual_whiteness_)
        return self

    # -- predictions ---------------------------------------------------------------
    def _validate_X(self, X):
        check_is_fitted(self)
        return validate_data(self, X, reset=False, dtype=np.float64)

    def _shape(self, Y):
        return Y[:, 0] if self._y_1d else Y

    def staged_predict(self, X):
        """Prediction after each kept stage, as a generator.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps.

        Yields
        ------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Sum of the stages so far.
        """
        X = self._validate_X(X)
        total = np.zeros((X.shape[0], self.n_outputs_))
        for _, _, part in self._run_stages(X):
            total = total + part
            yield self._shape(total)

    def decompose(self, X):
        """The additive part of each stage, and their sum.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps.

        Returns
        -------
        parts : :class:`~sklearn.utils.Bunch`
            ``stage_names`` (list of the kept stages' names, in order), one key per
            stage name holding that stage's part (an array shaped like
            :meth:`predict`'s output) and ``total``, their sum, which is what
            :meth:`predict` returns.
        """
        X = self._validate_X(X)
        parts = Bunch(stage_names=[])
        total = np.zeros((X.shape[0], self.n_outputs_))
        for name, _, part in self._run_stages(X):
            parts.stage_names.append(name)
            parts[name] = self._shape(part)
            total = total + part
        parts["total"] = self._shape(total)
        return parts

    def predict(self, X, return_std=False):
        """Sum of the stages' predictions, optionally with the noise model's std.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps.
        return_std : bool, default=False
            Also return the standard deviation of the noise model (the stationary
            standard deviation for ``"ar"``), the same for every row. Needs a
            ``noise_model``.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Deterministic prediction (the noise model's mean is not added; it is
            close to 0 when a stage fits an offset).
        y_std : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Only with ``return_std=True``.
        """
        y_pred = self.decompose(X).total
        if not return_std:
            return y_pred
        noise = self._check_noise("predict(return_std=True)")
        std = np.broadcast_to(noise.std(), (y_pred.shape[0], self.n_outputs_))
        return y_pred, self._shape(np.array(std))

    def sample(self, X, random_state=None):
        """Draw outputs with noise: the prediction plus a draw of the noise model.

        For ``noise_model="ar"`` the noise is one realisation of each output's
        autoregressive process simulated along the rows in the order given (treat
        ``X`` as consecutive time steps); for ``"gaussian"`` the rows' noise is
        independent.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Windows of ``n_steps`` time steps.
        random_state : int, RandomState instance or None, default=None
            Seed of the draw; ``None`` uses the booster's ``random_state``.

        Returns
        -------
        y_sample : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Prediction plus noise.
        """
        noise = self._check_noise("sample")
        y_pred = self.decompose(X).total
        seed = self.random_state if random_state is None else random_state
        draw = noise.sample(y_pred.shape[0], random_state=seed)
        Y = (y_pred[:, None] if self._y_1d else y_pred) + draw
        return self._shape(Y)

    def _check_noise(self, what):
        check_is_fitted(self)
        if self.noise_model_ is None:
            raise ValueError(
                f"{what} needs a noise model but noise_model=None; set noise_model="
                "'gaussian' or 'ar' and refit."
            )
        return self.noise_model_

    def inverse_predict(self, y, stage=None):
        """Invert a cyclic stage: its decoder's reconstruction of the input window.

        Delegates to the ``inverse_predict`` of a stage that has one (a
        :class:`~skhybrid.neural.CyclicRegressor`). ``y`` is that stage's output:
        the target itself when the cyclic stage comes first, else its additive part
        (``decompose(X)[stage]``, the part of ``y`` the earlier stages left). The
        columns this booster appended to the stage's input (see the class
        docstring) are removed, so the result is laid out like ``X``.

        Parameters
        ----------
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Outputs of the cyclic stage.
        stage : str or None, default=None
            Name of the stage to invert; ``None`` takes the only stage with
            ``inverse_predict``.

        Returns
        -------
        X_rec : ndarray of shape (n_samples, n_features)
            Reconstructed rows.
        """
        check_is_fitted(self)
        invertible = [
            (i, name)
            for i, (name, est) in enumerate(self.stages_)
            if hasattr(est, "inverse_predict")
        ]
        if stage is not None:
            chosen = [(i, name) for i, name in invertible if name == stage]
            if not chosen:
                raise ValueError(
                    f"stage={stage!r} is not a fitted stage with inverse_predict; "
                    f"such stages: {[name for _, name in invertible]}."
                )
        elif len(invertible) != 1:
            raise ValueError(
                "inverse_predict needs exactly one stage with an inverse_predict "
                f"method (a CyclicRegressor), or stage=<name>; found "
                f"{[name for _, name in invertible]}."
            )
        else:
            chosen = invertible
        i, _ = chosen[0]
        X_rec = np.asarray(self.stages_[i][1].inverse_predict(y), dtype=np.float64)
        if self._augmented_[i]:
            w = self.n_features_in_ // self.n_steps
            X_rec = split_steps(X_rec, self.n_steps)[:, :, :w]
            X_rec = X_rec.reshape(X_rec.shape[0], -1)
        return X_rec

    # -- convenience ---------------------------------------------------------------
    def _domain_stage(self):
        from skhybrid.domain import DomainModel

        check_is_fitted(self)
        for _, est in self.stages_:
            if isinstance(est, DomainModel):
                return est
        raise AttributeError(
            "this booster has no fitted DomainModel stage; read the parameters of "
            "a stage from stages_ instead."
        )

    @property
    def domain_params_(self):
        """``params_`` of the first fitted domain-model stage."""
        return self._domain_stage().params_

    @property
    def domain_params_std_(self):
        """``params_std_`` of the first fitted domain-model stage."""
        return self._domain_stage().params_std_


def _rmse(r):
    return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")


def _seed_stage(est, rng, active):
    """Give every unset ``random_state`` of a stage its own seed from ``rng``."""
    seeds = {}
    for key, value in sorted(est.get_params(deep=True).items()):
        if key == "random_state" or key.endswith("__random_state"):
            seed = int(rng.randint(np.iinfo(np.int32).max))
            if active and value is None:
                seeds[key] = seed
    if seeds:
        est.set_params(**seeds)
