"""A guide that states the measured candidate family states all of it.

The family is read from the code (:func:`skhybrid.experiments.free_run._family.zoo`),
so a model added there fails this test until every guide listing the family
names it; a guide once said "there is no stacking" while every run had
``stacked``.
"""

import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from skhybrid.experiments.free_run._family import zoo

ROOT = Path(__file__).resolve().parent.parent
GUIDES = [*sorted((ROOT / "docs").glob("*.md")), ROOT / "README.md"]

#: The sections where a user reads the family; each must exist and name it all.
FAMILY_SECTIONS = {
    (
        "own_machine.md",
        "5. The default candidate family, each choice made by cross-validation",
    ),
    ("experiments.md", "The measured benchmarks' candidate family"),
    ("choosing_a_model.md", "In the pipeline"),
}


def _family():
    # Every model the family can hold: a system with hybrids has them all.
    return list(zoo(SimpleNamespace(has_hybrids=lambda quick: True)))


def _sections(path):
    """``(heading, text)`` of each section, whitespace collapsed."""
    parts = re.split(r"^#+ (.*)$", path.read_text(), flags=re.MULTILINE)
    heads = ["", *parts[1::2]]
    return [
        (h.strip(), " ".join(t.split())) for h, t in zip(heads, parts[::2], strict=True)
    ]


def _named(text, family):
    return {m for m in family if f"`{m}`" in text}


def _stating_the_family():
    family = _family()
    out = {}
    for path in GUIDES:
        for head, text in _sections(path):
            named = _named(text, family)
            if (path.name, head) in FAMILY_SECTIONS or len(named) >= 3:
                out[(path.name, head)] = text
    return out


def test_the_family_is_read_from_the_code():
    family = _family()
    assert family[0] == "physics" and family[-1] == "stacked"
    assert "state-space hybrid" in family


@pytest.mark.parametrize("where", sorted(_stating_the_family()))
def test_a_guide_stating_the_family_names_every_model(where):
    text = _stating_the_family()[where]
    missing = [m for m in _family() if m not in _named(text, _family())]
    assert not missing, (
        f"{where[0]}, section {where[1]!r}, states the measured family without "
        f"{missing}: name each model in backticks, as skhybrid/experiments/"
        "free_run/_family.py defines the family."
    )
    assert "no stacking" not in text.lower()


def test_every_family_section_exists():
    assert FAMILY_SECTIONS <= set(_stating_the_family())
