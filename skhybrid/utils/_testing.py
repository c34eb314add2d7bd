"""Fast instances of every public estimator for scikit-learn's common checks.

``FAST_PARAMS`` plays the role of scikit-learn's ``INIT_PARAMS``: small, quick
configurations (and required arguments) keyed by class name. An estimator with
required arguments and no entry here makes ``tests/test_common.py`` fail loudly.

``EXPECTED_FAILED_CHECKS`` lists, per class name, checks that fail by design, each
with its reason. Keep it empty unless an issue allows an entry.
"""

import numpy as np
from sklearn.linear_model import Ridge

# Stages of the hybrid compositions (imported here, used in FAST_PARAMS below).
from skhybrid.domain import LinearStateSpaceModel, StateSpaceModel
from skhybrid.hybrid import TransformedInputSimulator
from skhybrid.neural import DenseRegressor
from skhybrid.utils.discovery import all_estimators

__all__ = [
    "EXPECTED_FAILED_CHECKS",
    "FAST_PARAMS",
    "expected_failed_checks",
    "fast_instances",
    "with_states",
]


class _AffineSum:
    """``a * sum(X, axis=1) + b`` as one shared column: a generic test function.

    A class with a fixed ``repr`` (a plain function's repr holds its memory address)
    so that test ids are the same in every pytest-xdist worker.
    """

    __name__ = "affine_sum"

    def __call__(self, X, *, a, b, xp=np):
        return a * xp.sum(X, axis=1, keepdims=True) + b

    def __repr__(self):
        return "affine_sum"


affine_sum = _AffineSum()


class _AffineStep:
    """``x(t+1) = a x + b sum(u)``: a one-state discrete map for any input width.

    With a fixed ``repr`` for the same reason as :class:`_AffineSum`.
    """

    __name__ = "affine_step"

    def __call__(self, x, u, *, xp, a, b):
        return a * x + b * xp.sum(u, axis=1, keepdims=True)

    def __repr__(self):
        return "affine_step"


affine_step = _AffineStep()


class _SumColumns:
    """``u.sum(axis=1, keepdims=True)``: any number of input columns as one.

    With a fixed ``repr`` for the same reason as :class:`_AffineSum`.
    """

    __name__ = "sum_columns"

    def __call__(self, inputs):
        return np.sum(np.asarray(inputs, dtype=float), axis=1, keepdims=True)

    def __repr__(self):
        return "sum_columns"


def _fitted_affine_physics():
    """A fitted one-state ``affine_step`` physics fed the sum of any inputs.

    A fitted model reads the number of input columns it was fitted on; the
    common checks fit on data of many widths, which the sum makes one. The
    record is the physics' own free run, so the fit stops at once.
    """
    u = np.sin(0.3 * np.arange(40.0))[:, None]
    x = np.zeros((40, 1))
    for t in range(39):
        x[t + 1] = 0.5 * x[t] + 0.1 * u[t]
    physics = StateSpaceModel(
        rhs=affine_step,
        params={"a": 0.5, "b": 0.1},
        state_names=["x"],
        observed=["x"],
        time="discrete",
    ).fit_simulation(u, x)
    return TransformedInputSimulator(physics, _SumColumns())


FAST_PARAMS = {
    # Hybrid compositions: a linear physics model, then a tiny dense network.
    "HybridBoostingRegressor": dict(
        stages=[
            ("physics", LinearStateSpaceModel()),
            (
                "dense",
                DenseRegressor(
                    hidden_layer_sizes=(8,),
                    max_epochs=8,
                    batch_size=32,
                    lr=0.03,
                    random_state=0,
                ),
            ),
        ]
    ),
    "HybridEnsembleRegressor": dict(
        domain=LinearStateSpaceModel(),
        neural=DenseRegressor(hidden_layer_sizes=(8,)),
        max_epochs=20,
        random_state=0,
    ),
    "StateSpaceHybridRegressor": dict(
        physics=StateSpaceModel(
            rhs=affine_step,
            params={"a": 0.5, "b": 0.1},
            state_names=["x"],
            observed=["x"],
            time="discrete",
        ),
        hidden_layer_sizes=(8,),
        encoder_hidden_layer_sizes=(8,),
        # One augmented state: the checks run its encoder and correction too.
        n_augmented_states=1,
        max_epochs=5,
        encoder_epochs=5,
        lr=0.01,
        random_state=0,
    ),
    # The static corrections: a linear one-step regressor; PhysicsCorrection's
    # physics is fitted already (kept as it is by clone).
    "NARXSimulator": dict(regressor=Ridge()),
    "PhysicsCorrection": dict(physics=_fitted_affine_physics(), regressor=Ridge()),
    # Frozen: the same fitted physics, fed the sum of any inputs.
    "TransformedInputSimulator": dict(
        estimator=_fitted_affine_physics().estimator, input_transform=_SumColumns()
    ),
    "ParametricModel": dict(func=affine_sum, params={"a": 0.5, "b": 0.0}),
    "WienerHammersteinModel": dict(order=2, n_knots=4, n_starts=1, max_nfev=5),
    "StateSpaceModel": dict(
        rhs=affine_step,
        params={"a": 0.5, "b": 0.1},
        state_names=["x"],
        observed=["x"],
        time="discrete",
    ),
    # Neural stages: tiny networks, few epochs. lr=0.03 and batch_size=32 give
    # check_regressors_train R^2 of about 0.75-0.83 (> 0.5 needed) in 8 epochs.
    "CyclicRegressor": dict(
        hidden_layer_sizes=(16,), max_epochs=8, batch_size=32, lr=0.03
    ),
    "DenseRegressor": dict(
        hidden_layer_sizes=(16,), max_epochs=8, batch_size=32, lr=0.03
    ),
    "RNNRegressor": dict(
        hidden_size=8, num_layers=1, max_epochs=8, batch_size=32, lr=0.03
    ),
}

