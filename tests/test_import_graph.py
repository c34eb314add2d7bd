"""No import cycle anywhere in skhybrid, function bodies included.

Every ``import`` statement of every module is read from its source (those inside
functions too, so a function-local import cannot hide a cycle), resolved to the
skhybrid module it runs, and the graph is checked for cycles. A package's
``__init__`` counts as the module ``skhybrid.package``: ``from skhybrid.hybrid
import X`` inside a module that ``skhybrid/hybrid/__init__.py`` itself imports
is a cycle.
"""

import ast
import importlib.util
import pkgutil
from pathlib import Path

import skhybrid

ROOT = Path(skhybrid.__file__).resolve().parent


def _modules():
    names = {"skhybrid": ROOT / "__init__.py"}
    for info in pkgutil.walk_packages([str(ROOT)], prefix="skhybrid."):
        spec = importlib.util.find_spec(info.name)
        names[info.name] = Path(spec.origin)
    return names


def _targets(node, module, is_package, known):
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if node.level:
        base = module if is_package else module.rsplit(".", 1)[0]
        for _ in range(node.level - 1):
            base = base.rsplit(".", 1)[0]
        source = f"{base}.{node.module}" if node.module else base
    else:
        source = node.module
    out = []
    for alias in node.names:
        sub = f"{source}.{alias.name}"
        out.append(sub if sub in known else source)
    return out


def import_graph():
    """``{module: {skhybrid modules its import statements run}}``."""
    modules = _modules()
    graph = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        edges = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for target in _targets(node, name, path.name == "__init__.py", modules):
                    if target in modules and target != name:
                        edges.add(target)
        graph[name] = edges
    return graph


def _cycles(graph):
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_graph_sees_function_local_imports():
    # The walker must see an import inside a function body, or it proves nothing.
    graph = import_graph()
    assert "skhybrid.experiments" in graph["skhybrid.cli"]
    assert _cycles({"a": {"b"}, "b": {"a"}, "c": set()}) == [["a", "b"]]


def test_no_import_cycle_in_skhybrid():
    cycles = _cycles(import_graph())
    assert cycles == [], "import cycles:\n" + "\n".join(" <-> ".join(c) for c in cycles)
