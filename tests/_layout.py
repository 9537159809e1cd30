"""The import graph of a package, from its source: every ``import`` statement counts,
wherever it stands (inside functions and under ``TYPE_CHECKING`` too), so a lazy import
cannot hide a dependency running backwards."""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx

MAX_LINES = 800


def module_name(package: Path, path: Path) -> str:
    parts = path.relative_to(package.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph(package: Path) -> nx.DiGraph:
    """Module -> modules of the same package it imports (``from p import x`` -> the
    submodule ``p.x`` when there is one)."""
    modules = {module_name(package, p): p for p in package.rglob("*.py")}
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
                if target in modules and target != name and target.startswith(package.name):
                    g.add_edge(name, target)
    return g


def module_problems(path: Path) -> list[str]:
    """What a library module breaks of the layout rules: size, ``__all__``, ``assert``."""
    text = path.read_text(encoding="utf-8")
    problems = []
    if len(text.splitlines()) > MAX_LINES:
        problems.append(f"{len(text.splitlines())} lines (> {MAX_LINES})")
    tree = ast.parse(text)
    assigned = {
        t.id
        for node in tree.body
        if isinstance(node, (ast.Assign, ast.AnnAssign))
        for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
        if isinstance(t, ast.Name)
    }
    if "__all__" not in assigned:
        problems.append("no __all__")
    # assertions vanish under python -O: library code raises the project's own errors
    if any(isinstance(node, ast.Assert) for node in ast.walk(tree)):
        problems.append("assert statement")
    return problems
