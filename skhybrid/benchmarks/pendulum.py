"""The paper's inverted pendulum (section 6.1; gymnasium's Pendulum-v1).

Simulated episodes with torques drawn in [-1, 1] N m train and test
interpolation; torques in [-2, 2] N m test extrapolation. The physics is the
paper's deliberately wrong pendulum (mass 5, length 10), frozen as the hybrids'
first stage and refitted in the ensemble.

Run it with ``skhybrid run pendulum`` (``--quick`` for a one-minute run).
"""

from skhybrid.datasets import make_pendulum
from skhybrid.domain import PendulumModel
from skhybrid.experiments import System

__all__ = ["SYSTEM", "Pendulum"]


class Pendulum(System):
    name = "pendulum"
    title = "Inverted pendulum (gymnasium Pendulum-v1)"
    section = "6.1"
    hybrid_physics = "physics (frozen)"
    ensemble_physics = "physics (refit)"

    def make_splits(self, settings):
        s = settings
        common = self._common(s)
        return {
            "train": make_pendulum(
                s.n_train, (-1.0, 1.0), random_state=s.seed, **common
            ),
            "interpolation": make_pendulum(
                s.n_test, (-1.0, 1.0), random_state=self.split_seed(s, 1000), **common
            ),
            "extrapolation": make_pendulum(
                s.n_test, (-2.0, 2.0), random_state=self.split_seed(s, 2000), **common
            ),
        }

    def split_descriptions(self):
        return {
            "train": "torques drawn in [-1, 1] N m",
            "interpolation": "new episodes, torques in [-1, 1] N m",
            "extrapolation": "new episodes, torques in [-2, 2] N m",
        }

    def physics(self, settings):
        n_steps = settings.n_steps
        return {
            # The paper's deliberately wrong physics: mass 5 and length 10, frozen.
            "physics (frozen)": PendulumModel(
                mass=5.0, length=10.0, fixed=("mass", "length"), n_steps=n_steps
            ),
            "physics (refit)": PendulumModel(mass=5.0, length=10.0, n_steps=n_steps),
        }


#: The system the pipeline runs.
SYSTEM = Pendulum()
NAME = SYSTEM.name
