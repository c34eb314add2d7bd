"""Free-run models of records that add no feedback loop to a physics' free run.

- :class:`NARXSimulator`: a one-step regressor on windows of past outputs and
  inputs, rolled forward by :func:`skhybrid.simulation.simulate` (the measured
  candidate family's "linear ARX" and "dense NARX");
- :class:`PhysicsCorrection`: a fitted physics simulated in free run plus a
  static regressor of its own recent simulated output and inputs, which predicts
  the physics' output error (the correction reads no measured output, so it
  cannot destabilise the simulation; the family's "physics + linear / dense /
  dense ensemble");
- :class:`TransformedInputSimulator`: a fitted model fed a transform of the
  record's inputs (the Silverbox's ``[u(t), u(t + 1)]``).

The first two fit whole records, ``fit(X, y)`` with ``X`` a record's
inputs and ``y`` its measured outputs (or lists of records), as
:class:`~skhybrid.domain.WienerHammersteinModel` does, and follow the library's
``simulate(inputs, initial, *, init="measured", n_samples=None,
random_state=None, return_std=False)`` contract. None of these has a noise
model, so sample paths and bands raise a ``ValueError``.

``_NARXSimulator``, ``_PhysicsCorrection`` and ``_TransformedInputs`` are the
names the classes had while private: aliases, so that run folders pickled under
them still load.
"""

from skhybrid.hybrid._narx import NARXSimulator

# _windows was defined here before the split; it is re-exported where it was.
from skhybrid.hybrid._physics_correction import (  # noqa: F401 (re-exported)
    PhysicsCorrection,
    _windows,
)
from skhybrid.hybrid._transformed_inputs import TransformedInputSimulator

__all__ = ["NARXSimulator", "PhysicsCorrection", "TransformedInputSimulator"]


#: The names of the classes while they were private: run folders pickled under
#: them still load, and code that imports them keeps working.
_NARXSimulator = NARXSimulator
_PhysicsCorrection = PhysicsCorrection
_TransformedInputs = TransformedInputSimulator
