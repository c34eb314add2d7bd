"""The noise models' parameters are checked by their constraints when fitted."""

import numpy as np
import pytest

from skhybrid.hybrid import AutoRegressiveNoise

RESIDUALS = np.random.default_rng(0).standard_normal((200, 1))


@pytest.mark.parametrize("max_lag", [-1, 0, 2.5, "3"])
def test_autoregressive_noise_refuses_a_max_lag_below_one(max_lag):
    # max_lag=-1 was accepted (and quietly raised to 1).
    with pytest.raises(
        ValueError,
        match=r"The 'max_lag' parameter of AutoRegressiveNoise must be an int in "
        r"the range \[1, inf\)",
    ):
        AutoRegressiveNoise(max_lag=max_lag).fit(RESIDUALS)


def test_autoregressive_noise_refuses_an_unknown_information_criterion():
    with pytest.raises(ValueError, match="The 'ic' parameter of AutoRegressiveNoise"):
        AutoRegressiveNoise(ic="mdl").fit(RESIDUALS)


def test_autoregressive_noise_still_fits_with_valid_parameters():
    noise = AutoRegressiveNoise(max_lag=3, ic="aic").fit(RESIDUALS)
    assert noise.n_outputs_ == 1
