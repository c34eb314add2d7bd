"""Whether a spec's physics can be kept in a run folder."""

import pickle

__all__ = ["check_picklable"]


def check_picklable(spec):
    """Refuse, before any fit, a physics the run folder cannot store.

    The run folder stores fitted models with cloudpickle
    (:meth:`~skhybrid.experiments._store.RunFolder.save_model`): functions
    defined in ``__main__`` (a script, a notebook cell), lambdas and closures
    are stored by value and load in a new session. What cloudpickle cannot
    store either (an open file, a lock, a generator) is refused here.
    """
    import cloudpickle

    for name in ("physics", "physics_inputs"):
        try:
            cloudpickle.dumps(getattr(spec, name), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError, ValueError) as exc:
            raise TypeError(
                f"spec.{name} cannot be pickled ({type(exc).__name__}: {exc}), so "
                "its fitted models cannot be kept in the run folder: keep only "
                "numbers, arrays and functions in it (no open file, lock or "
                "generator)."
            ) from None
