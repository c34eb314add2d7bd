"""Write a run's results: CSV, JSON, the paper's figures and one HTML page."""

import base64
import csv
import html
import json
import platform
import re
from pathlib import Path

import numpy as np

from skhybrid.experiments._claims import check_claims
from skhybrid.experiments._measured_report import measured_figure, measured_section
from skhybrid.experiments._paper_stochastic import band_figure, stochastic_html

__all__ = ["write_report"]

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
            window=result.settings.window,
        ).plot(ax=fig.subplots(1, n_outputs, squeeze=False))
        disp.figure_.suptitle(f"{result.system.title}: {split} test set")
        path = out_dir / f"{name}_rmse_{split}.png"
        disp.figure_.savefig(path, dpi=90)
        figures.append((f"RMSE in dB over windows, {split}", path))

    split = "interpolation"
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
            lags=result.settings.lags,  # the lags of the whiteness table too
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


def _table(rows, columns, formats=None):
    formats = formats or {}
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = []
    for row in rows:
        cells = []
        for c in columns:
            value = row.get(c, "")
            fmt = formats.get(c)
            if fmt and isinstance(value, (int, float)) and value is not None:
                value = format(value, fmt)
            cells.append(f"<td>{html.escape(str(value))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


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


CSS = """
body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1.5em;font-size:0.85em}
td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}
th{background:#eee} td:first-child,th:first-child{text-align:left}
img{max-width:100%;border:1px solid #ddd;margin:0.3em 0 1em}
.pass{color:#176617;font-weight:bold}.fail{color:#a31515;font-weight:bold}.na{color:#666;font-style:italic}
code{background:#f4f4f4;padding:1px 4px}
"""


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
        f"{result.settings.window} samples of 20 log10(RMSE); /oracle: RMSE over "
        "the oracle's (the true equations applied to each row); LB p: Ljung-Box "
        f"p-value of the residual at {result.settings.lags} lags.</p>"
    )
    parts.append(_table(summary, columns, formats))
    parts.append(
        "<h3>Whiteness</h3><p>Each model's residual beside the oracle's: Ljung-Box "
        f"statistic Q at {result.settings.lags} lags (lower is whiter) and the "
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


def _title(results):
    """The page's title: the systems' own titles where every one is measured."""
    measured = [getattr(r.system, "measured", False) for r in results]
    if all(measured):
        return "; ".join(r.system.title or r.system.name for r in results)
    if any(measured):
        return "the paper's section 6 and measured systems"
    return "the paper's section 6"


def _settings(results):
    """The settings table: a measured run's from its spec and seeds."""
    first = results[0]
    if not getattr(first.system, "measured", False):
        return first.settings.to_dict()
    return {
        "system": first.system.name,
        "seeds (searched at the first, refitted at each)": ", ".join(
            map(str, first.seeds)
        ),
        "quick": first.settings.quick,
        "n_init (samples that start each free run)": first.results[0].n_init,
        "dt [s]": first.results[0].dt,
        "estimation records (samples)": ", ".join(
            str(len(u)) for u in first.results[0].train[0]
        ),
    }


def write_report(results, out_dir, *, command=None, wall_time=None):
    """Write ``results.csv``, ``results.json``, figures and ``report.html``.

    Parameters
    ----------
    results : list of ExperimentResult or MeasuredResult
        One per system.
    out_dir : str or Path
        Folder to write to (created if missing).
    command : str or None, default=None
        The command line that made the run, shown in the report.
    wall_time : float or None, default=None
        Total seconds, shown in the report.

    Returns
    -------
    paths : dict of str to Path
        ``csv``, ``json``, ``html`` and ``figures`` (a list).
    """
    import skhybrid

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = [row for r in results for row in r.rows]
    # The columns of every row, in order of appearance (a measured benchmark's
    # rows have a unit and a validation RMSE, a paper system's the oracle ratio).
    fieldnames = list(dict.fromkeys(key for row in rows for key in row))
    csv_path = out_dir / "results.csv"
    with csv_path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fieldnames)
        writer.writeheader()
        writer.writerows(rows)

    figures, sections, systems = [], [], {}
    for result in results:
        if getattr(result.system, "measured", False):
            path = measured_figure(result, out_dir)
            figures.append(path)
            sections.append(measured_section(result, path))
            systems[result.system.name] = result.summary()
            continue
        figs = _figures(result, out_dir)
        claims = check_claims(result)
        figures.extend(path for _, path in figs)
        sections.append(_section(result, figs, claims))
        systems[result.system.name] = {
            "title": result.system.title,
            "settings": result.settings.to_dict(),
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
    environment = {
        "skhybrid": skhybrid.__version__,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "command": command,
        "wall_time_s": wall_time,
    }
    json_path = out_dir / "results.json"
    json_path.write_text(
        json.dumps({"environment": environment, "systems": systems}, indent=1)
    )

    title = _title(results)
    settings_html = _table(
        [{"setting": k, "value": v} for k, v in _settings(results).items()],
        ["setting", "value"],
    )
    total = "" if wall_time is None else f"<p>Total wall time: {wall_time:.1f} s.</p>"
    cmd = (
        ""
        if command is None
        else f"<p>Command: <code>{html.escape(command)}</code></p>"
    )
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>skhybrid: {html.escape(title)}</title>
<style>{CSS}</style></head><body>
<h1>Hybrid physics / neural / stochastic models: {html.escape(title)}</h1>
<p>skhybrid {html.escape(skhybrid.__version__)}, Python
{html.escape(platform.python_version())}.</p>{cmd}{total}
<h3>Settings</h3>{settings_html}
{"".join(sections)}
</body></html>
"""
    html_path = out_dir / "report.html"
    html_path.write_text(page)
    return {"csv": csv_path, "json": json_path, "html": html_path, "figures": figures}
