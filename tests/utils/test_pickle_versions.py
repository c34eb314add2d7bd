"""Pickles record the versions that made them and warn when loaded under others."""

import pickle
import warnings

import numpy as np
import pytest
import sklearn.exceptions

from skhybrid.exceptions import InconsistentVersionWarning, UnhelpfulCorrectionWarning
from skhybrid.hybrid import AutoRegressiveNoise, GaussianNoise
from skhybrid.utils import all_estimators
from skhybrid.utils._pickle import VersionedPickleMixin, package_versions
from skhybrid.utils._testing import fast_instances, with_states


def test_every_estimator_records_versions():
    for name, cls in all_estimators():
        assert issubclass(cls, VersionedPickleMixin), name


#: A fast instance's few epochs leave a state-space hybrid at its physics,
#: which it says; a pickle needs a fitted model, not a helpful correction.
UNHELPFUL = "ignore::skhybrid.exceptions.UnhelpfulCorrectionWarning"


@pytest.fixture(scope="module")
def fitted():
    """Every estimator, fitted once, and both noise models."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=UnhelpfulCorrectionWarning)
        return list(_fitted(np.random.default_rng(0)))


def _fitted(rng):
    X = rng.standard_normal((80, 4))
    y = np.column_stack([X[:, 0] + 0.1 * X[:, 3], np.sin(X[:, 1]), X[:, 2]])
    residuals = rng.standard_normal((200, 2))
    # Measured with noise: on exact data a linear model's zero coefficients are
    # fitted at rounding level, where the identifiability check cannot tell
    # their scale and warns.
    y = y + 0.01 * rng.standard_normal(y.shape)
    for estimator in fast_instances():
        name = type(estimator).__name__
        estimator = with_states(estimator, 3)
        if name == "WienerHammersteinModel":
            # FAST_PARAMS stop its refinement at max_nfev=5 on purpose (speed);
            # the fit says so, and a pickle needs a fitted model, not a converged
            # one.
            with pytest.warns(
                sklearn.exceptions.ConvergenceWarning, match="max_nfev=5"
            ):
                estimator.fit(X, y[:, 0])  # one output (its X: three inputs)
            yield name, estimator
            continue
        if name == "PhysicsCorrection":  # its physics has one output
            yield name, estimator.fit(X, y[:, 0])
            continue
        yield name, estimator.fit(X, y)
    yield "GaussianNoise", GaussianNoise().fit(residuals)
    yield "AutoRegressiveNoise", AutoRegressiveNoise(max_lag=2).fit(residuals)


def _edit(blob, package, fake):
    """The pickle with ``package``'s recorded version replaced by ``fake``."""
    real = package_versions()[package].encode()
    assert len(fake) == len(real)  # pickled strings are length-prefixed
    assert real in blob
    return blob.replace(real, fake.encode())


# scikit-learn warns too, for its own estimators inside ours (NARXSimulator's
# Ridge) whose pickled scikit-learn version the edit changes as well.
@pytest.mark.filterwarnings(
    "ignore:Trying to unpickle estimator:sklearn.exceptions.InconsistentVersionWarning"
)
@pytest.mark.parametrize("package", ["torch", "skhybrid", "scikit-learn", "skorch"])
def test_pickle_claiming_other_versions_warns_on_load(fitted, package):
    real = package_versions()[package]
    fake = "9" * len(real)
    for name, estimator in fitted:
        blob = pickle.dumps(estimator)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # same versions: not a word
            restored = pickle.loads(blob)
        assert type(restored) is type(estimator)
        with pytest.warns(InconsistentVersionWarning) as record:
            pickle.loads(_edit(blob, package, fake))
        messages = [str(w.message) for w in record]
        assert any(
            f"estimator {name} made with {package} {fake} (now {real})" in m
            for m in messages
        ), (name, messages)
        warning = next(w.message for w in record if name in str(w.message))
        assert warning.differences == {package: (fake, real)}


def test_warning_is_scikit_learns_kind():
    # A filter on scikit-learn's warning covers skhybrid's pickles too.
    assert issubclass(
        InconsistentVersionWarning, sklearn.exceptions.InconsistentVersionWarning
    )


def test_fitted_model_predicts_the_same_after_a_round_trip(fitted, rng):
    X = rng.standard_normal((80, 4))
    for name, estimator in fitted:
        if not hasattr(estimator, "predict"):
            continue
        restored = pickle.loads(pickle.dumps(estimator))
        np.testing.assert_array_equal(
            restored.predict(X), estimator.predict(X), err_msg=name
        )


class _Older(VersionedPickleMixin):
    def __init__(self, alpha=1.0):
        self.alpha = alpha


class _Newer(_Older):
    def __init__(self, alpha=1.0, beta="new"):
        super().__init__(alpha)
        self.beta = beta


def test_a_pickle_from_before_a_parameter_loads_it_at_its_default(monkeypatch):
    blob = pickle.dumps(_Older(alpha=2.0))
    # The class gains a parameter between pickling and loading.
    monkeypatch.setattr(_Older, "__init__", _Newer.__init__)
    restored = pickle.loads(blob)
    assert restored.alpha == 2.0
    assert restored.beta == "new"


@pytest.mark.filterwarnings(UNHELPFUL)
def test_a_state_space_hybrid_from_before_augmented_states_simulates_the_same():
    from skhybrid.hybrid import StateSpaceHybridRegressor

    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (3, 60, 1))
    y = np.cumsum(u, axis=1) * 0.1
    (estimator,) = (
        e for e in fast_instances() if isinstance(e, StateSpaceHybridRegressor)
    )
    model = estimator.set_params(n_augmented_states=0, n_init=3)
    model.fit_simulation(u, y)
    old = pickle.loads(pickle.dumps(model))
    for name in ("n_augmented_states", "physics_lr"):
        del old.__dict__[name]
    for name in ("n_augmented", "augmented_scale"):
        del old.module_.__dict__[name]
    restored = pickle.loads(pickle.dumps(old))
    assert restored.get_params()["n_augmented_states"] == 0
    np.testing.assert_array_equal(
        restored.simulate(u, y[:, :5]), model.simulate(u, y[:, :5])
    )
