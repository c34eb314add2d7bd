"""scikit-learn's common estimator checks over every public estimator of skhybrid.

Estimators are discovered from the package (``skhybrid.utils.all_estimators``), so a
new estimator cannot skip these checks; fast configurations live in
``skhybrid.utils._testing.FAST_PARAMS``.
"""

import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

from skhybrid.utils import all_estimators
from skhybrid.utils._testing import expected_failed_checks, fast_instances


def test_estimators_are_discovered():
    names = {name for name, _ in all_estimators()}
    assert {"LinearStateSpaceModel", "ParametricModel", "PendulumModel"} <= names
    assert "DomainModel" not in names  # abstract base


# scikit-learn's checks fit on a few rows of random data (as few as 8 residuals
# for 17 parameters, constant or duplicated columns): skhybrid's fits rightly say
# that the data do not determine their parameters. Those warnings are about the
# checks' data, not the estimators' contract, so they are ignored here, by
# category, as scikit-learn's own common tests ignore its ConvergenceWarning.
@pytest.mark.filterwarnings("ignore::skhybrid.exceptions.IdentifiabilityWarning")
# A state-space hybrid trained five epochs on the checks' random rows does not
# beat its physics, and says so; about the checks' data, not the contract.
@pytest.mark.filterwarnings("ignore::skhybrid.exceptions.UnhelpfulCorrectionWarning")
# FAST_PARAMS stop WienerHammersteinModel's refinement at max_nfev=5 (speed).
@pytest.mark.filterwarnings(
    "ignore:WienerHammersteinModel's refinement stopped at max_nfev"
    ":sklearn.exceptions.ConvergenceWarning"
)
@parametrize_with_checks(
    list(fast_instances()), expected_failed_checks=expected_failed_checks
)
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)


@pytest.mark.parametrize("name, cls", all_estimators())
def test_estimator_docstring_has_examples(name, cls):
    doc = cls.__doc__ or ""
    for section in ("Parameters", "Attributes", "Examples"):
        assert section in doc, f"{name}'s docstring lacks a {section} section"
