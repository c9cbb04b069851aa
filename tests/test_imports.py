"""The library's packages import one another one way: no two of them (a top-level module
counts as one) import each other, directly or around a longer loop."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "tangle_drake"

UNTANGLED_LATER: set[frozenset[str]] = {
    frozenset(("bench", "tangle_data")),  # the physical pick: to become the one episode
    frozenset(("pick", "tangle_data")),  # the demo's pick log: the demo above both
}
"""Pairs of packages that still import each other, to be untangled by the next steps of the
run-shape refactor; a pair leaves this set when its loop is gone (the test says so)."""


def unit(module: str) -> str:
    """``tangle_drake.pick.planner`` -> ``pick``; ``tangle_drake`` itself -> ``__init__``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def import_graph() -> dict[str, dict[str, set[str]]]:
    """unit -> the units it imports -> the files that do, every import counted (those inside
    functions too: a loop through a deferred import is still a loop)."""
    graph: dict[str, dict[str, set[str]]] = defaultdict(lambda: defaultdict(set))
    for path in PACKAGE.rglob("*.py"):
        module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        source = unit(module.removesuffix(".__init__"))
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = ([f"{node.module}.{alias.name}" for alias in node.names]
                         if node.module == "tangle_drake" else [node.module])
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            for name in names:
                if name.startswith("tangle_drake.") and unit(name) not in (source,
                                                                          "__version__"):
                    graph[source][unit(name)].add(str(path.relative_to(PACKAGE.parent)))
    return graph


def loops(graph: dict[str, dict[str, set[str]]]) -> list[list[str]]:
    """The strongly connected components of more than one unit (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in graph.get(node, {}):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while (top := stack.pop()) != node:
                component.append(top)
            found.append(sorted([node, *component]))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return [component for component in found if len(component) > 1]


def test_no_two_packages_import_each_other():
    graph = import_graph()
    pairs = {frozenset((a, b)) for a in graph for b in graph[a] if a in graph.get(b, {})}
    new = sorted(sorted(pair) for pair in pairs - UNTANGLED_LATER)
    assert not new, "packages that import each other:\n" + "\n".join(
        f"{a} <-> {b}: {sorted(graph[a][b])} / {sorted(graph[b][a])}" for a, b in new)
    gone = sorted(sorted(pair) for pair in UNTANGLED_LATER - pairs)
    assert not gone, f"untangled, take them out of UNTANGLED_LATER: {gone}"


def test_no_longer_loop_of_packages():
    graph = import_graph()
    allowed = set().union(*UNTANGLED_LATER) if UNTANGLED_LATER else set()
    found = [component for component in loops(graph) if not set(component) <= allowed]
    assert not found, f"import loops through several packages: {found}"


def test_the_check_finds_a_loop():
    graph = {"a": {"b": {"a.py"}}, "b": {"c": {"b.py"}}, "c": {"a": {"c.py"}}, "d": {}}
    assert loops(graph) == [["a", "b", "c"]]
