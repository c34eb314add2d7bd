"""Every domain model warns when the data determine only a combination of parameters."""

import warnings

import numpy as np
import pytest

from skhybrid.domain import LinearStateSpaceModel, ParametricModel, PendulumModel
from skhybrid.exceptions import IdentifiabilityWarning


def _product(X, *, a, b, c, xp=np):
    return a * b * X[:, :1] + c


def _data(seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(200, 2))
    return X, 3.0 * X[:, 0] + 0.5 + 0.01 * rng.normal(size=200)


def test_parameters_identifiable_only_as_a_product_warn_naming_them():
    X, y = _data()
    with pytest.warns(IdentifiabilityWarning, match=r"only the combination a\*b"):
        model = ParametricModel(_product, {"a": 1.0, "b": 1.0, "c": 0.0}).fit(X, y)
    # The determined combination is still fitted.
    assert model.params_["a"] * model.params_["b"] == pytest.approx(3.0, rel=0.01)
    # Fixing one of them removes the warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        ParametricModel(_product, {"a": 1.0, "b": 1.0, "c": 0.0}, fixed=("b",)).fit(
            X, y
        )


@pytest.mark.parametrize(
    "model",
    [LinearStateSpaceModel(), PendulumModel(mass=2.0, length=1.5)],
    ids=["linear", "pendulum"],
)
def test_identifiable_models_do_not_warn(model):
    from skhybrid.datasets import make_pendulum

    if isinstance(model, PendulumModel):
        data = make_pendulum(n_samples=500, random_state=0)
        X, y = data.X, data.y
    else:
        X, y = _data()
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        model.fit(X, y)


def _line(X, *, a, b, xp=np):
    return a * X[:, :1] + b


@pytest.mark.parametrize("b_start", [0.0, 0.5])
def test_a_parameter_determined_at_zero_does_not_warn(b_start):
    # Exact data whose intercept is 0: b is fitted to about 1e-10 and is fully
    # determined; scaled by its own tiny value its column vanished, and it was
    # said to be undetermined.
    X = np.random.default_rng(0).normal(size=(200, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error", IdentifiabilityWarning)
        model = ParametricModel(_line, {"a": 1.0, "b": b_start}).fit(X, 2 * X[:, 0])
    assert abs(model.params_["b"]) < 1e-6


def test_a_parameter_that_changes_nothing_still_warns_at_zero():
    def unused(X, *, a, b, xp=np):
        return a * X[:, :1] + 0.0 * b

    X = np.random.default_rng(0).normal(size=(200, 1))
    with pytest.warns(IdentifiabilityWarning, match="'b' does not change the fit"):
        ParametricModel(unused, {"a": 1.0, "b": 0.0}).fit(X, 2 * X[:, 0])


def test_tall_jacobian_uses_the_thin_svd():
    # A fit on 200,000 residuals: the full U of the SVD would take 320 GB.
    from skhybrid.domain import check_identifiability

    J = np.random.default_rng(0).normal(size=(200_000, 3))
    assert check_identifiability(J, ["a", "b", "c"]) is None
    J[:, 2] = J[:, 0]
    assert "'a' and 'c'" in check_identifiability(J, ["a", "b", "c"])
