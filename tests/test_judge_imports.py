"""The judge (evaluate, physics) imports no operation, and its imports form no circle.

The import graph is read from the source with ``ast`` (every ``import`` and ``from … import``,
the ones inside functions included), so a lazy import that dodges a circle at run time is caught
too; a fresh interpreter then confirms what importing the judge actually loads.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mjmotion"
JUDGE = ("mjmotion.evaluate", "mjmotion.physics")
#: Operations: they make new motion, the judge measures it.
OPERATIONS = ("blend", "registration", "stream", "hitpoint", "variations", "cleanup", "ik", "synth", "launchgrid", "style", "transform")


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def _nodes(tree: ast.AST, runtime_only: bool):
    """Every node of ``tree``; with ``runtime_only``, not those under ``if TYPE_CHECKING:``."""
    if not runtime_only:
        yield from ast.walk(tree)
        return
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            todo.extend(node.orelse)  # (the ``if`` body runs only under a type checker)
            continue
        todo.extend(ast.iter_child_nodes(node))


def import_graph(runtime_only: bool = False) -> dict[str, set[str]]:
    """``{module: the mjmotion modules it imports}`` for every module of the package; with
    ``runtime_only``, imports only a type checker runs (``if TYPE_CHECKING:``) are left out."""
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps: set[str] = set()
        for node in _nodes(ast.parse(path.read_text(encoding="utf-8")), runtime_only):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                    base = ".".join([*up, base] if base else up)
                # ``from . import x`` imports the module ``base.x`` when there is one.
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            else:
                continue
            deps |= {t for t in targets if t in modules and t != name}
        graph[name] = deps
    return graph


def closure(graph: dict[str, set[str]], start: str) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        m = todo.pop()
        for d in graph.get(m, ()):
            if d not in seen:
                seen.add(d)
                todo.append(d)
    return seen


def _is_operation(module: str) -> bool:
    parts = module.split(".")
    return len(parts) > 1 and parts[1] in OPERATIONS


@pytest.mark.parametrize("judge", JUDGE)
def test_the_judge_imports_no_operation(judge):
    graph = import_graph()
    assert judge in graph and graph[judge], "the graph reader found no imports: it is broken"
    bad = sorted(m for m in closure(graph, judge) if _is_operation(m))
    assert not bad, f"{judge} depends on operations: {bad}"


def test_the_judge_has_no_import_circle():
    graph = import_graph()
    for judge in JUDGE:
        for m in {judge} | closure(graph, judge):
            assert m not in closure(graph, m), f"{m} imports itself through a circle"


def test_the_graph_reader_sees_lazy_and_relative_imports():
    graph = import_graph()
    # cleanup imports evaluate at module level and ik.analytic relatively; launchgrid is an operation on the judge.
    assert {"mjmotion.feet", "mjmotion.ik.analytic"} <= graph["mjmotion.cleanup"] | closure(graph, "mjmotion.cleanup")
    assert "mjmotion.physics" in graph["mjmotion.launchgrid"]
    # commands.evaluate imports the judge only inside functions (lazily): still an edge.
    assert "mjmotion.evaluate" in graph["mjmotion.commands.evaluate"]


def test_importing_the_judge_loads_no_operation():
    code = (
        "import sys, mjmotion.evaluate, mjmotion.physics\n"
        f"ops = {OPERATIONS!r}\n"
        "print(sorted(m for m in sys.modules if m.startswith('mjmotion.') and m.split('.')[1] in ops))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]", out
