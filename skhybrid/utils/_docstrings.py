"""Numpydoc entries shared by several docstrings, written once.

A docstring names a shared fragment on a line of its own, ``%(name)s``, indented
as the entries around it; :func:`fill_doc` writes the fragment there when the
function or class is defined, so that ``help()``, numpydoc and Sphinx read the
whole text. The fragments below are the ones several subpackages share; a
fragment one subpackage alone uses lives there.
"""

import inspect
import re
import textwrap

__all__ = [
    "INITIAL_WINDOW_INPUTS",
    "NO_NOISE_SIMULATE_OPTIONS",
    "RECORDS_FEATURES_IN",
    "RECORDS_OUTPUTS",
    "RECORDS_X",
    "RECORD_INPUTS",
    "RECORD_INPUTS_INITIAL",
    "RECORD_MODEL_DOCS",
    "SIMULATE_FROM_STATE_DOCS",
    "fill_doc",
    "fill_docstring",
]

_PLACEHOLDER = re.compile(r"^([ \t]*)%\((\w+)\)s[ \t]*$", flags=re.MULTILINE)

#: ``simulate``'s noise options in a model without a noise model.
NO_NOISE_SIMULATE_OPTIONS = """\
n_samples : None
    Must be None: the model has no noise model.
random_state : None
    Unused (no noise model).
return_std : bool, default=False
    Must be False: the model has no noise model."""

#: ``simulate``'s ``inputs`` in every container form the contract takes.
RECORD_INPUTS = """\
inputs : array-like of shape (n_times, n_inputs), (n_trajectories, \
n_times, n_inputs) or list of 2-D arrays
    Inputs over the whole record, initial window included."""

#: ``simulate``'s ``inputs`` and ``initial`` where one record is simulated.
RECORD_INPUTS_INITIAL = """\
inputs : array-like of shape (n_times, n_inputs)
    Inputs over the whole record, initial window included.
initial : array-like of shape (n_init, n_outputs)
    Measured outputs of the first samples."""

#: ``fit_simulation``'s measured ``outputs``, in every container form of records.
RECORDS_OUTPUTS = """\
outputs : array-like of shape (n_times, n_outputs), (n_records, n_times, \
n_outputs) or list of (n_times_i, n_outputs) arrays
    Measured outputs of each record, aligned with ``inputs``."""

#: The ``inputs`` from which an initial state is estimated.
INITIAL_WINDOW_INPUTS = """\
inputs : array-like of shape (n_times, n_inputs), (n_records, n_times, \
n_inputs) or list of 2-D arrays
    Inputs over (at least) the initialisation window of each record."""

#: The ``X`` of a whole-record model's ``fit``: one record or several.
RECORDS_X = """\
X : array-like of shape (n_times, n_inputs), or list of them
    The inputs of one record, or of each of several records."""


#: ``simulate_from_state``'s ``inputs``: the records the known states start.
_STATES_RECORDS_INPUTS = """\
inputs : array-like of shape (n_times, n_inputs), (n_records, n_times, \
n_inputs) or list of 2-D arrays
    Inputs of each record."""

#: What ``simulate_from_state`` returns.
_SIMULATED_FROM_STATES = """\
outputs : ndarray or list of ndarray
    Simulated outputs ``(n_times, n_outputs)`` of each record, in the
    container form of ``inputs``; row 0 is the output of ``states``."""

#: The fragments of ``simulate_from_state``, which the state-space physics and
#: the state-space hybrid both answer.
SIMULATE_FROM_STATE_DOCS = {
    "simulated_from_states": _SIMULATED_FROM_STATES,
    "states_records_inputs": _STATES_RECORDS_INPUTS,
}

#: The fitted attributes naming the inputs of a model fitted on records ``X``.
RECORDS_FEATURES_IN = """\
n_features_in_ : int
    Number of inputs (columns of ``X``).
feature_names_in_ : ndarray of shape (`n_features_in_`,)
    Names of the inputs, where ``X`` was a DataFrame with string column
    names."""

#: The fragments of a model fitted on whole records that simulates without a
#: noise model: ``fit``'s records, ``simulate``'s inputs and its options.
RECORD_MODEL_DOCS = {
    "no_noise_simulate_options": NO_NOISE_SIMULATE_OPTIONS,
    "record_inputs": RECORD_INPUTS,
    "records_x": RECORDS_X,
}


def fill_docstring(doc, **fragments):
    """Write each ``%(name)s`` line of ``doc`` out as its fragment.

    Parameters
    ----------
    doc : str or None
        A docstring; None (docstrings stripped by ``python -OO``) stays None.
    **fragments : str
        The text of each placeholder, unindented; each of its lines takes the
        placeholder's indentation.

    Returns
    -------
    doc : str or None
        The docstring with every placeholder written out.

    Raises
    ------
    KeyError
        If ``doc`` names a fragment not given.
    """
    if doc is None:
        return None

    def write(match):
        indent, name = match.groups()
        if name not in fragments:
            raise KeyError(
                f"the docstring names the fragment %({name})s, which is not among "
                f"those given: {sorted(fragments)}."
            )
        return textwrap.indent(fragments[name], indent)

    return _PLACEHOLDER.sub(write, doc)


def fill_doc(**fragments):
    """Decorator: the docstrings of a function, or of a class and its methods, filled.

    On a class, the class docstring and those of the functions it defines
    itself are filled, so that one line above the class serves all of them.

    Parameters
    ----------
    **fragments : str
        The fragments, as :func:`fill_docstring` takes them.

    Returns
    -------
    decorate : callable
        Fills the docstrings of its argument and returns it.

    Raises
    ------
    KeyError
        If a docstring names a fragment not given, or a fragment given is named
        in none of the docstrings (a docstring edited without its decorator).

    Examples
    --------
    >>> from skhybrid.utils._docstrings import fill_doc
    >>> @fill_doc(entry="x : int\\n    A number.")
    ... def f(x):
    ...     '''Return x.
    ...
    ...     Parameters
    ...     ----------
    ...     %(entry)s
    ...     '''
    ...     return x
    >>> print(f.__doc__.splitlines()[4])
        x : int
    """

    def decorate(obj):
        owners = [obj]
        if isinstance(obj, type):
            owners += [m for m in vars(obj).values() if inspect.isfunction(m)]
        named = set()
        for owner in owners:
            if owner.__doc__:
                named.update(m.group(2) for m in _PLACEHOLDER.finditer(owner.__doc__))
            owner.__doc__ = fill_docstring(owner.__doc__, **fragments)
        unused = sorted(set(fragments) - named)
        if unused:
            raise KeyError(
                f"{obj.__qualname__}: fragments {unused} are given but no docstring "
                "names them."
            )
        return obj

    return decorate
