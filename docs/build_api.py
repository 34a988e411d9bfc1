"""Build the API reference of :mod:`mjmotion` from its docstrings with pdoc.

    python docs/build_api.py               # HTML into docs/api/ (git-ignored); open docs/api/index.html
    python docs/build_api.py -o build/api  # elsewhere

Every public module of the package is documented (``mjmotion`` lists only its own names in
``__all__``, which would hide the submodules from pdoc's walk, so they are named explicitly).
Docstrings are Google style (``Args:``, ``Attributes:``) with Sphinx cross-references
(``:func:`mjmotion.blend.blend```, ``:class:`~.curves.Spline```); pdoc renders the references as
links, and this script adds what pdoc does not check: every reference must name an object that
exists. The build fails (exit status 1) on any pdoc warning — a module that does not import, an
``__all__`` entry that does not resolve, an annotation or docstring pdoc cannot read — and on any
reference that does not resolve; ``tests/test_docs.py`` runs it.
"""

from __future__ import annotations

import argparse
import ast
import importlib
import inspect
import pkgutil
import re
import sys
import textwrap
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "mjmotion"

#: A Sphinx cross-reference role: ``:func:`name```, ``:class:`~pkg.Name```.
ROLE = re.compile(r"(?::py)?:(mod|func|data|const|class|meth|attr|exc|obj):`([^`]+)`")


def public_modules(package: str = PACKAGE) -> list[str]:
    """Every module of ``package`` whose dotted name has no part starting with ``_``, sorted."""
    pkg = importlib.import_module(package)
    names = [package]
    for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{package}."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


def _specs(names: list[str]) -> list[str]:
    """The module names to hand pdoc: it documents a package's submodules itself unless the
    package's ``__all__`` leaves them out, so only the ones no earlier package brings are named."""
    import pdoc.doc

    covered: set[str] = set()

    def walk(mod: pdoc.doc.Module) -> None:
        for sub in mod.submodules:
            covered.add(sub.modulename)
            walk(sub)

    specs = []
    for name in names:
        if name not in covered:
            specs.append(name)
            walk(pdoc.doc.Module.from_name(name))
    return specs


def _strip_tilde(docstring: str) -> str:
    """``:class:`~a.b.C``` → ``:class:`a.b.C```: pdoc links the target but does not know Sphinx's ``~``."""
    return ROLE.sub(lambda m: f":{m.group(1)}:`{m.group(2).lstrip('~')}`", docstring)


def _configure_pdoc(source: bool) -> None:
    import pdoc.render
    import pdoc.render_helpers

    # pdoc.render.env is documented as the place for custom filters; the docstring filter gains the ``~``.
    def to_markdown(context: Any, docstring: str) -> str:
        return pdoc.render_helpers.to_markdown_with_context(context, _strip_tilde(docstring))

    pdoc.render.env.filters["to_markdown"] = pdoc.render_helpers.pass_context(to_markdown)
    pdoc.render.configure(docformat="google", show_source=source, search=True, footer_text="mjmotion API reference")


def _resolve(target: str, module: ModuleType, owner: Any) -> bool:
    """Whether a reference ``target`` written in ``module`` (inside class ``owner``, if any) names an object."""
    name = target.lstrip("~").removesuffix("()")
    if name.startswith("."):  # relative to the module's package, like an import
        level = len(name) - len(name.lstrip("."))
        package = module.__name__ if hasattr(module, "__path__") else module.__name__.rpartition(".")[0]
        for _ in range(level - 1):
            package = package.rpartition(".")[0]
        name = ".".join(filter(None, (package, name.lstrip("."))))
        return _lookup(name) is not None
    if owner is not None and _getattr_chain(owner, name) is not None:
        return True
    if _getattr_chain(module, name) is not None:
        return True
    return _lookup(name) is not None


#: What a reference to an instance attribute resolves to (it has no object on the class).
_INSTANCE = object()


def _instance_attributes(cls: type) -> set[str]:
    """Names a class declares (annotations, dataclass fields) or assigns as ``self.NAME = …`` in its methods."""
    names: set[str] = set()
    for c in cls.__mro__:
        names |= set(getattr(c, "__annotations__", {}))
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(c)))
        except (OSError, TypeError, SyntaxError):
            continue
        for node in ast.walk(tree):
            target = node.target if isinstance(node, (ast.AnnAssign, ast.AugAssign)) else None
            targets = node.targets if isinstance(node, ast.Assign) else [target] if target else []
            for t in targets:
                if isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id == "self":
                    names.add(t.attr)
    return names


