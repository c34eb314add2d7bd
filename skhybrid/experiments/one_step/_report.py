"""The report's section of a simulated system: figures, tables and claims."""

import base64
import html
import re
from pathlib import Path

import numpy as np

from skhybrid.experiments.one_step._claims import check_claims
from skhybrid.experiments.one_step._stochastic import band_figure, stochastic_html
from skhybrid.experiments.run._html import table as _table

__all__ = ["noise_description", "simulated_report", "simulated_settings"]

#: Models whose residual autocorrelation is drawn (the paper's Fig. 5 and 8).
ACF_MODELS = ("physics", "physics+rnn (mse)", "physics+rnn (ljung-box)")


def _slug(text):
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _figures(result, out_dir):
    """Draw the box plots and residual ACFs; return ``[(title, path)]``."""
    # The object-oriented Figure API draws without pyplot, so a user's own
    # plotting session (its backend and open figures) is left alone.
    from matplotlib.figure import Figure

    from skhybrid.diagnostics import ResidualACFDisplay, RMSEBoxDisplay

    name = result.system.name
    figures = []
    for split in result.test_splits:
        n_outputs = len(result.target_names)
        fig = Figure(figsize=(4.2 * n_outputs, 6.5), layout="constrained")
        disp = RMSEBoxDisplay(
            rmse_db=result.windowed_db(split),
            output_names=result.target_names,
            window=result.sizes.window,
        ).plot(ax=fig.subplots(1, n_outputs, squeeze=False))
        disp.figure_.suptitle(f"{result.system.title}: {split} test set")
        path = out_dir / f"{name}_rmse_{split}.png"
        disp.figure_.savefig(path, dpi=90)
        figures.append((f"RMSE in dB over windows, {split}", path))

    # The residual ACFs on the first test set (the paper's interpolation set).
    split = result.test_splits[0]
    physics = result.system.hybrid_physics
    for model in ACF_MODELS:
        model = physics if model == "physics" else model
        if model not in result.predictions[split]:
            continue
        residual = result.splits[split].y - result.predictions[split][model]
        fig = Figure(figsize=(4.2 * residual.shape[1], 3.4), layout="constrained")
        disp = ResidualACFDisplay.from_predictions(
            result.splits[split].y,
            result.predictions[split][model],
            lags=result.sizes.lags,  # the lags of the whiteness table too
            name=model,
            output_names=result.target_names,
            ax=fig.subplots(1, residual.shape[1], squeeze=False),
        )
        disp.figure_.suptitle(f"Residual autocorrelation, {model} ({split})")
        path = out_dir / f"{name}_acf_{_slug(model)}.png"
        disp.figure_.savefig(path, dpi=90)
        figures.append((f"Residual ACF, {model}", path))
    band = band_figure(result, out_dir / f"{name}_band.png")
    if band is not None:
        chosen = result.stochastic["model"]
        figures.append((f"The chosen model's band, {chosen}", band))
    return figures


def _summary_rows(result):
    """One row per model and split: median window dB per output, ratios, p-values."""
    rows = {}
    for r in result.rows:
        key = (r["model"], r["split"])
        row = rows.setdefault(key, {"model": r["model"], "split": r["split"]})
        row[f"{r['output']} dB"] = r["median_window_rmse_db"]
        row[f"{r['output']} /oracle"] = r["rmse_over_oracle"]
        row[f"{r['output']} LB p"] = r["ljung_box_pvalue"]
        row["fit s"] = r["fit_time_s"] if r["fit_time_s"] is not None else ""
    return list(rows.values())


def noise_description(result):
    """One sentence: where the run's noise enters and what the oracle can reach."""
    data = result.splits["train"]
    kind = getattr(data, "noise_type", "measurement")
    levels = ", ".join(
        f"{name} {sd:g}"
        for name, sd in zip(result.target_names, data.noise, strict=True)
        if sd > 0
    )
    if kind == "process":
        return (
            f"Noise: process noise (standard deviation {levels}) enters the "
            "dynamics at every step and the states are measured exactly, so the "
            "true equations' one-step residual is white at the injected level."
        )
    return (
        f"Noise: measurement noise (standard deviation {levels}) on every "
        "measured state, inputs of a row included, so even the oracle's one-step "
        "residual is a moving average of the noise, not white."
    )


def _whiteness_rows(result):
    noise = np.asarray(result.splits["train"].noise, dtype=float)
    rows = {}
    for r in result.rows:
        row = rows.setdefault(
            (r["model"], r["split"]), {"model": r["model"], "split": r["split"]}
        )
        j = result.target_names.index(r["output"])
        row[f"{r['output']} Q"] = r["ljung_box_stat"]
        row[f"{r['output']} std/noise"] = (
            r["residual_std"] / noise[j] if noise[j] > 0 else float("nan")
        )
    return list(rows.values())


