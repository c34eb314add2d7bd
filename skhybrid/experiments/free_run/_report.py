"""A measured run's report section and figure, and where a test leaves the hull."""

import base64
import html
from pathlib import Path

import numpy as np

from skhybrid.experiments.free_run._verdicts import (
    coverage_verdict,
    input_verdict,
    standard_error_caveat,
    whiteness_verdict,
)
from skhybrid.experiments.run._html import p_value
from skhybrid.experiments.run._store import SELECTION_FILE, _slug
from skhybrid.model_selection import in_convex_hull

__all__ = ["hull_exit", "legend_beside", "measured_figure", "measured_section"]


def hull_exit(train, test, n_init):
    """First test index whose ``[y(t), y(t-1), u(t)]`` leaves the training hull."""

    def rows(u, y):
        y = np.ravel(y)
        return np.column_stack([y[1:], y[:-1], np.asarray(u)[1:, 0]])

    U, Y = train
    inside = in_convex_hull(
        rows(*test), np.vstack([rows(u, y) for u, y in zip(U, Y, strict=True)])
    )
    outside = np.flatnonzero(~inside) + 1
    return (int(outside[0]) if outside.size else None), int(outside.size)


def measured_figure(run, out_dir):
    """Draw the test records and each model's free run (first seed); return the path.

    Parameters
    ----------
    run : MeasuredRun
        A finished run.
    out_dir : Path
        Where ``<system>.png`` is written.

    Returns
    -------
    path : Path
        The figure's file.
    """
    # The object-oriented Figure API draws without pyplot: no backend is chosen
    # and a user's own plotting session is left alone.
    from matplotlib.figure import Figure

    result = run.results[0]
    system, tests, n_init, dt = result.system, result.tests, result.n_init, result.dt
    # Constrained layout makes room for the legends beside the panels.
    fig = Figure(figsize=(9.5 * max(1, len(tests)), 6), layout="constrained")
    axes = fig.subplots(2, max(1, len(tests)), sharex="col", squeeze=False)
    for j, (split, (_u, y)) in enumerate(tests.items()):
        t = np.arange(len(y)) * dt
        top, bottom = axes[0, j], axes[1, j]
        measured = system.scale * np.ravel(y)
        top.plot(t, measured, "k", lw=1.0, label="measured")
        # The axis is the measured signal's (with a margin): a model that runs
        # off it is clipped there and marked, not allowed to flatten the rest.
        low, high = _limits(measured)
        errors = {}
        for i, (label, pred) in enumerate(result.predictions[split].items()):
            if not np.all(np.isfinite(pred)):
                continue  # a failed free run is reported in the tables
            shown = system.scale * np.asarray(pred, dtype=float)
            if shown.min() < low or shown.max() > high:
                label = f"{label} (off scale, clipped)"
            top.plot(t, np.clip(shown, low, high), lw=0.8, label=label, color=f"C{i}")
            err = system.scale * (pred - np.ravel(y))
            err[:n_init] = np.nan
            # The black-box models' errors can be 100 times larger: the error
            # panel shows the physics-based ones, the largest drawn first.
            if label.startswith(("physics", "state-space")):
                errors[label] = (i, err)
        order = sorted(errors, key=lambda k: -np.nanmean(errors[k][1] ** 2))
        for label in order:
            i, err = errors[label]
            bottom.plot(t, err, lw=0.6, label=label, color=f"C{i}")
        if order:
            legend_beside(bottom)
        hull = result.hull.get(split)
        leaves = bool(hull and hull["first_outside"] is not None)
        for ax in (top, bottom):
            ax.axvspan(0, n_init * dt, color="0.9")
            if leaves:
                ax.axvline(hull["first_outside"] * dt, color="r", ls="--")
        band = getattr(result, "bands", {}).get(split)
        if band is not None:
            level = result.stochastic.get("level", 0.95)
            coverage = result.stochastic["tests"][split]["coverage"]
            text = "n/a" if coverage is None else f"{100 * coverage:.0f} %"
            top.fill_between(
                t,
                np.clip(system.scale * band[0], low, high),
                np.clip(system.scale * band[1], low, high),
                color="C0",
                alpha=0.2,
                lw=0,
                label=f"{100 * level:.0f} % band of {result.selected_model()} "
                f"(covers {text})",
            )
        top.set_ylim(low, high)
        top.set_title(f"{system.title}: {split} (seed {result.settings.seed})")
        unit = system.unit
        top.set_ylabel(f"output [{unit}]")
        bottom.set_ylabel(f"simulation error [{unit}]\n(physics-based models)")
        # The label names only what is drawn.
        marks = ["grey: init window"]
        if leaves:
            marks.append("red dashed line: first sample outside the training hull")
        bottom.set_xlabel(f"time [s] ({'; '.join(marks)})")
        legend_beside(top)
    path = Path(out_dir) / f"{_slug(system.name)}.png"
    fig.savefig(path, dpi=90)
    return path


