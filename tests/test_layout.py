"""The package's layout: no import circle anywhere in it, and the README's module map is the folder tree.

The import graph is the one ``tests/test_judge_imports.py`` reads with ``ast`` (every import,
function-level ones included), here without the imports only a type checker runs
(``if TYPE_CHECKING:``), which create no dependency when the code runs.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import test_judge_imports
from test_judge_imports import PACKAGE

ROOT = PACKAGE.parent
#: The graphs, read once for every test here (each read parses the whole package).
import_graph = functools.cache(test_judge_imports.import_graph)


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles of ``graph``: its strongly connected components of more than one
    module (or a module importing itself), each sorted (Tarjan's algorithm, without recursion)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[v] = min(low[v], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1 or v in graph.get(v, ()):
                    out.append(sorted(comp))
    return sorted(out)


def test_the_circle_finder_finds_circles_and_only_circles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a", "e"}, "e": set(), "f": {"f"}, "g": {"h"}, "h": {"g"}}
    assert circles(graph) == [["a", "b", "c"], ["f"], ["g", "h"]]
    assert circles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_no_import_circle_in_the_package():
    graph = import_graph(runtime_only=True)
    assert len(graph) > 100 and sum(len(d) for d in graph.values()) > 300  # (the reader sees the package)
    assert circles(graph) == []


def test_imports_only_a_type_checker_runs_are_not_dependencies():
    # The studio's session names the live stream's frame in annotations only; the app creates sessions.
    assert "mjmotion.studio.live" in import_graph()["mjmotion.studio.session"]
    assert "mjmotion.studio.live" not in import_graph(runtime_only=True)["mjmotion.studio.session"]
    assert "mjmotion.studio.session" in import_graph(runtime_only=True)["mjmotion.studio.app"]
    # ... and needs of the app only what its Host protocol names: no import of it at all.
    assert "mjmotion.studio.app" not in import_graph()["mjmotion.studio.session"]


# --- the README's module map -----------------------------------------------------------------
def module_map() -> dict[str, str]:
    """``{path: description}`` for every path the README's module map names in its first column
    (a row naming several paths gives each the row's description)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("| module | what it holds |")
    rows = []
    for line in text[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        rows.append(line)
    out: dict[str, str] = {}
    for row in rows:
        first, rest = row[1:].split(" | ", 1)
        for path in re.findall(r"`([^`]+)`", first):
            out[path] = rest
    return out


def _package_modules() -> list[Path]:
    return sorted(p.relative_to(ROOT) for p in PACKAGE.rglob("*.py") if p.name != "__init__.py")


def test_every_path_in_the_module_map_exists():
    paths = module_map()
    assert len(paths) > 30
    missing = [p for p in paths if not (ROOT / p).exists()]
    assert not missing, f"the README's module map names what the folder tree does not hold: {missing}"


def test_every_module_of_the_package_is_in_the_module_map():
    """A top-level module is named by its path; a subpackage by its folder, whose row names each of
    its modules in backticks (``grid``, ``paths``) or says it holds one module per verb/experiment."""
    paths = module_map()
    missing = []
    for rel in _package_modules():
        parts = rel.parts
        if len(parts) == 2:
            if rel.as_posix() not in paths:
                missing.append(rel.as_posix())
            continue
        folder = f"{parts[0]}/{parts[1]}/"
        row = paths.get(folder)
        if row is None:
            missing.append(folder)
            continue
        if "one module per" in row or rel.as_posix() in paths:
            continue
        name = parts[2].removesuffix(".py")  # a module, or the subpackage holding it (studio's ``tabs``)
        if f"`{name}`" not in row:
            missing.append(rel.as_posix())
    assert not missing, f"modules the README's module map does not name: {sorted(set(missing))}"


def test_every_module_of_the_package_is_an_attribute_after_import_mjmotion():
    """The README's ``mjmotion.trim.skip_leading_transient(motion)`` raised AttributeError after ``import
    mjmotion`` (and ``mjmotion.thresholds``, which the docs name): every module loads on first use."""
    import subprocess
    import sys

    named = sorted(p.stem if p.suffix == ".py" else p.name for p in PACKAGE.iterdir() if (p.suffix == ".py" or (p / "__init__.py").exists()))
    named = [n for n in named if not n.startswith("_")]
    assert {"trim", "bvh", "variations", "skin", "thresholds", "delivery"} <= set(named)
    code = "import mjmotion, sys; [getattr(mjmotion, m) for m in sys.argv[1:]]; print(mjmotion.trim.skip_leading_transient.__name__)"
    out = subprocess.run([sys.executable, "-c", code, *named], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "skip_leading_transient", out.stderr
