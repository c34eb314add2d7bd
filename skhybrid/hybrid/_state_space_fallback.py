"""A state-space hybrid never ends worse than its physics on its validation pieces.

After the joint training, the kept weights (the best epoch, the start
included) are scored on the monitored sub-sequences (the validation pieces, or
the training sub-sequences without them) beside the physics itself at its
starting parameters, simulated from its own least-squares state over the same
windows. Where the physics scores as well or better, the hybrid becomes its
physics exactly (:attr:`StateSpaceHybridModule.physics_only`); where no
trained epoch beat the physics, the correction did not help and the hybrid
says so (:class:`~skhybrid.exceptions.UnhelpfulCorrectionWarning` and
``correction_helped_ = False``).
"""

import math
import warnings

import numpy as np
import torch

from skhybrid.exceptions import UnhelpfulCorrectionWarning

__all__ = ["keep_physics_if_better"]


def _monitored_loss(net, module, Y, U, prior, k):
    """The criterion of ``net`` on sub-sequences ``Y``, ``U``, run by ``module``."""
    Yt, Ut = torch.as_tensor(Y), torch.as_tensor(U)
    with torch.no_grad():
        sim = module.rollout(
            Yt[:, :k],
            Ut[:, : k - 1],
            Ut[:, k - 1 : -1],
            None if prior is None else torch.as_tensor(prior),
        )
        loss = net.criterion_(sim / module.y_scale, Yt[:, k:] / module.y_scale)
    return float(loss)


def keep_physics_if_better(est, net, start, monitored):
    """Replace a trained hybrid by its physics where the physics does as well.

    Parameters
    ----------
    est : StateSpaceHybridRegressor
        Being fitted: ``module_``, ``best_epoch_``, ``n_epochs_`` and
        ``physics_`` set.
    net : skorch.NeuralNetRegressor
        Its trained net (for the criterion).
    start : dict
        The module's state dict at the start of the joint training (a zero
        correction, the physical parameters' starting values).
    monitored : tuple of ndarray
        ``(Y, U)`` of the sub-sequences early stopping watched: ``n_init``
        samples of window, then the simulated part.

    Returns
    -------
    physics_only : bool
        Whether the hybrid was replaced by its physics.
    """
    module, k = est.module_, est._k
    Y, U = monitored
    prior = est._window_prior(Y[:, :k], U[:, :k])
    kept_prior = prior if module.has_prior else None
    kept = _monitored_loss(net, module, Y, U, kept_prior, k)
    trained = {name: value.clone() for name, value in module.state_dict().items()}
    module.load_state_dict(start)
    module.physics_only = True
    physics = _monitored_loss(net, module, Y, U, prior, k)
    est.physics_validation_loss_ = physics
    physics_only = not (math.isfinite(kept) and kept < physics)
    if not physics_only:
        module.physics_only = False
        module.load_state_dict(trained)
    est.validation_loss_ = physics if physics_only else kept
    est.correction_helped_ = bool(
        not physics_only and est.best_epoch_ > 0 and np.isfinite(kept)
    )
    if not est.correction_helped_:
        where = (
            "validation pieces" if est.validation_scores_ else "training sub-sequences"
        )
        ends = (
            "it is its physics (at the starting parameters)"
            if physics_only
            else "it keeps its start (the physics with a zero correction)"
        )
        latent = (
            ""
            if est.n_augmented_states
            else "; where the physics may lack a state (an unmodelled mode, a "
            "flexible coupling), latent states on a long horizon "
            "(n_augmented_states=2, horizon=100)"
        )
        warnings.warn(
            f"the correction of {type(est).__name__} did not improve on its physics "
            f"on its {where} (loss {kept:.4g} at the best of {est.n_epochs_} "
            f"epochs, epoch {est.best_epoch_}, against the physics' {physics:.4g}): "
            f"{ends}, and correction_helped_ is False. The physics may already "
            "explain the records to their noise; otherwise try another horizon, "
            f"a lower lr or more records{latent}.",
            UnhelpfulCorrectionWarning,
            stacklevel=4,
        )
    return physics_only
