"""The paper's DC motor driving a load through a gear with backlash (section 6.3).

PWM excitation changing at 10 Hz trains and tests interpolation; at 100 Hz it
tests extrapolation. The physics is a first-order motor without the backlash. A
spec of the one-step protocol (:class:`~skhybrid.experiments.OneStepWindows`).

Run it with ``skhybrid run dc-motor``.
"""

from functools import partial

import numpy as np

from skhybrid.datasets import make_dc_motor
from skhybrid.domain import ParametricModel, dc_motor_step
from skhybrid.experiments import OneStepWindows, SystemSpec

__all__ = ["SPEC"]

#: The system: its simulators and physics (the paper states no claim here).
SPEC = SystemSpec(
    "dc-motor",
    title="DC motor driving a load through a gear with backlash",
    records=partial(make_dc_motor, excitation_hz=10.0),
    tests={
        "interpolation": partial(make_dc_motor, excitation_hz=10.0),
        "extrapolation": partial(make_dc_motor, excitation_hz=100.0),
    },
    physics=ParametricModel(
        partial(dc_motor_step, dt=0.001),
        {"gain": 1.0, "time_constant": 0.05},
        bounds={"gain": (0.0, np.inf), "time_constant": (1e-4, np.inf)},
    ),
    n_init=4,
    protocol=OneStepWindows(
        descriptions={
            "train": "PWM excitation changing at 10 Hz",
            "interpolation": "new runs, 10 Hz excitation",
            "extrapolation": "new runs, 100 Hz excitation",
        },
        section="6.3",
    ),
)
NAME = SPEC.name
