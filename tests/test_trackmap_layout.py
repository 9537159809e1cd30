"""The module layout of trackmap: no import cycle, the query side apart from the build side.

Every ``import`` statement counts, wherever it stands (inside functions and under
``TYPE_CHECKING`` too), so a lazy import cannot hide a dependency running backwards.
"""

from __future__ import annotations

from pathlib import Path

import networkx as nx
import pytest

from tests._layout import import_graph as _graph
from tests._layout import module_problems

PACKAGE = Path(__file__).resolve().parent.parent / "trackmap"

#: Modules answering queries on a loaded map: they must not need the build side.
QUERY_SIDE = (
    "trackmap.crs",
    "trackmap.defaults",
    "trackmap.kinds",
    "trackmap.linear",
    "trackmap.mapfile",
    "trackmap.model",
    "trackmap.network",
    "trackmap.routing",
    "trackmap.storage",
)
BUILD_SIDE = "trackmap.builder"


def import_graph() -> nx.DiGraph:
    return _graph(PACKAGE)


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
    assert module_problems(path) == []


if __name__ == "__main__":  # print the graph: python tests/test_trackmap_layout.py
    graph = import_graph()
    for mod in sorted(graph):
        print(f"{mod}: {', '.join(sorted(graph.successors(mod))) or '-'}")
