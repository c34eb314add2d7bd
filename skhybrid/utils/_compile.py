"""``torch.compile`` with an eager fallback, for the networks' training paths."""

import warnings

import torch

__all__ = ["CompiledOrEager"]


def _compile_errors():
    """What a failed compilation raises (inductor without a C++ compiler, say)."""
    import torch._dynamo
    import torch._inductor

    return tuple(
        error
        for error in (
            getattr(torch._dynamo.exc, "BackendCompilerFailed", None),
            getattr(getattr(torch._inductor, "exc", None), "InductorError", None),
        )
        if error is not None
    )


class CompiledOrEager:
    """A callable through :func:`torch.compile`, eager where that fails.

    torch compiles at the first call (and at each new shape): a compilation
    that fails there warns once, and every call from then on runs ``eager``.

    Parameters
    ----------
    eager : callable
        The function or module, run as it is.
    compile_kwargs : dict
        :func:`torch.compile`'s keyword arguments.
    what : str
        What is compiled, for the warning (``"the hybrid's step"``).
    """

    def __init__(self, eager, compile_kwargs, what):
        self.eager = eager
        self.compiled = torch.compile(eager, **compile_kwargs)
        self.what = what

    def __call__(self, *args):
        if self.compiled is not None:
            try:
                return self.compiled(*args)
            except Exception as exc:
                if not isinstance(exc, _compile_errors()):
                    raise
                warnings.warn(
                    f"torch.compile could not compile {self.what} "
                    f"({type(exc).__name__}); it runs eagerly.",
                    UserWarning,
                    stacklevel=2,
                )
                self.compiled = None
        return self.eager(*args)
