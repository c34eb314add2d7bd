"""The paper's double pendulum (section 6.2): a pendulum with an unmodelled small one.

Releases at 90 degrees train and test interpolation (the paper tests
interpolation only for this system), under process noise so that the true
model's one-step residual is white. The physics is a single pendulum. A spec of
the one-step protocol (:class:`~skhybrid.experiments.OneStepWindows`).

Run it with ``skhybrid run double-pendulum``.
"""

import numpy as np

from skhybrid.benchmarks._claims import claim
from skhybrid.datasets import make_double_pendulum
from skhybrid.diagnostics import ljung_box_test
from skhybrid.domain import ParametricModel, single_pendulum_step
from skhybrid.experiments import OneStepWindows, SystemSpec

__all__ = ["SPEC", "claims"]


def claims(result):
    """The claims of section 6.2, checked on a finished run.

    Parameters
    ----------
    result : ExperimentResult
        A run of the double pendulum.

    Returns
    -------
    claims : list of dict
        ``{"claim", "passed", "detail"}`` each.
    """
    # The paper's section 6.2 claim, on the states the dynamics carry: theta and
    # theta_dot (theta_ddot is a function of the full state, not a state).
    names = ["theta", "theta_dot"]
    cols = [result.target_names.index(n) for n in names]
    data = result.splits["interpolation"]
    residual = (
        data.y - result.predictions["interpolation"]["physics+rnn (ljung-box)"]
    )[:, cols]
    test = ljung_box_test(residual, result.sizes.lags, alpha=0.01)
    ratio = np.std(residual, axis=0) / np.asarray(data.noise)[cols]
    kind = getattr(data, "noise_type", "measurement")
    where = (
        ""
        if kind == "process"
        else " (measurement noise: the oracle's residual "
        "is not white either, so the claim cannot hold)"
    )
    return [
        claim(
            "The physics+RNN (Ljung-Box) residual on theta and theta_dot passes the "
            "whiteness test at 1 %",
            np.all(test.pvalue > 0.01),
            "p-values "
            + ", ".join(
                f"{n}: {p:.3g}" for n, p in zip(names, test.pvalue, strict=True)
            )
            + where,
        ),
        claim(
            "Its standard deviation is within 1.15x the injected noise",
            np.all(ratio <= 1.15),
            "std / noise "
            + ", ".join(f"{n}: {r:.3f}" for n, r in zip(names, ratio, strict=True)),
        ),
    ]


#: The system: its simulators, physics and claims.
SPEC = SystemSpec(
    "double-pendulum",
    title="Double pendulum with an unmodelled small pendulum",
    records=make_double_pendulum,
    tests={"interpolation": make_double_pendulum},
    physics=ParametricModel(
        single_pendulum_step,
        {"length": 1.0, "damping": 0.0},
        bounds={"length": (1e-3, np.inf)},
    ),
    n_init=4,
    protocol=OneStepWindows(
        # The whiteness claim of section 6.2 is testable only when the true
        # model's one-step residual is white, that is under process noise.
        noise_type="process",
        descriptions={
            "train": "releases at 90 degrees",
            "interpolation": "new releases at 90 degrees (the paper tests "
            "interpolation only for this system)",
        },
        section="6.2",
        claims=claims,
    ),
)
NAME = SPEC.name
