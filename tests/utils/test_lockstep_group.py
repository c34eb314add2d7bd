"""The lockstep group itself: batches gathered from threads, failures handed on."""

import threading

from skhybrid.utils._lockstep import current_member, run_in_lockstep


class _Request:
    """A request whose batched evaluation adds one to each value, or fails."""

    batches = []

    def __init__(self, value):
        self.value = value

    @classmethod
    def simulate_many(cls, requests):
        cls.batches.append(len(requests))
        if any(r.value < 0 for r in requests):
            raise RuntimeError("a batch that cannot be computed")
        return [r.value + 1 for r in requests]


def _ask(value):
    lockstep, i = current_member()
    return lockstep.evaluate(i, _Request(value))


def test_the_members_requests_are_computed_as_one_batch():
    _Request.batches = []
    outcomes = run_in_lockstep([1, 2, 3], _ask)
    assert outcomes == [2, 3, 4]
    assert _Request.batches == [3]


def test_a_batch_that_raises_reaches_every_member_instead_of_hanging():
    _Request.batches = []
    done = []

    def run():
        done.append(run_in_lockstep([1, -1, 3], _ask))

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=30)
    assert not thread.is_alive(), "the members waited for results that never came"
    (outcomes,) = done
    assert all(isinstance(o, RuntimeError) for o in outcomes)
    assert all("cannot be computed" in str(o) for o in outcomes)
