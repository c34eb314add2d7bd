"""Subpackages meet at public seams: no private imports or writes across them.

``skhybrid.utils`` is the package's shared internals (scikit-learn's private
compatibility helpers, pickling, transactions, the array API), as
``sklearn.utils`` is scikit-learn's: every subpackage may import from it.
Everything else crosses a subpackage boundary through public names of public
modules only, and no code assigns another object's private attribute.

Two deliberate seams: the command line (``skhybrid/cli.py``, ``__main__.py``) is
the experiments package's shell face and imports its run folder lazily, so that
``skhybrid --help`` answers before torch loads; and a subpackage may hand a
sibling an internal class by re-exporting it explicitly in its ``__init__``
(``from ._mod import _Name as _Name``, kept out of ``__all__``), as
``skhybrid.hybrid`` does for the measured zoo's corrections.
"""

import ast
from pathlib import Path

import pytest

import skhybrid

ROOT = Path(skhybrid.__file__).parent
SHARED = "utils"
#: Modules that belong to a subpackage they do not sit in.
FACE_OF = {"cli": "experiments", "__main__": "experiments"}


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        yield path.relative_to(ROOT)


def _subpackage(relative):
    """The first component of a module's path below skhybrid/ (file or folder)."""
    name = relative.parts[0].removesuffix(".py")
    return FACE_OF.get(name, name)


def _reexported(package):
    """Private names a subpackage's ``__init__`` re-exports as ``_X as _X``."""
    init = ROOT / package / "__init__.py"
    if not init.exists():
        return set()
    names = set()
    for node in ast.walk(ast.parse(init.read_text())):
        if isinstance(node, ast.ImportFrom):
            names |= {a.name for a in node.names if a.asname == a.name}
    return names


def _private_imports(relative):
    tree = ast.parse((ROOT / relative).read_text())
    own = _subpackage(relative)
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom) or not node.module:
            continue
        parts = node.module.split(".")
        if parts[0] != "skhybrid" or len(parts) < 2:
            continue
        other = parts[1]
        if other in (own, SHARED):
            continue
        if any(p.startswith("_") for p in parts[1:]):
            yield f"{relative}:{node.lineno}: from {node.module} import ..."
            continue
        for alias in node.names:
            private = alias.name.startswith("_") and not alias.name.startswith("__")
            if private and alias.name not in _reexported(other):
                yield f"{relative}:{node.lineno}: {alias.name} from {node.module}"


def _private_writes(relative):
    tree = ast.parse((ROOT / relative).read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        else:
            continue
        for target in targets:
            for sub in ast.walk(target):
                if (
                    isinstance(sub, ast.Attribute)
                    and sub.attr.startswith("_")
                    and not sub.attr.startswith("__")
                    and not (
                        isinstance(sub.value, ast.Name)
                        and sub.value.id in ("self", "cls")
                    )
                ):
                    yield f"{relative}:{node.lineno}: {ast.unparse(sub)} = ..."


@pytest.mark.parametrize("relative", list(_modules()), ids=str)
def test_no_private_import_across_subpackages(relative):
    assert list(_private_imports(relative)) == []


@pytest.mark.parametrize("relative", list(_modules()), ids=str)
def test_no_assignment_to_another_objects_private_attribute(relative):
    assert list(_private_writes(relative)) == []
