"""The public ``simulate`` of every free-run model, its signature written once.

Every free-run model (the domain's whole-record models and state-space physics,
the next-state predictors of :class:`~skhybrid.simulation.SimulatorMixin`, the
hybrid's state-space and record models, the stacks and searches of
``model_selection``) answers ``simulate(inputs, initial, *, init, n_samples,
random_state, return_std)``. :class:`SimulateContract` owns that signature and
its defaults; each model writes what differs, its ``_simulate``. It lives below
``domain/`` so that every layer that simulates derives from the one owner; the
checks of the arguments are :mod:`skhybrid.utils._simulate_checks`'.
"""

import types

from sklearn.utils.metaestimators import available_if

__all__ = ["SimulateContract"]


class SimulateContract:
    """The ``simulate`` method of a free-run model: one signature for every model.

    A subclass implements ``_simulate(inputs, initial, init, n_samples,
    random_state, return_std)``: it receives the arguments of :meth:`simulate`
    as they were passed, checks them and simulates. Its docstring is that of the
    subclass's public ``simulate``: a class that defines ``_simulate`` gets its
    own :meth:`simulate` (the code and signature below) carrying that
    docstring, so that ``help()``, numpydoc and Sphinx read each model's own
    text. Where ``_simulate`` is wrapped in
    :func:`~sklearn.utils.metaestimators.available_if`, so is ``simulate``. A
    class that defines ``simulate`` itself keeps it.
    """

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        hook = vars(cls).get("_simulate")
        if hook is None or "simulate" in vars(cls):
            return
        contract = SimulateContract.simulate
        method = types.FunctionType(
            contract.__code__,
            contract.__globals__,
            contract.__name__,
            contract.__defaults__,
            contract.__closure__,
        )
        method.__kwdefaults__ = dict(contract.__kwdefaults__)
        method.__module__ = cls.__module__
        method.__qualname__ = f"{cls.__qualname__}.simulate"
        method.__doc__ = hook.__doc__
        check = getattr(hook, "check", None)  # an available_if descriptor's
        cls.simulate = method if check is None else available_if(check)(method)

    def simulate(
        self,
        inputs,
        initial,
        *,
        init="measured",
        n_samples=None,
        random_state=None,
        return_std=False,
    ):
        """Simulate in free run: the subclass's ``_simulate``, which documents it."""
        return self._simulate(
            inputs, initial, init, n_samples, random_state, return_std
        )
