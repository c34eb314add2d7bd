"""Whether a spec's physics can be kept in a run folder."""

import pickle

__all__ = ["check_picklable"]


def check_picklable(spec):
    """Refuse, before any fit, a physics the run folder cannot store."""
    for name in ("physics", "physics_inputs"):
        try:
            pickle.dumps(getattr(spec, name))
        except (pickle.PicklingError, AttributeError, TypeError) as exc:
            raise TypeError(
                f"spec.{name} cannot be pickled ({exc}), so its fitted models "
                "cannot be kept in the run folder: define its functions at module "
                "level in a file (not in a notebook cell, a lambda or a closure)."
            ) from None
