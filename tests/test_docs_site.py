"""The documentation site builds without warnings and renders with all its images.

Builds the Sphinx site (MyST guides, the API reference, the gallery, which runs
every example) into a temporary folder with ``-W``, then opens the index and a
gallery page in headless Chromium and checks that every image loaded.
"""

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

# Building the site runs every gallery example again (about 2 minutes on two
# cores): the examples and the guides' code run in the default suite
# (test_examples.py, test_docs.py); the site's build with -W, its API reference
# and its rendering run with `pytest -m slow`.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def site(tmp_path_factory, shared_data_dir):
    for module in ("sphinx", "myst_parser", "sphinx_gallery", "pydata_sphinx_theme"):
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"{module} is not installed: pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site")
    work = tmp_path_factory.mktemp("docs-src")
    # Build from a copy, so generated pages never land in the working tree.
    shutil.copytree(
        ROOT / "docs", work / "docs", ignore=shutil.ignore_patterns("_build")
    )
    shutil.copytree(ROOT / "examples", work / "examples")
    env = {"SKHYBRID_DATA": str(shared_data_dir), "MPLBACKEND": "Agg"}
    result = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html", "docs", str(out)],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=600,
        env={**__import__("os").environ, **env},
        check=False,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    return out


def test_site_has_api_reference_and_gallery(site):
    api = (site / "api.html").read_text()
    for name in ("HybridBoostingRegressor", "simulate", "WindowLayout", "ljung_box"):
        assert name in api
    gallery = sorted((site / "auto_examples").glob("plot_*.html"))
    assert len(gallery) >= 8
    images = list((site / "_images").glob("sphx_glr_plot_*_001.png"))
    assert len(images) >= 8, [p.name for p in images]


@pytest.mark.parametrize(
    "page", ["index.html", "simulation.html", "auto_examples/plot_compositions.html"]
)
def test_pages_render_with_every_image(site, page, rendered_dom):
    probe = site / page
    html = probe.read_text()
    probe.write_text(
        html.replace(
            "</body>",
            "<script>window.addEventListener('load', () => {"
            "const imgs = [...document.images];"
            "const bad = imgs.filter(i => !(i.complete && i.naturalWidth > 0));"
            "document.body.setAttribute('data-images', imgs.length);"
            "document.body.setAttribute('data-missing', bad.length);});"
            "</script></body>",
        )
    )
    dom, _ = rendered_dom(probe)
    assert 'data-missing="0"' in dom, dom[-2000:]
    if page != "index.html":
        assert 'data-images="0"' not in dom


def test_gallery_code_gets_the_full_column(site):
    """Issue 26: gallery code lines were cut off beside the page's table of contents."""
    page = (site / "auto_examples" / "plot_compositions.html").read_text()
    assert "skhybrid.css" in page
    assert "page-toc" not in page  # no table of contents beside the code
    guide = (site / "hybrid.html").read_text()
    assert "page-toc" in guide  # guides keep their table of contents
    assert "overflow-x: auto" in (site / "_static" / "skhybrid.css").read_text()
