"""The stochastic part of a simulated system's models (the paper's one-step protocol).

A paper system's models predict each row's next state from a window of measured
states and inputs. What they leave is judged as a measured system's free runs
are (:mod:`skhybrid.experiments._stochastic`), on a **validation split**: new
episodes simulated like the training split's, which no fit reads and no test
split shares. The chosen model is the one with the lowest validation RMSE
(relative to the oracle's, averaged over the outputs). For it, per output: the
residual tests (Ljung-Box whiteness, correlation with the inputs) on the
validation split and on each test split, an autoregressive noise model fitted on
the validation residuals, and its 95 % band around the one-step predictions of
each test split with the band's **coverage** (the share of test rows inside it).
"""

import numpy as np

from skhybrid.experiments._stochastic import (
    BAND_LEVEL,
    band_coverage,
    fit_noise,
    residual_tests,
)
from skhybrid.experiments.run._html import p_value

__all__ = [
    "VALIDATION_SPLIT",
    "band_figure",
    "choose_on_validation",
    "paper_band",
    "paper_stochastic",
    "stochastic_html",
]

#: Name of the validation split among a paper system's predictions.
VALIDATION_SPLIT = "validation"


def _newest_inputs(data):
    """The inputs at each row's newest step (columns ``name[t]``), or None."""
    names = list(getattr(data, "feature_names", []))
    columns = [
        names.index(f"{name}[t]")
        for name in getattr(data, "input_names", [])
        if f"{name}[t]" in names
    ]
    if not columns:
        return None
    return np.asarray(data.X, dtype=float)[:, columns]


def _relative_rmse(data, pred):
    """RMSE of ``pred`` over the oracle's, averaged over the outputs."""
    y = np.asarray(data.y, dtype=float)
    rmse = np.sqrt(np.mean((y - pred) ** 2, axis=0))
    oracle = np.sqrt(np.mean((y - np.asarray(data.oracle, dtype=float)) ** 2, axis=0))
    return float(np.mean(rmse / np.where(oracle > 0, oracle, 1.0)))


def choose_on_validation(result):
    """The model with the lowest validation RMSE over the oracle's, and every score.

    Parameters
    ----------
    result : ExperimentResult
        A paper system's run with its ``validation`` split predicted.

    Returns
    -------
    chosen : str or None
        The model; None without a validation split.
    scores : dict of str to float
        Each model's validation RMSE over the oracle's (mean over outputs).
    """
    data = getattr(result, "validation", None)
    preds = result.predictions.get(VALIDATION_SPLIT, {})
    if data is None or not preds:
        return None, {}
    scores = {
        model: _relative_rmse(data, np.asarray(pred, dtype=float))
        for model, pred in preds.items()
    }
    finite = {m: s for m, s in scores.items() if np.isfinite(s)}
    return (min(finite, key=finite.get) if finite else None), scores


def _tests(residual, inputs):
    """Residual tests; without inputs, whiteness only."""
    if inputs is None:  # a constant column: no correlation with an input is tested
        inputs = np.ones((len(residual), 1))
    return residual_tests(residual, inputs)


def _noise_models(result, model):
    """The AR noise model of ``model``'s validation residuals, per output."""
    y = np.asarray(result.validation.y, dtype=float)
    pred = np.asarray(result.predictions[VALIDATION_SPLIT][model], dtype=float)
    return [fit_noise([y[:, j] - pred[:, j]]) for j in range(y.shape[1])]


def paper_band(result, model, split):
    """The 95 % band of ``model``'s one-step predictions of ``split``.

    Parameters
    ----------
    result : ExperimentResult
        The run.
    model : str
        A model with validation predictions.
    split : str
        A test split.

    Returns
    -------
    lower, upper : ndarray of shape (n_rows, n_outputs)
        The band (NaN for an output whose noise model could not be fitted).
    """
    y = np.asarray(result.splits[split].y, dtype=float)
    pred = np.asarray(result.predictions[split][model], dtype=float)
    lower, upper = np.full_like(y, np.nan), np.full_like(y, np.nan)
    for j, (noise, _) in enumerate(_noise_models(result, model)):
        if noise is not None:
            lower[:, j], upper[:, j], _ = band_coverage(y[:, j], pred[:, j], 0, noise)
    return lower, upper


def paper_stochastic(result):
    """The chosen model's stochastic part on a paper system's run.

    Parameters
    ----------
    result : ExperimentResult
        The run, its models' predictions of the validation and test splits.

    Returns
    -------
    part : dict
        ``model`` (chosen on validation), ``validation_rmse_over_oracle`` of
        every model, ``level`` of the band and, per output under ``outputs``:
        ``noise`` (the AR noise model of the validation residuals),
        ``validation`` (its residual tests) and ``tests`` by split (residual
        tests and ``coverage``). Empty without a validation split.
    """
    chosen, scores = choose_on_validation(result)
    if chosen is None:
        return {}
    data = result.validation
    y = np.asarray(data.y, dtype=float)
    pred = np.asarray(result.predictions[VALIDATION_SPLIT][chosen], dtype=float)
    inputs = _newest_inputs(data)
    outputs = {}
    for j, (name, (noise, description)) in enumerate(
        zip(result.target_names, _noise_models(result, chosen), strict=True)
    ):
        entry = {
            "noise": description,
            "validation": _tests(y[:, j] - pred[:, j], inputs),
            "tests": {},
        }
        for split in result.test_splits:
            test = result.splits[split]
            y_t = np.asarray(test.y, dtype=float)[:, j]
            p_t = np.asarray(result.predictions[split][chosen], dtype=float)[:, j]
            tests = _tests(y_t - p_t, _newest_inputs(test))
            tests["coverage"] = (
                None if noise is None else band_coverage(y_t, p_t, 0, noise)[2]
            )
            entry["tests"][split] = tests
        outputs[name] = entry
    return {
        "model": chosen,
        "chosen_on": "the validation split: new episodes like the training split's",
        "validation_rmse_over_oracle": scores,
        "level": BAND_LEVEL,
        "outputs": outputs,
    }