def legend_beside(ax):
    """The legend of ``ax`` to its right, outside the panel: it covers no data.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        A panel with labelled artists.

    Returns
    -------
    legend : matplotlib.legend.Legend
        The legend, anchored at the panel's top right corner.
    """
    return ax.legend(
        fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0
    )


def _limits(measured, margin=0.25):
    """The measured signal's range widened by ``margin`` of its span each side."""
    finite = measured[np.isfinite(measured)]
    if finite.size == 0:
        return -1.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    pad = margin * (high - low) or max(abs(high), 1.0) * margin
    return low - pad, high + pad


def failure_reason(run, split, model):
    """Why ``model`` has no test figure on ``split``, in words (or None).

    Parameters
    ----------
    run : MeasuredRun
        A finished run.
    split : str
        A test record's name.
    model : str
        A model's name.

    Returns
    -------
    reason : str or None
        The first seed's reason: its fit failed, its free run diverged (with
        the error), or the protocol is not defined for it.
    """
    for result in run.results:
        fit = result.fits.get(model, {})
        selection = fit.get("selection") or {}
        if selection.get("failed"):
            return f"not fitted: {selection['failed']}"
        if split.endswith("_original_protocol"):
            return (
                "not defined: this protocol starts from a StateSpaceModel "
                "physics' state"
            )
        error = selection.get("diverged_on_" + split)
        if error:
            return f"free run diverged: {error}"
    return None


def _stochastic_html(summary, unit):
    """The stochastic part's subsection: residual tests, noise model, band."""
    rows = []
    for seed, part in summary.get("stochastic", {}).items():
        noise = part.get("noise", {})
        if not noise.get("fitted"):
            reason = noise.get("reason", "no model chosen")
            rows.append(
                f"<tr><td>{seed}</td><td>{html.escape(str(part.get('model')))}</td>"
                f"<td colspan='7'>no noise model: {html.escape(reason)}</td></tr>"
            )
            continue
        lags = ", ".join(map(str, noise["lags"])) or "none (white)"
        val = part.get("validation", {})
        level = part.get("level", 0.95)
        rows.append(
            f"<tr><td>{seed}</td><td>{html.escape(part['model'])}</td>"
            "<td>held-out blocks (CV)</td>"
            f"<td>{p_value(val.get('ljung_box_pvalue'))}</td>"
            f"<td>{p_value(val.get('input_correlation_pvalue'))}</td>"
            f"<td>AR lags {lags}; std {noise['std']:.3g}, innovations "
            f"{noise['innovation_std']:.3g}, mean {noise['mean']:.3g}</td>"
            f"<td></td><td>{_reading(val)}</td></tr>"
        )
        for split, tests in part.get("tests", {}).items():
            coverage = tests.get("coverage")
            covered = "n/a" if coverage is None else f"{100 * coverage:.1f} %"
            rows.append(
                f"<tr><td>{seed}</td><td></td><td>{html.escape(split)}</td>"
                f"<td>{p_value(tests.get('ljung_box_pvalue'))}</td>"
                f"<td>{p_value(tests.get('input_correlation_pvalue'))}</td><td></td>"
                f"<td>{covered}</td><td>{_reading(tests, level)}</td></tr>"
            )
    if not rows:
        return ""
    coverage = "; ".join(
        f"{html.escape(split)}: {_coverage_text(spread)}"
        for split, spread in summary.get("band_coverage", {}).items()
    )
    level = next(iter(summary["stochastic"].values())).get("level", 0.95)
    return f"""<h4>The stochastic part of the chosen model</h4>
<p>What the chosen model leaves: its out-of-fold free-run residuals over the
held-out blocks of the estimation records (never a test record) are tested for
whiteness (Ljung-Box) and for correlation with the inputs (missing input
dynamics), and an autoregressive noise model is fitted to them [{unit}]. Its
{100 * level:.0f} % simulation band, <code>y_sim + mean &plusmn; z std</code>,
is laid on each test record's free run; its coverage is the share of test
samples inside it (nominal {100 * level:.0f} %; lower means the residuals on
test are larger than on the held-out blocks). Coverage over seeds: {coverage}.</p>
<table><tr><th>seed</th><th>chosen</th><th>residuals of</th>
<th>Ljung-Box p</th><th>input correlation p</th><th>noise model</th>
<th>band coverage</th><th>reading (at 5 %)</th></tr>
{"".join(rows)}</table>
"""


