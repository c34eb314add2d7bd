"""Rows of a batched free run: parameter sets of one or several fits, simulated once.

A :class:`~skhybrid.domain.StateSpaceModel` fitted by simulation error
simulates its records at several parameter sets at once (a Jacobian's steps,
the starts' short fits, the folds of a search): each set's records become rows
of one free run, each row with its own parameter values. :class:`SetRows` holds
one fit's request; :func:`simulate_rows` runs any number of them, those of
models with the same equations in one simulation, records of other lengths
padded to the longest.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["SetRows", "simulate_rows"]

#: Most row-samples (rows times the longest record) of one merged free run.
MAX_RUN_SAMPLES = 2**21

#: The settings two models must share for their rows to run in one simulation.
SHARED_SETTINGS = (
    "rhs",
    "output",
    "state_names",
    "observed",
    "time",
    "dt",
    "method",
    "n_substeps",
    "input_points",
    "solver_options",
    "initial_state",
    "estimate_observed",
    "n_init",
    "n_steps",
)


def simulation_key(model):
    """What decides whether two models' rows can share a simulation."""
    return repr(
        (
            type(model),
            sorted(model.params),
            *((name, getattr(model, name)) for name in SHARED_SETTINGS),
        )
    )


@dataclass
class SetRows:
    """One fit's parameter sets as rows of a free run, and how to read the run.

    Attributes
    ----------
    run : callable
        ``run(U, Y, params, structure, per_row) -> (outputs, states)``: the
        free run of the model whose equations simulate the rows.
    key : str
        :func:`simulation_key` of the model, with its fixed values.
    structure : tuple
        The model's ``(n_states, observed, guess)``.
    U, Y : ndarray of shape (n_records, n_times, n_inputs) and (n_records, \
n_window, n_outputs)
        The records' inputs, and their measured outputs over (at least) the
        initial-state window, which is all the run reads of them.
    params : dict
        Each parameter's value: a float for every row, or an array of one per
        row.
    finish : callable
        ``finish(outputs) -> residuals`` of the simulated outputs ``(n_rows,
        n_times, n_outputs)``.
    copies : int, default=1
        The rows are the records ``copies`` times over (one copy per
        parameter set): they are laid out once, in the run's own array.
    """

    run: Any
    key: str
    structure: tuple
    U: np.ndarray
    Y: np.ndarray
    params: dict
    finish: Any
    copies: int = 1

    @property
    def n_rows(self):
        """Rows of the free run: the records, ``copies`` times."""
        return self.copies * len(self.U)

    @staticmethod
    def simulate_many(requests):
        """:func:`simulate_rows` of ``requests`` (what a lockstep group calls)."""
        return simulate_rows(requests)

    def simulate(self):
        """This request's residuals, simulated on its own."""
        per_row = {name for name, v in self.params.items() if np.ndim(v)}
        U, Y = (np.tile(a, (self.copies, 1, 1)) for a in (self.U, self.Y))
        out, _ = self.run(U, Y, self.params, self.structure, per_row)
        return self.finish(out)


def simulate_rows(requests):
    """The residuals of every request, those of one simulation key in one run.

    Parameters
    ----------
    requests : list of SetRows
        What each fit asks for.

    Returns
    -------
    residuals : list
        What each request's ``finish`` gives, in order, or the exception its
        simulation raised (rows of one key that fail together are simulated
        again each on its own).
    """
    results = [None] * len(requests)
    groups = {}
    for i, request in enumerate(requests):
        groups.setdefault(request.key, []).append(i)
    for members in groups.values():
        for chunk in _chunks(members, requests):
            group = [requests[i] for i in chunk]
            for i, result in zip(chunk, _simulate_group(group), strict=True):
                results[i] = result
    return results


def _chunks(members, requests):
    """The members of one key packed into runs of at most :data:`MAX_RUN_SAMPLES`.

    Beyond that many row-samples a free run costs in proportion to its rows,
    so merging saves nothing and only holds more memory at once.
    """
    chunks, current, rows, longest = [], [], 0, 0
    for i in members:
        n_rows, n_times = requests[i].n_rows, requests[i].U.shape[1]
        grown = (rows + n_rows) * max(longest, n_times)
        if current and grown > MAX_RUN_SAMPLES:
            chunks.append(current)
            current, rows, longest = [], 0, 0
        current.append(i)
        rows, longest = rows + n_rows, max(longest, n_times)
    if current:
        chunks.append(current)
    return chunks


def _simulate_group(group):
    """The results of requests of one key: one run, or each alone if it fails."""
    if len(group) == 1:
        return [_outcome(group[0].simulate)]
    try:
        out, _ = group[0].run(*_merged(group))
    except Exception:  # noqa: BLE001 - then each request on its own
        return [_outcome(request.simulate) for request in group]
    results, start = [], 0
    for request in group:
        n_rows, n_times = request.n_rows, request.U.shape[1]
        rows = out[start : start + n_rows, :n_times]
        results.append(_outcome(lambda r=request, rows=rows: r.finish(rows)))
        start += n_rows
    return results


def _outcome(compute):
    """What ``compute()`` returns, or the exception it raises."""
    try:
        return compute()
    except Exception as exc:  # noqa: BLE001 - raised in the fit that asked
        return exc


def _merged(group):
    """``(U, Y, params, structure, per_row)`` of a group's rows stacked."""

    def stacked(name):
        # Each request's records, ``copies`` times, zero-padded to the longest.
        arrays = [getattr(r, name) for r in group]
        n_times = max(a.shape[1] for a in arrays)
        n_rows = sum(r.n_rows for r in group)
        out = np.zeros((n_rows, n_times, arrays[0].shape[2]), arrays[0].dtype)
        start = 0
        for r, a in zip(group, arrays, strict=True):
            for _ in range(r.copies):
                out[start : start + len(a), : a.shape[1]] = a
                start += len(a)
        return out

    U, Y = stacked("U"), stacked("Y")
    params, per_row = {}, set()
    for name in group[0].params:
        values = [r.params[name] for r in group]
        if all(np.ndim(v) == 0 for v in values) and all(
            float(v) == float(values[0]) for v in values
        ):
            params[name] = values[0]
            continue
        params[name] = np.concatenate(
            [
                np.broadcast_to(v, (r.n_rows,))
                for v, r in zip(values, group, strict=True)
            ]
        )
        per_row.add(name)
    return U, Y, params, group[0].structure, per_row
