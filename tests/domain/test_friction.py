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


@pytest.mark.parametrize("eps", [0.0, -1e-4, np.nan, np.array([1e-4, 0.0])])
@pytest.mark.parametrize(
    "law",
    [
        lambda v, eps: coulomb_viscous_friction(v, xp=np, Fc=1, Fv=1, eps=eps),
        lambda v, eps: asymmetric_friction(
            v, xp=np, Fc_pos=1, Fc_neg=1, Fv_pos=1, Fv_neg=1, eps=eps
        ),
        lambda v, eps: stribeck_friction(v, xp=np, Fc=1, Fs=2, vs=0.1, Fv=1, eps=eps),
    ],
    ids=["coulomb_viscous", "asymmetric", "stribeck"],
)
def test_friction_laws_refuse_an_eps_that_is_not_positive(law, eps):
    # eps=0 gave NaN at rest; a negative eps flipped the friction's sign.
    with pytest.raises(ValueError, match=r"eps of \w+ must be a finite number > 0"):
        law(V, eps)


@pytest.mark.parametrize("vs", [0.0, -0.1, torch.tensor(0.0)])
def test_stribeck_friction_refuses_a_stribeck_velocity_that_is_not_positive(vs):
    # vs=0 gave NaN at rest.
    with pytest.raises(ValueError, match="vs of stribeck_friction must be"):
        stribeck_friction(V, xp=np, Fc=1, Fs=2, vs=vs, Fv=1)


def test_friction_laws_accept_positive_tensor_parameters_with_gradients():
    eps = torch.tensor(1e-3, requires_grad=True)
    force = coulomb_viscous_friction(torch.tensor(V), xp=torch, Fc=1.0, Fv=1.0, eps=eps)
    force.sum().backward()
    assert torch.isfinite(eps.grad)