def _reading(tests, level=None):
    """The verdicts of one row of residual tests, in words (HTML)."""
    verdicts = [
        whiteness_verdict(tests.get("ljung_box_pvalue")),
        input_verdict(tests.get("input_correlation_pvalue")),
    ]
    if level is not None:
        verdicts.append(coverage_verdict(tests.get("coverage"), level))
    return html.escape("; ".join(verdicts))


def _params_html(run, summary):
    """The physics' parameters by seed, with what their standard errors assume."""
    items, caveats = [], []
    for result in run.results:
        seed = str(result.settings.seed)
        physics = (summary.get("stochastic", {}).get(seed) or {}).get(
            "physics_validation"
        ) or {}
        caveats.append(standard_error_caveat(physics.get("ljung_box_pvalue")))
        items.append((seed, _params_text(result.params.get("physics"))))
    if len(set(caveats)) == 1:  # the same reading at every seed: said once
        listed = "".join(f"<li>seed {seed}: {text}</li>" for seed, text in items)
        caveat = html.escape(caveats[0][0].upper() + caveats[0][1:])
        return f"<ul>{listed}</ul><p>{caveat}.</p>"
    listed = "".join(
        f"<li>seed {seed}: {text} ({html.escape(caveat)})</li>"
        for (seed, text), caveat in zip(items, caveats, strict=True)
    )
    return f"<ul>{listed}</ul>"


def _chosen_cv_text(summary):
    """The CV RMSE of each seed's chosen model: mean &plusmn; std over its folds."""
    entries = [
        summary.get("cv_rmse", {}).get(seed, {}).get(model)
        for seed, model in summary.get("chosen_model", {}).items()
    ]
    entries = [e for e in entries if e]
    if not entries:
        return ""
    mean = np.mean([e["mean"] for e in entries])
    std = np.mean([e["std"] for e in entries])
    return f"{mean:.4g} &plusmn; {std:.2g}"


def _coverage_text(spread):
    if spread["mean"] is None:
        return "n/a"
    return f"{100 * spread['mean']:.1f} &plusmn; {100 * spread['std']:.1f} %"


def _params_text(params):
    """The fitted physical parameters as ``name = value ± std``, settings left out.

    A fixed parameter (a setting such as the sample period, or one the user
    froze) was not fitted and is not listed; a parameter whose standard error
    could not be computed shows its value alone.
    """
    if not params:
        return "none"
    items = []
    for name, p in params.items():
        if p.get("fixed") or np.ndim(p["value"]) != 0:
            continue
        text = f"{html.escape(name)} = {float(p['value']):.5g}"
        if p.get("std") is not None and np.ndim(p["std"]) == 0:
            text += f" &plusmn; {float(p['std']):.2g}"
        items.append(text)
    return ", ".join(items) or "none fitted"


def _cv_text(summary, model):
    """A model's CV RMSE: mean &plusmn; std over the folds (the seeds' mean)."""
    entries = [v[model] for v in summary.get("cv_rmse", {}).values() if model in v]
    if not entries:
        return ""
    mean = np.mean([e["mean"] for e in entries])
    std = np.mean([e["std"] for e in entries])
    return f"{mean:.4g} &plusmn; {std:.2g}"


def spread_text(spread, *, deterministic=False, unit="", plus_minus="±"):
    """A figure over seeds in words: its mean, and its spread where it has one.

    Parameters
    ----------
    spread : dict
        ``{mean, std, by_seed, n_failed}`` over the run's seeds.
    deterministic : bool, default=False
        Whether no fit of the model depends on the seed.
    unit : str, default=""
        Written after the figure.
    plus_minus : str, default="±"
        The sign between mean and standard deviation.

    Returns
    -------
    text : str
        ``"mean ± std"``; ``"mean (deterministic)"`` for a model that cannot
        vary with the seed; ``"mean (one seed)"`` where a single seed scored,
        which gives no spread (never "± 0"); ``"failed"`` where none did.
    """
    if spread["mean"] is None:
        return "failed"
    unit = f" {unit}" if unit else ""
    scored = [v for v in spread.get("by_seed", []) if v is not None]
    if deterministic and spread["std"] == 0:
        # The same fit at every seed: no spread to show.
        text = f"{spread['mean']:.4g}{unit} (deterministic)"
    elif len(scored) == 1:
        text = f"{spread['mean']:.4g}{unit} (one seed)"
    else:
        text = f"{spread['mean']:.4g} {plus_minus} {spread['std']:.2g}{unit}"
    if spread.get("n_failed"):
        text += f" ({spread['n_failed']} failed)"
    return text


def _figure_text(spread, reason=None, deterministic=False):
    if spread["mean"] is None:
        return "failed" if reason is None else f"failed ({html.escape(reason)})"
    return html.escape(spread_text(spread, deterministic=deterministic))


