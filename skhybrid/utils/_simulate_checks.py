"""The argument checks of the ``simulate`` contract, written once.

Every free-run model (:func:`skhybrid.simulation.simulate`, the domain's
whole-record models, the hybrid's state-space and record models) takes the
same options ``init``, ``n_samples`` and ``return_std``, and reads records of
the widths it was fitted on. The checks live here, below ``domain/``, so that
every layer that simulates calls the one owner.
"""

import numpy as np

__all__ = [
    "INITS",
    "check_fitted_widths",
    "check_initial_states",
    "check_simulate_options",
]

#: The initial-state options of the ``simulate`` contract.
INITS = ("measured", "least_squares")

#: What a model without a noise model tells its user to do instead.
NO_NOISE_REMEDY = "call simulate without them"


def check_simulate_options(
    estimator,
    init,
    n_samples,
    return_std,
    *,
    noise_model=None,
    supported=INITS,
    remedy=NO_NOISE_REMEDY,
):
    """Check ``simulate``'s options against what ``estimator`` supports.

    Parameters
    ----------
    estimator : object
        The model that simulates; its class name goes into the messages.
    init : str
        The initial-state option, one of :data:`INITS`.
    n_samples : int or None
        Number of sample paths, or None for the deterministic path.
    return_std : bool
        Whether the mean and standard deviation over sample paths are asked.
    noise_model : object or None, default=None
        The noise model the sample paths draw from; None where the model has
        none, which refuses ``n_samples`` and ``return_std``.
    supported : tuple of str, default=INITS
        The ``init`` options this model implements.
    remedy : str, default="call simulate without them"
        What the message tells the user to do where a noise model is missing.

    Returns
    -------
    stochastic : bool
        Whether sample paths are asked (``n_samples`` given or ``return_std``).

    Raises
    ------
    ValueError
        If ``init`` is not an option of the contract or of this model, if
        ``n_samples < 1``, or if sample paths are asked without a noise model.
    TypeError
        If ``n_samples`` is neither an int nor None.
    """
    name = type(estimator).__name__
    if not isinstance(init, str) or init not in INITS:
        raise ValueError(f"init must be one of {INITS}; got init={init!r}.")
    if init not in supported:
        raise ValueError(
            f"{name} supports init in {supported}; got init={init!r}. Its free "
            "run starts from the measured window as it is."
        )
    if n_samples is not None:
        if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)):
            raise TypeError(f"n_samples must be an int or None; got {n_samples!r}.")
        if n_samples < 1:
            raise ValueError(f"n_samples must be >= 1; got n_samples={n_samples}.")
    stochastic = n_samples is not None or bool(return_std)
    if stochastic and noise_model is None:
        raise ValueError(
            f"n_samples={n_samples!r} and return_std={return_std!r} need a noise "
            f"model; {name} has none: {remedy}."
        )
    return stochastic


def check_fitted_widths(estimator, n_inputs, n_outputs):
    """Raise a ValueError where a record's widths differ from the fitted ones.

    Parameters
    ----------
    estimator : estimator
        The fitted model, read for ``n_features_in_`` and ``n_outputs_``.
        Models pickled while their classes were private lack them: nothing is
        checked against what they lack.
    n_inputs : int
        The columns of the records' inputs.
    n_outputs : int
        The columns of the records' measured initial outputs.

    Raises
    ------
    ValueError
        If a width differs from the fitted one.
    """
    name = type(estimator).__name__
    expected = getattr(estimator, "n_features_in_", None)
    if expected is not None and n_inputs != expected:
        raise ValueError(
            f"inputs has {n_inputs} column(s); this {name} was fitted on "
            f"{expected} input(s)."
        )
    expected = getattr(estimator, "n_outputs_", None)
    if expected is not None and n_outputs != expected:
        raise ValueError(
            f"initial has {n_outputs} column(s); this {name} was fitted on "
            f"{expected} output(s)."
        )


def check_initial_states(states, n_records, n_states, state_names, *, whose=""):
    """The known initial states of ``simulate_from_state``, one row a record.

    Parameters
    ----------
    states : array-like of shape (n_states,) or (n_records, n_states)
        The state at the first sample of each record.
    n_records : int
        The number of records simulated.
    n_states : int
        The number of states the model starts from.
    state_names : sequence of str
        Their names, for the message.
    whose : str, default=""
        Whose states they are, for the message (``"the physics' "``).

    Returns
    -------
    states : ndarray of shape (n_records, n_states)
        The states as floats.

    Raises
    ------
    ValueError
        If ``states`` does not hold one state of ``n_states`` per record.
    """
    x0 = np.atleast_2d(np.asarray(states, dtype=float))
    if x0.shape != (n_records, n_states):
        raise ValueError(
            f"states must have shape ({n_records}, {n_states}) for {n_records} "
            f"record(s) of {whose}state_names={list(state_names)!r}; got shape "
            f"{x0.shape}."
        )
    return x0