def _getattr_chain(obj: Any, dotted: str) -> Any:
    for part in dotted.split("."):
        if isinstance(obj, type) and not hasattr(obj, part) and part in _instance_attributes(obj):
            obj = _INSTANCE
            continue
        if obj is _INSTANCE:
            return None
        if not hasattr(obj, part):
            try:  # a submodule not imported by its package yet
                obj = importlib.import_module(f"{obj.__name__}.{part}") if isinstance(obj, ModuleType) else None
            except ImportError:
                obj = None
            if obj is None:
                return None
        else:
            obj = getattr(obj, part)
    return _INSTANCE if obj is None else obj  # (an attribute whose value is None still exists)


def _lookup(dotted: str) -> Any:
    """The object an absolute dotted name names (longest importable module, then attributes), or ``None``."""
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        try:
            mod = importlib.import_module(".".join(parts[:k]))
        except (ImportError, TypeError, ValueError):  # (not a module name at all)
            continue
        rest = ".".join(parts[k:])
        return _getattr_chain(mod, rest) if rest else mod
    return None


def _docstrings(doc: Any) -> Iterator[tuple[Any, str]]:
    """``(documented object, its docstring)`` for a pdoc module and everything documented in it."""
    yield doc, doc.docstring
    for member in getattr(doc, "own_members", []):
        if member.taken_from[0] != doc.modulename and not hasattr(member, "own_members"):
            continue  # re-exported names are checked where they are defined
        yield from _docstrings(member) if hasattr(member, "own_members") else [(member, member.docstring)]


def broken_references(modules: list[Any]) -> list[str]:
    """``"module.qualname: :role:`target`"`` for every cross-reference that names nothing."""
    out = []
    for mod in modules:
        for doc, text in _docstrings(mod):
            owner = doc.obj if hasattr(doc, "own_members") and doc.kind == "class" else None
            if owner is None and "." in doc.qualname:  # a method or attribute: its class's names count
                owner = _getattr_chain(mod.obj, doc.qualname.rpartition(".")[0])
            for m in ROLE.finditer(text):
                if not _resolve(m.group(2), mod.obj, owner):
                    out.append(f"{doc.fullname}: :{m.group(1)}:`{m.group(2)}` names nothing")
    return out


def build(out: Path, source: bool = True) -> list[str]:
    """Write the HTML reference into ``out`` (with each object's highlighted source if ``source``,
    which takes half the time); return every problem found (empty = a clean build)."""
    sys.path.insert(0, str(ROOT))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _configure_pdoc(source)
        import pdoc
        import pdoc.doc

        package = importlib.import_module(PACKAGE)
        for name in getattr(package, "__all__", ()):
            getattr(package, name)  # lazy names (PEP 562 __getattr__) are loaded before pdoc reads __all__
        names = public_modules()
        modules = [pdoc.doc.Module.from_name(n) for n in names]  # (cached: the same objects pdoc renders)
        pdoc.pdoc(*_specs(names), output_directory=out)
    problems = [f"pdoc: {w.category.__name__}: {w.message}" for w in caught if _is_pdoc(w)]
    return problems + broken_references(modules)


def _is_pdoc(w: warnings.WarningMessage) -> bool:
    """A warning pdoc raised about our code (not a library's deprecation notice at import)."""
    return "pdoc" in Path(w.filename).parts or issubclass(w.category, UserWarning) and "mjmotion" in str(w.message)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description="Build mjmotion's API reference with pdoc; fail on any warning.")
    p.add_argument("-o", "--output", default=str(ROOT / "docs" / "api"), metavar="DIR", help="output folder (default: docs/api)")
    p.add_argument("--no-source", action="store_true", help="leave out each object's source (twice as fast; the test's build)")
    args = p.parse_args(argv)
    problems = build(Path(args.output), source=not args.no_source)
    for line in problems:
        print(f"error: {line}", file=sys.stderr)
    if problems:
        return 1
    print(f"wrote {Path(args.output) / 'index.html'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
