"""Subpackages meet at public seams: no private imports or writes across them.

``skhybrid.utils`` is the package's shared internals (scikit-learn's private
compatibility helpers, pickling, transactions, the array API), as
``sklearn.utils`` is scikit-learn's: every subpackage may import from it.
Everything else crosses a subpackage boundary through public names of public
modules only, and no code assigns another object's private attribute.
"""

import ast
from pathlib import Path

import pytest

import skhybrid

ROOT = Path(skhybrid.__file__).parent
SHARED = "utils"


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        yield path.relative_to(ROOT)


def _subpackage(relative):
    """The first component of a module's path below skhybrid/ (file or folder)."""
    return relative.parts[0].removesuffix(".py")


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
            if alias.name.startswith("_") and not alias.name.startswith("__"):
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
