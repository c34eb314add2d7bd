"""Networks of several fits trained side by side, their steps computed as one.

Fits run in lockstep (:func:`skhybrid.utils._lockstep.run_in_lockstep`: the
folds of one candidate of a search, in threads of one process) train each
their own skorch net: their own data pieces, initial weights, optimiser state,
early stopping and learning-rate schedule. Only the arithmetic is shared: each
net's forward pass is a request, and once every fit still running has asked,
the requests whose modules have the same structure are computed in one call,
``torch.func.vmap`` over the members' stacked weights (a member's gradients
flow back to its own weights); the backward passes that follow are then run
as one. A member's results are those it gets alone, up to floating point.

Batch normalisation takes part: the members' running statistics are passed
stacked, updated in place by the batched call (``torch.func`` allows an
in-place write to a tensor batched like the input), and each member's slice is
copied back into its own module. A layer that normalises by its batch's
statistics must see the member's own rows only, so such members are computed
together only with members whose batch has as many rows (never padded).

The gain is the hardware's: a rollout of a small network is thousands of tiny
operations, launch-bound on a GPU, so that several members cost about one
there; on a CPU the operations are larger and the gain smaller.
"""

from itertools import chain

import torch
from torch.func import functional_call, vmap

from skhybrid.utils._lockstep import current_member

__all__ = ["Backward", "Forward", "lockstep_backward", "lockstep_infer"]


#: Signatures whose batched call raised once: their members run alone.
_UNBATCHABLE = set()


def _batch_norms(module):
    """``module``'s batch-normalisation layers, by name."""
    return {
        name: m
        for name, m in module.named_modules()
        if isinstance(m, torch.nn.modules.batchnorm._BatchNorm)
    }


def _signature(module, x, grad):
    """What must agree for two members' forward passes to run as one call.

    A module opts in with ``lockstep_signature()``, which returns what else
    (besides its class, layers and tensors' shapes) must agree between two
    members: the attributes its forward pass reads that are not tensors. A
    module without it, or whose signature is None (a wrapper around a module
    without one), runs alone: its signature is None.
    """
    opted_in = getattr(module, "lockstep_signature", None)
    own = None if opted_in is None else opted_in()
    if own is None:
        return None
    tensors = chain(module.named_parameters(), module.named_buffers())
    # A batch-norm layer in training mode normalises by its batch's statistics
    # (and updates its running statistics from them): a member's batch is
    # then never padded, and only batches of one length are computed as one.
    batch_statistics = tuple(m.training for m in _batch_norms(module).values())
    return (
        type(module),
        repr(module),
        tuple((n, tuple(t.shape), t.dtype, str(t.device)) for n, t in tensors),
        tuple(x.shape[1:]),
        len(x) if any(batch_statistics) else None,
        x.dtype,
        str(x.device),
        bool(grad),
        module.training,
        batch_statistics,
        own,
    )


class Forward:
    """One member's forward pass: ``module(x)``, with or without gradients.

    Parameters
    ----------
    module : torch.nn.Module
        The member's module.
    x : torch.Tensor
        Its batch (rows first).
    grad : bool
        Whether the pass records gradients (training) or not (validation).
    """

    def __init__(self, module, x, grad):
        self.module, self.x, self.grad = module, x, grad

    @classmethod
    def simulate_many(cls, requests):
        """Each request's output, those of one structure computed in one call.

        Parameters
        ----------
        requests : list of Forward

        Returns
        -------
        outputs : list of torch.Tensor or Exception
            One per request, in order.
        """
        groups = {}
        for i, request in enumerate(requests):
            key = _signature(request.module, request.x, request.grad)
            if key is None or key in _UNBATCHABLE:
                key = ("alone", i)
            groups.setdefault(key, []).append(i)
        outputs = [None] * len(requests)
        for key, members in groups.items():
            chosen = [requests[i] for i in members]
            for i, out in zip(members, _forward_group(key, chosen), strict=True):
                outputs[i] = out
        return outputs


def _alone(request):
    try:
        with torch.set_grad_enabled(request.grad):
            return request.module(request.x)
    except Exception as exc:  # noqa: BLE001 - handed to the member that asked
        return exc


