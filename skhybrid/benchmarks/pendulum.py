"""The paper's inverted pendulum (section 6.1; gymnasium's Pendulum-v1).

Simulated episodes with torques drawn in [-1, 1] N m train and test
interpolation; torques in [-2, 2] N m test extrapolation. The physics is the
paper's deliberately wrong pendulum (mass 5, length 10), frozen as the hybrids'
first stage and refitted in the ensemble. A spec of the one-step protocol
(:class:`~skhybrid.experiments.OneStepWindows`).

Run it with ``skhybrid run pendulum`` (``--quick`` for a one-minute run).
"""

from functools import partial

import numpy as np

from skhybrid.benchmarks._claims import (
    NEURAL_HYBRIDS,
    claim,
    median_window_db,
    rmse,
)
from skhybrid.datasets import make_pendulum
from skhybrid.domain import PendulumModel
from skhybrid.experiments import OneStepWindows, SystemSpec

__all__ = ["SPEC", "claims"]


def claims(result):
    """The claims of section 6.1, checked on a finished run.

    Parameters
    ----------
    result : ExperimentResult
        A run of the pendulum.

    Returns
    -------
    claims : list of dict
        ``{"claim", "passed", "detail"}`` each.
    """
    claims = []
    out = "theta_dot"
    if "extrapolation" in result.predictions:
        med = {
            m: median_window_db(result, "extrapolation", m, out)
            for m in (*NEURAL_HYBRIDS, "dense", "rnn")
            if m in result.predictions["extrapolation"]
        }
        best = min(NEURAL_HYBRIDS, key=lambda m: med.get(m, np.inf))
        passed = med[best] < min(med["dense"], med["rnn"])
        claims.append(
            claim(
                "Extrapolation: the best physics+neural hybrid has a lower median "
                "theta_dot RMSE than the dense network and the RNN alone",
                passed,
                f"{best}: {med[best]:.1f} dB; dense: {med['dense']:.1f} dB; "
                f"rnn: {med['rnn']:.1f} dB (median over windows)",
            )
        )
    ratio = rmse(result, "interpolation", "physics+rnn (mse)", out) / rmse(
        result, "interpolation", "oracle", out
    )
    claims.append(
        claim(
            "Interpolation: the physics+RNN hybrid's theta_dot RMSE is within 1.2x "
            "the oracle's",
            ratio <= 1.2,
            f"RMSE ratio physics+rnn (mse) / oracle = {ratio:.3f}",
        )
    )
    return claims


#: The system: its simulators, physics and claims.
SPEC = SystemSpec(
    "pendulum",
    title="Inverted pendulum (gymnasium Pendulum-v1)",
    records=partial(make_pendulum, torque_range=(-1.0, 1.0)),
    tests={
        "interpolation": partial(make_pendulum, torque_range=(-1.0, 1.0)),
        "extrapolation": partial(make_pendulum, torque_range=(-2.0, 2.0)),
    },
    physics={
        # The paper's deliberately wrong physics: mass 5 and length 10, frozen.
        "physics (frozen)": PendulumModel(
            mass=5.0, length=10.0, fixed=("mass", "length")
        ),
        "physics (refit)": PendulumModel(mass=5.0, length=10.0),
    },
    n_init=4,
    protocol=OneStepWindows(
        hybrid_physics="physics (frozen)",
        ensemble_physics="physics (refit)",
        descriptions={
            "train": "torques drawn in [-1, 1] N m",
            "interpolation": "new episodes, torques in [-1, 1] N m",
            "extrapolation": "new episodes, torques in [-2, 2] N m",
        },
        section="6.1",
        claims=claims,
    ),
)
NAME = SPEC.name
