"""A measured benchmark's facts: its module's constants, read into its spec."""

from types import SimpleNamespace

import numpy as np
import pytest

from skhybrid.benchmarks import MEASURED
from skhybrid.benchmarks._common import FACTS, measured_spec
from skhybrid.domain import StateSpaceModel


def first_order(x, u, *, xp, a, b):
    return a * x + b * u


def _arguments():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((200, 1))
    return dict(
        records=[(u, 0.5 * u)],
        physics=StateSpaceModel(
            first_order, {"a": 0.5, "b": 1.0}, state_names=["y"], time="discrete"
        ),
    )


@pytest.mark.parametrize("name", list(MEASURED))
def test_the_spec_reads_every_fact_from_the_module(name):
    module = MEASURED[name]
    files = SimpleNamespace(n_init=7, dt=0.25)
    spec = measured_spec(module, files, **_arguments())
    for constant, argument in FACTS.items():
        assert getattr(spec, argument) == getattr(module, constant), constant
    assert (spec.n_init, spec.dt) == (7, 0.25)
    # HYBRIDS, read by the runner before the files, decides the spec's family.
    assert spec.has_hybrids() is getattr(module, "HYBRIDS", True)


def test_a_fact_given_twice_is_refused():
    module = MEASURED["emps"]
    files = SimpleNamespace(n_init=7, dt=0.25)
    with pytest.raises(TypeError, match=r"\['title'\] of skhybrid.benchmarks.emps"):
        measured_spec(module, files, title="another", **_arguments())
