"""Write a run's results: ``results.csv``, ``results.json``, figures, one HTML page.

Each system's result draws its own figures and writes its own section
(``result.report(out_dir)``, its settings table ``result.report_settings()``
and its title ``result.report_title``): a simulated system's in
:mod:`skhybrid.experiments.one_step._report`, a measured one's in
:mod:`skhybrid.experiments.free_run._report`. This module assembles the page.
"""

import csv
import html
import json
import platform
from pathlib import Path

from skhybrid.experiments.run._html import table as _table

__all__ = ["CSS", "write_report"]

CSS = """
body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1.5em;font-size:0.85em}
td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}
th{background:#eee} td:first-child,th:first-child{text-align:left}
img{max-width:100%;border:1px solid #ddd;margin:0.3em 0 1em}
.pass{color:#176617;font-weight:bold}.fail{color:#a31515;font-weight:bold}.na{color:#666;font-style:italic}
code{background:#f4f4f4;padding:1px 4px}
"""


def _title(results):
    """The page's title: the systems' titles, each once."""
    return "; ".join(dict.fromkeys(r.report_title for r in results))


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
        drawn, section, summary = result.report(out_dir)
        figures.extend(drawn)
        sections.append(section)
        systems[result.system.name] = summary
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
        [{"setting": k, "value": v} for k, v in results[0].report_settings().items()],
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