_PENDULUM_LAYOUT = (
    "PendulumModel's equations need 4 columns per time step [cos, sin, theta_dot, "
    "torque] and 3 outputs; this check feeds random data of other shapes, which the "
    "model rejects with a ValueError by design. tests/domain/test_pendulum.py runs "
    "the same API contract on pendulum-shaped data."
)

EXPECTED_FAILED_CHECKS = {
    "PendulumModel": {
        "check_dict_unchanged": _PENDULUM_LAYOUT,
        "check_dont_overwrite_parameters": _PENDULUM_LAYOUT,
        "check_dtype_object": _PENDULUM_LAYOUT,
        "check_estimators_dtypes": _PENDULUM_LAYOUT,
        "check_estimators_fit_returns_self": _PENDULUM_LAYOUT,
        "check_estimators_nan_inf": _PENDULUM_LAYOUT,
        "check_estimators_overwrite_params": _PENDULUM_LAYOUT,
        "check_estimators_pickle": _PENDULUM_LAYOUT,
        "check_estimators_pickle(readonly_memmap=True)": _PENDULUM_LAYOUT,
        "check_f_contiguous_array_estimator": _PENDULUM_LAYOUT,
        "check_fit2d_1feature": _PENDULUM_LAYOUT,
        "check_fit2d_1sample": _PENDULUM_LAYOUT,
        "check_fit2d_predict1d": _PENDULUM_LAYOUT,
        "check_fit_check_is_fitted": _PENDULUM_LAYOUT,
        "check_fit_idempotent": _PENDULUM_LAYOUT,
        "check_fit_score_takes_y": _PENDULUM_LAYOUT,
        "check_methods_sample_order_invariance": _PENDULUM_LAYOUT,
        "check_methods_subset_invariance": _PENDULUM_LAYOUT,
        "check_n_features_in": _PENDULUM_LAYOUT,
        "check_n_features_in_after_fitting": _PENDULUM_LAYOUT,
        "check_pipeline_consistency": _PENDULUM_LAYOUT,
        "check_positive_only_tag_during_fit": _PENDULUM_LAYOUT,
        "check_readonly_memmap_input": _PENDULUM_LAYOUT,
        "check_regressor_data_not_an_array": _PENDULUM_LAYOUT,
        "check_regressor_multioutput": _PENDULUM_LAYOUT,
        "check_regressors_int": _PENDULUM_LAYOUT,
        "check_regressors_no_decision_function": _PENDULUM_LAYOUT,
        "check_regressors_train": _PENDULUM_LAYOUT,
        "check_regressors_train(readonly_memmap=True)": _PENDULUM_LAYOUT,
        "check_regressors_train(readonly_memmap=True,X_dtype=float32)": (
            _PENDULUM_LAYOUT
        ),
        "check_supervised_y_2d": _PENDULUM_LAYOUT,
    },
}


def fast_instances():
    """Yield one fast instance of every public estimator of skhybrid."""
    for name, cls in all_estimators():
        yield cls(**FAST_PARAMS.get(name, {}))


def with_states(estimator, n_states):
    """A clone of ``estimator`` whose state-space physics has ``n_states`` states.

    State-space models declare their states (``state_names``, ``observed``); the
    fast instances declare one. Tests that fit every estimator on data with more
    states give those models as many, all observed. Other estimators are cloned
    unchanged. The clone matters: nested parameters are shared between the fast
    instances.
    """
    from sklearn.base import clone

    estimator = clone(estimator)
    names = [f"x{i}" for i in range(n_states)]
    for prefix in ("", "physics__"):
        if f"{prefix}state_names" in estimator.get_params():
            estimator.set_params(
                **{f"{prefix}state_names": names, f"{prefix}observed": names}
            )
    return estimator


def expected_failed_checks(estimator):
    """Checks that ``estimator`` fails by design, with the reason (a dict)."""
    return EXPECTED_FAILED_CHECKS.get(type(estimator).__name__, {})
