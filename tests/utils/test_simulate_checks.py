"""The one owner of the ``simulate`` contract's argument checks."""

import numpy as np
import pytest

from skhybrid.utils._simulate_checks import (
    INITS,
    check_fitted_widths,
    check_simulate_options,
)


class _Model:
    n_features_in_ = 2
    n_outputs_ = 1


def test_options_of_the_contract():
    model = _Model()
    assert check_simulate_options(model, "measured", None, False) is False
    noise = object()
    assert check_simulate_options(model, "least_squares", 3, False, noise_model=noise)
    assert check_simulate_options(
        model, "measured", np.int64(2), True, noise_model=noise
    )
    with pytest.raises(ValueError, match=r"init must be one of .*got init='rest'"):
        check_simulate_options(model, "rest", None, False)
    with pytest.raises(ValueError, match=r"_Model supports init in \('measured',\)"):
        check_simulate_options(model, INITS[1], None, False, supported=INITS[:1])
    with pytest.raises(TypeError, match="n_samples must be an int or None; got True"):
        check_simulate_options(model, "measured", True, False, noise_model=noise)
    with pytest.raises(ValueError, match="n_samples must be >= 1; got n_samples=0"):
        check_simulate_options(model, "measured", 0, False, noise_model=noise)


def test_missing_noise_model_names_the_remedy():
    with pytest.raises(ValueError, match="_Model has none: call simulate without"):
        check_simulate_options(_Model(), "measured", 5, False)
    with pytest.raises(
        ValueError, match=r"return_std=True need a noise model; .*: fit one"
    ):
        check_simulate_options(_Model(), "measured", None, True, remedy="fit one")


def test_fitted_widths():
    check_fitted_widths(_Model(), 2, 1)
    check_fitted_widths(object(), 5, 5)  # nothing fitted to check against
    with pytest.raises(ValueError, match=r"inputs has 3 column\(s\); this _Model"):
        check_fitted_widths(_Model(), 3, 1)
    with pytest.raises(ValueError, match=r"initial has 2 column\(s\); .* 1 output"):
        check_fitted_widths(_Model(), 2, 2)
