"""The torch module of the state-space hybrid: encoder, physics, correction."""

import torch
from torch import nn

from skhybrid.utils._array_api import get_namespace
from skhybrid.utils._compile import CompiledOrEager
from skhybrid.utils._lockstep import physics_signature

__all__ = ["ACTIVATIONS", "EncoderModule", "StateSpaceHybridModule", "mlp"]

#: The array namespace the physics runs in inside the module, resolved once
#: here: looking it up from the tensors at every step (as the physics' public
#: ``step`` does) breaks a :func:`torch.compile` graph at every sample.
_XP = get_namespace(torch.empty(0))


#: The hidden layers' activations a perceptron may have, by name.
ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU, "elu": nn.ELU, "silu": nn.SiLU}


def mlp(n_in, n_out, hidden, activation="tanh"):
    """A float64 perceptron.

    Parameters
    ----------
    n_in, n_out : int
        Input and output widths.
    hidden : sequence of int
        Hidden layer widths.
    activation : {"tanh", "relu", "elu", "silu"}, default="tanh"
        The hidden layers' activation.

    Returns
    -------
    module : torch.nn.Sequential
        Freshly initialised from torch's global random generator.
    """
    layers, width = [], n_in
    for size in hidden:
        layers += [nn.Linear(width, int(size)), ACTIVATIONS[activation]()]
        width = int(size)
    layers.append(nn.Linear(width, n_out))
    return nn.Sequential(*layers).double()


