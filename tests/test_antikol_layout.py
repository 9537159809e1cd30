"""The module layout of antikol: no import cycle, modules of a bounded size with ``__all__``
and without ``assert``, and the data flow running one way — ingest, table, positioning,
analysis — with the applications (on-board unit, live map, evaluation, simulator, command
lines) on top."""

from __future__ import annotations

from pathlib import Path

import networkx as nx
import pytest

from tests._layout import import_graph, module_problems

PACKAGE = Path(__file__).resolve().parent.parent / "antikol"
#: The stages of the data flow, in order: each may import only the ones before it.
FLOW = ("ingest", "table", "positioning", "analysis")
#: Built on the flow; no stage may import them.
APPLICATIONS = ("onboard", "serve", "evaluation", "sim", "cli")
#: What every stage may use: errors, the collector pause, kinds, numbers, the report
#: record, thresholds.
BASE = (
    "antikol.errors",
    "antikol.gcpause",
    "antikol.kinds",
    "antikol.numeric",
    "antikol.report",
    "antikol.thresholds",
)
#: The one import against the flow: the table keeps the nearest vehicles by the paper's
#: planar distance (formulas 4-9), which live with the rest of the paper's geometry.
ALLOWED_BACKWARDS = {("antikol.table", "antikol.analysis.geometry")}


def _stage(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_no_import_cycle():
    assert list(nx.simple_cycles(import_graph(PACKAGE))) == []


@pytest.mark.parametrize(
    "path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(PACKAGE))
)
def test_module_size_exports_and_no_assert(path):
    assert module_problems(path) == []


def test_the_data_flow_runs_one_way():
    backwards = []
    for a, b in import_graph(PACKAGE).edges:
        sa, sb = _stage(a), _stage(b)
        if sa not in FLOW or (a, b) in ALLOWED_BACKWARDS:
            continue
        if sb in APPLICATIONS or (sb in FLOW and FLOW.index(sb) > FLOW.index(sa)):
            backwards.append(f"{a} -> {b}")
    assert backwards == []


def test_the_base_imports_only_the_base():
    g = import_graph(PACKAGE)
    assert {m: sorted(set(g.successors(m)) - set(BASE)) for m in BASE} == {m: [] for m in BASE}


def test_no_relative_imports_hide_from_the_graph():
    # the graph follows absolute imports only; the code base writes no relative ones
    import ast

    relative = [
        str(p.relative_to(PACKAGE))
        for p in PACKAGE.rglob("*.py")
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
        if isinstance(node, ast.ImportFrom) and node.level > 0
    ]
    assert relative == []


def test_every_stage_is_seen():
    stages = {_stage(m) for m in import_graph(PACKAGE)}
    assert set(FLOW) | set(APPLICATIONS) <= stages
