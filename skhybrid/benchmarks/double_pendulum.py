"""The paper's double pendulum (section 6.2): a pendulum with an unmodelled small one.

Releases at 90 degrees train and test interpolation (the paper tests
interpolation only for this system), under process noise so that the true
model's one-step residual is white. The physics is a single pendulum.

Run it with ``skhybrid run double-pendulum``.
"""

import numpy as np

from skhybrid.datasets import make_double_pendulum
from skhybrid.domain import ParametricModel, single_pendulum_step
from skhybrid.experiments import System

__all__ = ["SYSTEM", "DoublePendulum"]


class DoublePendulum(System):
    name = "double-pendulum"
    title = "Double pendulum with an unmodelled small pendulum"
    section = "6.2"
    # The whiteness claim of section 6.2 is testable only when the true model's
    # one-step residual is white, that is under process noise.
    default_noise_type = "process"

    def make_splits(self, settings):
        s = settings
        common = self._common(s)
        return {
            "train": make_double_pendulum(s.n_train, random_state=s.seed, **common),
            "interpolation": make_double_pendulum(
                s.n_test, random_state=self.split_seed(s, 1000), **common
            ),
        }

    def split_descriptions(self):
        return {
            "train": "releases at 90 degrees",
            "interpolation": "new releases at 90 degrees (the paper tests "
            "interpolation only for this system)",
        }

    def physics(self, settings):
        return {
            "physics": ParametricModel(
                single_pendulum_step,
                {"length": 1.0, "damping": 0.0},
                bounds={"length": (1e-3, np.inf)},
                n_steps=settings.n_steps,
            )
        }


#: The system the pipeline runs.
SYSTEM = DoublePendulum()
NAME = SYSTEM.name
