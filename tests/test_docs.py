"""The code blocks of the Markdown guides run, so the docs cannot drift from the code.

Each guide's ```python blocks run in order in one namespace (a guide is one
session). README.md's block is run by tests/test_readme.py.
"""

import re
from pathlib import Path

import matplotlib
import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"
GUIDES = sorted(
    p for p in DOCS.glob("*.md") if re.search(r"```python\n", p.read_text())
)


@pytest.mark.parametrize("guide", GUIDES, ids=[p.name for p in GUIDES])
def test_guide_code_blocks_run(guide, monkeypatch, tmp_path, request):
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if guide.name == "datasets.md":  # its loader example reads the measured data
        monkeypatch.setenv(
            "SKHYBRID_DATA", str(request.getfixturevalue("shared_data_dir"))
        )
    monkeypatch.chdir(tmp_path)  # a guide that writes files writes them here
    blocks = re.findall(r"```python\n(.*?)```", guide.read_text(), flags=re.DOTALL)
    namespace = {"__name__": "__guide__"}
    for i, block in enumerate(blocks):
        exec(compile(block, f"{guide.name} block {i + 1}", "exec"), namespace)  # noqa: S102
    plt.close("all")