# -- the report ---------------------------------------------------------------------
#: Rows of a test split drawn with the band (its first episode's first rows).
BAND_ROWS = 300


def stochastic_html(part):
    """The report's subsection on the chosen model's stochastic part.

    Parameters
    ----------
    part : dict
        :func:`paper_stochastic`'s result.

    Returns
    -------
    html : str
        A heading, what was done, and one table row per output and split.
    """
    import html

    if not part:
        return ""
    rows = []
    for output, entry in part["outputs"].items():
        noise = entry["noise"]
        if noise.get("fitted"):
            lags = ", ".join(map(str, noise["lags"])) or "none (white)"
            model = (
                f"AR lags {lags}; std {noise['std']:.3g}, innovations "
                f"{noise['innovation_std']:.3g}, mean {noise['mean']:.3g}"
            )
        else:
            model = f"none: {noise.get('reason', '')}"
        val = entry["validation"]
        rows.append(
            f"<tr><td>{html.escape(output)}</td><td>validation</td>"
            f"<td>{p_value(val.get('ljung_box_pvalue'))}</td>"
            f"<td>{p_value(val.get('input_correlation_pvalue'))}</td>"
            f"<td>{html.escape(model)}</td><td></td></tr>"
        )
        for split, tests in entry["tests"].items():
            coverage = tests.get("coverage")
            covered = "n/a" if coverage is None else f"{100 * coverage:.1f} %"
            rows.append(
                f"<tr><td></td><td>{html.escape(split)}</td>"
                f"<td>{p_value(tests.get('ljung_box_pvalue'))}</td>"
                f"<td>{p_value(tests.get('input_correlation_pvalue'))}</td><td></td>"
                f"<td>{covered}</td></tr>"
            )
    level = 100 * part["level"]
    return f"""<h3>The stochastic part of the chosen model</h3>
<p>Chosen on {html.escape(part["chosen_on"])}: <b>{html.escape(part["model"])}</b>,
the lowest one-step RMSE over the oracle's there (mean over the outputs). Its
residuals on the validation split, which no fit read, are tested for whiteness
(Ljung-Box) and for correlation with the inputs (missing input dynamics), and an
autoregressive noise model is fitted to them, per output. Its {level:.0f} % band,
<code>prediction + mean &plusmn; z std</code>, is laid on each test split's
one-step predictions; its coverage is the share of test rows inside it (nominal
{level:.0f} %; lower means the residuals on the test split are larger than on
validation, as outside the training hull).</p>
<table><tr><th>output</th><th>residuals of</th><th>Ljung-Box p</th>
<th>input correlation p</th><th>noise model</th><th>band coverage</th></tr>
{"".join(rows)}</table>
"""


def band_figure(result, path):
    """The chosen model's one-step predictions with their band, each output a panel.

    Parameters
    ----------
    result : ExperimentResult
        The run (its ``stochastic`` part filled).
    path : Path
        Where the PNG goes.

    Returns
    -------
    path : Path or None
        ``path``, or None where no model was chosen.
    """
    from matplotlib.figure import Figure

    part = getattr(result, "stochastic", {})
    if not part:
        return None
    model = part["model"]
    split = result.test_splits[-1]  # outside the training hull where it has one
    data = result.splits[split]
    rows = slice(0, min(BAND_ROWS, len(data.y)))
    groups = getattr(data, "groups", None)
    if groups is not None:  # one episode: its rows are consecutive time steps
        first = np.flatnonzero(np.asarray(groups) == np.asarray(groups)[0])
        rows = slice(0, min(BAND_ROWS, len(first)))
    y = np.asarray(data.y, dtype=float)[rows]
    pred = np.asarray(result.predictions[split][model], dtype=float)[rows]
    lower, upper = (b[rows] for b in paper_band(result, model, split))
    names = result.target_names
    fig = Figure(figsize=(4.2 * len(names), 3.2), layout="constrained")
    axes = fig.subplots(1, len(names), squeeze=False)[0]
    steps = np.arange(len(y))
    for j, ax in enumerate(axes):
        ax.fill_between(
            steps,
            lower[:, j],
            upper[:, j],
            color="tab:orange",
            alpha=0.3,
            label=f"{100 * part['level']:.0f} % band",
        )
        ax.plot(steps, y[:, j], color="k", lw=0.8, label="measured")
        ax.plot(steps, pred[:, j], color="tab:orange", lw=0.8, label=model)
        coverage = part["outputs"][names[j]]["tests"][split]["coverage"]
        covered = "" if coverage is None else f", coverage {100 * coverage:.1f} %"
        ax.set_title(f"{names[j]}{covered}", fontsize=9)
        ax.set_xlabel("row (time step)")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{result.system.title}: {model} on the {split} split")
    fig.savefig(path, dpi=90)
    return path
