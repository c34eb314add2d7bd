"""The paper's DC motor driving a load through a gear with backlash (section 6.3).

PWM excitation changing at 10 Hz trains and tests interpolation; at 100 Hz it
tests extrapolation. The physics is a first-order motor without the backlash.

Run it with ``skhybrid run dc-motor``.
"""

from functools import partial

import numpy as np

from skhybrid.datasets import make_dc_motor
from skhybrid.domain import ParametricModel, dc_motor_step
from skhybrid.experiments import System

__all__ = ["SYSTEM", "DCMotor"]


class DCMotor(System):
    name = "dc-motor"
    title = "DC motor driving a load through a gear with backlash"
    section = "6.3"

    def make_splits(self, settings):
        s = settings
        common = self._common(s)
        return {
            "train": make_dc_motor(
                s.n_train, excitation_hz=10.0, random_state=s.seed, **common
            ),
            "interpolation": make_dc_motor(
                s.n_test,
                excitation_hz=10.0,
                random_state=self.split_seed(s, 1000),
                **common,
            ),
            "extrapolation": make_dc_motor(
                s.n_test,
                excitation_hz=100.0,
                random_state=self.split_seed(s, 2000),
                **common,
            ),
        }

    def split_descriptions(self):
        return {
            "train": "PWM excitation changing at 10 Hz",
            "interpolation": "new runs, 10 Hz excitation",
            "extrapolation": "new runs, 100 Hz excitation",
        }

    def physics(self, settings):
        return {
            "physics": ParametricModel(
                partial(dc_motor_step, dt=0.001),
                {"gain": 1.0, "time_constant": 0.05},
                bounds={"gain": (0.0, np.inf), "time_constant": (1e-4, np.inf)},
                n_steps=settings.n_steps,
            )
        }


#: The system the pipeline runs.
SYSTEM = DCMotor()
NAME = SYSTEM.name
