"""The module layout of trackmap: no import cycle, the query side apart from the build side.

Every ``import`` statement counts, wherever it stands (inside functions and under
``TYPE_CHECKING`` too), so a lazy import cannot hide a dependency running backwards.
"""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "trackmap"

#: Modules answering queries on a loaded map: they must not need the build side.
QUERY_SIDE = (
    "trackmap.crs",
    "trackmap.defaults",
    "trackmap.kinds",
    "trackmap.mapfile",
    "trackmap.model",
    "trackmap.network",
    "trackmap.routing",
    "trackmap.storage",
)
BUILD_SIDE = "trackmap.builder"
MAX_LINES = 800


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> nx.DiGraph:
    """Module -> trackmap modules it imports (``from trackmap import x`` -> the submodule)."""
    modules = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    g = nx.DiGraph()
    g.add_nodes_from(modules)
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [f"{node.module}.{a.name}" for a in node.names]
                targets = [t if t in modules else node.module for t in targets]
            for target in targets:
                while target not in modules and "." in target:
                    target = target.rsplit(".", 1)[0]
                if target in modules and target != name and target.startswith("trackmap"):
                    g.add_edge(name, target)
    return g


def test_no_import_cycle():
    cycles = list(nx.simple_cycles(import_graph()))
    assert cycles == []


def test_every_module_is_seen():
    g = import_graph()
    assert {"trackmap", "trackmap.network", "trackmap.routing", BUILD_SIDE} <= set(g)


@pytest.mark.parametrize("module", QUERY_SIDE)
def test_query_side_does_not_need_the_build_side(module):
    reached = nx.descendants(import_graph(), module)
    assert not {m for m in reached if m == BUILD_SIDE or m.startswith(BUILD_SIDE + ".")}


def test_mapfile_does_not_need_the_network():
    assert "trackmap.network" not in nx.descendants(import_graph(), "trackmap.mapfile")


def test_routing_does_not_need_the_network():
    assert "trackmap.network" not in nx.descendants(import_graph(), "trackmap.routing")


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: p.name)
def test_module_size_and_exports(path):
    text = path.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= MAX_LINES
    tree = ast.parse(text)
    assigned = {
        t.id
        for node in tree.body
        if isinstance(node, (ast.Assign, ast.AnnAssign))
        for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
        if isinstance(t, ast.Name)
    }
    assert "__all__" in assigned
    # assertions vanish under python -O: library code raises trackmap's own errors
    assert not any(isinstance(node, ast.Assert) for node in ast.walk(tree))


if __name__ == "__main__":  # print the graph: python tests/test_trackmap_layout.py
    graph = import_graph()
    for mod in sorted(graph):
        print(f"{mod}: {', '.join(sorted(graph.successors(mod))) or '-'}")
