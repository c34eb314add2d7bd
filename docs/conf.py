"""Sphinx configuration of the skhybrid documentation.

Build the site (into docs/_build/html) with::

    pip install -c constraints.txt -e ".[docs]"
    sphinx-build -W -b html docs docs/_build/html

The Markdown guides (docs/*.md) are pages through MyST; the API reference lists
every name in each subpackage's ``__all__`` (api.rst is written below, at build
time, so it cannot drift from the code); the gallery runs examples/plot_*.py.
"""

import importlib
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import torch

import skhybrid
from skhybrid.utils.discovery import PUBLIC_MODULES

# The gallery's networks are small: one torch thread is as fast, and on a busy
# 2-core machine two threads spin against each other (plot_compositions: 19 s with
# one thread, 105 s with two, under a load of 10). The test suite does the same
# (conftest.py).
torch.set_num_threads(1)

HERE = Path(__file__).resolve().parent

project = "skhybrid"
author = "skhybrid developers"
copyright = "2026, skhybrid developers"
release = skhybrid.__version__
version = release

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

templates_path = ["_templates"]
autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

html_theme = "pydata_sphinx_theme"
html_title = f"skhybrid {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    # Gallery examples hold long code lines: no page table of contents there,
    # so the code gets the column's full width (with _static/skhybrid.css).
    "secondary_sidebar_items": {
        "*": ["page-toc"],
        "generated/*": ["page-toc"],
        "auto_examples/*": [],
    },
}
html_static_path = ["_static"]
html_css_files = ["skhybrid.css"]

# The measured-data example reads the shared benchmark folder when it is there.
os.environ.setdefault("SKHYBRID_DATA", str(HERE.parent.parent / "shared" / "data"))
sphinx_gallery_conf = {
    "examples_dirs": str(HERE.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
}


def _write_api_reference():
    """api.rst: one autosummary table per subpackage, from its ``__all__``."""
    lines = [
        "API reference",
        "=============",
        "",
        "Every public class and function of skhybrid, by subpackage (the names in",
        "each subpackage's ``__all__``).",
        "",
    ]
    for name in PUBLIC_MODULES:
        module = importlib.import_module(f"skhybrid.{name}")
        title = f":mod:`skhybrid.{name}`"
        summary = (module.__doc__ or "").strip().splitlines()[0]
        lines += [
            title,
            "-" * len(title),
            "",
            summary,
            "",
            f".. currentmodule:: skhybrid.{name}",
            "",
        ]
        lines += [".. autosummary::", "   :toctree: generated", "   :nosignatures:", ""]
        lines += [f"   {public}" for public in sorted(module.__all__)]
        lines.append("")
    (HERE / "api.rst").write_text("\n".join(lines))


_write_api_reference()