def _forward_group(key, requests):
    """The outputs of requests of one structure: one batched call, or each alone.

    Each member's rows are padded (its first rows repeated) to the longest
    batch's; the padding's outputs are dropped (members whose batch-norm
    layers use their batch's statistics all have as many rows, see
    :func:`_signature`). Running statistics updated by the call are copied
    back into each member's module. Where the batched call raises (an
    operation ``vmap`` cannot batch), each runs alone.
    """
    if len(requests) == 1:
        return [_alone(requests[0])]
    base = requests[0].module
    names = [n for n, _ in base.named_parameters()]
    buffers = [n for n, _ in base.named_buffers()]
    rows = max(len(r.x) for r in requests)
    xs = [r.x if len(r.x) == rows else _pad(r.x, rows) for r in requests]
    try:
        with torch.set_grad_enabled(requests[0].grad):
            params = {
                n: torch.stack([dict(r.module.named_parameters())[n] for r in requests])
                for n in names
            }
            bufs = {
                n: torch.stack([dict(r.module.named_buffers())[n] for r in requests])
                for n in buffers
            }

            def one(p, b, x):
                return functional_call(base, (p, b), (x,))

            out = vmap(one)(params, bufs, torch.stack(xs))
    except Exception:  # noqa: BLE001 - not batchable: each member alone
        _UNBATCHABLE.add(key)
        return [_alone(r) for r in requests]
    _keep_running_statistics(requests, bufs)
    return [_member_output(out, i, len(r.x)) for i, r in enumerate(requests)]


def _running_statistics(module):
    """Names of the buffers ``module``'s forward pass updates in training mode."""
    return [
        f"{name}.{b}" if name else b
        for name, layer in _batch_norms(module).items()
        if layer.training
        for b, _ in layer.named_buffers(recurse=False)
    ]


def _keep_running_statistics(requests, bufs):
    """Copy each member's slice of the updated stacked buffers into its module."""
    updated = _running_statistics(requests[0].module)
    if not updated:
        return
    with torch.no_grad():
        for i, request in enumerate(requests):
            own = dict(request.module.named_buffers())
            for name in updated:
                own[name].copy_(bufs[name][i])


def _member_output(out, i, rows):
    """Member ``i``'s first ``rows`` rows of a batched output (or of each part)."""
    if isinstance(out, tuple):
        return tuple(_member_output(part, i, rows) for part in out)
    return out[i, :rows]


def _pad(x, rows):
    """``x`` with its first rows repeated up to ``rows`` rows."""
    index = torch.arange(rows, device=x.device) % len(x)
    return x[index]


class Backward:
    """One member's backward pass from its loss.

    Parameters
    ----------
    loss : torch.Tensor
        The member's scalar loss, from the output of a :class:`Forward`.
    """

    def __init__(self, loss):
        self.loss = loss

    @classmethod
    def simulate_many(cls, requests):
        """Run the requests' backward passes as one.

        The members' losses depend on their own weights only (their outputs
        are separate slices of a batched call), so one backward pass of all
        of them gives each member its own gradients.

        Parameters
        ----------
        requests : list of Backward

        Returns
        -------
        results : list of None or Exception
            None where the gradients were computed.
        """
        try:
            torch.autograd.backward([r.loss for r in requests])
        except Exception as exc:  # noqa: BLE001 - handed to every member
            return [exc] * len(requests)
        return [None] * len(requests)


def lockstep_infer(module, x):
    """``module(x)``, computed with the other members' passes where in lockstep.

    Parameters
    ----------
    module : torch.nn.Module
        The member's module.
    x : torch.Tensor
        Its batch.

    Returns
    -------
    y : torch.Tensor
    """
    member = current_member()
    if member is None:
        return module(x)
    lockstep, i = member
    return lockstep.evaluate(i, Forward(module, x, torch.is_grad_enabled()))


def lockstep_backward(loss):
    """``loss.backward()``, run with the other members' where in lockstep.

    Parameters
    ----------
    loss : torch.Tensor
        The member's scalar loss.
    """
    member = current_member()
    if member is None:
        loss.backward()
        return
    lockstep, i = member
    lockstep.evaluate(i, Backward(loss))
