"""The friction forces a model's equations can call, in NumPy and torch."""

import numpy as np
import pytest
import torch
from numpy.testing import assert_allclose

from skhybrid.domain import (
    asymmetric_friction,
    coulomb_viscous_friction,
    stribeck_friction,
)

V = np.linspace(-2.0, 2.0, 401)


def test_asymmetric_friction_is_each_directions_law_and_reduces_to_the_symmetric():
    f = asymmetric_friction(V, xp=np, Fc_pos=20, Fc_neg=25, Fv_pos=150, Fv_neg=220)
    fast = np.abs(V) > 0.01
    pos, neg = fast & (V > 0), fast & (V < 0)
    assert_allclose(f[pos], 150 * V[pos] + 20)
    assert_allclose(f[neg], 220 * V[neg] - 25)
    same = asymmetric_friction(V, xp=np, Fc_pos=20, Fc_neg=20, Fv_pos=150, Fv_neg=150)
    assert_allclose(same, coulomb_viscous_friction(V, xp=np, Fc=20, Fv=150), atol=1e-9)


def test_stribeck_falls_from_static_to_coulomb_friction():
    f = stribeck_friction(V, xp=np, Fc=20, Fs=30, vs=0.1, Fv=0.0)
    # Just past the smoothing, the static level; well past vs, Coulomb's.
    assert stribeck_friction(np.array(1e-3), xp=np, Fc=20, Fs=30, vs=0.1, Fv=0.0) == (
        pytest.approx(30.0, rel=1e-3)
    )
    assert_allclose(f[np.abs(V) > 0.5], 20 * np.sign(V[np.abs(V) > 0.5]), rtol=1e-9)
    # Odd in the velocity, and equal to Coulomb + viscous when Fs == Fc.
    assert_allclose(f, -f[::-1], atol=1e-12)
    plain = stribeck_friction(V, xp=np, Fc=20, Fs=20, vs=0.1, Fv=3.0)
    assert_allclose(plain, coulomb_viscous_friction(V, xp=np, Fc=20, Fv=3.0))


@pytest.mark.parametrize(
    ("law", "params"),
    [
        (coulomb_viscous_friction, {"Fc": 20.0, "Fv": 5.0}),
        (
            asymmetric_friction,
            {"Fc_pos": 20.0, "Fc_neg": 25.0, "Fv_pos": 150.0, "Fv_neg": 220.0},
        ),
        (stribeck_friction, {"Fc": 20.0, "Fs": 30.0, "vs": 0.1, "Fv": 2.0}),
    ],
)
def test_numpy_and_torch_agree_and_torch_differentiates(law, params):
    v = torch.tensor(V, requires_grad=True)
    out = law(v, xp=torch, **params)
    assert_allclose(out.detach().numpy(), law(V, xp=np, **params), rtol=1e-12)
    out.sum().backward()
    assert torch.all(torch.isfinite(v.grad))