def _params_rows(result):
    rows = []
    for model, params in result.params.items():
        for name, p in params.items():
            value, std = np.asarray(p["value"]), p["std"]
            std = None if std is None else np.asarray(std)
            if p.get("fixed"):
                text = (
                    f"{float(value):.6g}"
                    if value.ndim == 0
                    else np.array2string(
                        value, formatter={"float_kind": "{:.4g}".format}
                    )
                )
                rows.append(
                    {"model": model, "parameter": name, "value": text, "std": "fixed"}
                )
                continue
            if value.ndim == 0:
                text = f"{float(value):.6g}"
                err = "" if std is None else f"{float(std):.3g}"
            else:
                text = np.array2string(value, formatter={"float_kind": "{:.4g}".format})
                err = (
                    ""
                    if std is None
                    else np.array2string(std, formatter={"float_kind": "{:.2g}".format})
                )
            rows.append({"model": model, "parameter": name, "value": text, "std": err})
    return rows


def _section(result, figures, claims):
    s = result.system
    parts = [f"<h2>{html.escape(s.title)} (paper section {s.section})</h2>"]
    descr = s.split_descriptions()
    parts.append(
        "<ul>"
        + "".join(
            f"<li><b>{html.escape(k)}</b>: {html.escape(v)}; "
            f"{len(result.splits[k].y)} rows"
            + (
                f"; {100 * result.hull[k]:.1f} % of rows outside the convex hull "
                "of the training rows"
                if k in result.hull
                else ""
            )
            + "</li>"
            for k, v in descr.items()
        )
        + "</ul>"
    )
    parts.append(f"<p>{html.escape(noise_description(result))}</p>")
    if claims:
        parts.append("<h3>The paper's claims on this run</h3><ul>")
        for c in claims:
            cls, word = {
                True: ("pass", "holds"),
                False: ("fail", "fails"),
                None: ("na", "not evaluated"),
            }[c["passed"]]
            parts.append(
                f"<li><span class='{cls}'>{word}</span>: {html.escape(c['claim'])}"
                f" ({html.escape(c['detail'])})</li>"
            )
        parts.append("</ul>")
    summary = _summary_rows(result)
    columns = (
        ["model", "split"]
        + [f"{o} {k}" for k in ("dB", "/oracle", "LB p") for o in result.target_names]
        + ["fit s"]
    )
    formats = {c: ".2f" for c in columns if c.endswith("dB") or "oracle" in c}
    formats.update({c: ".3g" for c in columns if c.endswith("LB p")})
    formats["fit s"] = ".1f"
    parts.append(
        "<h3>Results</h3><p>dB: median over windows of "
        f"{result.sizes.window} samples of 20 log10(RMSE); /oracle: RMSE over "
        "the oracle's (the true equations applied to each row); LB p: Ljung-Box "
        f"p-value of the residual at {result.sizes.lags} lags.</p>"
    )
    parts.append(_table(summary, columns, formats))
    parts.append(
        "<h3>Whiteness</h3><p>Each model's residual beside the oracle's: Ljung-Box "
        f"statistic Q at {result.sizes.lags} lags (lower is whiter) and the "
        "residual's standard deviation over the injected noise's.</p>"
    )
    white_columns = ["model", "split"] + [
        f"{o} {k}" for k in ("Q", "std/noise") for o in result.target_names
    ]
    white_formats = {c: ".4g" for c in white_columns if c.endswith(" Q")}
    white_formats.update({c: ".3f" for c in white_columns if c.endswith("noise")})
    parts.append(_table(_whiteness_rows(result), white_columns, white_formats))
    parts.append(stochastic_html(getattr(result, "stochastic", {})))
    params = _params_rows(result)
    if params:
        parts.append("<h3>Fitted physical parameters</h3>")
        parts.append(_table(params, ["model", "parameter", "value", "std"]))
    for title, path in figures:
        data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
        parts.append(
            f"<h4>{html.escape(title)}</h4>"
            f"<img alt='{html.escape(title)}' src='data:image/png;base64,{data}'>"
        )
    warned = {k: v["warnings"] for k, v in result.fits.items() if v["warnings"]}
    if warned:
        parts.append("<h3>Warnings raised while fitting</h3><ul>")
        for model, messages in warned.items():
            for m in messages:
                parts.append(f"<li>{html.escape(model)}: {html.escape(m)}</li>")
        parts.append("</ul>")
    return "\n".join(parts)


def simulated_settings(result):
    """The report's settings table of a simulated system's run: settings and sizes."""
    return result.system.settings_table(result.settings)


def simulated_report(result, out_dir):
    """Draw a simulated system's figures; its section and its ``results.json`` part.

    Parameters
    ----------
    result : ExperimentResult
        The scored run.
    out_dir : Path
        Where the figures go.

    Returns
    -------
    figures : list of Path
        The figures drawn.
    section : str
        The system's HTML section (tables, figures, claims).
    summary : dict
        Its part of ``results.json``.
    """
    figs = _figures(result, out_dir)
    claims = check_claims(result)
    summary = {
        "title": result.system.title,
        "settings": simulated_settings(result),
        "wall_time_s": result.wall_time,
        "hull_outside_share": result.hull,
        "noise_type": getattr(result.splits["train"], "noise_type", None),
        "noise": np.asarray(result.splits["train"].noise).tolist(),
        "claims": claims,
        "stochastic": getattr(result, "stochastic", {}),
        "params": result.params,
        "fits": result.fits,
        "results": result.rows,
    }
    return [path for _, path in figs], _section(result, figs, claims), summary
