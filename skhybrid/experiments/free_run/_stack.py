"""The family's stack: a weighted average of its models' free runs, chosen like them.

The last model of the measured family is a
:class:`~skhybrid.model_selection.StackedSimulation` of the other models: their
free runs averaged with non-negative weights that sum to one. The weights are
fitted on the models' out-of-fold free runs (what each model's search kept of
its chosen candidate on every fold), and the stack's own CV score is
cross-fitted: fold ``k`` is scored with weights fitted on the other folds only,
so the stack competes with the models on equal terms and is chosen only where
averaging lowers the cross-validated RMSE. Nothing is fitted again: the stack
of a seed averages that seed's refitted models with the weights fitted on every
fold.
"""

import numpy as np

from skhybrid.model_selection import (
    RecordBlockSplit,
    StackedSimulation,
    _cross_fitted_weights,
    take_pieces,
)

__all__ = ["STACK", "averaged_run", "choose_stack"]

#: The stack's name in the family.
STACK = "stacked"


def _targets(ctx, n_splits):
    """Each fold's held-out measured outputs after their first ``n_init``, joined.

    The samples, in the order, that a model's out-of-fold free runs hold.
    """
    U, Y = list(ctx.U), list(ctx.Y)
    targets = []
    for _, test in RecordBlockSplit(n_splits, n_init=ctx.n_init).split(U, Y):
        _, Y_test = take_pieces(U, Y, test)
        targets.append(
            np.concatenate(
                [
                    np.asarray(y, dtype=float).reshape(len(y), -1)[ctx.n_init :].ravel()
                    for y in Y_test
                ]
            )
        )
    return targets


def _runs(dep, targets):
    """A model's out-of-fold runs where it has a usable one on every fold, or None."""
    if dep is None or dep.get("model") is None:
        return None
    runs = dep.get("runs")
    if runs is None or len(runs) != len(targets):
        return None
    runs = [np.asarray(run, dtype=float).ravel() for run in runs]
    usable = all(
        run.shape == target.shape and np.all(np.isfinite(run))
        for run, target in zip(runs, targets, strict=True)
    )
    return runs if usable else None


def _stack(deps, weights):
    """The stack of the models with a positive weight, fitted models as they are."""
    kept = {name: w for name, w in weights.items() if w > 0}
    total = sum(kept.values())
    return StackedSimulation._from_fitted(
        [(name, deps[name]["model"]) for name in kept],
        [w / total for w in kept.values()],
    )


def _deterministic(deps, weights):
    """Whether every model with a positive weight is deterministic."""
    return all(
        (deps[name]["fit"].get("selection") or {}).get("deterministic", False)
        for name, w in weights.items()
        if w > 0
    )


def choose_stack(model, ctx, deps, *, n_splits):
    """The family's stack: its weights and cross-fitted CV score, and the stack.

    At the run's first seed the weights are fitted on the required models'
    out-of-fold free runs; at a later seed (``ctx.searched``) the first seed's
    weights average this seed's refitted models.

    Parameters
    ----------
    model : ZooModel
        The stack's entry in the family: ``requires`` names the models averaged.
    ctx : MeasuredContext
        The system, the estimation records and the settings.
    deps : dict of str to dict
        For each required model: ``model`` (fitted at this seed), ``fit`` (its
        fit record) and ``runs`` (its out-of-fold free runs).
    n_splits : int
        The folds the models' searches cut (fewer where the records are short,
        as :class:`~skhybrid.model_selection.RecordBlockSplit` decides).

    Returns
    -------
    fitted : StackedSimulation or None
        The stack of this seed's models (None where fewer than two models have
        out-of-fold runs on every fold).
    selection : dict
        The weights on every fold and by fold, the CV RMSE (official units),
        the folds; ``failed`` says why where there is no stack.
    runs : list of ndarray or None
        The stack's out-of-fold free runs: on each fold, the models' runs
        averaged with the weights fitted on the other folds.
    """
    if ctx.searched is not None:
        selection = {
            **ctx.searched["selection"],
            "searched_at_seed": int(ctx.searched["seed"]),
        }
        weights = selection.get("weights")
        if not weights:
            return None, selection, None
        missing = [
            name
            for name, w in weights.items()
            if w > 0 and deps.get(name, {}).get("model") is None
        ]
        if missing:
            selection["failed"] = (
                f"{', '.join(missing)}, averaged with a weight, failed at this seed"
            )
            return None, selection, None
        selection["deterministic"] = _deterministic(deps, weights)
        return _stack(deps, weights), selection, ctx.searched["runs"]
    scale = ctx.system.scale
    targets = _targets(ctx, n_splits)
    oof = {name: _runs(deps.get(name), targets) for name in model.requires}
    members = [name for name, runs in oof.items() if runs is not None]
    selection = {
        "members": members,
        "cv_folds": len(targets),
        "fitted_on": "the models' out-of-fold free runs",
        "validation_start": int(ctx.n_init),
    }
    if len(members) < 2:
        selection.update(
            validation_rmse=float("inf"),
            failed=(
                f"{len(members)} model(s) have out-of-fold free runs on every "
                "fold; a stack needs two"
            ),
        )
        return None, selection, None
    fold_w, w = _cross_fitted_weights([oof[m] for m in members], targets)
    runs = [
        np.column_stack([oof[m][k] for m in members]) @ fold_w[k]
        for k in range(len(targets))
    ]
    by_fold = [
        scale * float(np.sqrt(np.mean((run - target) ** 2)))
        for run, target in zip(runs, targets, strict=True)
    ]
    weights = {m: float(v) for m, v in zip(members, w, strict=True)}
    selection.update(
        weights=weights,
        fold_weights=[
            {m: float(v) for m, v in zip(members, row, strict=True)} for row in fold_w
        ],
        chosen_candidate="weights fitted on every fold",
        validation_rmse=float(np.mean(by_fold)),
        cv_rmse_std=float(np.std(by_fold)),
        cv_rmse_chosen_by_fold=by_fold,
        deterministic=_deterministic(deps, weights),
    )
    return _stack(deps, weights), selection, runs


def averaged_run(stack, runs, errors):
    """The stack's free run of a record from its members' runs of it.

    The same numbers as ``stack.simulate`` (the same products and sums, in the
    same order), without simulating every member a second time.

    Parameters
    ----------
    stack : StackedSimulation
        The fitted stack.
    runs : dict of str to ndarray
        Each member's free run of the record, flattened.
    errors : dict of str to str
        Why a member's free run failed, by member.

    Returns
    -------
    run : ndarray or None
        The weighted average, flattened; None where a member with a weight has
        no run of the record.
    error : str or None
        Why it failed: the first failed member's reason.
    """
    total, error = 0.0, None
    for (name, _), w in zip(stack.estimators, stack.weights_, strict=True):
        if w == 0:
            continue
        if name not in runs:
            return None, None
        run = np.asarray(runs[name], dtype=float)
        total = total + w * run.reshape(len(run), -1)
        if error is None and errors.get(name):
            error = f"{name}'s free run failed: {errors[name]}"
    return np.ravel(total), error