def measured_section(run, figure):
    """The report's HTML section of a measured run.

    Parameters
    ----------
    run : MeasuredRun
        A finished run.
    figure : Path
        Its figure, embedded in the page.

    Returns
    -------
    section : str
        HTML.
    """
    summary = run.summary()
    unit = html.escape(summary["unit"])
    seeds = ", ".join(str(s) for s in summary["seeds"])
    rows = []
    fixed = set(summary.get("deterministic", []))
    for split, scores in summary["test_rmse"].items():
        chosen = summary["chosen_test_rmse"][split]
        ratio = summary.get("chosen_test_over_cv", {}).get(split)
        ratio = "" if not ratio or ratio["mean"] is None else f"{ratio['mean']:.2f}"
        rows.append(
            f"<tr><td>{html.escape(split)}</td><td><b>chosen by CV</b></td>"
            f"<td><b>{_figure_text(chosen)}</b></td>"
            f"<td><b>{_chosen_cv_text(summary)}</b></td><td><b>{ratio}</b></td>"
            "<td>ours</td></tr>"
        )
        for model, spread in scores.items():
            reason = (
                failure_reason(run, split, model) if spread["mean"] is None else None
            )
            rows.append(
                f"<tr><td>{html.escape(split)}</td><td>{html.escape(model)}</td>"
                f"<td>{_figure_text(spread, reason, model in fixed)}</td>"
                f"<td>{_cv_text(summary, model)}</td><td></td><td>ours</td></tr>"
            )
        for label, entry in summary["published"].get(split, {}).items():
            rows.append(
                f"<tr><td>{html.escape(split)}</td><td>{html.escape(label)}</td>"
                f"<td>{entry['rmse']:.4g}</td><td></td><td></td>"
                f"<td>{html.escape(entry['source'])}</td></tr>"
            )
    # Published figures of another protocol (another record, split or
    # initialisation) are listed apart: they are not comparable with the table.
    apart = "".join(
        f"<li>{html.escape(group)}: {html.escape(label)} {entry['rmse']:.4g} "
        f"[{unit}] ({html.escape(entry['source'])})</li>"
        for group, table in summary["published"].items()
        if group not in summary["test_rmse"]
        for label, entry in table.items()
    )
    if apart:
        apart = (
            f"<p>Published under another protocol (not comparable):</p><ul>{apart}</ul>"
        )
    params = _params_html(run, summary)
    data = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
    chosen = ", ".join(
        f"seed {s}: {html.escape(str(m))}" for s, m in summary["chosen_model"].items()
    )
    notes = (
        f"<p>Candidates: {html.escape(summary['notes'])}</p>"
        if summary["notes"]
        else ""
    )
    stochastic = _stochastic_html(summary, unit)
    searched = summary.get("searched_at_seed", summary["seeds"][0])
    weights = summary.get("stack_weights") or {}
    stack = ""
    if weights:
        terms = ", ".join(
            f"{html.escape(model)} {w:.3g}"
            for model, w in sorted(weights.items(), key=lambda kv: -kv[1])
        )
        stack = (
            "<p>The stack (<code>stacked</code>) averages the models' free runs "
            f"with the weights {terms}, fitted on their out-of-fold runs; its CV "
            "RMSE is cross-fitted (each fold scored with weights fitted on the "
            "other folds).</p>"
        )
    return f"""<h2>{html.escape(summary["title"])}</h2>
<p>Free-run simulation RMSE on the test record(s) [{unit}], mean &plusmn; standard
deviation over seeds {seeds} (searched at seed {searched}, each choice refitted at
every seed; "deterministic" where no fit depends on the seed); the first
{summary["n_init"]} measured samples initialise the state. Every model was fitted on
the estimation records only. Every choice
(window and segment lengths, the hybrid's horizon T, the model quoted) was made by
blocked cross-validation of the estimation records: each record cut into blocks,
every candidate fitted on the other blocks and simulated over the held-out one;
its CV RMSE (mean &plusmn; standard deviation over the folds) is what a user should
expect, and test / CV says how the chosen model's test compares with it.
quick = {summary["quick"]}, {summary["wall_time_s"]:.0f} s.</p>
<p>Sealed selection: <code>{SELECTION_FILE}</code>, SHA-256
<code>{summary["selection_sha256"]}</code>, written before any test record was
read.</p>{notes}
<table><tr><th>test</th><th>model</th><th>test RMSE [{unit}]</th>
<th>CV RMSE [{unit}]</th><th>test / CV</th><th>source</th></tr>
{"".join(rows)}</table>
<p>Chosen by the lowest mean CV RMSE (never on a test record): {chosen}.</p>
{stack}{apart}
<p>Physics parameters fitted (value &plusmn; standard error):</p>{params}
{stochastic}
<h4>Test records and free runs (seed {summary["seeds"][0]})</h4>
<img alt='{html.escape(summary["title"])}' src='data:image/png;base64,{data}'>
"""