class StateSpaceHybridModule(nn.Module):
    """Encoder, physics and correction as one module, trained on simulated horizons.

    ``forward(Z)`` reads packed sub-sequences (see :meth:`pack`): the first
    ``n_init`` samples are the encoder's window, the model simulates the rest
    and returns the simulated outputs divided by ``y_scale``, ``(n, T,
    n_outputs)``, the targets being the measured outputs after the window
    divided by the same scale.

    Parameters
    ----------
    physics : skhybrid.domain.StateSpaceModel
        The physics at its starting parameters (its public
        :meth:`~skhybrid.domain.StateSpaceModel.step`,
        :meth:`~skhybrid.domain.StateSpaceModel.observe` and
        :meth:`~skhybrid.domain.DomainModel.unpack_params` run in torch).
    encoder, correction : torch.nn.Module
        The encoder (window features to standardised state) and the state
        correction (standardised states and inputs to a correction per state).
    parameters : BoundedParameters
        The free physical parameters.
    n_init : int
        Samples of the encoder's window.
    n_outputs, n_inputs : int
        Widths of the records.
    observed : list of int or None
        Indices of the measured states (None: an output function).
    corr_idx : list of int
        States the correction reads.
    continuous_correction : bool
        Whether the correction enters the continuous-time equations (``rhs``).
    encoder_absolute : bool
        Whether the encoder reads the window's absolute output level.
    has_prior : bool
        Whether a packed sample ends in the physics' state estimate, which the
        encoder corrects.
    scales : dict of ndarray
        ``state_mean``, ``state_scale``, ``step_scale``, ``y_mean``,
        ``y_scale``, ``y_rel_scale``, ``u_mean``, ``u_scale`` and
        ``correction_scale`` (the correction's unit per state, 0 where a state
        is not corrected), registered as buffers.
    dt : float or None
        The sample period (for the continuous correction's rate).
    n_augmented : int, default=0
        Latent states beside the physics' own, in standardised units: the
        encoder estimates them, the correction reads them and moves them by
        ``augmented_scale`` times its output per sample, and the physics never
        sees them. They follow the physics' states in the state vector.
    augmented_scale : float, default=0.1
        Change of an augmented state per sample per unit of the correction's
        output.
    """

    # Defaults for modules pickled before augmented states existed.
    n_augmented = 0
    augmented_scale = 0.1
    #: Whether the module is its physics alone: the state from the physics'
    #: least-squares estimate (the prior, given), no correction. Set where
    #: the trained correction did no better than the physics.
    physics_only = False

    def __init__(
        self,
        physics,
        encoder,
        correction,
        parameters,
        *,
        n_init,
        n_outputs,
        n_inputs,
        observed,
        corr_idx,
        continuous_correction,
        encoder_absolute,
        has_prior,
        scales,
        dt,
        n_augmented=0,
        augmented_scale=0.1,
    ):
        super().__init__()
        self.physics = physics
        self.encoder = encoder
        self.correction = correction
        self.params = parameters
        self.n_init = n_init
        self.n_outputs = n_outputs
        self.n_inputs = n_inputs
        self.observed = observed
        self.corr_idx = list(corr_idx)
        self.continuous_correction = continuous_correction
        self.encoder_absolute = encoder_absolute
        self.has_prior = has_prior
        self.dt = dt
        self.n_augmented = int(n_augmented)
        self.augmented_scale = float(augmented_scale)
        for name, value in scales.items():
            self.register_buffer(name, torch.as_tensor(value, dtype=torch.float64))

    def lockstep_signature(self):
        """What besides its tensors two modules must share to be run as one.

        The settings the forward pass reads, and the physics' equations and
        fixed parameter values (see :mod:`skhybrid.neural._lockstep`).
        """
        return repr(
            (
                *physics_signature(self.physics),
                self.physics_only,
                self.n_init,
                self.n_outputs,
                self.n_inputs,
                self.observed,
                self.corr_idx,
                self.continuous_correction,
                self.encoder_absolute,
                self.has_prior,
                self.dt,
                self.n_augmented,
                self.augmented_scale,
            )
        )

    # -- the model -----------------------------------------------------------------
    @property
    def n_physics_states(self):
        """Number of the physics' states (the augmented ones follow them)."""
        return self.state_mean.shape[0]

    def physical_params(self):
        """Every physical parameter by name, free ones differentiable.

        Returns
        -------
        params : dict
            Tensors of the free parameters, values of the fixed ones.
        """
        return self.physics.unpack_params(self.params())

    def _rollout_params(self):
        """:meth:`physical_params` without the physics' fitted check.

        The module's own physics is set up when the module is built, so the
        check (which breaks a :func:`torch.compile` graph) is left out of the
        forward pass.
        """
        return self.physics.unpack_params_in(self.params(), _XP)

    def encode(self, Yw, Uw, prior=None):
        """State at the last sample of windows ``Yw (n, k, p)``, ``Uw (n, k-1, m)``."""
        n = Yw.shape[0]
        if self.physics_only:
            # The physics' own start: its least-squares state, the augmented
            # states (which the physics never sees) at zero.
            return torch.cat([prior, prior.new_zeros((n, self.n_augmented))], dim=1)
        last = Yw[:, -1]
        parts = [((Yw[:, :-1] - last[:, None]) / self.y_rel_scale).reshape(n, -1)]
        if self.encoder_absolute:
            parts.append((last - self.y_mean) / self.y_scale)
        if self.n_inputs and Uw.shape[1]:
            us = (Uw - self.u_mean) / self.u_scale
            parts.append(us.reshape(n, -1))
        feats = torch.cat(parts, dim=1)
        if feats.shape[1] == 0:
            feats = torch.zeros((n, 1), dtype=Yw.dtype, device=Yw.device)
        z = self.encoder(feats)
        n_physics = self.n_physics_states
        z, augmented = z[:, :n_physics], z[:, n_physics:]
        base = self.state_mean.expand(n, -1) if prior is None else prior
        scale = self.state_scale
        if self.observed is not None:
            # The observed states start from their last measured values, also
            # over the physics' estimate, which is biased where the physics is
            # wrong; the encoder corrects them in units of a step's change.
            base = base.clone()
            base[:, self.observed] = last
            scale = scale.clone()
            scale[self.observed] = self.step_scale[self.observed]
        return torch.cat([base + scale * z, augmented], dim=1)

    def observe(self, x, params):
        """The outputs ``(n, n_outputs)`` of states ``x`` (augmented ones ignored)."""
        # The physics' output map without the checks and the namespace lookup
        # of its public ``observe`` (graph breaks in a compiled rollout).
        return self.physics.observe_in(
            x[:, : self.n_physics_states], params, _XP, self.observed
        )

    def correct(self, x, u):
        """The correction ``(n, n_states + n_augmented)`` at states ``x``.

        ``x`` holds the physics' states, then the augmented ones (if any).
        """
        idx = self.corr_idx
        feats = [(x[:, idx] - self.state_mean[idx]) / self.state_scale[idx]]
        if self.n_augmented:
            feats.append(x[:, self.n_physics_states :])
        if self.n_inputs:
            feats.append((u - self.u_mean) / self.u_scale)
        return self.correction(torch.cat(feats, dim=1))

    def _physics_step(self, x, u, params, correction=None):
        """The physics' :meth:`~skhybrid.domain.StateSpaceModel.step`, unchecked.

        Its checks and namespace lookup, which break a :func:`torch.compile`
        graph at every sample, are done once: the module's physics is set up
        and runs in torch.
        """
        return self.physics.step_in(x, u, params, _XP, correction)

    def advance(self, x, u, params):
        """The state one sample after ``x`` under ``u``, corrected."""
        n_physics = self.n_physics_states
        xp, augmented = x[:, :n_physics], x[:, n_physics:]
        if self.physics_only:
            x_next = self._physics_step(xp, u, params)
            return torch.cat([x_next, augmented], dim=1)
        if self.continuous_correction:
            # dx/dt = f(x, u) + c * S / dt * net(x, u), integrated with the
            # physics: one sample of the correction moves each state by about
            # c * S, as in the "step" form. The augmented states are held
            # over the sample inside the integration.
            rate = self.correction_scale / float(self.dt)

            def term(z, v):
                full = torch.cat([z, augmented], dim=1)
                return rate * self.correct(full, v)[:, :n_physics]

            x_next = self._physics_step(xp, u, params, correction=term)
            c = self.correct(x, u) if self.n_augmented else None
        else:
            c = self.correct(x, u)
            x_next = self._physics_step(xp, u, params)
            x_next = x_next + self.correction_scale * c[:, :n_physics]
        if not self.n_augmented:
            return x_next
        moved = augmented + self.augmented_scale * c[:, n_physics:]
        return torch.cat([x_next, moved], dim=1)

    def step(self, x, u, params):
        """One sample of :meth:`rollout`: the state after ``x`` and its outputs.

        Parameters
        ----------
        x : torch.Tensor of shape (n, n_states + n_augmented)
            The states.
        u : torch.Tensor of shape (n, n_inputs)
            The inputs acting from them.
        params : dict
            The physical parameters (:meth:`physical_params`).

        Returns
        -------
        x_next : torch.Tensor of shape (n, n_states + n_augmented)
            The corrected states one sample later (:meth:`advance`).
        y : torch.Tensor of shape (n, n_outputs)
            Their outputs (:meth:`observe`).
        """
        x = self.advance(x, u, params)
        return x, self.observe(x, params)

    def compile_step(self, compile_kwargs):
        """Run :meth:`rollout`'s :meth:`step` through :func:`torch.compile`, or not.

        One sample's step is a small graph: it compiles in seconds, where the
        whole rollout (every sample of the horizon unrolled) takes many
        minutes on the CPU, and it runs each sample's arithmetic (physics,
        integrator and correction, forward and backward) as a few fused
        kernels instead of dozens of small operations. The loop over the
        samples stays in Python. A compilation that fails (no C++ compiler,
        for example) warns once and the module steps eagerly.

        Parameters
        ----------
        compile_kwargs : dict or None
            :func:`torch.compile`'s keyword arguments (shapes static unless
            they say otherwise: a fit has a few batch sizes), or None to step
            eagerly again. The compiled step is never pickled or copied.
        """
        if compile_kwargs is None:
            self.__dict__.pop("_compiled_step", None)
        else:
            self.__dict__["_compiled_step"] = CompiledOrEager(
                self.step, {"dynamic": False, **compile_kwargs}, "the hybrid's step"
            )

    def __getstate__(self):
        # A copy: the module being pickled keeps its compiled step.
        state = dict(super().__getstate__())
        state.pop("_compiled_step", None)
        return state

    def rollout(self, Yw, Uw, U_future, prior=None, params=None):
        """Outputs ``(n, T, p)`` after the window under inputs ``U_future (n, T, m)``.

        ``U_future[:, 0]`` acts from the window's last sample.
        """
        params = self._rollout_params() if params is None else params
        step = self.__dict__.get("_compiled_step") or self.step
        x = self.encode(Yw, Uw, prior)
        outs = []
        for t in range(U_future.shape[1]):
            x, y = step(x, U_future[:, t], params)
            outs.append(y)
        return torch.stack(outs, dim=1)

    # -- training --------------------------------------------------------------
    def pack(self, Y, U, prior=None):
        """Pack sub-sequences into the rows :meth:`forward` reads.

        Parameters
        ----------
        Y : torch.Tensor of shape (n, L, n_outputs)
            Measured outputs: the window's ``n_init`` samples, then the targets.
        U : torch.Tensor of shape (n, L, n_inputs)
            Inputs aligned with ``Y``.
        prior : torch.Tensor of shape (n, n_states) or None
            The physics' state at the window's last sample (with ``has_prior``).

        Returns
        -------
        Z : torch.Tensor of shape (n, L * (n_outputs + n_inputs) [+ n_states])
        """
        parts = [Y.reshape(len(Y), -1), U.reshape(len(U), -1)]
        if self.has_prior:
            parts.append(prior)
        return torch.cat(parts, dim=1)

    def unpack(self, Z):
        """``(Y, U, prior)`` from packed rows (see :meth:`pack`)."""
        n_states = self.n_physics_states if self.has_prior else 0
        width = self.n_outputs + self.n_inputs
        L = (Z.shape[1] - n_states) // width
        Y = Z[:, : L * self.n_outputs].reshape(len(Z), L, self.n_outputs)
        U = Z[:, L * self.n_outputs : L * width].reshape(len(Z), L, self.n_inputs)
        prior = Z[:, L * width :] if self.has_prior else None
        return Y, U, prior

    def forward(self, Z):
        """Simulated outputs after each packed window, divided by ``y_scale``.

        Parameters
        ----------
        Z : torch.Tensor of shape (n, width)
            Packed sub-sequences (:meth:`pack`).

        Returns
        -------
        y : torch.Tensor of shape (n, L - n_init, n_outputs)
        """
        Y, U, prior = self.unpack(Z)
        k = self.n_init
        sim = self.rollout(Y[:, :k], U[:, : k - 1], U[:, k - 1 : -1], prior)
        return sim / self.y_scale


class EncoderModule(nn.Module):
    """The encoder alone on packed windows, for its pre-training.

    ``forward(Z)`` returns the standardised state estimate at the end of each
    packed window (the sub-sequences of :meth:`StateSpaceHybridModule.pack`).

    Parameters
    ----------
    hybrid : StateSpaceHybridModule
        Whose encoder is trained (shared, not copied).
    """

    def __init__(self, hybrid):
        super().__init__()
        self.hybrid = hybrid

    def lockstep_signature(self):
        """The hybrid's (see :meth:`StateSpaceHybridModule.lockstep_signature`)."""
        return self.hybrid.lockstep_signature()

    def forward(self, Z):
        h = self.hybrid
        Y, U, _ = h.unpack(Z)
        k = h.n_init
        state = h.encode(Y[:, :k], U[:, : k - 1])[:, : h.n_physics_states]
        return (state - h.state_mean) / h.state_scale
