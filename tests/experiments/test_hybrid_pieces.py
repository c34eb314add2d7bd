"""A record too short for the state-space hybrid is said, in the run's terms."""

import warnings

import numpy as np

from skhybrid.domain import StateSpaceModel
from skhybrid.experiments.free_run._family import _records
from skhybrid.hybrid import StateSpaceHybridRegressor


def decay(x, u, *, xp, a):
    return a * x + u


def test_a_piece_too_short_to_train_on_is_named_by_its_record_and_samples():
    # Two records cut into pieces: the short record's one piece holds fewer
    # than n_init + horizon samples. The hybrid warns with the piece's index
    # and keeps it in unused_records_; the run maps it back to the record and
    # the samples it was cut from.
    rng = np.random.default_rng(0)
    U = [rng.uniform(-1, 1, (90, 1)), rng.uniform(-1, 1, (6, 1))]
    Y = [np.cumsum(u, axis=0) * 0.1 for u in U]
    origins = []
    pieces_U, pieces_Y = _records(U, Y, 3, origins)
    assert origins[-1] == (1, 0, 6)
    physics = StateSpaceModel(
        decay, {"a": 0.5}, state_names=["y"], observed=["y"], time="discrete"
    )
    model = StateSpaceHybridRegressor(
        physics, n_init=3, horizon=5, max_epochs=1, random_state=0
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.fit_simulation(pieces_U, pieces_Y)
    assert any("uses none of record 3 (6 samples" in str(w.message) for w in caught)
    assert [origins[k] for k in model.unused_records_] == [(1, 0, 6)]
