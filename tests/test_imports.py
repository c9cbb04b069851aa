"""The library's packages import one another one way: no two of them (a top-level module
counts as one) import each other, directly or around a longer loop."""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "tangle_drake"


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
    pairs = sorted({tuple(sorted((a, b))) for a in graph for b in graph[a]
                    if a in graph.get(b, {})})
    assert not pairs, "packages that import each other:\n" + "\n".join(
        f"{a} <-> {b}: {sorted(graph[a][b])} / {sorted(graph[b][a])}" for a, b in pairs)


def test_no_longer_loop_of_packages():
    assert not loops(import_graph()), "import loops through several packages"


def test_the_check_finds_a_loop():
    graph = {"a": {"b": {"a.py"}}, "b": {"c": {"b.py"}}, "c": {"a": {"c.py"}}, "d": {}}
    assert loops(graph) == [["a", "b", "c"]]


LAYOUT = PACKAGE.parent / "docs" / "systems.md"
ROW = re.compile(r"^\| ([a-z ]+) \| (`tangle_drake/[^|]+) \|", re.M)


def layout_stages() -> dict[str, int]:
    """Each unit of the layout table (docs/systems.md) by its stage's place in the order."""
    stages: list[str] = []
    found: dict[str, int] = {}
    for stage, cell in ROW.findall(LAYOUT.read_text()):
        if stage not in stages:
            stages.append(stage)
        for path in re.findall(r"`([^`]+)`", cell):
            name = path.removeprefix("tangle_drake/").removesuffix("/").removesuffix(".py")
            assert name not in found, f"the layout names {name} twice"
            found[name] = stages.index(stage)
    return found


def test_the_layout_table_names_every_package_once():
    units = {path.stem for path in PACKAGE.iterdir()
             if (path.is_dir() and (path / "__init__.py").exists())
             or (path.suffix == ".py" and path.name != "__init__.py")}
    units |= {path.name for path in PACKAGE.iterdir() if path.is_dir()
              and not path.name.startswith("__") and any(path.iterdir())}
    assert set(layout_stages()) == units


def test_every_import_goes_to_the_same_or_an_earlier_stage():
    stage = layout_stages()
    backwards = sorted(f"{a} ({stage[a]}) imports {b} ({stage[b]}): {sorted(files)[0]}"
                       for a, imported in import_graph().items() if a in stage
                       for b, files in imported.items() if stage[b] > stage[a])
    assert not backwards, "\n".join(backwards)
