"""What ``skhybrid run`` prints of a finished run: :func:`summary_lines`."""

from skhybrid.experiments.free_run._report import spread_text
from skhybrid.experiments.one_step._claims import check_claims

__all__ = ["summary_lines"]

#: How the console words a claim's verdict.
_VERDICTS = {True: "holds", False: "FAILS", None: "not evaluated"}


def summary_lines(result):
    """The console's summary of one system's finished run, line by line.

    Parameters
    ----------
    result : ExperimentResult or MeasuredRun
        A system's run, as :meth:`RunPlan.fit` returns it.

    Returns
    -------
    lines : list of str
        A one-step system's paper claims, each with its verdict; a measured
        system's chosen model, the seal's hash and the chosen model's test
        RMSE over the seeds.
    """
    if result.system.measured:
        return _measured_lines(result)
    return [
        f"  [{_VERDICTS[claim['passed']]}] {claim['claim']}: {claim['detail']}"
        for claim in check_claims(result)
    ]


def _measured_lines(run):
    """A measured run's choice, seal and chosen test RMSE."""
    name, unit = run.system.name, run.system.unit
    chosen_line = (
        f"  {name}: chosen by cross-validation of the estimation records: "
        f"{run.selected_model()}"
    )
    seal_line = (
        f"  sealed selection sha256 {run.sha256[:16]}... (selection.json), written "
        "before the test records were read"
    )
    lines = [chosen_line, seal_line]
    _, chosen = run.test_summary()
    seeds = ", ".join(map(str, run.seeds))
    models = set(run.chosen().values())
    # One model at every seed, none of whose fits depends on the seed.
    deterministic = len(models) == 1 and models <= set(run.deterministic_models())
    for split, spread in chosen.items():
        text = spread_text(
            spread, deterministic=deterministic, unit=unit, plus_minus="+-"
        )
        lines.append(f"  {split}: {text} (seeds {seeds})")
    return lines
